// weft.gpu on lavapipe (or a real GPU) under the validation layer: object lifetimes,
// round trips, compute and render results checked on the CPU, every misuse path.
#include <doctest/doctest.h>
#include <algorithm>
#include <array>
#include <span>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>
#include <unistd.h>
import weft.core;
import weft.gpu;
import weft.test.gpu;

using namespace weft;
using weft::test::expect_no_validation_messages;

namespace {
gpu::Device& device() { return weft::test::gpu().device; }

template <class T>
std::span<const std::byte> bytes_of(const std::vector<T>& v) {
  return std::as_bytes(std::span(v));
}

template <class T>
std::vector<T> as_vector(const std::vector<std::byte>& bytes) {
  std::vector<T> out(bytes.size() / sizeof(T));
  std::memcpy(out.data(), bytes.data(), out.size() * sizeof(T));
  return out;
}

std::filesystem::path temp_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("weft-test-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

constexpr const char* fullscreen_vs = R"(#version 460
layout(location = 0) out vec2 uv;
void main() {
  vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
  uv = p;
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
})";
}  // namespace

TEST_CASE("adapter and device report sane limits") {
  const auto& info = device().adapter_info();
  CHECK(!info.name.empty());
  CHECK(info.api_version_string() >= std::string("1.3"));
  CHECK(info.limits.max_texture_dimension_2d >= 4096);
  CHECK(info.limits.max_push_constant_size >= 128);
  CHECK(info.limits.max_compute_invocations >= 128);
  expect_no_validation_messages();
}

TEST_CASE("buffer round trip through staging and through a mapped buffer") {
  std::vector<std::uint32_t> data(1000);
  for (std::uint32_t i = 0; i < data.size(); ++i) data[i] = i * 2654435761u;
  auto buffer = device().create_buffer_with_data(
      {.label = "round-trip", .size = 4000, .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopySrc}, bytes_of(data));
  REQUIRE(buffer);
  auto back = device().queue().read_buffer(*buffer);
  REQUIRE(back);
  CHECK(as_vector<std::uint32_t>(*back) == data);

  auto mapped = device().create_buffer({.label = "mapped", .size = 64, .usage = gpu::BufferUsage::MapWrite});
  REQUIRE(mapped);
  REQUIRE(mapped->mapped());
  CHECK(mapped->mapped()->size() == 64);
  expect_no_validation_messages();
}

TEST_CASE("fill_buffer then copy, with the barrier the graph would place") {
  auto a = device().create_buffer({.label = "a", .size = 256, .usage = gpu::BufferUsage::CopyDst | gpu::BufferUsage::CopySrc});
  auto b = device().create_buffer({.label = "b", .size = 256, .usage = gpu::BufferUsage::MapRead});
  REQUIRE(a);
  REQUIRE(b);
  auto enc = device().create_command_encoder("fill-copy");
  REQUIRE(enc);
  enc->fill_buffer(*a, 0xdeadbeef);
  const gpu::BufferBarrier barrier{&*a, gpu::Access::CopyDst, gpu::Access::CopySrc};
  enc->barrier({}, std::span(&barrier, 1));
  enc->copy_buffer_to_buffer(*a, 0, *b, 0, 256);
  const gpu::BufferBarrier host{&*b, gpu::Access::CopyDst, gpu::Access::HostRead};
  enc->barrier({}, std::span(&host, 1));
  auto cmd = enc->finish();
  REQUIRE(cmd);
  REQUIRE(device().queue().submit(std::move(*cmd)));
  REQUIRE(device().queue().wait_idle());
  auto view = b->mapped();
  REQUIRE(view);
  std::uint32_t first = 0, last = 0;
  std::memcpy(&first, view->data(), 4);
  std::memcpy(&last, view->data() + 252, 4);
  CHECK(first == 0xdeadbeefu);
  CHECK(last == 0xdeadbeefu);
  expect_no_validation_messages();
}

TEST_CASE("one barrier call moves any number of textures: on the stack (3) and beyond it (20)") {
  for (std::uint32_t count : {3u, 20u}) {
    INFO(count << " textures");
    constexpr std::uint32_t side = 4;
    std::vector<gpu::Texture> textures;
    std::vector<gpu::Buffer> uploads, readbacks;
    for (std::uint32_t i = 0; i < count; ++i) {
      auto t = device().create_texture({.label = "many", .size = {side, side, 1}, .format = gpu::Format::R32Float,
                                        .usage = gpu::TextureUsage::CopyDst | gpu::TextureUsage::CopySrc |
                                                 gpu::TextureUsage::Sampled});
      REQUIRE(t);
      textures.push_back(std::move(*t));
      std::vector<float> values(side * side, float(i) + 0.5f);
      auto up = device().create_buffer_with_data({.label = "up", .size = side * side * 4, .usage = gpu::BufferUsage::CopySrc},
                                                 bytes_of(values));
      auto down = device().create_buffer(
          {.label = "down", .size = side * side * 4, .usage = gpu::BufferUsage::CopyDst | gpu::BufferUsage::MapRead});
      REQUIRE(up);
      REQUIRE(down);
      uploads.push_back(std::move(*up));
      readbacks.push_back(std::move(*down));
    }
    auto enc = device().create_command_encoder("many-barriers");
    REQUIRE(enc);
    std::vector<gpu::TextureBarrier> to_dst, to_src;
    for (const auto& t : textures) {
      to_dst.push_back({&t, gpu::Access::Undefined, gpu::Access::CopyDst});
      to_src.push_back({&t, gpu::Access::CopyDst, gpu::Access::CopySrc});
    }
    enc->barrier(to_dst, {});
    for (std::uint32_t i = 0; i < count; ++i) enc->copy_buffer_to_texture(uploads[i], 0, textures[i]);
    enc->barrier(to_src, {});
    for (std::uint32_t i = 0; i < count; ++i) enc->copy_texture_to_buffer(textures[i], readbacks[i], 0);
    std::vector<gpu::BufferBarrier> host;
    for (const auto& b : readbacks) host.push_back({&b, gpu::Access::CopyDst, gpu::Access::HostRead});
    enc->barrier({}, host);
    auto cmd = enc->finish();
    REQUIRE(cmd);
    REQUIRE(device().queue().submit(std::move(*cmd)));
    REQUIRE(device().queue().wait_idle());
    for (std::uint32_t i = 0; i < count; ++i) {
      auto view = readbacks[i].mapped();
      REQUIRE(view);
      float last = 0.0f;
      std::memcpy(&last, view->data() + (side * side - 1) * 4, 4);
      CHECK(last == float(i) + 0.5f);
      CHECK(textures[i].state() == gpu::Access::CopySrc);
    }
    expect_no_validation_messages();
  }
}

TEST_CASE("synchronization validation catches a missing barrier (so the suites can trust silence)") {
  auto a = device().create_buffer({.label = "hazard-a", .size = 256, .usage = gpu::BufferUsage::CopyDst | gpu::BufferUsage::CopySrc});
  auto b = device().create_buffer({.label = "hazard-b", .size = 256, .usage = gpu::BufferUsage::CopyDst});
  REQUIRE(a);
  REQUIRE(b);
  auto enc = device().create_command_encoder("hazard");
  REQUIRE(enc);
  enc->fill_buffer(*a, 1);
  enc->copy_buffer_to_buffer(*a, 0, *b, 0, 256);  // reads what fill wrote, no barrier
  auto cmd = enc->finish();
  REQUIRE(cmd);
  REQUIRE(device().queue().submit(std::move(*cmd)));
  REQUIRE(device().queue().wait_idle());
  auto messages = weft::test::gpu().instance.take_validation_messages();
  REQUIRE(!messages.empty());
  CHECK(std::any_of(messages.begin(), messages.end(), [](auto& m) { return contains(m, "SYNC-HAZARD-READ"); }));
}

TEST_CASE("compute shader result matches the CPU") {
  const std::uint32_t n = 4096;
  std::vector<float> input(n);
  for (std::uint32_t i = 0; i < n; ++i) input[i] = float(i) * 0.25f - 100.0f;
  auto in = device().create_buffer_with_data({.label = "in", .size = n * 4, .usage = gpu::BufferUsage::Storage}, bytes_of(input));
  auto out = device().create_buffer({.label = "out", .size = n * 4, .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopySrc});
  REQUIRE(in);
  REQUIRE(out);
  auto shader = device().create_shader_module({.label = "square-plus", .stage = gpu::ShaderStage::Compute, .glsl = R"(#version 460
layout(local_size_x = 64) in;
layout(set = 0, binding = 0) readonly buffer In { float x[]; };
layout(set = 0, binding = 1) writeonly buffer Out { float y[]; };
layout(push_constant) uniform P { float offset; uint n; };
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i < n) y[i] = x[i] * x[i] + offset;
})"});
  REQUIRE_MESSAGE(shader, (shader ? "" : shader.error().message));
  auto bgl = device().create_bind_group_layout(
      {.label = "square-bgl",
       .entries = {{0, gpu::BindingType::ReadOnlyStorageBuffer, gpu::ShaderStage::Compute},
                   {1, gpu::BindingType::StorageBuffer, gpu::ShaderStage::Compute}}});
  REQUIRE(bgl);
  auto layout = device().create_pipeline_layout({.label = "square-layout", .bind_group_layouts = {&*bgl}, .push_constant_size = 8});
  REQUIRE(layout);
  auto pipeline = device().create_compute_pipeline({.label = "square", .layout = &*layout, .module = &*shader});
  REQUIRE(pipeline);
  auto group = device().create_bind_group({.label = "square-group", .layout = &*bgl, .entries = {gpu::bind(0, *in), gpu::bind(1, *out)}});
  REQUIRE(group);
  auto enc = device().create_command_encoder("compute");
  REQUIRE(enc);
  {
    auto pass = enc->begin_compute_pass("square");
    pass.set_pipeline(*pipeline);
    pass.set_bind_group(0, *group);
    struct {
      float offset;
      std::uint32_t n;
    } push{3.5f, n};
    pass.push(push);
    pass.dispatch(n / 64);
    pass.end();
  }
  auto cmd = enc->finish();
  REQUIRE(cmd);
  REQUIRE(device().queue().submit(std::move(*cmd)));
  auto back = device().queue().read_buffer(*out);
  REQUIRE(back);
  auto y = as_vector<float>(*back);
  int wrong = 0;
  for (std::uint32_t i = 0; i < n; ++i)
    if (y[i] != input[i] * input[i] + 3.5f) ++wrong;
  CHECK(wrong == 0);
  expect_no_validation_messages();
}

TEST_CASE("dispatch_indirect runs the group count a shader wrote; a bad args buffer is an error naming it") {
  // The flow weft's neural BTF list uses: a shader counts work and writes the group count, the
  // next dispatch reads it (barrier storage-write -> indirect), under synchronization validation.
  const std::uint32_t n = 1000;  // 16 groups of 64, the last partly used
  auto out = device().create_buffer({.label = "out", .size = 1024 * 4, .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopySrc | gpu::BufferUsage::CopyDst});
  auto args = device().create_buffer({.label = "args", .size = 16, .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::Indirect});
  REQUIRE(out);
  REQUIRE(args);
  auto count = device().create_shader_module({.label = "count", .stage = gpu::ShaderStage::Compute, .glsl = R"(#version 460
layout(local_size_x = 1) in;
layout(set = 0, binding = 0) writeonly buffer Args { uint pad, gx, gy, gz; };  // uvec3 would align to 16
layout(push_constant) uniform P { uint n; };
void main() { gx = (n + 63u) / 64u; gy = 1u; gz = 1u; })"});
  auto mark = device().create_shader_module({.label = "mark", .stage = gpu::ShaderStage::Compute, .glsl = R"(#version 460
layout(local_size_x = 64) in;
layout(set = 0, binding = 0) writeonly buffer Out { uint y[]; };
layout(push_constant) uniform P { uint n; };
void main() { if (gl_GlobalInvocationID.x < n) y[gl_GlobalInvocationID.x] = gl_GlobalInvocationID.x + 1u; })"});
  REQUIRE_MESSAGE(count, (count ? "" : count.error().message));
  REQUIRE_MESSAGE(mark, (mark ? "" : mark.error().message));
  auto bgl = device().create_bind_group_layout({.label = "one", .entries = {{0, gpu::BindingType::StorageBuffer, gpu::ShaderStage::Compute}}});
  REQUIRE(bgl);
  auto layout = device().create_pipeline_layout({.label = "one", .bind_group_layouts = {&*bgl}, .push_constant_size = 4});
  REQUIRE(layout);
  auto count_pipeline = device().create_compute_pipeline({.label = "count", .layout = &*layout, .module = &*count});
  auto mark_pipeline = device().create_compute_pipeline({.label = "mark", .layout = &*layout, .module = &*mark});
  REQUIRE(count_pipeline);
  REQUIRE(mark_pipeline);
  auto args_group = device().create_bind_group({.label = "args", .layout = &*bgl, .entries = {gpu::bind(0, *args)}});
  auto out_group = device().create_bind_group({.label = "out", .layout = &*bgl, .entries = {gpu::bind(0, *out)}});
  REQUIRE(args_group);
  REQUIRE(out_group);
  SUBCASE("the written count runs") {
    auto enc = device().create_command_encoder("indirect");
    REQUIRE(enc);
    enc->fill_buffer(*out, 0);
    {
      auto pass = enc->begin_compute_pass("count");
      pass.set_pipeline(*count_pipeline);
      pass.set_bind_group(0, *args_group);
      pass.push(n);
      pass.dispatch(1);
      pass.end();
    }
    const gpu::BufferBarrier barriers[] = {{&*args, gpu::Access::StorageWrite, gpu::Access::IndirectBuffer},
                                           {&*out, gpu::Access::CopyDst, gpu::Access::StorageWrite}};
    enc->barrier({}, barriers);
    {
      auto pass = enc->begin_compute_pass("mark");
      pass.set_pipeline(*mark_pipeline);
      pass.set_bind_group(0, *out_group);
      pass.push(n);
      pass.dispatch_indirect(*args, 4);
      pass.end();
    }
    auto cmd = enc->finish();
    REQUIRE_MESSAGE(cmd, (cmd ? "" : cmd.error().message));
    REQUIRE(device().queue().submit(std::move(*cmd)));
    auto back = device().queue().read_buffer(*out);
    REQUIRE(back);
    auto y = as_vector<std::uint32_t>(*back);
    int wrong = 0;
    for (std::uint32_t i = 0; i < 1024; ++i)
      if (y[i] != (i < n ? i + 1 : 0u)) ++wrong;  // 15 groups would miss the last 40
    CHECK(wrong == 0);
  }
  SUBCASE("without indirect usage, or reading past the end") {
    for (std::uint64_t offset : {std::uint64_t(0), std::uint64_t(8), std::uint64_t(2)}) {
      CAPTURE(offset);
      auto enc = device().create_command_encoder("bad-indirect");
      REQUIRE(enc);
      {
        auto pass = enc->begin_compute_pass("mark");
        pass.set_pipeline(*mark_pipeline);
        pass.set_bind_group(0, *out_group);
        pass.push(n);
        pass.dispatch_indirect(offset == 0 ? *out : *args, offset);
        pass.end();
      }
      auto cmd = enc->finish();
      REQUIRE(!cmd);
      CHECK(contains(cmd.error().message, "'mark'"));
      CHECK(contains(cmd.error().message, offset == 0 ? "'out'" : "'args'"));
      CHECK(contains(cmd.error().message, offset == 0 ? "indirect usage" : "offset"));
    }
  }
  expect_no_validation_messages();
}

TEST_CASE("render to texture: depth test keeps the nearer quad, colours exact at known pixels") {
  const std::uint32_t w = 64, h = 48;
  auto color = device().create_texture({.label = "rt-color", .size = {w, h, 1}, .format = gpu::Format::RGBA8Unorm,
                                        .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
  auto depth = device().create_texture({.label = "rt-depth", .size = {w, h, 1}, .format = gpu::Format::Depth32Float,
                                        .usage = gpu::TextureUsage::DepthAttachment});
  REQUIRE(color);
  REQUIRE(depth);
  // Two quads as triangle lists: red at z=0.7 covering all; green at z=0.3 covering the left half.
  struct Vertex {
    float x, y, z, r, g, b;
  };
  auto quad = [](float x0, float x1, float z, float r, float g, float b) {
    return std::vector<Vertex>{{x0, -1, z, r, g, b}, {x1, -1, z, r, g, b}, {x1, 1, z, r, g, b},
                               {x0, -1, z, r, g, b}, {x1, 1, z, r, g, b}, {x0, 1, z, r, g, b}};
  };
  std::vector<Vertex> vertices = quad(-1, 0, 0.3f, 0, 1, 0);  // drawn first, nearer
  auto far = quad(-1, 1, 0.7f, 1, 0, 0);
  vertices.insert(vertices.end(), far.begin(), far.end());
  auto vbo = device().create_buffer_with_data({.label = "quads", .size = vertices.size() * sizeof(Vertex), .usage = gpu::BufferUsage::Vertex},
                                              bytes_of(vertices));
  REQUIRE(vbo);
  auto vs = device().create_shader_module({.label = "quad.vert", .stage = gpu::ShaderStage::Vertex, .glsl = R"(#version 460
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 color;
layout(location = 0) out vec3 v_color;
void main() { v_color = color; gl_Position = vec4(position, 1.0); })"});
  auto fs = device().create_shader_module({.label = "quad.frag", .stage = gpu::ShaderStage::Fragment, .glsl = R"(#version 460
layout(location = 0) in vec3 v_color;
layout(location = 0) out vec4 out_color;
void main() { out_color = vec4(v_color, 1.0); })"});
  REQUIRE(vs);
  REQUIRE(fs);
  auto layout = device().create_pipeline_layout({.label = "quad-layout"});
  REQUIRE(layout);
  auto pipeline = device().create_render_pipeline(
      {.label = "quad",
       .layout = &*layout,
       .vertex = &*vs,
       .fragment = &*fs,
       .vertex_buffers = {{.stride = sizeof(Vertex),
                           .attributes = {{gpu::VertexFormat::Float32x3, 0, 0}, {gpu::VertexFormat::Float32x3, 12, 1}}}},
       .color_targets = {{gpu::Format::RGBA8Unorm}},
       .depth_stencil = gpu::DepthStencilState{}});
  REQUIRE_MESSAGE(pipeline, (pipeline ? "" : pipeline.error().message));
  auto enc = device().create_command_encoder("render");
  REQUIRE(enc);
  enc->transition(*color, gpu::Access::ColorAttachment);
  enc->transition(*depth, gpu::Access::DepthAttachment);
  {
    auto pass = enc->begin_render_pass({.label = "quads",
                                        .color_attachments = {{.view = &color->view(), .clear_color = {0, 0, 1, 1}}},
                                        .depth_attachment = gpu::DepthAttachment{.view = &depth->view()}});
    pass.set_pipeline(*pipeline);
    pass.set_vertex_buffer(0, *vbo);
    pass.draw(12);
    pass.end();
  }
  auto cmd = enc->finish();
  REQUIRE_MESSAGE(cmd, (cmd ? "" : cmd.error().message));
  REQUIRE(device().queue().submit(std::move(*cmd)));
  auto pixels = device().queue().read_texture(*color);
  REQUIRE(pixels);
  REQUIRE(pixels->size() == w * h * 4);
  auto px = [&](std::uint32_t x, std::uint32_t y) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(pixels->data()) + (y * w + x) * 4;
    return std::array<int, 4>{p[0], p[1], p[2], p[3]};
  };
  CHECK((px(5, 10) == std::array<int, 4>{0, 255, 0, 255}));   // left: green, nearer, drawn first
  CHECK((px(60, 40) == std::array<int, 4>{255, 0, 0, 255}));  // right: red only
  expect_no_validation_messages();
}

TEST_CASE("textures: upload, sample in a fullscreen pass, read back") {
  const std::uint32_t w = 8, h = 8;
  std::vector<std::uint8_t> texels(w * h * 4);
  for (std::uint32_t i = 0; i < w * h; ++i) {
    texels[i * 4 + 0] = std::uint8_t(i * 4);
    texels[i * 4 + 1] = std::uint8_t(255 - i * 4);
    texels[i * 4 + 2] = 17;
    texels[i * 4 + 3] = 255;
  }
  auto src = device().create_texture({.label = "src", .size = {w, h, 1}, .format = gpu::Format::RGBA8Unorm,
                                      .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
  auto dst = device().create_texture({.label = "dst", .size = {w, h, 1}, .format = gpu::Format::RGBA8Unorm,
                                      .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
  REQUIRE(src);
  REQUIRE(dst);
  REQUIRE(device().queue().write_texture(*src, bytes_of(texels)));
  auto sampler = device().create_sampler({.label = "nearest", .mag_filter = gpu::FilterMode::Nearest, .min_filter = gpu::FilterMode::Nearest});
  REQUIRE(sampler);
  auto vs = device().create_shader_module({.label = "fullscreen.vert", .stage = gpu::ShaderStage::Vertex, .glsl = fullscreen_vs});
  auto fs = device().create_shader_module({.label = "copy.frag", .stage = gpu::ShaderStage::Fragment, .glsl = R"(#version 460
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
layout(set = 0, binding = 0) uniform sampler2D src;
void main() { color = texture(src, uv); })"});
  REQUIRE(vs);
  REQUIRE(fs);
  auto bgl = device().create_bind_group_layout({.label = "copy-bgl", .entries = {{0, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment}}});
  REQUIRE(bgl);
  auto layout = device().create_pipeline_layout({.label = "copy-layout", .bind_group_layouts = {&*bgl}});
  REQUIRE(layout);
  auto pipeline = device().create_render_pipeline({.label = "copy", .layout = &*layout, .vertex = &*vs, .fragment = &*fs,
                                                   .color_targets = {{gpu::Format::RGBA8Unorm}}});
  REQUIRE(pipeline);
  auto group = device().create_bind_group({.label = "copy-group", .layout = &*bgl, .entries = {gpu::bind(0, src->view(), &*sampler)}});
  REQUIRE(group);
  auto enc = device().create_command_encoder("sample");
  REQUIRE(enc);
  enc->transition(*dst, gpu::Access::ColorAttachment);
  {
    auto pass = enc->begin_render_pass({.label = "copy", .color_attachments = {{.view = &dst->view()}}});
    pass.set_pipeline(*pipeline);
    pass.set_bind_group(0, *group);
    pass.draw(3);
    pass.end();
  }
  auto cmd = enc->finish();
  REQUIRE(cmd);
  REQUIRE(device().queue().submit(std::move(*cmd)));
  auto back = device().queue().read_texture(*dst);
  REQUIRE(back);
  CHECK(std::memcmp(back->data(), texels.data(), texels.size()) == 0);
  expect_no_validation_messages();
}

TEST_CASE("timestamps are monotonic and in nanoseconds") {
  auto queries = device().create_query_set("timing", 2);
  REQUIRE(queries);
  auto buffer = device().create_buffer({.label = "work", .size = 1 << 20, .usage = gpu::BufferUsage::CopyDst});
  REQUIRE(buffer);
  auto enc = device().create_command_encoder("timed");
  REQUIRE(enc);
  enc->reset_query_set(*queries);
  enc->write_timestamp(*queries, 0);
  enc->fill_buffer(*buffer, 7);
  enc->write_timestamp(*queries, 1);
  auto cmd = enc->finish();
  REQUIRE(cmd);
  REQUIRE(device().queue().submit(std::move(*cmd)));
  REQUIRE(device().queue().wait_idle());
  auto t = queries->read_timestamps_ns(0, 2);
  REQUIRE(t);
  CHECK((*t)[1] >= (*t)[0]);
  CHECK((*t)[1] - (*t)[0] < 10e9);
  expect_no_validation_messages();
}

TEST_CASE("memory blocks: placed resources and the first-fit sub-allocator") {
  auto block = device().create_memory_block("heap", 1 << 20);
  REQUIRE(block);
  auto a = block->allocate(1000, 256);
  auto b = block->allocate(5000, 4096);
  REQUIRE(a);
  REQUIRE(b);
  CHECK(*a == 0);
  CHECK(*b % 4096 == 0);
  CHECK(*b >= 1000);
  block->release(*a);
  auto c = block->allocate(900, 256);
  REQUIRE(c);
  CHECK(*c == 0);  // the freed hole is reused
  CHECK(!block->allocate(2u << 20, 1));
  block->release(*b);
  block->release(*c);
  auto whole = block->allocate(1 << 20, 1);  // neighbours merged back into one range
  CHECK(whole.has_value());

  gpu::TextureDescriptor desc{.label = "placed", .size = {32, 32, 1}, .format = gpu::Format::RGBA8Unorm,
                              .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst};
  auto req = device().memory_requirements(desc);
  REQUIRE(req);
  CHECK(req->size >= 32 * 32 * 4);
  auto placed = device().create_texture(desc, {&*block, 0});
  CHECK(placed);
  auto misaligned = device().create_texture(desc, {&*block, req->alignment > 1 ? std::uint64_t(1) : std::uint64_t(0)});
  if (req->alignment > 1) {
    REQUIRE(!misaligned);
    CHECK(contains(misaligned.error().message, "placed"));
    CHECK(contains(misaligned.error().message, "aligned"));
  }
  auto overflow = device().create_texture(desc, {&*block, (1 << 20) - req->alignment});
  REQUIRE(!overflow);
  CHECK(contains(overflow.error().message, "overflow"));
  expect_no_validation_messages();
}

TEST_CASE("misuse returns errors naming the label, before Vulkan sees it") {
  auto& d = device();
  SUBCASE("zero-size buffer") {
    auto b = d.create_buffer({.label = "empty", .size = 0, .usage = gpu::BufferUsage::Storage});
    REQUIRE(!b);
    CHECK(b.error().kind == ErrorKind::InvalidArgument);
    CHECK(contains(b.error().message, "'empty'"));
  }
  SUBCASE("storage usage on a depth format") {
    auto t = d.create_texture({.label = "depth-storage", .size = {4, 4, 1}, .format = gpu::Format::Depth32Float,
                               .usage = gpu::TextureUsage::Storage});
    REQUIRE(!t);
    CHECK(contains(t.error().message, "'depth-storage'"));
    CHECK(contains(t.error().message, "storage"));
  }
  SUBCASE("too many mips, zero size, size over the limit") {
    CHECK(!d.create_texture({.label = "mips", .size = {4, 4, 1}, .usage = gpu::TextureUsage::Sampled, .mip_level_count = 4}));
    CHECK(!d.create_texture({.label = "zero", .size = {0, 4, 1}, .usage = gpu::TextureUsage::Sampled}));
    CHECK(!d.create_texture({.label = "huge", .size = {1u << 20, 4, 1}, .usage = gpu::TextureUsage::Sampled}));
  }
  SUBCASE("a buffer without STORAGE bound to a storage slot") {
    auto bgl = d.create_bind_group_layout({.label = "bgl", .entries = {{0, gpu::BindingType::StorageBuffer}}});
    auto u = d.create_buffer({.label = "uniforms-only", .size = 64, .usage = gpu::BufferUsage::Uniform});
    REQUIRE(bgl);
    REQUIRE(u);
    auto g = d.create_bind_group({.label = "bad-group", .layout = &*bgl, .entries = {gpu::bind(0, *u)}});
    REQUIRE(!g);
    CHECK(contains(g.error().message, "'bad-group'"));
    CHECK(contains(g.error().message, "'uniforms-only'"));
    CHECK(contains(g.error().message, "storage"));
  }
  SUBCASE("a bind group missing a binding, or with one the layout lacks") {
    auto bgl = d.create_bind_group_layout({.label = "two", .entries = {{0, gpu::BindingType::UniformBuffer}, {1, gpu::BindingType::Sampler}}});
    auto u = d.create_buffer({.label = "u", .size = 64, .usage = gpu::BufferUsage::Uniform});
    REQUIRE(bgl);
    REQUIRE(u);
    auto missing = d.create_bind_group({.label = "missing", .layout = &*bgl, .entries = {gpu::bind(0, *u)}});
    REQUIRE(!missing);
    CHECK(contains(missing.error().message, "binding 1"));
    auto extra = d.create_bind_group({.label = "extra", .layout = &*bgl, .entries = {gpu::bind(5, *u)}});
    REQUIRE(!extra);
    CHECK(contains(extra.error().message, "binding 5"));
  }
  SUBCASE("duplicate bindings in a layout") {
    auto bgl = d.create_bind_group_layout({.label = "dup", .entries = {{0, gpu::BindingType::UniformBuffer}, {0, gpu::BindingType::Sampler}}});
    REQUIRE(!bgl);
    CHECK(contains(bgl.error().message, "'dup'"));
  }
  SUBCASE("mapping a device-local buffer") {
    auto b = d.create_buffer({.label = "gpu-only", .size = 16, .usage = gpu::BufferUsage::Storage});
    REQUIRE(b);
    auto m = b->mapped();
    REQUIRE(!m);
    CHECK(contains(m.error().message, "'gpu-only'"));
  }
  SUBCASE("copy from a buffer without COPY_SRC, reported at finish()") {
    auto a = d.create_buffer({.label = "no-copy-src", .size = 16, .usage = gpu::BufferUsage::Storage});
    auto b = d.create_buffer({.label = "dst", .size = 16, .usage = gpu::BufferUsage::CopyDst});
    auto enc = d.create_command_encoder("misuse");
    REQUIRE(enc);
    enc->copy_buffer_to_buffer(*a, 0, *b, 0, 16);
    auto cmd = enc->finish();
    REQUIRE(!cmd);
    CHECK(contains(cmd.error().message, "'no-copy-src'"));
  }
  SUBCASE("draw without a pipeline; attachments of different sizes") {
    auto big = d.create_texture({.label = "big", .size = {16, 16, 1}, .usage = gpu::TextureUsage::ColorAttachment});
    auto small = d.create_texture({.label = "small", .size = {8, 8, 1}, .usage = gpu::TextureUsage::ColorAttachment});
    REQUIRE(big);
    REQUIRE(small);
    {
      auto enc = d.create_command_encoder("no-pipeline");
      enc->transition(*big, gpu::Access::ColorAttachment);
      auto pass = enc->begin_render_pass({.label = "p", .color_attachments = {{.view = &big->view()}}});
      pass.draw(3);
      pass.end();
      auto cmd = enc->finish();
      REQUIRE(!cmd);
      CHECK(contains(cmd.error().message, "without a pipeline"));
    }
    {
      auto enc = d.create_command_encoder("sizes");
      auto pass = enc->begin_render_pass({.label = "mrt", .color_attachments = {{.view = &big->view()}, {.view = &small->view()}}});
      pass.end();
      auto cmd = enc->finish();
      REQUIRE(!cmd);
      CHECK(contains(cmd.error().message, "'mrt'"));
      CHECK(contains(cmd.error().message, "'small'"));
    }
  }
  SUBCASE("push constants larger than the layout") {
    auto layout = d.create_pipeline_layout({.label = "small-push", .push_constant_size = 4});
    REQUIRE(layout);
    auto cs = d.create_shader_module({.label = "noop", .stage = gpu::ShaderStage::Compute,
                                      .glsl = "#version 460\nlayout(local_size_x=1) in;\nlayout(push_constant) uniform P { float a; };\nvoid main(){}"});
    REQUIRE(cs);
    auto pipeline = d.create_compute_pipeline({.label = "noop", .layout = &*layout, .module = &*cs});
    REQUIRE(pipeline);
    auto enc = d.create_command_encoder("push");
    auto pass = enc->begin_compute_pass("push");
    pass.set_pipeline(*pipeline);
    pass.push(std::array<float, 4>{});
    pass.end();
    auto cmd = enc->finish();
    REQUIRE(!cmd);
    CHECK(contains(cmd.error().message, "'noop'"));
  }
  SUBCASE("a vertex shader used as a compute shader; pipeline without layout") {
    auto vs = d.create_shader_module({.label = "a-vertex-shader", .stage = gpu::ShaderStage::Vertex, .glsl = fullscreen_vs});
    REQUIRE(vs);
    auto layout = d.create_pipeline_layout({.label = "l"});
    auto p = d.create_compute_pipeline({.label = "wrong-stage", .layout = &*layout, .module = &*vs});
    REQUIRE(!p);
    CHECK(contains(p.error().message, "'a-vertex-shader'"));
    CHECK(!d.create_compute_pipeline({.label = "no-layout", .module = &*vs}));
  }
  expect_no_validation_messages();
}

TEST_CASE("shader errors name the file and line; #include and the cache work") {
  const auto dir = temp_dir("shaders");
  SUBCASE("syntax error") {
    const auto path = dir / "broken.comp";
    std::ofstream(path) << "#version 460\nlayout(local_size_x = 1) in;\nvoid main() { float x = ; }\n";
    auto m = device().create_shader_module({.label = "broken", .stage = gpu::ShaderStage::Compute, .path = path});
    REQUIRE(!m);
    CHECK(m.error().kind == ErrorKind::Shader);
    CHECK(contains(m.error().message, path.string() + ":3"));
  }
  SUBCASE("missing file") {
    auto m = device().create_shader_module({.label = "missing", .stage = gpu::ShaderStage::Compute, .path = dir / "nope.comp"});
    REQUIRE(!m);
    CHECK(m.error().kind == ErrorKind::NotFound);
    CHECK(contains(m.error().message, "nope.comp"));
  }
  SUBCASE("error inside an included file names that file") {
    std::ofstream(dir / "bad.glsl") << "// header\nfloat helper() { return undefined_thing; }\n";
    std::ofstream(dir / "main.comp") << "#version 460\n#include \"bad.glsl\"\nlayout(local_size_x = 1) in;\nvoid main() {}\n";
    auto m = device().create_shader_module({.label = "inc", .stage = gpu::ShaderStage::Compute, .path = dir / "main.comp"});
    REQUIRE(!m);
    CHECK(contains(m.error().message, "bad.glsl:2"));
    CHECK(contains(m.error().message, "undefined_thing"));
  }
  SUBCASE("include from an include dir, defines, and a memory-cache hit on the second compile") {
    std::ofstream(dir / "common.glsl") << "float twice(float x) { return 2.0 * x; }\n";
    const std::string src = "#version 460\n#include <common.glsl>\nlayout(local_size_x = 1) in;\n"
                            "layout(set=0, binding=0) buffer B { float v[]; };\nvoid main() { v[0] = twice(SCALE); }\n";
    gpu::ShaderModuleDescriptor desc{.label = "inc-ok", .stage = gpu::ShaderStage::Compute, .glsl = src,
                                     .include_dirs = {dir}, .defines = {{"SCALE", "4.0"}}};
    auto first = gpu::compile_glsl(desc);
    REQUIRE_MESSAGE(first, (first ? "" : first.error().message));
    const auto before = gpu::shader_cache_stats();
    auto second = gpu::compile_glsl(desc);
    REQUIRE(second);
    CHECK(*first == *second);
    CHECK(gpu::shader_cache_stats().memory_hits == before.memory_hits + 1);
    desc.defines[0].value = "5.0";  // a different define is a different program
    auto third = gpu::compile_glsl(desc);
    REQUIRE(third);
    CHECK(*third != *first);
  }
  std::filesystem::remove_all(dir);
  expect_no_validation_messages();
}

TEST_CASE("handles are move-only RAII values that outlive moves") {
  auto t = device().create_texture({.label = "moved", .size = {4, 4, 1}, .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
  REQUIRE(t);
  gpu::Texture moved = std::move(*t);
  CHECK(&moved.view().texture() == &moved);  // the default view follows its texture
  std::vector<gpu::Buffer> buffers;
  for (int i = 0; i < 8; ++i) {
    auto b = device().create_buffer({.label = "b" + std::to_string(i), .size = 64, .usage = gpu::BufferUsage::Uniform});
    REQUIRE(b);
    buffers.push_back(std::move(*b));
  }
  const auto allocated = device().allocated_bytes();
  buffers.clear();
  CHECK(device().allocated_bytes() < allocated);
  static_assert(!std::is_copy_constructible_v<gpu::Buffer>);
  static_assert(!std::is_copy_constructible_v<gpu::Texture>);
  expect_no_validation_messages();
}

// The viewer's window thread and render thread share one device (weft view --scene-device
// shared): recording, submitting and waiting from two threads at once must be what Vulkan
// allows (the validation layer's thread-safety checks report a command pool or queue used by
// two threads at once), and each thread's results must be its own.
TEST_CASE("two threads record, submit and wait on one device") {
  constexpr int rounds = 40;
  auto work = [](std::uint32_t seed, std::string* failure) {
    auto buffer = device().create_buffer({.label = weft::format("thread-{}", seed), .size = 4096,
                                          .usage = gpu::BufferUsage::CopyDst | gpu::BufferUsage::CopySrc});
    auto target = device().create_texture({.label = weft::format("thread-{}-target", seed), .size = {16, 16, 1},
                                           .format = gpu::Format::RGBA8Unorm,
                                           .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
    if (!buffer || !target) {
      *failure = "creating the thread's objects failed";
      return;
    }
    for (int round = 0; round < rounds; ++round) {
      std::vector<std::uint32_t> data(1024);
      for (std::size_t i = 0; i < data.size(); ++i) data[i] = seed * 1000003u + std::uint32_t(round) * 7919u + std::uint32_t(i);
      if (auto ok = device().queue().write_buffer(*buffer, 0, bytes_of(data)); !ok) {
        *failure = ok.error().what();
        return;
      }
      auto back = device().queue().read_buffer(*buffer);
      if (!back || as_vector<std::uint32_t>(*back) != data) {
        *failure = weft::format("thread {} round {}: the buffer did not read back what was written", seed, round);
        return;
      }
      // A render pass too: a clear to this thread's colour, read back.
      auto enc = device().create_command_encoder(weft::format("thread-{}-clear", seed));
      if (!enc) {
        *failure = enc.error().what();
        return;
      }
      enc->transition(*target, gpu::Access::ColorAttachment);
      const float shade = float((seed * 40 + std::uint32_t(round)) % 256) / 255.0f;
      auto pass = enc->begin_render_pass(
          {.label = "clear", .color_attachments = {{.view = &target->view(), .clear_color = {shade, 0, 1, 1}}}});
      pass.end();
      auto cmd = enc->finish();
      if (!cmd || !device().queue().submit(std::move(*cmd))) {
        *failure = "submitting the clear failed";
        return;
      }
      auto pixels = device().queue().read_texture(*target);
      if (!pixels || std::to_integer<int>((*pixels)[0]) != int(std::lround(shade * 255.0f))) {
        *failure = weft::format("thread {} round {}: the cleared texture read back another colour", seed, round);
        return;
      }
    }
  };
  std::string failure_a, failure_b;
  std::thread a(work, 1u, &failure_a), b(work, 2u, &failure_b);
  a.join();
  b.join();
  CHECK_MESSAGE(failure_a.empty(), failure_a);
  CHECK_MESSAGE(failure_b.empty(), failure_b);
  REQUIRE(device().queue().wait_idle());
  expect_no_validation_messages();
}
