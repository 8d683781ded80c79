// weft-triangle: the smallest complete weft.gpu program. Builds a torus and a sphere on the
// CPU, renders them lit and depth-tested into an offscreen texture, reads it back, writes PNG.
//   weft-triangle [-o out.png] [--size WxH]
#include <glm/gtc/matrix_transform.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <expected>
#include <span>
#include <string>
#include <vector>
#include "weft-triangle_shaders.h"
#include <weft/args.h>
import weft.core;
import weft.gpu;
import weft.image;

using namespace weft;

namespace {

struct Vertex {
  vec3 position;
  vec3 normal;
};
struct Mesh {
  std::vector<Vertex> vertices;
  std::vector<std::uint32_t> indices;
};

// A (u, v) grid wrapped onto a surface by `at`, which returns position and normal.
template <class F>
Mesh parametric(std::uint32_t nu, std::uint32_t nv, F at) {
  Mesh m;
  for (std::uint32_t j = 0; j <= nv; ++j)
    for (std::uint32_t i = 0; i <= nu; ++i) m.vertices.push_back(at(float(i) / nu, float(j) / nv));
  for (std::uint32_t j = 0; j < nv; ++j)
    for (std::uint32_t i = 0; i < nu; ++i) {
      const std::uint32_t a = j * (nu + 1) + i, b = a + 1, c = a + nu + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
    }
  return m;
}

Mesh torus(float major, float minor) {
  return parametric(96, 48, [=](float u, float v) {
    const float a = u * 2 * pi, b = v * 2 * pi;
    const vec3 center{major * std::cos(a), 0, major * std::sin(a)};
    const vec3 n{std::cos(a) * std::cos(b), std::sin(b), std::sin(a) * std::cos(b)};
    return Vertex{center + minor * n, n};
  });
}

Mesh sphere(float radius) {
  return parametric(64, 32, [=](float u, float v) {
    const float phi = u * 2 * pi, theta = v * pi;
    const vec3 n{std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
    return Vertex{radius * n, n};
  });
}

struct DrawConstants {
  mat4 view_projection;
  mat4 model;
  vec4 albedo;
  vec4 light_direction;
  vec4 camera_position;
};

struct GpuMesh {
  gpu::Buffer vertices;
  gpu::Buffer indices;
  std::uint32_t index_count;
};

Result<GpuMesh> upload(gpu::Device& device, const Mesh& mesh, const std::string& label) {
  auto vb = device.create_buffer_with_data({.label = label + " vertices", .size = 0, .usage = gpu::BufferUsage::Vertex},
                                           std::as_bytes(std::span(mesh.vertices)));
  if (!vb) return std::unexpected(vb.error());
  auto ib = device.create_buffer_with_data({.label = label + " indices", .size = 0, .usage = gpu::BufferUsage::Index},
                                           std::as_bytes(std::span(mesh.indices)));
  if (!ib) return std::unexpected(ib.error());
  return GpuMesh{std::move(*vb), std::move(*ib), std::uint32_t(mesh.indices.size())};
}

Result<void> run(const std::string& output, std::uint32_t width, std::uint32_t height) {
  auto instance = gpu::Instance::create({.application_name = "weft-triangle"});
  if (!instance) return std::unexpected(instance.error());
  auto adapter = instance->request_adapter();
  if (!adapter) return std::unexpected(adapter.error());
  log::info(weft::format("adapter: {} ({}, {})", adapter->info().name, adapter->info().driver,
                         to_string(adapter->info().type)));
  auto device = adapter->request_device();
  if (!device) return std::unexpected(device.error());

  auto color = device->create_texture({.label = "color", .size = {width, height, 1}, .format = gpu::Format::RGBA8Unorm,
                                       .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
  if (!color) return std::unexpected(color.error());
  auto depth = device->create_texture({.label = "depth", .size = {width, height, 1}, .format = gpu::Format::Depth32Float,
                                       .usage = gpu::TextureUsage::DepthAttachment});
  if (!depth) return std::unexpected(depth.error());

  auto vs = device->create_shader_module({.label = "mesh.vert", .stage = gpu::ShaderStage::Vertex, .spirv = shaders::mesh_vert()});
  auto fs = device->create_shader_module({.label = "mesh.frag", .stage = gpu::ShaderStage::Fragment, .spirv = shaders::mesh_frag()});
  if (!vs) return std::unexpected(vs.error());
  if (!fs) return std::unexpected(fs.error());
  auto layout = device->create_pipeline_layout({.label = "mesh", .push_constant_size = sizeof(DrawConstants)});
  if (!layout) return std::unexpected(layout.error());
  auto pipeline = device->create_render_pipeline(
      {.label = "lit mesh",
       .layout = &*layout,
       .vertex = &*vs,
       .fragment = &*fs,
       .vertex_buffers = {{.stride = sizeof(Vertex),
                           .attributes = {{gpu::VertexFormat::Float32x3, 0, 0}, {gpu::VertexFormat::Float32x3, 12, 1}}}},
       .cull_mode = gpu::CullMode::Back,
       .front_face_clockwise = true,  // the projection flips y for Vulkan, which flips winding
       .color_targets = {{gpu::Format::RGBA8Unorm}},
       .depth_stencil = gpu::DepthStencilState{}});
  if (!pipeline) return std::unexpected(pipeline.error());

  auto ring = upload(*device, torus(1.0f, 0.35f), "torus");
  auto ball = upload(*device, sphere(0.7f), "sphere");
  if (!ring) return std::unexpected(ring.error());
  if (!ball) return std::unexpected(ball.error());

  const vec3 eye{0.0f, 2.2f, 3.6f};
  mat4 projection = glm::perspectiveRH_ZO(glm::radians(40.0f), float(width) / float(height), 0.1f, 50.0f);
  projection[1][1] *= -1.0f;  // Vulkan's clip space has y pointing down
  const mat4 view = glm::lookAtRH(eye, vec3(0.0f, 0.0f, 0.0f), vec3(0.0f, 1.0f, 0.0f));
  const vec4 light{glm::normalize(vec3(0.6f, 1.0f, 0.4f)), 0.0f};

  auto encoder = device->create_command_encoder("frame");
  if (!encoder) return std::unexpected(encoder.error());
  encoder->transition(*color, gpu::Access::ColorAttachment);
  encoder->transition(*depth, gpu::Access::DepthAttachment);
  {
    auto pass = encoder->begin_render_pass({.label = "lit meshes",
                                            .color_attachments = {{.view = &color->view(), .clear_color = {0.02f, 0.02f, 0.03f, 1.0f}}},
                                            .depth_attachment = gpu::DepthAttachment{.view = &depth->view()}});
    pass.set_pipeline(*pipeline);
    auto draw = [&](const GpuMesh& mesh, const mat4& model, vec3 albedo) {
      pass.push(DrawConstants{projection * view, model, vec4(albedo, 1.0f), light, vec4(eye, 1.0f)});
      pass.set_vertex_buffer(0, mesh.vertices);
      pass.set_index_buffer(mesh.indices);
      pass.draw_indexed(mesh.index_count);
    };
    draw(*ring, glm::rotate(mat4(1.0f), glm::radians(20.0f), vec3(1, 0, 0)), {0.80f, 0.32f, 0.10f});
    draw(*ball, glm::translate(mat4(1.0f), vec3(0.35f, 0.1f, 0.2f)), {0.15f, 0.45f, 0.80f});
    pass.end();
  }
  auto commands = encoder->finish();
  if (!commands) return std::unexpected(commands.error());
  if (auto ok = device->queue().submit(std::move(*commands)); !ok) return ok;
  auto pixels = device->queue().read_texture(*color);
  if (!pixels) return std::unexpected(pixels.error());

  image::Image8 out = image::Image8::filled(width, height, 4);
  std::memcpy(out.pixels.data(), pixels->data(), out.pixels.size());
  if (auto ok = image::save_png(output, out); !ok) return ok;
  if (instance->validation_enabled() && instance->validation_message_count() > 0)
    return fail(ErrorKind::Internal, "{} validation messages (see above)", instance->validation_message_count());
  log::info(weft::format("wrote {} ({}x{})", output, width, height));
  return {};
}

}  // namespace

int main(int argc, char** argv) {
  std::string output = "triangle.png";
  std::uint32_t width = 800, height = 600;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if ((arg == "-o" || arg == "--output") && i + 1 < argc) {
      output = argv[++i];
    } else if (arg == "--size" && i + 1 < argc) {
      if (!weft::args::size_into(argv[++i], 8192, width, height)) {
        std::fprintf(stderr, "weft-triangle: --size expects WxH with sides 1..8192, got '%s'\n", argv[i]);
        return 2;
      }
    } else if (arg == "-h" || arg == "--help") {
      std::printf("usage: weft-triangle [-o out.png] [--size WxH]\n");
      return 0;
    } else {
      std::fprintf(stderr, "weft-triangle: unknown or incomplete argument '%s'\nusage: weft-triangle [-o out.png] [--size WxH]\n",
                   arg.c_str());
      return 2;
    }
  }
  if (auto ok = run(output, width, height); !ok) {
    std::fprintf(stderr, "weft-triangle: %s\n", ok.error().what().c_str());
    return 1;
  }
  return 0;
}
