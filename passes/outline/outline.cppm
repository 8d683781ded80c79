// weft.base_pass.outline — lines where the distance to the camera jumps (silhouettes and
// creases between objects), drawn over any colour: the HDR scene colour or the tone-mapped
// image. Usable on any scene; off the edges the colour passes through unchanged.
module;
export module weft.base_pass.outline;
import weft.pipeline;

export namespace weft::passes {
const pipeline::PassTypeDescriptor& outline_pass_type();
}  // namespace weft::passes
