// FurFrame: ShellFurPass in a frame of its own (clear -> fur -> readback), for the fur tests
// and benchmark, which need a camera the scene format does not have.
module;
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <expected>
#include <memory>
#include <optional>
#include <span>
#include <vector>
#include <glm/glm.hpp>
#include <glm/gtc/packing.hpp>
module weft.example.fur_frame;
import weft.pass.shell_fur;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.image;

namespace weft::passes {

using namespace fur;

struct FurFrame::State {
  gpu::Device* device = nullptr;
  FurFrameSettings settings;
  gpu::Buffer uniforms;
  gpu::Texture shadow, color, depth;
  std::optional<CompiledGraph> graph;
};

FurFrame::FurFrame(FurFrame&&) noexcept = default;
FurFrame& FurFrame::operator=(FurFrame&&) noexcept = default;
FurFrame::~FurFrame() = default;

Result<FurFrame> FurFrame::create(gpu::Device& device, const FurFrameSettings& s) {
  if (s.width == 0 || s.height == 0 || s.width > 16384 || s.height > 16384)
    return fail(ErrorKind::InvalidArgument, "fur frame: size {}x{} must be within 1..16384", s.width, s.height);
  frame::FrameUniforms u;
  u.view = s.view;
  u.projection = s.projection;
  u.view_projection = s.projection * s.view;
  u.inverse_view_projection = glm::inverse(u.view_projection);
  u.light_view_projection = mat4(1.0f);
  u.camera_position = vec4(s.camera_position, 1.0f);
  const float length = glm::length(s.towards_light);
  u.light_direction = vec4(length > 0.0f ? s.towards_light / length : vec3(0, 1, 0), 0.0f);
  u.light_color = vec4(s.light_radiance, 0.0f);
  u.environment = vec4(1.0f, 0.0f, 0.0f, 0.0f);
  u.viewport = vec4(float(s.width), float(s.height), 1.0f / float(s.width), 1.0f / float(s.height));
  u.irradiance_sh = frame::constant_irradiance_sh(s.sky_radiance);
  auto uniforms = device.create_buffer_with_data(
      {.label = "fur_frame.uniforms", .size = sizeof(u), .usage = gpu::BufferUsage::Uniform}, std::as_bytes(std::span(&u, 1)));
  if (!uniforms) return std::unexpected(uniforms.error());
  // A 1x1 shadow map at the far plane: nothing is in shadow.
  auto shadow = device.create_texture({.label = "fur_frame.no_shadow", .size = {1, 1, 1}, .format = gpu::Format::Depth32Float,
                                       .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
  if (!shadow) return std::unexpected(shadow.error());
  const float far_depth = 1.0f;
  if (auto ok = device.queue().write_texture(*shadow, std::as_bytes(std::span(&far_depth, 1))); !ok)
    return std::unexpected(ok.error());
  auto color = device.create_texture({.label = "fur_frame.color", .size = {s.width, s.height, 1},
                                      .format = gpu::Format::RGBA16Float,
                                      .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
  if (!color) return std::unexpected(color.error());
  auto depth = device.create_texture({.label = "fur_frame.depth", .size = {s.width, s.height, 1},
                                      .format = gpu::Format::Depth32Float, .usage = gpu::TextureUsage::DepthAttachment});
  if (!depth) return std::unexpected(depth.error());
  FurFrame f;
  f.state_ = std::make_unique<State>(State{&device, s, std::move(*uniforms), std::move(*shadow), std::move(*color),
                                           std::move(*depth), std::nullopt});
  return f;
}

Result<void> FurFrame::set_draws(const ShellFurPass& pass, std::span<const ShellFurDraw> draws) {
  State& s = *state_;
  s.graph.reset();
  RenderGraph graph("fur_frame");
  auto& board = graph.blackboard();
  frame::put_scene_targets(board, {.uniforms = graph.import_buffer("frame_uniforms", &s.uniforms, gpu::Access::UniformRead),
                                   .shadow_map = graph.import_texture("no_shadow", &s.shadow, gpu::Access::ShaderRead)});
  struct Clear {
    TextureHandle color, depth;
  };
  const vec4 clear_color = s.settings.clear_color;
  const TextureHandle color = graph.import_texture("scene_color", &s.color, gpu::Access::Undefined);
  const TextureHandle depth = graph.import_texture("scene_depth", &s.depth, gpu::Access::Undefined);
  auto& clear = graph.add_pass<Clear>(
      "clear",
      [&](PassBuilder& b, Clear& d) {
        d.color = b.write(color, TextureUse::ColorAttachment);
        d.depth = b.write(depth, TextureUse::DepthAttachment);
      },
      [clear_color](const PassResources& res, const Clear& d, PassContext& ctx) {
        auto p = ctx.encoder().begin_render_pass({.label = "clear",
                                                  .color_attachments = {{.view = &res.view(d.color), .clear_color = clear_color}},
                                                  .depth_attachment = gpu::DepthAttachment{.view = &res.view(d.depth)}});
        p.end();
      });
  frame::put_scene_targets(board, {.color = clear.color, .depth = clear.depth});
  if (auto ok = pass.add(graph, draws); !ok) return ok;
  auto targets = frame::scene_targets(board, {.environment = false});
  if (!targets) return std::unexpected(targets.error());
  graph.mark_output(targets->color, gpu::Access::CopySrc);
  auto compiled = graph.compile({.output_extent = {s.settings.width, s.settings.height, 1}, .device = s.device});
  if (!compiled) return std::unexpected(compiled.error().to_error());
  s.graph.emplace(std::move(*compiled));
  return {};
}

Result<FrameStats> FurFrame::execute(bool timestamps) {
  State& s = *state_;
  if (!s.graph) return fail(ErrorKind::InvalidArgument, "fur frame: set_draws() before execute()");
  return s.graph->execute(*s.device, {.timestamps = timestamps});
}

Result<image::Image> FurFrame::read_color() {
  State& s = *state_;
  auto bytes = s.device->queue().read_texture(s.color);
  if (!bytes) return std::unexpected(bytes.error());
  image::Image out = image::Image::filled(s.settings.width, s.settings.height, 4);
  if (bytes->size() != out.pixels.size() * 2)
    return fail(ErrorKind::Internal, "fur frame: read {} bytes for {} half floats", bytes->size(), out.pixels.size());
  for (std::size_t i = 0; i < out.pixels.size(); ++i) {
    std::uint16_t half = 0;
    std::memcpy(&half, bytes->data() + 2 * i, 2);
    out.pixels[i] = glm::unpackHalf1x16(half);
  }
  return out;
}

}  // namespace weft::passes
