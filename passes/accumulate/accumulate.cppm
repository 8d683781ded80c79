// weft.base_pass.accumulate — temporal accumulation of a still view: each frame the renderer
// moves the projection by a sub-pixel Halton offset (RenderOptions::sample_index) and this
// pass averages the frames into a history it keeps, so a view that rests converges towards a
// box-filtered supersampling of N samples per pixel (docs/anti-aliasing.md#accumulation).
module;
export module weft.base_pass.accumulate;
import weft.pipeline;

export namespace weft::passes {
const pipeline::PassTypeDescriptor& accumulate_pass_type();
}  // namespace weft::passes
