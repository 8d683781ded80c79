// MSAA for the frame's passes: a pipeline kept in every sample count its frames draw with,
// and the resolve pass that turns a multisampled texture into one value per texel.
module;
#include <cstdint>
#include <expected>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <weft/try.h>
module weft.frame;
import weft.core;
import weft.gpu;
import weft.graph;

namespace weft::frame {

struct PipelineSamples::State {
  gpu::RenderPipelineDescriptor desc;
  std::shared_ptr<const gpu::PipelineLayout> layout;  // desc.layout: the caller's may move
  std::optional<gpu::ShaderModule> vertex;  // always set (a module has no empty state)
  std::optional<gpu::ShaderModule> fragment;
  std::optional<gpu::ShaderModule> multisample_fragment;  // for counts above 1, when set
  bool alpha_to_coverage = false;
  std::mutex mutex;
  std::map<std::uint32_t, gpu::RenderPipeline> pipelines;  // by sample count; nodes stay put
};

Result<PipelineSamples> PipelineSamples::create(gpu::Device& device, std::shared_ptr<const gpu::PipelineLayout> layout,
                                                gpu::RenderPipelineDescriptor desc,
                                                gpu::ShaderModule vertex, std::optional<gpu::ShaderModule> fragment,
                                                bool alpha_to_coverage) {
  auto state = std::make_shared<State>();
  if (!layout) return fail(ErrorKind::InvalidArgument, "render pipeline '{}': no pipeline layout", desc.label);
  state->desc = std::move(desc);
  state->layout = std::move(layout);
  state->desc.layout = state->layout.get();
  state->vertex.emplace(std::move(vertex));
  state->fragment = std::move(fragment);
  state->alpha_to_coverage = alpha_to_coverage;
  state->desc.vertex = &*state->vertex;
  state->desc.fragment = state->fragment ? &*state->fragment : nullptr;
  state->desc.multisample = {};
  WEFT_TRY(auto single, device.create_render_pipeline(state->desc));
  state->pipelines.emplace(1u, std::move(single));
  PipelineSamples out;
  out.state_ = std::move(state);
  return out;
}

Result<const gpu::RenderPipeline*> PipelineSamples::at(gpu::Device& device, std::uint32_t samples) const {
  const std::lock_guard lock(state_->mutex);
  if (auto it = state_->pipelines.find(samples); it != state_->pipelines.end()) return &it->second;
  gpu::RenderPipelineDescriptor desc = state_->desc;
  desc.label += weft::format(" ({}x MSAA)", samples);
  desc.multisample = {.count = samples, .alpha_to_coverage = state_->alpha_to_coverage && samples > 1};
  if (samples > 1 && state_->multisample_fragment) desc.fragment = &*state_->multisample_fragment;
  WEFT_TRY(auto pipeline, device.create_render_pipeline(desc));
  return &state_->pipelines.emplace(samples, std::move(pipeline)).first->second;
}

const gpu::RenderPipeline& PipelineSamples::single_sample() const { return state_->pipelines.at(1u); }
void PipelineSamples::set_multisample_fragment(gpu::ShaderModule fragment) {
  const std::lock_guard lock(state_->mutex);
  state_->multisample_fragment.emplace(std::move(fragment));
}
bool PipelineSamples::alpha_to_coverage() const { return state_->alpha_to_coverage; }

gpu::RenderPipelineDescriptor lit_mesh_pipeline_descriptor(std::string label, const gpu::PipelineLayout& layout,
                                                           gpu::Format color_format, gpu::Format depth_format,
                                                           gpu::VertexBufferLayout vertices) {
  return {.label = std::move(label),
          .layout = &layout,
          .vertex_buffers = {std::move(vertices)},
          .cull_mode = gpu::CullMode::None,
          .color_targets = {{color_format}},
          .depth_stencil = gpu::DepthStencilState{.format = depth_format}};
}

Result<PipelineSamples> create_lit_mesh_pipelines(gpu::Device& device, std::string label,
                                                  std::shared_ptr<const gpu::PipelineLayout> layout,
                                                  gpu::ShaderModule vertex,
                                                  gpu::ShaderModule fragment, gpu::VertexBufferLayout vertices,
                                                  bool alpha_to_coverage) {
  if (!layout) return fail(ErrorKind::InvalidArgument, "render pipeline '{}': no pipeline layout", label);
  auto desc = lit_mesh_pipeline_descriptor(std::move(label), *layout, scene_color_format, scene_depth_format, std::move(vertices));
  return PipelineSamples::create(
      device, std::move(layout), std::move(desc),
      std::move(vertex), std::move(fragment), alpha_to_coverage);
}

Result<TextureHandle> add_resolve_pass(RenderGraph& graph, std::string name, TextureHandle source,
                                       gpu::ResolveMode depth_mode) {
  const auto desc = graph.texture_desc(source);
  if (!desc) return fail(ErrorKind::InvalidArgument, "resolve pass '{}': the source is not a texture of this graph", name);
  if (desc->sample_count == 1)
    return fail(ErrorKind::InvalidArgument, "resolve pass '{}': texture '{}' has one sample; nothing to resolve", name,
                graph.resource_name(source.index));
  const bool depth = gpu::format_info(desc->format).depth;
  struct Data {
    TextureHandle source, target;
  };
  TextureDesc single = *desc;
  single.sample_count = 1;
  single.extra_usage = gpu::TextureUsage::None;
  auto& data = graph.add_pass<Data>(
      name,
      [&](PassBuilder& b, Data& d) {
        // Read, not written, so any number of passes can resolve one version and others go on
        // drawing into it: colour resolves as a transfer (the source a copy source), depth in a
        // render pass whose multisampled attachment is read-only.
        d.source = b.read(source, depth ? TextureUse::DepthRead : TextureUse::CopySrc);
        d.target = b.write(b.create_texture(name, single), depth ? TextureUse::DepthAttachment : TextureUse::CopyDst);
      },
      [name, depth, depth_mode](const PassResources& res, const Data& d, PassContext& ctx) {
        if (!depth) return ctx.encoder().resolve_texture(res.texture(d.source), res.texture(d.target));
        gpu::RenderPassDescriptor pass{.label = name};
        pass.depth_attachment = gpu::DepthAttachment{.view = &res.view(d.source), .load = gpu::LoadOp::Load,
                                                     .read_only = true, .resolve_target = &res.view(d.target),
                                                     .resolve_mode = depth_mode};
        ctx.encoder().begin_render_pass(pass).end();
      });
  return data.target;
}

}  // namespace weft::frame
