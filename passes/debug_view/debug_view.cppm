// weft.base_pass.debug_view — pictures of what a frame computes: the camera's depth as
// distance, and world-space normals reconstructed from it, as an 8-bit image that can be the
// frame's output (`"outputs": ["debug.color"]`) or shown in the viewer. Any resource can also be
// written as it is with `weft render --output NAME`.
module;
export module weft.base_pass.debug_view;
import weft.pipeline;

export namespace weft::passes {
const pipeline::PassTypeDescriptor& debug_view_pass_type();
}  // namespace weft::passes
