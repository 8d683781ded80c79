// weft.example.fur_frame — ShellFurPass in a frame of its own (clear -> fur -> readback) with
// any camera (orthographic too), for the fur tests, the fur benchmark and studies: a harness
// next to the example, not in the feature's exported interface, and built without the tests
// (weft-bench-fur needs it).
module;
#include <cstdint>
#include <expected>
#include <memory>
#include <span>
export module weft.example.fur_frame;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.image;
import weft.pass.shell_fur;

export namespace weft::passes {

// A minimal frame around ShellFurPass for tests, benchmarks and accuracy studies, with any
// camera (orthographic too): clears "scene_color" (RGBA16F) and "scene_depth", draws the fur
// under one directional light and a constant sky, and reads back linear RGBA.
struct FurFrameSettings {
  std::uint32_t width = 64, height = 64;
  mat4 view{1.0f};
  mat4 projection{1.0f};  // Vulkan clip space (y down, depth 0..1)
  vec3 camera_position{0.0f};
  vec3 towards_light{0.0f, 1.0f, 0.0f};
  vec3 light_radiance{pi};  // pi: a white Lambert surface facing the light reads 1
  vec3 sky_radiance{0.0f};
  vec4 clear_color{0.0f, 0.0f, 0.0f, 1.0f};
};

class FurFrame {
 public:
  static Result<FurFrame> create(gpu::Device& device, const FurFrameSettings& settings);
  FurFrame(FurFrame&&) noexcept;
  FurFrame& operator=(FurFrame&&) noexcept;
  ~FurFrame();
  // Builds and compiles the frame's graph for these draws (which must outlive it).
  Result<void> set_draws(const ShellFurPass& pass, std::span<const ShellFurDraw> draws);
  Result<FrameStats> execute(bool timestamps = false);
  // The colour target after execute(): width x height x 4 linear floats.
  Result<image::Image> read_color();

 private:
  FurFrame() = default;
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace weft::passes
