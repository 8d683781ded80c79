// Dear ImGui's draw lists drawn by a pass of the frame's graph, through weft.gpu (Debian's
// imgui_impl_vulkan would put Vulkan calls outside the backend). Vertices and indices go
// into host-visible buffers the graph imports; the font atlas is a sampled texture.
module;
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <expected>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>
#include <imgui.h>
module weft.viewer;
import weft.core;
import weft.gpu;
import weft.graph;

namespace weft::viewer::detail {

namespace {
constexpr const char* vertex_glsl = R"(#version 450
layout(location = 0) in vec2 position;
layout(location = 1) in vec2 uv;
layout(location = 2) in vec4 color;
layout(push_constant) uniform Push { vec2 scale; vec2 translate; } push;
layout(location = 0) out vec2 out_uv;
layout(location = 1) out vec4 out_color;
void main() {
  out_uv = uv;
  out_color = color;
  gl_Position = vec4(position * push.scale + push.translate, 0.0, 1.0);
}
)";
// The target is a UNORM window texture showing sRGB-encoded values, as ImGui's colours are.
constexpr const char* fragment_glsl = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D atlas;
layout(location = 0) in vec2 uv;
layout(location = 1) in vec4 color;
layout(location = 0) out vec4 out_color;
void main() { out_color = color * texture(atlas, uv); }
)";
struct Push {
  float scale[2];
  float translate[2];
};
}  // namespace

struct UiRenderer::State {
  gpu::Device* device = nullptr;
  gpu::BindGroupLayout bind_layout;
  gpu::PipelineLayout layout;
  gpu::RenderPipeline pipeline;
  gpu::Sampler sampler;
  gpu::Texture atlas;
  gpu::BindGroup atlas_group;
  std::optional<gpu::Buffer> vertices, indices;
};

Result<UiRenderer> UiRenderer::create(gpu::Device& device, gpu::Format target) {
  auto vs = device.create_shader_module({.label = "ui.vert", .stage = gpu::ShaderStage::Vertex, .glsl = vertex_glsl});
  if (!vs) return std::unexpected(vs.error());
  auto fs = device.create_shader_module({.label = "ui.frag", .stage = gpu::ShaderStage::Fragment, .glsl = fragment_glsl});
  if (!fs) return std::unexpected(fs.error());
  auto bind_layout = device.create_bind_group_layout(
      {.label = "ui", .entries = {{0, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment}}});
  if (!bind_layout) return std::unexpected(bind_layout.error());
  auto layout = device.create_pipeline_layout(
      {.label = "ui", .bind_group_layouts = {&*bind_layout}, .push_constant_size = sizeof(Push)});
  if (!layout) return std::unexpected(layout.error());
  gpu::VertexBufferLayout vertex_layout{
      .stride = sizeof(ImDrawVert),
      .attributes = {{gpu::VertexFormat::Float32x2, std::uint32_t(offsetof(ImDrawVert, pos)), 0},
                     {gpu::VertexFormat::Float32x2, std::uint32_t(offsetof(ImDrawVert, uv)), 1},
                     {gpu::VertexFormat::Unorm8x4, std::uint32_t(offsetof(ImDrawVert, col)), 2}}};
  auto pipeline = device.create_render_pipeline({.label = "ui", .layout = &*layout, .vertex = &*vs, .fragment = &*fs,
                                                 .vertex_buffers = {vertex_layout},
                                                 .color_targets = {{target, gpu::BlendMode::Alpha}}});
  if (!pipeline) return std::unexpected(pipeline.error());
  auto sampler = device.create_sampler({.label = "ui"});
  if (!sampler) return std::unexpected(sampler.error());

  unsigned char* pixels = nullptr;
  int width = 0, height = 0;
  ImGui::GetIO().Fonts->GetTexDataAsRGBA32(&pixels, &width, &height);
  auto atlas = device.create_texture({.label = "ui font atlas", .size = {std::uint32_t(width), std::uint32_t(height), 1},
                                      .format = gpu::Format::RGBA8Unorm,
                                      .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
  if (!atlas) return std::unexpected(atlas.error());
  if (auto ok = device.queue().write_texture(
          *atlas, std::as_bytes(std::span(pixels, std::size_t(width) * std::size_t(height) * 4)));
      !ok)
    return std::unexpected(ok.error());
  auto group = device.create_bind_group(
      {.label = "ui font atlas", .layout = &*bind_layout, .entries = {gpu::bind(0, atlas->view(), &*sampler)}});
  if (!group) return std::unexpected(group.error());
  UiRenderer r;
  r.state_ = std::make_shared<State>(State{&device, std::move(*bind_layout), std::move(*layout), std::move(*pipeline),
                                           std::move(*sampler), std::move(*atlas), std::move(*group), {}, {}});
  return r;
}

// Grows a host-visible buffer to hold `bytes` (by doubling, so a busy UI stops reallocating).
static Result<void> ensure(gpu::Device& device, std::optional<gpu::Buffer>& buffer, std::uint64_t bytes,
                           gpu::BufferUsage usage, const char* label) {
  if (buffer && buffer->size() >= bytes) return {};
  std::uint64_t size = buffer ? buffer->size() : 64 * 1024;
  while (size < bytes) size *= 2;
  buffer.reset();
  auto made = device.create_buffer({.label = label, .size = size, .usage = usage | gpu::BufferUsage::MapWrite});
  if (!made) return std::unexpected(made.error());
  buffer.emplace(std::move(*made));
  return {};
}

Result<TextureHandle> UiRenderer::add_pass(RenderGraph& graph, TextureHandle target, const void* draw_data_ptr) {
  const auto* draw_data = static_cast<const ImDrawData*>(draw_data_ptr);
  auto& s = *state_;
  // Indices widened to 32 bits (weft.gpu binds uint32 index buffers).
  const std::uint64_t vertex_bytes = std::max<std::uint64_t>(std::uint64_t(draw_data->TotalVtxCount) * sizeof(ImDrawVert), 4);
  const std::uint64_t index_bytes = std::max<std::uint64_t>(std::uint64_t(draw_data->TotalIdxCount) * 4, 4);
  if (auto ok = ensure(*s.device, s.vertices, vertex_bytes, gpu::BufferUsage::Vertex, "ui vertices"); !ok)
    return std::unexpected(ok.error());
  if (auto ok = ensure(*s.device, s.indices, index_bytes, gpu::BufferUsage::Index, "ui indices"); !ok)
    return std::unexpected(ok.error());
  auto vertex_span = s.vertices->mapped();
  auto index_span = s.indices->mapped();
  if (!vertex_span) return std::unexpected(vertex_span.error());
  if (!index_span) return std::unexpected(index_span.error());
  auto* vertex_out = reinterpret_cast<ImDrawVert*>(vertex_span->data());
  auto* index_out = reinterpret_cast<std::uint32_t*>(index_span->data());

  struct Draw {
    std::uint32_t index_count, first_index;
    std::int32_t base_vertex;
    std::int32_t x, y;
    std::uint32_t w, h;
  };
  auto draws = std::make_shared<std::vector<Draw>>();
  std::uint32_t vertex_base = 0, index_base = 0;
  const ImVec2 origin = draw_data->DisplayPos, scale = draw_data->FramebufferScale;
  for (int l = 0; l < draw_data->CmdListsCount; ++l) {
    const ImDrawList* list = draw_data->CmdLists[l];
    std::memcpy(vertex_out + vertex_base, list->VtxBuffer.Data, std::size_t(list->VtxBuffer.Size) * sizeof(ImDrawVert));
    for (int i = 0; i < list->IdxBuffer.Size; ++i) index_out[index_base + i] = list->IdxBuffer.Data[i];
    for (const ImDrawCmd& cmd : list->CmdBuffer) {
      if (cmd.UserCallback || cmd.ElemCount == 0) continue;
      const float x0 = (cmd.ClipRect.x - origin.x) * scale.x, y0 = (cmd.ClipRect.y - origin.y) * scale.y;
      const float x1 = (cmd.ClipRect.z - origin.x) * scale.x, y1 = (cmd.ClipRect.w - origin.y) * scale.y;
      if (x1 <= x0 || y1 <= y0) continue;
      draws->push_back({cmd.ElemCount, index_base + cmd.IdxOffset, std::int32_t(vertex_base + cmd.VtxOffset),
                        std::int32_t(x0), std::int32_t(y0), std::uint32_t(x1 - x0), std::uint32_t(y1 - y0)});
    }
    vertex_base += std::uint32_t(list->VtxBuffer.Size);
    index_base += std::uint32_t(list->IdxBuffer.Size);
  }
  const Push push{{2.0f / draw_data->DisplaySize.x, 2.0f / draw_data->DisplaySize.y},
                  {-1.0f - origin.x * 2.0f / draw_data->DisplaySize.x, -1.0f - origin.y * 2.0f / draw_data->DisplaySize.y}};

  struct Data {
    TextureHandle target;
    BufferHandle vertices, indices;
    TextureHandle atlas;
  };
  const BufferHandle vertices = graph.import_buffer("ui vertices", &*s.vertices, gpu::Access::HostWrite);
  const BufferHandle indices = graph.import_buffer("ui indices", &*s.indices, gpu::Access::HostWrite);
  const TextureHandle atlas = graph.import_texture("ui font atlas", &s.atlas, gpu::Access::ShaderRead);
  auto state = state_;
  auto& data = graph.add_pass<Data>(
      "ui",
      [&](PassBuilder& b, Data& d) {
        d.target = b.write(target, TextureUse::ColorAttachment);
        d.vertices = b.read(vertices, BufferUse::Vertex);
        d.indices = b.read(indices, BufferUse::Index);
        d.atlas = b.read(atlas, TextureUse::Sampled);
      },
      [state, draws, push](const PassResources& res, const Data& d, PassContext& ctx) {
        auto pass = ctx.encoder().begin_render_pass(
            {.label = "ui", .color_attachments = {{.view = &res.view(d.target), .load = gpu::LoadOp::Load}}});
        pass.set_pipeline(state->pipeline);
        pass.set_bind_group(0, state->atlas_group);
        pass.set_vertex_buffer(0, res.buffer(d.vertices));
        pass.set_index_buffer(res.buffer(d.indices));
        pass.push(push);
        for (const Draw& draw : *draws) {
          pass.set_scissor_rect(draw.x, draw.y, draw.w, draw.h);
          pass.draw_indexed(draw.index_count, 1, draw.first_index, draw.base_vertex);
        }
        pass.end();
      });
  return data.target;
}

}  // namespace weft::viewer::detail
