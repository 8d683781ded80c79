// Imports weft.graph from the installed package, declares a three-pass graph without a device
// and compiles it: the pass that reaches no output is culled, the other two run producer first.
#include <cstdio>
import weft.core;
import weft.gpu;
import weft.graph;

int main() {
  using namespace weft;
  RenderGraph graph("consumer");
  const TextureDesc desc{.size = gpu::Extent3D{16, 16, 1}, .format = gpu::Format::RGBA8Unorm};
  TextureHandle made;
  graph.add_pass("make", [&](PassBuilder& b) { made = b.write(b.create_texture("made", desc), TextureUse::ColorAttachment); });
  TextureHandle shown;
  graph.add_pass("show", [&](PassBuilder& b) {
    (void)b.read(made, TextureUse::Sampled);
    shown = b.write(b.create_texture("shown", desc), TextureUse::ColorAttachment);
  });
  graph.add_pass("unused", [&](PassBuilder& b) { (void)b.write(b.create_texture("unused", desc), TextureUse::ColorAttachment); });
  graph.mark_output(shown);
  auto compiled = graph.compile({.output_extent = {16, 16, 1}});
  if (!compiled) {
    std::fprintf(stderr, "compile failed: %s\n", compiled.error().to_string().c_str());
    return 1;
  }
  const auto order = compiled->order();
  if (order.size() != 2 || order[0] != 0 || order[1] != 1) {
    std::fprintf(stderr, "expected passes 0, 1 in order (2 culled), got %zu passes\n", order.size());
    return 1;
  }
  std::printf("weft consumer: graph '%s' compiled, %zu of %zu passes kept\n", graph.name().c_str(), order.size(),
              graph.pass_count());
  return 0;
}
