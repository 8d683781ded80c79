// weft.base_pass.tonemap — "scene_color" (linear HDR) to the frame's output texture (RGBA8,
// sRGB-encoded): exposure, then ACES or a plain clamp (the analytic tests use the clamp).
module;
#include <expected>
#include <memory>
#include <string_view>
export module weft.base_pass.tonemap;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.pipeline;

export namespace weft::passes {

enum class ToneOperator : std::uint32_t { Clamp = 0, Aces = 1 };

struct TonemapSettings {
  float exposure = 1.0f;
  ToneOperator tone_operator = ToneOperator::Aces;
};

inline constexpr gpu::Format output_format = gpu::Format::RGBA8Unorm;

class TonemapPass {
 public:
  static Result<TonemapPass> create(gpu::Device& device);
  // Reads `color` (linear HDR; an invalid handle: the blackboard's scene colour) and writes
  // `output` (an RGBA8 texture of the frame's size; an invalid handle: a transient named
  // "<name>.color"); returns the output's new version. `name` names the graph pass.
  Result<TextureHandle> add(RenderGraph& graph, TextureHandle color, TextureHandle output, const TonemapSettings& settings,
                            std::string_view name = "tonemap") const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// The pass type of tone mapping to the 8-bit image (pass_type.cpp); weft::register_builtins() registers it.
const pipeline::PassTypeDescriptor& tonemap_pass_type();

}  // namespace weft::passes
