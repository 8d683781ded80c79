module;
#include <cstdint>
#include <expected>
#include <memory>
#include <string>
#include <string_view>
#include <vector>
#include <weft/try.h>
#include "weft_pass_tonemap_shaders.h"
module weft.base_pass.tonemap;
import weft.frame;

namespace weft::passes {

struct TonemapPass::State {
  gpu::BindGroupLayout bind_layout;
  gpu::PipelineLayout layout;
  gpu::RenderPipeline pipeline;
  gpu::Sampler sampler;
};

namespace {
struct Push {
  float exposure;
  std::uint32_t operator_kind;
};
}  // namespace

Result<TonemapPass> TonemapPass::create(gpu::Device& device) {
  WEFT_TRY(auto vs, device.create_shader_module({.label = "fullscreen.vert", .stage = gpu::ShaderStage::Vertex, .spirv = frame::fullscreen_vertex_spirv()}));
  WEFT_TRY(auto fs, device.create_shader_module({.label = "tonemap.frag", .stage = gpu::ShaderStage::Fragment, .spirv = shaders::tonemap_frag()}));
  WEFT_TRY(auto bind_layout, device.create_bind_group_layout(
        {.label = "tonemap", .entries = {{0, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment}}}));
  WEFT_TRY(auto layout, device.create_pipeline_layout({.label = "tonemap", .bind_group_layouts = {&bind_layout}, .push_constant_size = sizeof(Push)}));
  WEFT_TRY(auto pipeline, device.create_render_pipeline({.label = "tonemap", .layout = &layout, .vertex = &vs, .fragment = &fs,
                                                   .color_targets = {{output_format}}}));
  WEFT_TRY(auto sampler, device.create_sampler({.label = "tonemap", .mag_filter = gpu::FilterMode::Nearest, .min_filter = gpu::FilterMode::Nearest}));
  TonemapPass pass;
  pass.state_ = std::make_shared<State>(State{std::move(bind_layout), std::move(layout), std::move(pipeline),
                                              std::move(sampler)});
  return pass;
}

Result<TextureHandle> TonemapPass::add(RenderGraph& graph, TextureHandle color, TextureHandle output,
                                       const TonemapSettings& settings, std::string_view name) const {
  struct Data {
    TextureHandle color, output;
  };
  if (!color) {
    WEFT_TRY(const frame::SceneTargets shared,
             frame::scene_targets(graph.blackboard(),
                                  {.uniforms = false, .environment = false, .shadow_map = false, .depth = false}));
    color = shared.color;
  }
  auto state = state_;
  const Push push{settings.exposure, std::uint32_t(settings.tone_operator)};
  const std::string transient_name = output ? std::string() : std::string(name) + ".color";
  auto& data = graph.add_pass<Data>(
      name,
      [&](PassBuilder& b, Data& d) {
        d.color = b.read(color, TextureUse::Sampled);
        TextureHandle target = output;
        if (!target) target = b.create_texture(transient_name, {.format = output_format});
        d.output = b.write(target, TextureUse::ColorAttachment);
      },
      [state, push](const PassResources& res, const Data& d, PassContext& ctx) {
        auto group = ctx.device().create_bind_group(
            {.label = "tonemap", .layout = &state->bind_layout, .entries = {gpu::bind(0, res.view(d.color), &state->sampler)}});
        if (!group) return ctx.encoder().report_error(group.error());
        const auto& frame_group = ctx.keep(std::move(*group));  // alive until the frame is done
        auto pass = ctx.encoder().begin_render_pass({.label = "tonemap", .color_attachments = {{.view = &res.view(d.output), .load = gpu::LoadOp::DontCare}}});
        pass.set_pipeline(state->pipeline);
        pass.set_bind_group(0, frame_group);
        pass.push(push);
        pass.draw(3);
        pass.end();
      });
  return data.output;
}

}  // namespace weft::passes
