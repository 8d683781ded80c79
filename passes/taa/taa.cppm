// weft.base_pass.taa — temporal anti-aliasing for a moving camera: each frame is jittered by a
// Halton sub-pixel offset (RenderOptions::sample_index), and the history of earlier frames is
// reprojected through the scene's depth and the last frame's camera, clamped to the current
// frame's 3x3 neighbourhood (so what was disoccluded or changed does not ghost) and blended in.
// weft's scenes are static, so the camera's motion is every pixel's motion: the depth
// reprojection is exact for every pass that writes depth (docs/anti-aliasing.md#taa).
module;
export module weft.base_pass.taa;
import weft.pipeline;

export namespace weft::passes {
const pipeline::PassTypeDescriptor& taa_pass_type();
}  // namespace weft::passes
