// MSAA, mip uploads and anisotropy in weft.gpu, on lavapipe (or a GPU) under the validation
// layer: coverage against the standard sample positions, resolves of colour and depth,
// alpha-to-coverage's ends, and every misuse named with its label and count.
#include <doctest/doctest.h>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <span>
#include <string>
#include <vector>
import weft.core;
import weft.gpu;
import weft.test.gpu;

using namespace weft;
using weft::test::expect_no_validation_messages;

namespace {
gpu::Device& device() { return weft::test::gpu().device; }
bool contains(const std::string& haystack, const std::string& needle) { return haystack.find(needle) != std::string::npos; }
std::uint32_t max_samples() {
  const auto& l = device().adapter_info().limits;
  return gpu::max_sample_count(l.color_sample_counts & l.depth_sample_counts);
}

// A triangle whose right edge is the vertical line x = edge (in pixels) of a `width`-wide
// target, everything left of it white; its alpha is `alpha`.
constexpr const char* edge_vs = R"(#version 460
layout(push_constant) uniform P { float edge_ndc; float alpha; } p;
void main() {
  // Wide enough that the long side passes left of the target: only x = edge_ndc bounds it.
  vec2 v[3] = vec2[3](vec2(-9.0, -3.0), vec2(p.edge_ndc, -3.0), vec2(p.edge_ndc, 9.0));
  gl_Position = vec4(v[gl_VertexIndex], 0.5, 1.0);
})";
constexpr const char* white_fs = R"(#version 460
layout(push_constant) uniform P { float edge_ndc; float alpha; } p;
layout(location = 0) out vec4 color;
void main() { color = vec4(1.0, 1.0, 1.0, p.alpha); })";

struct EdgeRender {
  std::vector<float> red;  // per pixel of row 0
};

// Draws the edge triangle into a `samples`-sample RGBA32F target of width x 1, resolved (when
// multisampled) into a single-sample one that is read back.
EdgeRender render_edge(std::uint32_t samples, float edge_px, float alpha, bool alpha_to_coverage, std::uint32_t width = 4) {
  const std::uint32_t height = 1;
  auto vs = device().create_shader_module({.label = "edge.vert", .stage = gpu::ShaderStage::Vertex, .glsl = edge_vs});
  auto fs = device().create_shader_module({.label = "white.frag", .stage = gpu::ShaderStage::Fragment, .glsl = white_fs});
  REQUIRE(vs);
  REQUIRE(fs);
  auto layout = device().create_pipeline_layout({.label = "edge", .push_constant_size = 8});
  REQUIRE(layout);
  auto pipeline = device().create_render_pipeline({.label = "edge",
                                                   .layout = &*layout,
                                                   .vertex = &*vs,
                                                   .fragment = &*fs,
                                                   .color_targets = {{gpu::Format::RGBA32Float}},
                                                   .multisample = {.count = samples, .alpha_to_coverage = alpha_to_coverage}});
  REQUIRE(pipeline);
  auto target = device().create_texture({.label = "edge-ms", .size = {width, height, 1}, .format = gpu::Format::RGBA32Float,
                                         .usage = samples == 1 ? gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc
                                                               : gpu::TextureUsage::ColorAttachment,
                                         .sample_count = samples});
  REQUIRE(target);
  std::optional<gpu::Texture> resolved;
  if (samples > 1) {
    auto r = device().create_texture({.label = "edge-resolved", .size = {width, height, 1}, .format = gpu::Format::RGBA32Float,
                                      .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
    REQUIRE(r);
    resolved.emplace(std::move(*r));
  }
  auto enc = device().create_command_encoder("edge");
  REQUIRE(enc);
  enc->transition(*target, gpu::Access::ColorAttachment);
  if (resolved) enc->transition(*resolved, gpu::Access::ColorAttachment);
  {
    auto pass = enc->begin_render_pass(
        {.label = "edge",
         .color_attachments = {{.view = &target->view(), .clear_color = vec4(0.0f),
                                .resolve_target = resolved ? &resolved->view() : nullptr}}});
    pass.set_pipeline(*pipeline);
    const float push[2] = {edge_px / float(width) * 2.0f - 1.0f, alpha};
    pass.set_push_constants(std::as_bytes(std::span(push)));
    pass.draw(3);
    pass.end();
  }
  auto cmd = enc->finish();
  REQUIRE(cmd);
  REQUIRE(device().queue().submit(std::move(*cmd)));
  auto back = device().queue().read_texture(resolved ? *resolved : *target);
  REQUIRE(back);
  EdgeRender out;
  for (std::uint32_t x = 0; x < width; ++x) {
    float r;
    std::memcpy(&r, back->data() + x * 16, 4);
    out.red.push_back(r);
  }
  return out;
}
}  // namespace

TEST_CASE("the adapter reports its sample counts; Vulkan guarantees 1 and 4") {
  const auto& l = device().adapter_info().limits;
  CHECK((l.color_sample_counts & 1u));
  CHECK((l.color_sample_counts & 4u));
  CHECK((l.depth_sample_counts & 4u));
  CHECK((l.depth_resolve_modes & 1u));  // sample zero is always there
  CHECK(l.max_sampler_anisotropy >= 1.0f);
  CHECK(gpu::sample_counts_text(1 | 4) == "1, 4");
  CHECK(gpu::max_sample_count(1 | 2 | 8) == 8);
}

TEST_CASE("4x MSAA covers an edge pixel by the standard sample positions and resolves to their average") {
  // An edge at x = 1.3 px: pixel 1 is covered left of 0.3 of its width. One sample per pixel
  // (at 0.5) misses it; the standard 4x positions have one sample left of 0.3 (x = 0.125).
  const auto single = render_edge(1, 1.3f, 1.0f, false);
  CHECK(single.red == std::vector<float>{1.0f, 0.0f, 0.0f, 0.0f});
  const auto msaa = render_edge(4, 1.3f, 1.0f, false);
  CHECK(msaa.red[0] == doctest::Approx(1.0f));
  CHECK(msaa.red[1] == doctest::Approx(0.25f));
  CHECK(msaa.red[2] == doctest::Approx(0.0f));
  // An edge at 1.7 px: samples at 0.125, 0.375 and 0.625 are left of it.
  CHECK(render_edge(4, 1.7f, 1.0f, false).red[1] == doctest::Approx(0.75f));
  expect_no_validation_messages();
}

TEST_CASE("alpha-to-coverage: alpha 0 covers nothing, 1 everything, 0.5 some samples") {
  const auto none = render_edge(4, 4.0f, 0.0f, true);
  const auto all = render_edge(4, 4.0f, 1.0f, true);
  const auto half = render_edge(4, 4.0f, 0.5f, true);
  for (int x = 0; x < 4; ++x) {
    CHECK(none.red[x] == doctest::Approx(0.0f));
    CHECK(all.red[x] == doctest::Approx(1.0f));
    CHECK(half.red[x] > 0.0f);
    CHECK(half.red[x] < 1.0f);
  }
  expect_no_validation_messages();
}

TEST_CASE("a multisampled depth attachment resolves by sample zero into a single-sample depth") {
  auto ms = device().create_texture({.label = "depth-ms", .size = {4, 4, 1}, .format = gpu::Format::Depth32Float,
                                     .usage = gpu::TextureUsage::DepthAttachment, .sample_count = 4});
  auto single = device().create_texture({.label = "depth-resolved", .size = {4, 4, 1}, .format = gpu::Format::Depth32Float,
                                         .usage = gpu::TextureUsage::DepthAttachment | gpu::TextureUsage::CopySrc});
  REQUIRE(ms);
  REQUIRE(single);
  auto enc = device().create_command_encoder("depth-resolve");
  REQUIRE(enc);
  enc->transition(*ms, gpu::Access::DepthAttachment);
  enc->transition(*single, gpu::Access::DepthAttachment);
  enc->begin_render_pass({.label = "depth-resolve",
                          .depth_attachment = gpu::DepthAttachment{.view = &ms->view(), .clear_depth = 0.25f,
                                                                   .resolve_target = &single->view()}})
      .end();
  auto cmd = enc->finish();
  REQUIRE(cmd);
  REQUIRE(device().queue().submit(std::move(*cmd)));
  auto back = device().queue().read_texture(*single);
  REQUIRE(back);
  REQUIRE(back->size() == 16 * 4);
  for (std::size_t i = 0; i < 16; ++i) {
    float d;
    std::memcpy(&d, back->data() + i * 4, 4);
    CHECK(d == 0.25f);
  }
  expect_no_validation_messages();
}

TEST_CASE("sample counts are checked against the adapter, naming the label and the count") {
  const std::uint32_t too_many = max_samples() * 2;
  auto bad = device().create_texture({.label = "too-many", .size = {4, 4, 1}, .format = gpu::Format::RGBA16Float,
                                      .usage = gpu::TextureUsage::ColorAttachment, .sample_count = too_many});
  REQUIRE_FALSE(bad);
  CHECK(contains(bad.error().message, "'too-many'"));
  CHECK(contains(bad.error().message, std::to_string(too_many) + " samples"));
  CHECK(contains(bad.error().message, gpu::sample_counts_text(device().adapter_info().limits.color_sample_counts)));
  auto three = device().create_texture({.label = "three", .size = {4, 4, 1}, .format = gpu::Format::RGBA8Unorm,
                                        .usage = gpu::TextureUsage::ColorAttachment, .sample_count = 3});
  REQUIRE_FALSE(three);
  CHECK(contains(three.error().message, "3 samples"));
  auto mips = device().create_texture({.label = "ms-mips", .size = {4, 4, 1}, .format = gpu::Format::RGBA8Unorm,
                                       .usage = gpu::TextureUsage::ColorAttachment, .mip_level_count = 2, .sample_count = 4});
  REQUIRE_FALSE(mips);
  CHECK(contains(mips.error().message, "one mip level"));
  auto storage = device().create_texture({.label = "ms-storage", .size = {4, 4, 1}, .format = gpu::Format::RGBA8Unorm,
                                          .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::Storage,
                                          .sample_count = 4});
  REQUIRE_FALSE(storage);
  CHECK(contains(storage.error().message, "storage"));

  auto layout = device().create_pipeline_layout({.label = "a2c", .push_constant_size = 8});
  auto vs = device().create_shader_module({.label = "edge.vert", .stage = gpu::ShaderStage::Vertex, .glsl = edge_vs});
  auto fs = device().create_shader_module({.label = "white.frag", .stage = gpu::ShaderStage::Fragment, .glsl = white_fs});
  REQUIRE(layout);
  REQUIRE(vs);
  REQUIRE(fs);
  auto a2c = device().create_render_pipeline({.label = "a2c-single", .layout = &*layout, .vertex = &*vs, .fragment = &*fs,
                                              .color_targets = {{gpu::Format::RGBA8Unorm}},
                                              .multisample = {.count = 1, .alpha_to_coverage = true}});
  REQUIRE_FALSE(a2c);
  CHECK(contains(a2c.error().message, "'a2c-single'"));
  CHECK(contains(a2c.error().message, "alpha-to-coverage"));
  auto many = device().create_render_pipeline({.label = "many", .layout = &*layout, .vertex = &*vs, .fragment = &*fs,
                                               .color_targets = {{gpu::Format::RGBA8Unorm}},
                                               .multisample = {.count = too_many}});
  REQUIRE_FALSE(many);
  CHECK(contains(many.error().message, std::to_string(too_many) + " samples"));
  expect_no_validation_messages();
}

TEST_CASE("recording misuse: mixed sample counts, a pipeline of another count, bad resolve targets, copies") {
  auto ms = device().create_texture({.label = "color-ms", .size = {4, 4, 1}, .format = gpu::Format::RGBA8Unorm,
                                     .usage = gpu::TextureUsage::ColorAttachment, .sample_count = 4});
  auto single = device().create_texture({.label = "color-1", .size = {4, 4, 1}, .format = gpu::Format::RGBA8Unorm,
                                         .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
  auto other = device().create_texture({.label = "color-f16", .size = {4, 4, 1}, .format = gpu::Format::RGBA16Float,
                                        .usage = gpu::TextureUsage::ColorAttachment});
  auto depth1 = device().create_texture({.label = "depth-1", .size = {4, 4, 1}, .format = gpu::Format::Depth32Float,
                                         .usage = gpu::TextureUsage::DepthAttachment});
  REQUIRE(ms);
  REQUIRE(single);
  REQUIRE(other);
  REQUIRE(depth1);
  auto expect_error = [](auto record, const std::vector<std::string>& words) {
    auto enc = device().create_command_encoder("misuse");
    REQUIRE(enc);
    record(*enc);
    auto cmd = enc->finish();
    REQUIRE_FALSE(cmd);
    for (const auto& w : words) CHECK_MESSAGE(contains(cmd.error().message, w), cmd.error().message);
  };
  expect_error(
      [&](gpu::CommandEncoder& e) {
        e.begin_render_pass({.label = "mixed",
                             .color_attachments = {{.view = &ms->view()}},
                             .depth_attachment = gpu::DepthAttachment{.view = &depth1->view()}});
      },
      {"'mixed'", "'depth-1' has 1 samples", "'color-ms' has 4"});
  expect_error(
      [&](gpu::CommandEncoder& e) {
        e.begin_render_pass({.label = "format", .color_attachments = {{.view = &ms->view(), .resolve_target = &other->view()}}});
      },
      {"'color-f16'", "'color-ms'"});
  expect_error(
      [&](gpu::CommandEncoder& e) {
        e.begin_render_pass({.label = "nothing", .color_attachments = {{.view = &single->view(), .resolve_target = &single->view()}}});
      },
      {"one sample"});
  auto layout = device().create_pipeline_layout({.label = "edge", .push_constant_size = 8});
  auto vs = device().create_shader_module({.label = "edge.vert", .stage = gpu::ShaderStage::Vertex, .glsl = edge_vs});
  auto fs = device().create_shader_module({.label = "white.frag", .stage = gpu::ShaderStage::Fragment, .glsl = white_fs});
  auto pipeline = device().create_render_pipeline({.label = "one-sample", .layout = &*layout, .vertex = &*vs,
                                                   .fragment = &*fs, .color_targets = {{gpu::Format::RGBA8Unorm}}});
  REQUIRE(pipeline);
  expect_error(
      [&](gpu::CommandEncoder& e) {
        e.transition(*ms, gpu::Access::ColorAttachment);
        auto pass = e.begin_render_pass({.label = "count", .color_attachments = {{.view = &ms->view()}}});
        pass.set_pipeline(*pipeline);
        pass.end();
      },
      {"'one-sample' renders 1 samples", "have 4"});
  auto ms_copy = device().create_texture({.label = "ms-copy", .size = {4, 4, 1}, .format = gpu::Format::RGBA8Unorm,
                                          .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc,
                                          .sample_count = 4});
  REQUIRE(ms_copy);
  auto read = device().queue().read_texture(*ms_copy);
  REQUIRE_FALSE(read);
  CHECK(contains(read.error().message, "resolve it"));
  expect_no_validation_messages();
}

TEST_CASE("write_texture_levels uploads a whole mip chain in one submission") {
  auto t = device().create_texture({.label = "chain", .size = {8, 4, 1}, .format = gpu::Format::RGBA8Unorm,
                                    .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst | gpu::TextureUsage::CopySrc,
                                    .mip_level_count = 4});
  REQUIRE(t);
  std::vector<std::vector<std::uint8_t>> levels;
  for (std::uint32_t m = 0, w = 8, h = 4; m < 4; ++m, w = std::max(1u, w / 2), h = std::max(1u, h / 2)) {
    std::vector<std::uint8_t> level(w * h * 4);
    for (std::size_t i = 0; i < level.size(); ++i) level[i] = std::uint8_t(m * 50 + i);
    levels.push_back(level);
  }
  std::vector<std::span<const std::byte>> spans;
  for (const auto& l : levels) spans.push_back(std::as_bytes(std::span(l)));
  REQUIRE(device().queue().write_texture_levels(*t, spans));
  for (std::uint32_t m = 0; m < 4; ++m) {
    auto back = device().queue().read_texture(*t, m);
    REQUIRE(back);
    REQUIRE(back->size() == levels[m].size());
    CHECK(std::memcmp(back->data(), levels[m].data(), levels[m].size()) == 0);
  }
  // A level of the wrong size is named with the size it should have.
  spans[2] = std::as_bytes(std::span(levels[1]));
  auto wrong = device().queue().write_texture_levels(*t, spans);
  REQUIRE_FALSE(wrong);
  CHECK(contains(wrong.error().message, "mip 2"));
  CHECK(contains(wrong.error().message, "2x1"));
  expect_no_validation_messages();
}

TEST_CASE("sampler anisotropy: clamped to the adapter, refused below 1, as NaN and with a nearest filter") {
  CHECK(device().create_sampler({.label = "aniso", .max_anisotropy = 1e6f}));
  CHECK(device().create_sampler({.label = "off", .max_anisotropy = 1.0f}));
  auto low = device().create_sampler({.label = "low", .max_anisotropy = 0.5f});
  REQUIRE_FALSE(low);
  CHECK(contains(low.error().message, "'low'"));
  CHECK_FALSE(device().create_sampler({.label = "nan", .max_anisotropy = std::nanf("")}));
  if (device().adapter_info().limits.max_sampler_anisotropy > 1.0f) {
    auto nearest = device().create_sampler({.label = "nearest-aniso", .min_filter = gpu::FilterMode::Nearest, .max_anisotropy = 4.0f});
    REQUIRE_FALSE(nearest);
    CHECK(contains(nearest.error().message, "linear"));
  }
  expect_no_validation_messages();
}

namespace {
// A constant-coloured 16x16 texture with its 5 mips (each level the same colour), drawn over a
// 16x4 target through `sampler` with uv stretched 8 times along x: every pixel's footprint is
// anisotropic, and whatever the filter does, a constant texture must read back its colour.
std::vector<std::uint8_t> sample_constant(const gpu::Sampler& sampler, std::uint32_t size = 16, float stretch = 8.0f) {
  constexpr const char* vs = R"(#version 460
layout(push_constant) uniform P { float stretch; } push;
layout(location = 0) out vec2 uv;
void main() {
  vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
  uv = p * vec2(push.stretch, push.stretch / 8.0) + 0.3;
  gl_Position = vec4(p * 2.0 - 1.0, 0.5, 1.0);
})";
  constexpr const char* fs = R"(#version 460
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;
void main() { color = texture(tex, uv); })";
  auto v = device().create_shader_module({.label = "aniso.vert", .stage = gpu::ShaderStage::Vertex, .glsl = vs});
  auto f = device().create_shader_module({.label = "aniso.frag", .stage = gpu::ShaderStage::Fragment, .glsl = fs});
  REQUIRE(v);
  REQUIRE(f);
  auto bind_layout = device().create_bind_group_layout(
      {.label = "aniso", .entries = {{0, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment}}});
  REQUIRE(bind_layout);
  auto layout = device().create_pipeline_layout({.label = "aniso", .bind_group_layouts = {&*bind_layout}, .push_constant_size = 4});
  REQUIRE(layout);
  auto pipeline = device().create_render_pipeline({.label = "aniso", .layout = &*layout, .vertex = &*v, .fragment = &*f,
                                                   .color_targets = {{gpu::Format::RGBA8Unorm}}});
  REQUIRE(pipeline);
  std::uint32_t mips = 1;
  for (std::uint32_t s = size; s > 1; s /= 2) ++mips;
  auto texture = device().create_texture({.label = "constant", .size = {size, size, 1}, .format = gpu::Format::RGBA8Unorm,
                                          .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst,
                                          .mip_level_count = mips});
  REQUIRE(texture);
  std::vector<std::vector<std::uint8_t>> levels;
  for (std::uint32_t side = size; side >= 1; side /= 2) {
    std::vector<std::uint8_t> texels(std::size_t(side) * side * 4);
    for (std::size_t i = 0; i < texels.size(); i += 4) texels[i] = 200, texels[i + 1] = 100, texels[i + 2] = 50, texels[i + 3] = 255;
    levels.push_back(std::move(texels));
  }
  std::vector<std::span<const std::byte>> spans;
  for (const auto& l : levels) spans.push_back(std::as_bytes(std::span(l)));
  REQUIRE(device().queue().write_texture_levels(*texture, spans));
  auto target = device().create_texture({.label = "aniso-target", .size = {16, 4, 1}, .format = gpu::Format::RGBA8Unorm,
                                         .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
  REQUIRE(target);
  auto group = device().create_bind_group({.label = "aniso", .layout = &*bind_layout, .entries = {gpu::bind(0, texture->view(), &sampler)}});
  REQUIRE(group);
  auto enc = device().create_command_encoder("aniso");
  REQUIRE(enc);
  enc->transition(*target, gpu::Access::ColorAttachment);
  {
    auto pass = enc->begin_render_pass({.label = "aniso", .color_attachments = {{.view = &target->view()}}});
    pass.set_pipeline(*pipeline);
    pass.set_bind_group(0, *group);
    pass.set_push_constants(std::as_bytes(std::span(&stretch, 1)));
    pass.draw(3);
    pass.end();
  }
  auto cmd = enc->finish();
  REQUIRE(cmd);
  REQUIRE(device().queue().submit(std::move(*cmd)));
  auto back = device().queue().read_texture(*target);
  REQUIRE(back);
  std::vector<std::uint8_t> out(back->size());
  std::memcpy(out.data(), back->data(), back->size());
  return out;
}
}  // namespace

TEST_CASE("trilinear and anisotropic samplers read a constant mip chain as its colour, wherever the adapter filters") {
  for (float anisotropy : {1.0f, 16.0f}) {
    CAPTURE(anisotropy);
    auto sampler = device().create_sampler({.label = "trilinear", .address_mode = gpu::AddressMode::Repeat, .max_anisotropy = anisotropy});
    REQUIRE(sampler);
    // A footprint 8 times longer than wide, an ordinary one, and none at all (the same uv
    // everywhere: zero derivatives, which must not make a filter divide by zero).
    for (auto [size, stretch] : {std::pair{16u, 8.0f}, std::pair{1u, 8.0f}, std::pair{16u, 1.0f}, std::pair{16u, 0.0f}}) {
      CAPTURE(size);
      CAPTURE(stretch);
      const auto pixels = sample_constant(*sampler, size, stretch);
      int worst = 0;
      for (std::size_t i = 0; i < pixels.size(); i += 4)
        worst = std::max({worst, std::abs(pixels[i] - 200), std::abs(pixels[i + 1] - 100), std::abs(pixels[i + 2] - 50)});
      CHECK(worst <= 1);
    }
  }
  expect_no_validation_messages();
}
