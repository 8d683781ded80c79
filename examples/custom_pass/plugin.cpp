// The Sobel pass as a weft plugin: the pass type "sobel_edges" (input `color`, an 8-bit image;
// output `edges`), registered when weft loads the library:
//   weft --plugin libweft_sobel_plugin.so render SCENE --pipeline examples/pipelines/sobel_plugin.json
// It is built out of tree against the installed weft (plugin/CMakeLists.txt), which is how a
// user ships a pass without rebuilding weft.
module;
#include <cstdint>
#include <expected>
#include <memory>
#include <optional>
#include <utility>
#include <weft/plugin.h>  // WEFT_PLUGIN: macros only, so the global fragment is its place
module custom.sobel;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.pipeline;

namespace custom {
namespace {

class SobelFramePass final : public weft::pipeline::FramePass {
 public:
  explicit SobelFramePass(float strength) : strength_(strength) {}
  weft::Result<void> prepare(weft::gpu::Device& device, const weft::pipeline::PassFrame&) override {
    if (pass_) return {};
    auto pass = SobelEdgePass::create(device);
    if (!pass) return std::unexpected(pass.error());
    pass_.emplace(std::move(*pass));
    return {};
  }
  weft::Result<void> add(weft::RenderGraph& graph, const weft::pipeline::PassFrame&,
                         weft::pipeline::PassSlots& slots) override {
    slots.set_output("edges", pass_->add(graph, slots.input("color"), {.strength = strength_}));
    return {};
  }

 private:
  float strength_;
  std::optional<SobelEdgePass> pass_;
};

weft::Result<std::unique_ptr<weft::pipeline::FramePass>> create(const weft::pipeline::PassOptions& options) {
  return std::make_unique<SobelFramePass>(float(options.number("strength")));
}

const weft::pipeline::PassTypeDescriptor& sobel_pass_type() {
  static const weft::pipeline::PassTypeDescriptor d{
      .name = "sobel_edges",
      .summary = "Sobel edge magnitude of an image's luminance, as grey (a plugin: examples/custom_pass)",
      .doc = "docs/writing-a-pass.md",
      .inputs = {{.name = "color", .formats = {weft::gpu::Format::RGBA8Unorm}, .meaning = "the image"}},
      .outputs = {{.name = "edges", .formats = {weft::gpu::Format::RGBA8Unorm}, .meaning = "edge strength"}},
      .options = {weft::pipeline::number_option("strength", 0.0, 100.0, 1.0,
                                                "gradient magnitude scale before clamping to [0, 1]")},
      .create = &create,
  };
  return d;
}

void register_sobel(weft::pipeline::PluginRegistrar& registrar) { registrar.add_pass_type(sobel_pass_type()); }

}  // namespace
}  // namespace custom

WEFT_PLUGIN(custom::register_sobel)
