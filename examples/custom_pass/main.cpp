// weft-custom-pass: a frame of three passes — a procedural scene (render), the user-written
// Sobel edge pass (compute, sobel_edge_pass.cppm) and a readback copy (transfer) — compiled
// and executed by the render graph, then saved as a PNG.
//
//   weft-custom-pass [output.png] [--size WxH] [--dot graph.dot] [--check]
//
// --check turns on the validation layer with synchronization validation and fails on any
// message (this is how ctest runs it).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <vector>
#include <weft/args.h>
import weft.core;
import weft.gpu;
import weft.graph;
import weft.image;
import custom.sobel;

using namespace weft;

namespace {

constexpr const char* fullscreen_vert = R"(#version 460
void main() {
  vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
})";

// Three discs over a soft gradient: something with edges to find.
constexpr const char* scene_frag = R"(#version 460
layout(location = 0) out vec4 color;
layout(push_constant) uniform Push { vec2 size; };
void main() {
  vec2 uv = gl_FragCoord.xy / size.y;  // y in [0, 1], x scaled by the aspect ratio
  float right = size.x / size.y;
  vec3 c = mix(vec3(0.10, 0.12, 0.20), vec3(0.35, 0.30, 0.25), uv.y);
  if (distance(uv, vec2(0.30 * right, 0.40)) < 0.18) c = vec3(0.90, 0.35, 0.20);
  if (distance(uv, vec2(0.65 * right, 0.55)) < 0.22) c = vec3(0.20, 0.70, 0.45);
  if (distance(uv, vec2(0.50 * right, 0.80)) < 0.10) c = vec3(0.95, 0.90, 0.30);
  color = vec4(c, 1.0);
})";

struct ScenePipeline {
  gpu::PipelineLayout layout;
  gpu::RenderPipeline pipeline;
};

Result<ScenePipeline> make_scene_pipeline(gpu::Device& device) {
  auto vs = device.create_shader_module({.label = "fullscreen.vert", .stage = gpu::ShaderStage::Vertex, .glsl = fullscreen_vert});
  if (!vs) return std::unexpected(vs.error());
  auto fs = device.create_shader_module({.label = "scene.frag", .stage = gpu::ShaderStage::Fragment, .glsl = scene_frag});
  if (!fs) return std::unexpected(fs.error());
  auto layout = device.create_pipeline_layout({.label = "scene", .push_constant_size = 2 * sizeof(float)});
  if (!layout) return std::unexpected(layout.error());
  auto pipeline = device.create_render_pipeline({.label = "scene", .layout = &*layout, .vertex = &*vs, .fragment = &*fs,
                                                 .color_targets = {{gpu::Format::RGBA8Unorm}}});
  if (!pipeline) return std::unexpected(pipeline.error());
  return ScenePipeline{std::move(*layout), std::move(*pipeline)};
}

int run(int argc, char** argv) {
  std::filesystem::path output = "custom_pass.png";
  std::string dot_path;
  std::uint32_t width = 640, height = 360;
  bool check = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--size") == 0 && i + 1 < argc) {
      if (!weft::args::size_into(argv[++i], 8192, width, height)) {
        std::fprintf(stderr, "weft-custom-pass: --size wants WxH with sides 1..8192 (e.g. 640x360), got '%s'\n", argv[i]);
        return 2;
      }
    } else if (std::strcmp(argv[i], "--dot") == 0 && i + 1 < argc) {
      dot_path = argv[++i];
    } else if (std::strcmp(argv[i], "--check") == 0) {
      check = true;
    } else if (std::strcmp(argv[i], "-h") == 0 || std::strcmp(argv[i], "--help") == 0) {
      std::printf("usage: weft-custom-pass [output.png] [--size WxH] [--dot graph.dot] [--check]\n");
      return 0;
    } else if (argv[i][0] == '-') {
      std::fprintf(stderr, "weft-custom-pass: unknown or incomplete argument '%s'\n"
                           "usage: weft-custom-pass [output.png] [--size WxH] [--dot graph.dot] [--check]\n", argv[i]);
      return 2;
    } else {
      output = argv[i];
    }
  }

  auto instance = gpu::Instance::create(
      {.application_name = "weft-custom-pass", .validation = check, .synchronization_validation = check});
  if (!instance) return std::fprintf(stderr, "%s\n", instance.error().what().c_str()), 1;
  auto adapter = instance->request_adapter();
  if (!adapter) return std::fprintf(stderr, "%s\n", adapter.error().what().c_str()), 1;
  auto device = adapter->request_device({.label = "custom-pass"});
  if (!device) return std::fprintf(stderr, "%s\n", device.error().what().c_str()), 1;
  std::printf("adapter: %s\n", adapter->info().name.c_str());

  auto scene = make_scene_pipeline(*device);
  if (!scene) return std::fprintf(stderr, "%s\n", scene.error().what().c_str()), 1;
  auto sobel = custom::SobelEdgePass::create(*device);
  if (!sobel) return std::fprintf(stderr, "%s\n", sobel.error().what().c_str()), 1;
  auto readback = device->create_buffer({.label = "readback", .size = std::uint64_t(width) * height * 4,
                                         .usage = gpu::BufferUsage::MapRead | gpu::BufferUsage::CopyDst});
  if (!readback) return std::fprintf(stderr, "%s\n", readback.error().what().c_str()), 1;

  RenderGraph graph("custom_pass");

  // Pass 1: the scene, drawn into a transient texture the size of the output.
  struct SceneData {
    TextureHandle color;
  };
  const float size[2] = {float(width), float(height)};
  auto& scene_pass = graph.add_pass<SceneData>(
      "scene",
      [&](PassBuilder& b, SceneData& d) {
        d.color = b.write(b.create_texture("scene_color", {.size = RelativeSize{1.0f}}), TextureUse::ColorAttachment);
        b.blackboard().put("scene_color", d.color);
      },
      [&scene, size](const PassResources& res, const SceneData& d, PassContext& ctx) {
        auto pass = ctx.encoder().begin_render_pass({.label = "scene", .color_attachments = {{.view = &res.view(d.color)}}});
        pass.set_pipeline(scene->pipeline);
        pass.push(size);
        pass.draw(3);
        pass.end();
      });

  // Pass 2: the user-written pass, added in one line.
  const TextureHandle edges = sobel->add(graph, scene_pass.color, {.strength = 2.0f});

  // Pass 3: copy the edges into a host-visible buffer; the buffer is the frame's output.
  struct ReadbackData {
    TextureHandle edges;
    BufferHandle buffer;
  };
  const BufferHandle readback_handle = graph.import_buffer("readback", &*readback, gpu::Access::Undefined);
  auto& copy = graph.add_pass<ReadbackData>(
      "readback",
      [&](PassBuilder& b, ReadbackData& d) {
        d.edges = b.read(edges, TextureUse::CopySrc);
        d.buffer = b.write(readback_handle, BufferUse::CopyDst);
      },
      [](const PassResources& res, const ReadbackData& d, PassContext& ctx) {
        ctx.encoder().copy_texture_to_buffer(res.texture(d.edges), res.buffer(d.buffer), 0);
      });
  graph.mark_output(copy.buffer, gpu::Access::HostRead);

  auto compiled = graph.compile({.output_extent = {width, height, 1}, .device = &*device});
  if (!compiled) return std::fprintf(stderr, "%s\n", compiled.error().to_string().c_str()), 1;
  std::printf("%s", compiled->dump().c_str());
  if (!dot_path.empty()) {
    const std::string dot = compiled->to_dot();
    if (auto ok = write_file_atomically(dot_path, {std::as_bytes(std::span(dot))}, "DOT graph"); !ok)
      return std::fprintf(stderr, "weft-custom-pass: %s\n", ok.error().what().c_str()), 1;
    std::printf("wrote %s (render with: dot -Tsvg %s -o graph.svg)\n", dot_path.c_str(), dot_path.c_str());
  }

  auto stats = compiled->execute(*device);
  if (!stats) return std::fprintf(stderr, "%s\n", stats.error().what().c_str()), 1;
  std::printf("\n%s", stats->format_table().c_str());

  auto bytes = readback->mapped();
  if (!bytes) return std::fprintf(stderr, "%s\n", bytes.error().what().c_str()), 1;
  image::Image8 picture = image::Image8::filled(width, height, 4);
  std::memcpy(picture.pixels.data(), bytes->data(), picture.pixels.size());
  std::size_t edge_pixels = 0;
  for (std::size_t i = 0; i < picture.pixels.size(); i += 4) edge_pixels += picture.pixels[i] > 128 ? 1 : 0;
  if (auto saved = image::save_png(output, picture); !saved)
    return std::fprintf(stderr, "%s\n", saved.error().what().c_str()), 1;
  std::printf("\nwrote %s (%ux%u, %zu edge pixels)\n", output.string().c_str(), width, height, edge_pixels);

  if (check) {
    const auto messages = instance->take_validation_messages();
    for (const auto& m : messages) std::fprintf(stderr, "validation: %s\n", m.c_str());
    if (!messages.empty()) return 1;
    if (edge_pixels == 0) return std::fprintf(stderr, "no edges found\n"), 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return run(argc, argv); }
