module;
#include <expected>
#include <string_view>
#include <memory>
#include <vector>
#include <weft/try.h>
#include "weft_pass_background_shaders.h"
module weft.base_pass.background;
import weft.frame;

namespace weft::passes {

struct BackgroundPass::State {
  gpu::BindGroupLayout bind_layout;
  std::shared_ptr<const gpu::PipelineLayout> layout;
  frame::PipelineSamples pipeline;  // draws into a multisampled scene colour as it is
  gpu::Sampler sampler;
};

Result<BackgroundPass> BackgroundPass::create(gpu::Device& device) {
  WEFT_TRY(auto vs, device.create_shader_module({.label = "fullscreen.vert", .stage = gpu::ShaderStage::Vertex, .spirv = frame::fullscreen_vertex_spirv()}));
  WEFT_TRY(auto fs, device.create_shader_module({.label = "background.frag", .stage = gpu::ShaderStage::Fragment, .spirv = shaders::background_frag()}));
  WEFT_TRY(auto bind_layout, device.create_bind_group_layout(
        {.label = "background",
         .entries = {{0, gpu::BindingType::UniformBuffer, gpu::ShaderStage::Fragment},
                     {1, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment}}}));
  WEFT_TRY(auto made_layout, device.create_pipeline_layout({.label = "background", .bind_group_layouts = {&bind_layout}}));
  // Shared with the pipelines of other sample counts, made when a frame first asks.
  const auto layout = std::make_shared<const gpu::PipelineLayout>(std::move(made_layout));
  WEFT_TRY(auto pipeline, frame::PipelineSamples::create(device, layout,
        {.label = "background",
         .layout = layout.get(),
         .color_targets = {{gpu::Format::RGBA16Float}},
         .depth_stencil = gpu::DepthStencilState{.format = gpu::Format::Depth32Float, .depth_write = false,
                                                 .compare = gpu::CompareFunction::LessEqual}},
        std::move(vs), std::move(fs)));
  WEFT_TRY(auto sampler, device.create_sampler({.label = "environment", .address_mode = gpu::AddressMode::Repeat}));
  BackgroundPass pass;
  pass.state_ = std::make_shared<State>(State{std::move(bind_layout), layout, std::move(pipeline),
                                              std::move(sampler)});
  return pass;
}

Result<void> BackgroundPass::add(RenderGraph& graph, std::string_view name) const {
  struct Data {
    BufferHandle uniforms;
    TextureHandle environment, color, depth;
  };
  WEFT_TRY(const frame::SceneTargets shared, frame::scene_targets(graph.blackboard(), {.shadow_map = false}));
  auto state = state_;
  const std::uint32_t samples = frame::scene_sample_count(graph);
  auto& data = graph.add_pass<Data>(
      name,
      [&](PassBuilder& b, Data& d) {
        d.uniforms = b.read(shared.uniforms, BufferUse::Uniform);
        d.environment = b.read(shared.environment, TextureUse::Sampled);
        d.depth = b.read(shared.depth, TextureUse::DepthRead);
        d.color = b.write(shared.color, TextureUse::ColorAttachment);
      },
      [state, samples](const PassResources& res, const Data& d, PassContext& ctx) {
        auto pipeline = state->pipeline.at(ctx.device(), samples);
        if (!pipeline) return ctx.encoder().report_error(pipeline.error());
        auto group = ctx.device().create_bind_group(
            {.label = "background",
             .layout = &state->bind_layout,
             .entries = {gpu::bind(0, res.buffer(d.uniforms)), gpu::bind(1, res.view(d.environment), &state->sampler)}});
        if (!group) return ctx.encoder().report_error(group.error());
        const auto& frame_group = ctx.keep(std::move(*group));  // alive until the frame is done
        auto pass = ctx.encoder().begin_render_pass(
            {.label = "background",
             .color_attachments = {{.view = &res.view(d.color), .load = gpu::LoadOp::Load}},
             .depth_attachment = gpu::DepthAttachment{.view = &res.view(d.depth), .read_only = true}});
        pass.set_pipeline(**pipeline);
        pass.set_bind_group(0, frame_group);
        pass.draw(3);
        pass.end();
      });
  frame::put_scene_targets(graph.blackboard(), {.color = data.color});
  return {};
}

}  // namespace weft::passes
