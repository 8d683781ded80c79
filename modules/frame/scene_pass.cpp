// The frame's shared targets on the blackboard, and the one helper that draws lit meshes into
// the scene colour (forward, shell_fur, skin_sss, ssdf_lighting, neural_btf and user features).
module;
#include <cstdint>
#include <expected>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <weft/try.h>
module weft.frame;
import weft.core;
import weft.gpu;
import weft.graph;

namespace weft::frame {

namespace {
// The only place the well-known keys are written.
constexpr std::string_view uniforms_key = "frame_uniforms";
constexpr std::string_view environment_key = "environment";
constexpr std::string_view shadow_map_key = "shadow_map";
constexpr std::string_view color_key = "scene_color";
constexpr std::string_view depth_key = "scene_depth";
}  // namespace

namespace {
template <class Handle>
Result<Handle> lookup(const Blackboard& board, std::string_view key, bool needed) {
  if (needed) return board.get<Handle>(key);
  return board.find<Handle>(key).value_or(Handle{});
}
}  // namespace

Result<SceneTargets> scene_targets(const Blackboard& board, SceneTargetNeeds needs) {
  SceneTargets t;
  WEFT_TRY(t.uniforms, lookup<BufferHandle>(board, uniforms_key, needs.uniforms));
  WEFT_TRY(t.environment, lookup<TextureHandle>(board, environment_key, needs.environment));
  WEFT_TRY(t.shadow_map, lookup<TextureHandle>(board, shadow_map_key, needs.shadow_map));
  WEFT_TRY(t.color, lookup<TextureHandle>(board, color_key, needs.color));
  WEFT_TRY(t.depth, lookup<TextureHandle>(board, depth_key, needs.depth));
  return t;
}

std::uint32_t scene_sample_count(const RenderGraph& graph) {
  const auto color = graph.blackboard().find<TextureHandle>(color_key);
  if (!color || !*color) return 1;
  const auto desc = graph.texture_desc(*color);
  return desc ? desc->sample_count : 1;
}

void put_scene_targets(Blackboard& board, const SceneTargets& t) {
  if (t.uniforms) board.put(uniforms_key, t.uniforms);
  if (t.environment) board.put(environment_key, t.environment);
  if (t.shadow_map) board.put(shadow_map_key, t.shadow_map);
  if (t.color) board.put(color_key, t.color);
  if (t.depth) board.put(depth_key, t.depth);
}

Result<void> add_scene_color_pass(RenderGraph& graph, ScenePassDesc desc, DrawScene draw) {
  WEFT_TRY(SceneTargets shared, scene_targets(graph.blackboard(), {.environment = desc.reads_environment,
                                                                 .color = !desc.clear_color,
                                                                 .depth = !desc.clear_color}));
  // Persistent assets: each one imported once, however many draws use it, so the graph
  // shows (and orders) it once.
  std::vector<std::pair<const gpu::Texture*, TextureHandle>> textures;
  std::vector<std::pair<const gpu::Buffer*, BufferHandle>> buffers;
  for (const auto& t : desc.textures) {
    if (!t.texture) continue;
    bool seen = false;
    for (const auto& [known, handle] : textures) seen = seen || known == t.texture;
    if (!seen) textures.emplace_back(t.texture, graph.import_texture(t.label, t.texture, gpu::Access::ShaderRead));
  }
  for (const auto& b : desc.buffers) {
    if (!b.buffer) continue;
    bool seen = false;
    for (const auto& [known, handle] : buffers) seen = seen || known == b.buffer;
    if (!seen) buffers.emplace_back(b.buffer, graph.import_buffer(b.label, b.buffer, gpu::Access::StorageRead));
  }

  struct Data {
    SceneTargets targets;
  };
  const bool environment = desc.reads_environment;
  const std::optional<vec4> clear = desc.clear_color;
  const std::uint32_t samples = clear ? desc.samples : scene_sample_count(graph);
  auto& data = graph.add_pass<Data>(
      desc.name,
      [&](PassBuilder& b, Data& d) {
        d.targets.uniforms = b.read(shared.uniforms, BufferUse::Uniform);
        d.targets.shadow_map = b.read(shared.shadow_map, TextureUse::Sampled);
        if (environment) d.targets.environment = b.read(shared.environment, TextureUse::Sampled);
        for (const auto& [texture, handle] : textures) b.read(handle, TextureUse::Sampled);
        for (const auto& [buffer, handle] : buffers) b.read(handle, BufferUse::StorageRead);
        const TextureHandle color =
            clear ? b.create_texture(color_key, {.size = RelativeSize{1.0f}, .format = scene_color_format, .sample_count = samples})
                  : shared.color;
        const TextureHandle depth =
            clear ? b.create_texture(depth_key, {.size = RelativeSize{1.0f}, .format = scene_depth_format, .sample_count = samples})
                  : shared.depth;
        d.targets.color = b.write(color, TextureUse::ColorAttachment);
        d.targets.depth = b.write(depth, TextureUse::DepthAttachment);
      },
      [name = desc.name, clear, samples, draw_scene = std::move(draw)](const PassResources& res, const Data& d,
                                                                        PassContext& ctx) {
        const gpu::LoadOp load = clear ? gpu::LoadOp::Clear : gpu::LoadOp::Load;
        auto pass = ctx.encoder().begin_render_pass(
            {.label = name,
             .color_attachments = {{.view = &res.view(d.targets.color), .load = load,
                                    .clear_color = clear.value_or(vec4(0.0f, 0.0f, 0.0f, 1.0f))}},
             .depth_attachment = gpu::DepthAttachment{.view = &res.view(d.targets.depth), .load = load}});
        ScenePassDraw scene{.pass = pass,
                            .context = ctx,
                            .uniforms = res.buffer(d.targets.uniforms),
                            .shadow_map = res.view(d.targets.shadow_map),
                            .environment = d.targets.environment ? &res.view(d.targets.environment) : nullptr,
                            .samples = samples};
        draw_scene(scene);
        pass.end();
      });
  put_scene_targets(graph.blackboard(), {.color = data.targets.color, .depth = data.targets.depth});
  return {};
}

}  // namespace weft::frame
