// Full-screen passes: one pipeline shape and one draw call shared by every post-process.
module;
#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <weft/try.h>
#include "weft_frame_shaders.h"
module weft.frame;
import weft.core;
import weft.gpu;
import weft.graph;

namespace weft::frame {

Result<FullscreenPipeline> create_fullscreen_pipeline(gpu::Device& device, std::string label,
                                                      std::span<const std::uint32_t> fragment_spirv,
                                                      std::uint32_t textures, bool uniforms, std::uint32_t push_size,
                                                      gpu::Format target) {
  WEFT_TRY(auto vs, device.create_shader_module({.label = "fullscreen.vert", .stage = gpu::ShaderStage::Vertex,
                                                 .spirv = fullscreen_vertex_spirv()}));
  WEFT_TRY(auto fs, device.create_shader_module({.label = label + ".frag", .stage = gpu::ShaderStage::Fragment,
                                                 .spirv = fragment_spirv}));
  std::vector<gpu::BindGroupLayoutEntry> entries;
  for (std::uint32_t i = 0; i < textures; ++i) entries.push_back({i, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment});
  if (uniforms) entries.push_back({textures, gpu::BindingType::UniformBuffer, gpu::ShaderStage::Fragment});
  WEFT_TRY(auto bind_layout, device.create_bind_group_layout({.label = label, .entries = std::move(entries)}));
  WEFT_TRY(auto layout, device.create_pipeline_layout(
                            {.label = label, .bind_group_layouts = {&bind_layout}, .push_constant_size = push_size}));
  WEFT_TRY(auto pipeline, device.create_render_pipeline({.label = label, .layout = &layout, .vertex = &vs, .fragment = &fs,
                                                          .color_targets = {{target}}}));
  return FullscreenPipeline{std::move(bind_layout), std::move(layout), std::move(pipeline), textures, uniforms};
}

void draw_fullscreen(PassContext& context, const FullscreenPipeline& pipeline, std::string_view label,
                     const gpu::TextureView& target, std::span<const gpu::TextureView* const> textures,
                     const gpu::Sampler& sampler, const gpu::Buffer* uniforms, std::span<const std::byte> push) {
  std::vector<gpu::BindGroupEntry> entries;
  for (std::uint32_t i = 0; i < textures.size(); ++i) entries.push_back(gpu::bind(i, *textures[i], &sampler));
  if (uniforms && pipeline.uniforms) entries.push_back(gpu::bind(std::uint32_t(textures.size()), *uniforms));
  auto group = context.device().create_bind_group(
      {.label = std::string(label), .layout = &pipeline.bind_layout, .entries = std::move(entries)});
  if (!group) return context.encoder().report_error(group.error());
  const auto& kept = context.keep(std::move(*group));  // alive until the frame is done
  auto pass = context.encoder().begin_render_pass(
      {.label = std::string(label), .color_attachments = {{.view = &target, .load = gpu::LoadOp::DontCare}}});
  pass.set_pipeline(pipeline.pipeline);
  pass.set_bind_group(0, kept);
  if (!push.empty()) pass.set_push_constants(push);
  pass.draw(3);
  pass.end();
}

Result<TextureHandle> add_fullscreen_pass(RenderGraph& graph, FullscreenPass p, const FullscreenPipeline& pipeline,
                                          const gpu::Sampler& sampler, std::shared_ptr<const void> owner) {
  constexpr std::size_t max_inputs = 4;
  if (p.inputs.size() > max_inputs)
    return fail(ErrorKind::InvalidArgument, "full-screen pass '{}': {} inputs, at most {}", p.name, p.inputs.size(), max_inputs);
  WEFT_TRY(const SceneTargets shared,
           scene_targets(graph.blackboard(), {.environment = false, .shadow_map = false, .color = false, .depth = false}));
  struct Data {
    BufferHandle uniforms;
    std::array<TextureHandle, max_inputs> inputs{};
    TextureHandle target;
  };
  const std::size_t n = p.inputs.size();
  auto& data = graph.add_pass<Data>(
      p.name,
      [&](PassBuilder& b, Data& d) {
        d.uniforms = b.read(shared.uniforms, BufferUse::Uniform);
        for (std::size_t i = 0; i < n; ++i) d.inputs[i] = b.read(p.inputs[i], TextureUse::Sampled);
        d.target = b.write(p.target ? p.target : b.create_texture(p.name + ".color", {.format = p.format}),
                           TextureUse::ColorAttachment);
      },
      [pipeline = &pipeline, sampler = &sampler, owner = std::move(owner), push = std::move(p.push), label = p.name,
       n](const PassResources& res, const Data& d, PassContext& ctx) {
        std::array<const gpu::TextureView*, max_inputs> in{};
        for (std::size_t i = 0; i < n; ++i) in[i] = &res.view(d.inputs[i]);
        draw_fullscreen(ctx, *pipeline, label, res.view(d.target), std::span(in.data(), n), *sampler,
                        &res.buffer(d.uniforms), push);
      });
  return data.target;
}

Result<std::shared_ptr<const TemporalPipelines>> TemporalPipelines::create(gpu::Device& device, const std::string& label,
                                                                           std::span<const std::uint32_t> blend_spirv,
                                                                           std::uint32_t blend_textures,
                                                                           std::uint32_t push_size) {
  WEFT_TRY(auto blend, create_fullscreen_pipeline(device, label, blend_spirv, blend_textures, false, push_size,
                                                  gpu::Format::RGBA16Float));
  std::map<gpu::Format, FullscreenPipeline> output;
  for (gpu::Format f : {gpu::Format::RGBA8Unorm, scene_color_format}) {
    WEFT_TRY(auto p, create_fullscreen_pipeline(device, label + ".output", shaders::temporal_output_frag(), 1, false,
                                                sizeof(std::uint32_t), f));
    output.emplace(f, std::move(p));
  }
  WEFT_TRY(auto sampler, device.create_sampler({.label = label, .max_lod = 0}));
  return std::make_shared<const TemporalPipelines>(TemporalPipelines{std::move(blend), std::move(output), std::move(sampler)});
}

Result<TextureHandle> TemporalPipelines::add_output(RenderGraph& graph, std::string name, TextureHandle history,
                                                   TextureHandle target, gpu::Format format,
                                                   std::shared_ptr<const void> owner) const {
  const auto pipeline = output.find(format);
  if (pipeline == output.end())
    return fail(ErrorKind::Unsupported, "pass '{}': a temporal pass writes rgba8unorm or rgba16float colour, not {}", name,
                gpu::format_info(format).name);
  const std::uint32_t display_encoded = format == gpu::Format::RGBA8Unorm ? 1u : 0u;
  const auto bytes = std::as_bytes(std::span(&display_encoded, 1));
  return add_fullscreen_pass(graph, {.name = std::move(name), .inputs = {history}, .target = target, .format = format,
                                     .push = std::vector<std::byte>(bytes.begin(), bytes.end())},
                             pipeline->second, sampler, std::move(owner));
}

Result<bool> HistoryTextures::ensure(gpu::Device& device, std::string_view label, gpu::Extent3D size, gpu::Format format) {
  if (textures_[0] && size.width == size_.width && size.height == size_.height && textures_[0]->format() == format)
    return false;
  for (int i = 0; i < 2; ++i) {
    WEFT_TRY(auto t, device.create_texture({.label = weft::format("{}.history.{}", label, i),
                                            .size = size,
                                            .format = format,
                                            .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::ColorAttachment}));
    textures_[i] = std::move(t);
  }
  size_ = size;
  return true;
}

std::pair<TextureHandle, TextureHandle> HistoryTextures::import(RenderGraph& graph, std::string_view name, bool valid) {
  const int read = int(flip_), write = 1 - read;
  flip_ = !flip_;
  return {graph.import_texture(std::string(name) + ".history", &*textures_[read],
                               valid ? gpu::Access::ShaderRead : gpu::Access::Undefined),
          graph.import_texture(std::string(name) + ".history_next", &*textures_[write], gpu::Access::Undefined)};
}

struct ColorEffect::State {
  std::string label;
  std::map<gpu::Format, FullscreenPipeline> pipelines;  // by colour format
  gpu::Sampler sampler;
};

Result<ColorEffect> ColorEffect::create(gpu::Device& device, std::string label, std::span<const std::uint32_t> fragment_spirv,
                                        std::uint32_t textures, bool uniforms, std::uint32_t push_size,
                                        gpu::SamplerDescriptor sampler) {
  std::map<gpu::Format, FullscreenPipeline> pipelines;
  for (gpu::Format f : {gpu::Format::RGBA8Unorm, scene_color_format}) {
    WEFT_TRY(auto p, create_fullscreen_pipeline(device, label, fragment_spirv, textures, uniforms, push_size, f));
    pipelines.emplace(f, std::move(p));
  }
  if (sampler.label.empty()) sampler.label = label;
  WEFT_TRY(auto made_sampler, device.create_sampler(sampler));
  ColorEffect effect;
  effect.state_ = std::make_shared<const State>(State{std::move(label), std::move(pipelines), std::move(made_sampler)});
  return effect;
}

Result<TextureHandle> ColorEffect::add(RenderGraph& graph, std::string_view name, std::vector<TextureHandle> inputs,
                                       TextureHandle target, std::span<const std::byte> push) const {
  const auto desc = inputs.empty() ? std::nullopt : graph.texture_desc(inputs.front());
  if (!desc || !state_->pipelines.contains(desc->format))
    return fail(ErrorKind::Unsupported, "pass '{}': input 'color' must be rgba8unorm or rgba16float", name);
  return add_fullscreen_pass(graph,
                             {.name = std::string(name),
                              .inputs = std::move(inputs),
                              .target = target,
                              .format = desc->format,
                              .push = {push.begin(), push.end()}},
                             state_->pipelines.at(desc->format), state_->sampler, state_);
}

}  // namespace weft::frame
