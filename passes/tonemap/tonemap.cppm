// weft.base_pass.tonemap — "scene_color" (linear HDR) to the frame's output texture (RGBA8,
// sRGB-encoded): exposure, then ACES or a plain clamp (the analytic tests use the clamp).
module;
#include <expected>
#include <memory>
export module weft.base_pass.tonemap;
import weft.core;
import weft.gpu;
import weft.graph;

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
  // Reads "scene_color" and writes `output` (an RGBA8 texture); returns its new version.
  Result<TextureHandle> add(RenderGraph& graph, TextureHandle output, const TonemapSettings& settings) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

}  // namespace weft::passes
