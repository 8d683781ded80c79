// The base passes composed by hand in a graph, checked against analytic results:
// a white furnace, a Lambert sphere's terminator and cosine fall-off, a cast shadow.
#include <doctest/doctest.h>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>
#include <glm/gtc/matrix_transform.hpp>
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.base_pass.shadow;
import weft.base_pass.forward;
import weft.base_pass.background;
import weft.base_pass.tonemap;
import weft.test.gpu;

using namespace weft;

namespace {

frame::MeshData uv_sphere(float r, std::uint32_t nu, std::uint32_t nv) {
  frame::MeshData m{"sphere", {}, {}};
  for (std::uint32_t j = 0; j <= nv; ++j)
    for (std::uint32_t i = 0; i <= nu; ++i) {
      const float phi = 2 * pi * i / nu, theta = pi * j / nv;
      const vec3 n{std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
      frame::Vertex v;
      v.position = r * n;
      v.normal = n;
      v.curvature = 1.0f / r;
      m.vertices.push_back(v);
    }
  for (std::uint32_t j = 0; j < nv; ++j)
    for (std::uint32_t i = 0; i < nu; ++i) {
      const std::uint32_t a = j * (nu + 1) + i, b = a + 1, c = a + nu + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
    }
  return m;
}

frame::MeshData quad(float half) {
  frame::MeshData m{"floor", {}, {0, 2, 1, 0, 3, 2}};
  for (vec2 p : {vec2(-half, -half), vec2(half, -half), vec2(half, half), vec2(-half, half)}) {
    frame::Vertex v;
    v.position = {p.x, 0, p.y};
    v.normal = {0, 1, 0};
    m.vertices.push_back(v);
  }
  return m;
}

struct Setup {
  std::uint32_t width = 96, height = 96;
  vec3 eye{0, 0, 4}, target{0, 0, 0};
  float fov_degrees = 45.0f;
  vec3 towards_light{1, 0, 0};
  vec3 light_radiance{0.0f};
  vec3 environment{0.0f};
  float exposure = 1.0f;
};

struct Rendered {
  std::vector<std::uint8_t> rgba;
  std::uint32_t width, height;
  [[nodiscard]] std::array<int, 3> at(std::uint32_t x, std::uint32_t y) const {
    const auto* p = rgba.data() + (std::size_t(y) * width + x) * 4;
    return {p[0], p[1], p[2]};
  }
};

// The frame the renderer builds, by hand: shadow -> forward -> background -> tonemap.
Rendered render(const Setup& s, std::span<const frame::DrawItem> items) {
  auto& device = weft::test::gpu().device;
  auto shadow = passes::ShadowPass::create(device, {.resolution = 512});
  auto forward = passes::ForwardPass::create(device);
  auto background = passes::BackgroundPass::create(device);
  auto tonemap = passes::TonemapPass::create(device);
  REQUIRE(shadow);
  REQUIRE(forward);
  REQUIRE(background);
  REQUIRE(tonemap);

  // A 4x2 constant environment map, so background and reflections see `environment`.
  auto env = device.create_texture({.label = "environment", .size = {4, 2, 1}, .format = gpu::Format::RGBA32Float,
                                    .usage = gpu::TextureUsage::Sampled | gpu::TextureUsage::CopyDst});
  REQUIRE(env);
  std::vector<vec4> texels(8, vec4(s.environment, 1.0f));
  REQUIRE(device.queue().write_texture(*env, std::as_bytes(std::span(texels))));

  frame::FrameUniforms u;
  u.view = glm::lookAtRH(s.eye, s.target, vec3(0, 1, 0));
  u.projection = frame::perspective_vk(glm::radians(s.fov_degrees), float(s.width) / s.height, 0.1f, 50.0f);
  u.view_projection = u.projection * u.view;
  u.inverse_view_projection = glm::inverse(u.view_projection);
  u.light_view_projection = passes::fit_light_view_projection(s.towards_light, vec3(-2.5f), vec3(2.5f));
  u.camera_position = vec4(s.eye, 1);
  u.light_direction = vec4(glm::normalize(s.towards_light), 0);
  u.light_color = vec4(s.light_radiance, 0);
  u.environment = vec4(1, 0, 1, 0);
  std::vector<float> sky(8 * 4 * 3);
  for (std::size_t i = 0; i < sky.size(); i += 3) std::memcpy(&sky[i], &s.environment, 12);
  u.irradiance_sh = frame::irradiance_sh(sky, 8, 4);
  u.viewport = vec4(s.width, s.height, 1.0f / s.width, 1.0f / s.height);
  auto uniforms = device.create_buffer_with_data({.label = "frame_uniforms", .size = sizeof(u), .usage = gpu::BufferUsage::Uniform},
                                                 std::as_bytes(std::span(&u, 1)));
  REQUIRE(uniforms);
  auto output = device.create_texture({.label = "output", .size = {s.width, s.height, 1}, .format = passes::output_format,
                                       .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
  REQUIRE(output);

  RenderGraph graph("base-passes");
  frame::put_scene_targets(graph.blackboard(),
                           {.uniforms = graph.import_buffer("frame_uniforms", &*uniforms, gpu::Access::UniformRead),
                            .environment = graph.import_texture("environment", &*env, gpu::Access::ShaderRead)});
  shadow->add(graph, items, u.light_view_projection);
  REQUIRE(forward->add(graph, items));
  REQUIRE(background->add(graph));
  auto out = tonemap->add(graph, {}, graph.import_texture("output", &*output, gpu::Access::Undefined),
                          {.exposure = s.exposure, .tone_operator = passes::ToneOperator::Clamp});
  REQUIRE(out);
  graph.mark_output(*out, gpu::Access::CopySrc);
  auto compiled = graph.compile({.output_extent = {s.width, s.height, 1}, .device = &device});
  REQUIRE_MESSAGE(compiled, (compiled ? "" : compiled.error().to_string()));
  auto stats = compiled->execute(device);
  REQUIRE_MESSAGE(stats, (stats ? "" : stats.error().message));
  auto pixels = device.queue().read_texture(*output);
  REQUIRE(pixels);
  Rendered r{std::vector<std::uint8_t>(pixels->size()), s.width, s.height};
  std::memcpy(r.rgba.data(), pixels->data(), pixels->size());
  weft::test::expect_no_validation_messages();
  return r;
}

float srgb_to_linear(int code) {
  const float c = code / 255.0f;
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

}  // namespace

TEST_CASE("white furnace: a white sphere under a constant sky of radiance 0.5 disappears") {
  auto& device = weft::test::gpu().device;
  auto sphere = frame::upload_mesh(device, uv_sphere(1.0f, 64, 32));
  REQUIRE(sphere);
  const frame::DrawItem item{.mesh = &*sphere, .material = {.base_color = vec3(1.0f), .metallic = 0.0f, .roughness = 0.6f}};
  const auto image = render({.environment = vec3(0.5f)}, std::span(&item, 1));
  const int sky = image.at(2, 2)[0];
  CHECK(std::abs(sky - 188) <= 1);  // 0.5 linear is sRGB code 188
  int worst = 0;
  for (std::uint32_t y = 20; y < 76; ++y)
    for (std::uint32_t x = 20; x < 76; ++x)
      for (int c : image.at(x, y)) worst = std::max(worst, std::abs(c - sky));
  CHECK(worst <= 3);  // the sphere (silhouette included) is indistinguishable from the sky
}

TEST_CASE("Lambert sphere lit from +x: terminator at the centre column, cosine fall-off, black night side") {
  auto& device = weft::test::gpu().device;
  auto sphere = frame::upload_mesh(device, uv_sphere(1.0f, 128, 64));
  REQUIRE(sphere);
  // Roughness 1 keeps GGX small; radiance pi makes a white Lambert surface read cos(theta).
  const frame::DrawItem item{.mesh = &*sphere, .material = {.base_color = vec3(1.0f), .roughness = 1.0f}};
  const Setup s{.width = 128, .height = 128, .eye = {0, 0, 6}, .fov_degrees = 30.0f, .towards_light = {1, 0, 0},
                .light_radiance = vec3(pi)};
  const auto image = render(s, std::span(&item, 1));
  // Cast the pixel's ray at the unit sphere to know the true normal there.
  const mat4 inverse_vp = glm::inverse(frame::perspective_vk(glm::radians(30.0f), 1.0f, 0.1f, 50.0f) *
                                       glm::lookAtRH(s.eye, s.target, vec3(0, 1, 0)));
  const std::uint32_t y = 64;
  int lit_pixels = 0;
  for (std::uint32_t x = 0; x < 128; ++x) {
    const vec4 far = inverse_vp * vec4((x + 0.5f) / 64.0f - 1.0f, (y + 0.5f) / 64.0f - 1.0f, 1.0f, 1.0f);
    const vec3 d = glm::normalize(vec3(far) / far.w - s.eye);
    const float b = glm::dot(s.eye, d), c = glm::dot(s.eye, s.eye) - 1.0f, disc = b * b - c;
    if (disc < 0.05f) continue;  // misses, or grazes the silhouette
    const vec3 n = s.eye + (-b - std::sqrt(disc)) * d;
    const float lit = srgb_to_linear(image.at(x, y)[0]);
    if (n.x < -0.03f) {
      CHECK_MESSAGE(lit == 0.0f, "x=" << x);
    } else if (n.x > 0.1f) {
      // (1 - F) cos(theta) with F ~ 0.04, plus a little GGX at roughness 1.
      const float expected = 0.958f * n.x;
      CHECK_MESSAGE(lit >= 0.95f * expected - 0.01f, "x=" << x << " lit=" << lit << " expected=" << expected);
      CHECK_MESSAGE(lit <= 1.15f * expected + 0.01f, "x=" << x << " lit=" << lit << " expected=" << expected);
      ++lit_pixels;
    }
  }
  CHECK(lit_pixels > 15);
}

TEST_CASE("a sphere over a floor casts a shadow straight down under an overhead light") {
  auto& device = weft::test::gpu().device;
  auto sphere = frame::upload_mesh(device, uv_sphere(0.5f, 48, 24));
  auto floor = frame::upload_mesh(device, quad(2.0f));
  REQUIRE(sphere);
  REQUIRE(floor);
  const frame::DrawItem items[] = {
      {.mesh = &*sphere, .model = glm::translate(mat4(1.0f), vec3(0, 1.0f, 0)), .material = {.base_color = vec3(0.8f), .roughness = 1.0f}},
      {.mesh = &*floor, .material = {.base_color = vec3(0.8f), .roughness = 1.0f}}};
  // Camera looking straight down from high above: the sphere hides the shadow, so look from the side.
  const Setup s{.width = 128, .height = 96, .eye = {0, 2.5f, 4.0f}, .target = {0, 0.3f, 0}, .towards_light = {0, 1, 0},
                .light_radiance = vec3(2.0f), .environment = vec3(0.05f)};
  const auto image = render(s, items);
  // Project floor points to pixels: directly under the sphere (shadowed) vs 1.5 units to the side.
  const mat4 vp = frame::perspective_vk(glm::radians(45.0f), 128.0f / 96.0f, 0.1f, 50.0f) *
                  glm::lookAtRH(s.eye, s.target, vec3(0, 1, 0));
  auto pixel = [&](vec3 p) {
    const vec4 c = vp * vec4(p, 1.0f);
    return std::array<std::uint32_t, 2>{std::uint32_t((c.x / c.w * 0.5f + 0.5f) * 128), std::uint32_t((c.y / c.w * 0.5f + 0.5f) * 96)};
  };
  const auto under = pixel({0, 0, 0.35f});  // in front of the sphere's foot, inside the umbra
  const auto aside = pixel({1.5f, 0, 0.35f});
  const int dark = image.at(under[0], under[1])[0], bright = image.at(aside[0], aside[1])[0];
  CHECK(bright > 150);
  CHECK(dark < 70);
}
