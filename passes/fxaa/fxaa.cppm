// weft.base_pass.fxaa — fast approximate anti-aliasing (Lottes' FXAA 3.11, quality form) on
// the tone-mapped image: where the luma contrast marks an edge, the edge's direction and
// ends are searched and the pixel is blended across it by its distance to the nearer end.
// One full-screen pass; the cheapest anti-aliasing weft has (docs/anti-aliasing.md).
module;
export module weft.base_pass.fxaa;
import weft.pipeline;

export namespace weft::passes {
const pipeline::PassTypeDescriptor& fxaa_pass_type();
}  // namespace weft::passes
