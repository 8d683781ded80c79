// custom.sobel — a post-process pass written by a user of weft: Sobel edge detection over
// any sampled texture, as one compute dispatch. It is the worked example of
// docs/writing-a-pass.md; copy this file to start a new pass.
module;
#include <cstdint>
#include <expected>
#include <memory>
#include <utility>
export module custom.sobel;
import weft.core;
import weft.gpu;
import weft.graph;

export namespace custom {

struct SobelSettings {
  float strength = 1.0f;  // gradient magnitude scale before clamping to [0, 1]
};

class SobelEdgePass {
 public:
  // Everything that does not change per frame (shader, layouts, pipeline, sampler) is made
  // once, here, not in the execute callback.
  static weft::Result<SobelEdgePass> create(weft::gpu::Device& device);

  // Declares the pass: reads `source` (sampled), creates an RGBA8 texture of the output's
  // size and writes the edges into it (storage). Returns the edges texture; later passes
  // read that handle (or find it on the blackboard as "edges").
  weft::TextureHandle add(weft::RenderGraph& graph, weft::TextureHandle source, const SobelSettings& settings = {}) const;

 private:
  struct Gpu {
    weft::gpu::BindGroupLayout bind_layout;
    weft::gpu::PipelineLayout layout;
    weft::gpu::ComputePipeline pipeline;
    weft::gpu::Sampler sampler;
  };
  std::shared_ptr<const Gpu> gpu_;  // shared with the execute callbacks of every frame
};

}  // namespace custom

namespace custom {

namespace gpu = weft::gpu;

constexpr const char* sobel_glsl = R"(#version 460
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0) uniform sampler2D source;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D edges;
layout(push_constant) uniform Push { float strength; };

float luma(ivec2 p) {
  p = clamp(p, ivec2(0), textureSize(source, 0) - 1);
  return dot(texelFetch(source, p, 0).rgb, vec3(0.2126, 0.7152, 0.0722));
}

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(p, imageSize(edges)))) return;
  float gx = luma(p + ivec2(1, -1)) + 2.0 * luma(p + ivec2(1, 0)) + luma(p + ivec2(1, 1))
           - luma(p + ivec2(-1, -1)) - 2.0 * luma(p + ivec2(-1, 0)) - luma(p + ivec2(-1, 1));
  float gy = luma(p + ivec2(-1, 1)) + 2.0 * luma(p + ivec2(0, 1)) + luma(p + ivec2(1, 1))
           - luma(p + ivec2(-1, -1)) - 2.0 * luma(p + ivec2(0, -1)) - luma(p + ivec2(1, -1));
  float e = clamp(strength * length(vec2(gx, gy)), 0.0, 1.0);
  imageStore(edges, p, vec4(e, e, e, 1.0));
})";

weft::Result<SobelEdgePass> SobelEdgePass::create(gpu::Device& device) {
  // GLSL compiled at run time (and cached); built-in passes use build-time SPIR-V instead.
  auto module = device.create_shader_module({.label = "sobel.comp", .stage = gpu::ShaderStage::Compute, .glsl = sobel_glsl});
  if (!module) return std::unexpected(module.error());
  auto bind_layout = device.create_bind_group_layout(
      {.label = "sobel",
       .entries = {{0, gpu::BindingType::TextureSampler, gpu::ShaderStage::Compute},
                   {1, gpu::BindingType::StorageTexture, gpu::ShaderStage::Compute, gpu::Format::RGBA8Unorm}}});
  if (!bind_layout) return std::unexpected(bind_layout.error());
  auto layout = device.create_pipeline_layout(
      {.label = "sobel", .bind_group_layouts = {&*bind_layout}, .push_constant_size = sizeof(float)});
  if (!layout) return std::unexpected(layout.error());
  auto pipeline = device.create_compute_pipeline({.label = "sobel", .layout = &*layout, .module = &*module});
  if (!pipeline) return std::unexpected(pipeline.error());
  auto sampler = device.create_sampler(
      {.label = "sobel", .mag_filter = gpu::FilterMode::Nearest, .min_filter = gpu::FilterMode::Nearest});
  if (!sampler) return std::unexpected(sampler.error());
  SobelEdgePass pass;
  pass.gpu_ = std::make_shared<const Gpu>(
      Gpu{std::move(*bind_layout), std::move(*layout), std::move(*pipeline), std::move(*sampler)});
  return pass;
}

weft::TextureHandle SobelEdgePass::add(weft::RenderGraph& graph, weft::TextureHandle source,
                                       const SobelSettings& settings) const {
  // The handles this pass uses: filled by setup, read by execute.
  struct Data {
    weft::TextureHandle source, edges;
  };
  auto& data = graph.add_pass<Data>(
      "sobel_edges",
      // Setup: runs now. Declare every resource the pass touches and how.
      [&](weft::PassBuilder& b, Data& d) {
        d.source = b.read(source, weft::TextureUse::Sampled);
        d.edges = b.create_texture("edges", {.size = weft::RelativeSize{1.0f}, .format = gpu::Format::RGBA8Unorm});
        d.edges = b.write(d.edges, weft::TextureUse::StorageWrite);  // keep the new version
        b.blackboard().put("edges", d.edges);
      },
      // Execute: runs at every CompiledGraph::execute() unless the pass is culled. It may
      // only touch what setup declared; the graph has already placed the barriers.
      [gpu = gpu_, strength = settings.strength](const weft::PassResources& res, const Data& d,
                                                 weft::PassContext& ctx) {
        auto group = ctx.device().create_bind_group(
            {.label = "sobel",
             .layout = &gpu->bind_layout,
             .entries = {gpu::bind(0, res.view(d.source), &gpu->sampler), gpu::bind(1, res.view(d.edges))}});
        if (!group) return ctx.encoder().report_error(group.error());
        const gpu::Extent3D size = res.extent(d.edges);
        auto pass = ctx.encoder().begin_compute_pass("sobel");
        pass.set_pipeline(gpu->pipeline);
        pass.set_bind_group(0, ctx.keep(std::move(*group)));  // alive until the frame has run
        pass.push(strength);
        pass.dispatch((size.width + 7) / 8, (size.height + 7) / 8);
        pass.end();
      });
  return data.edges;
}

}  // namespace custom
