// weft.pass.neural_btf on lavapipe, under validation + synchronization validation: the shader's
// decoder (the decode kernel, same GLSL as the material) against the CPU decode on a grid of
// texels and directions including θ = 0 and θ = 90°; the batched (tiled) decoder against the
// CPU decode on random queries; a flat quad seen straight on through the renderer against the
// CPU decode per pixel (key light, then the ambient term alone), through both decoders; the
// cushion scene (examples/scenes/neural_btf.json) through the batched path against the
// fragment path, both rendered here; the renderer adds the passes only for scenes with
// neural_btf materials; material errors; the reference mode (the raw BTF in a storage buffer,
// drawn through the fragment path) against the CPU sample_reference per pixel.
#include <doctest/doctest.h>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>
#include <random>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.btf;
import weft.btf.model;
import weft.pass.neural_btf;
import weft.test.gpu;

using namespace weft;

namespace {

gpu::Device& device() { return weft::test::gpu().device; }

renderer::Renderer& shared_renderer() {
  static auto r = renderer::Renderer::create(device());
  REQUIRE(r);
  return *r;
}

std::filesystem::path temp_dir() {
  const auto dir = std::filesystem::temp_directory_path() / "weft-test-neural-btf-gpu";
  std::filesystem::create_directories(dir);
  return dir;
}

scene::Scene load(const std::string& json) {
  auto desc = scene::parse_scene(json, temp_dir());
  REQUIRE_MESSAGE(desc, (desc ? "" : desc.error().message));
  auto s = scene::load_scene(*desc);
  REQUIRE_MESSAGE(s, (s ? "" : s.error().message));
  return std::move(*s);
}

vec3 tangent_direction(float theta_deg, float phi_deg) {
  const float t = glm::radians(theta_deg), p = glm::radians(phi_deg);
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

// A paper-shaped decoder (8 + 4 -> 106 -> 106 -> 106 -> 3) whose outputs mostly lie in
// (0, 1), so that an 8-bit frame can show them: the last layer is damped and lifted.
btf::NeuralBtf displayable_model(std::uint32_t clusters, bool scales) {
  auto m = btf::random_model({.width = 4, .height = 4, .clusters = clusters, .scales = scales, .seed = 11});
  auto& last = m.decoder.layers.back();
  for (float& w : last.weights) w *= 0.2f;
  for (float& b : last.bias) b = 0.35f;
  m.output_scale = 0.8f;
  return m;
}

// A 2 x 2 quad facing +z at the origin, seen from z = 40 with a 3.4° lens (nearly
// orthographic), lit by `lights`; the material is `material`.
std::string quad_scene(const std::string& material, const std::string& lights, const char* sky = "[0, 0, 0]",
                       std::uint32_t size = 64) {
  return weft::format(R"({{"version": 1, "output": {{"width": {0}, "height": {0}}},
    "camera": {{"position": [0, 0, 40], "target": [0, 0, 0], "fov": 3.4, "near": 30, "far": 50}},
    "environment": {{"color": {1}}},
    "lights": {2},
    "meshes": {{"quad": {{"primitive": "plane", "size": 2, "subdivisions": 1}}}},
    "materials": {{"cloth": {3}}},
    "objects": [{{"name": "quad", "mesh": "quad", "material": "cloth", "transform": {{"rotation_degrees": [90, 0, 0]}}}}]}})",
                      size, sky, lights, material);
}

double linear(const image::Image8& img, std::uint32_t x, std::uint32_t y, int c) {
  return image::srgb_to_linear(img.at(x, y, std::uint32_t(c)) / 255.0f);
}

// What the material computes at pixel (x, y) of a `size`² frame of quad_scene, on the CPU: the
// ray hits z = 0 at p; uv from the plane primitive's mapping; ω_i, ω_o in the mesh's tangent
// frame (rotated like the object). `ok` is false off the quad and near texel edges.
struct PixelInputs {
  bool ok = false;
  std::size_t texel = 0;
  vec3 light, view;
};
PixelInputs pixel_inputs(const scene::Scene& s, std::uint32_t x, std::uint32_t y, std::uint32_t size, vec3 towards_light,
                         glm::uvec2 grid, float uv_scale) {
  const mat4 inverse_vp = glm::inverse(s.camera.projection(1.0f) * s.camera.view());
  const vec2 ndc((x + 0.5f) / float(size) * 2.0f - 1.0f, (y + 0.5f) / float(size) * 2.0f - 1.0f);
  const vec4 a = inverse_vp * vec4(ndc, 0.0f, 1.0f), b = inverse_vp * vec4(ndc, 1.0f, 1.0f);
  const vec3 o = vec3(a) / a.w, d = glm::normalize(vec3(b) / b.w - o);
  const vec3 p = o + d * (-o.z / d.z);
  // Plane primitive: (x, 0, z) with uv ((x / size) + 0.5, (z / size) + 0.5); rotated 90° about
  // x, mesh z becomes world -y.
  const vec2 uv(p.x / 2.0f + 0.5f, -p.y / 2.0f + 0.5f);
  PixelInputs in;
  if (uv.x < 0.02f || uv.x > 0.98f || uv.y < 0.02f || uv.y > 0.98f) return in;
  const vec2 st = uv * uv_scale * vec2(grid);
  const vec2 f = st - glm::floor(st);
  if (glm::any(glm::lessThan(f, vec2(0.03f))) || glm::any(glm::greaterThan(f, vec2(0.97f)))) return in;
  const int tx = int(std::floor(st.x)) % int(grid.x), ty = int(std::floor(st.y)) % int(grid.y);
  in.texel = std::size_t(ty) * grid.x + std::size_t(tx);
  const mat3 rotate(s.objects[0].transform);
  const vec3 n = glm::normalize(rotate * s.meshes[0].normals[0]);
  const vec4 tangent = s.meshes[0].tangents[0];
  vec3 t = rotate * vec3(tangent);
  t = glm::normalize(t - n * glm::dot(n, t));
  const vec3 bt = -glm::cross(n, t) * (tangent.w < 0.0f ? -1.0f : 1.0f);  // along +v, as the shader
  const vec3 v = glm::normalize(s.camera.position - p);
  in.view = vec3(glm::dot(v, t), glm::dot(v, bt), glm::dot(v, n));
  in.light = vec3(glm::dot(towards_light, t), glm::dot(towards_light, bt), glm::dot(towards_light, n));
  in.ok = true;
  return in;
}

std::string save_model(const btf::NeuralBtf& m, const std::string& name) {
  const auto path = temp_dir() / name;
  auto ok = btf::save_wbtf(m, path);
  REQUIRE_MESSAGE(ok, (ok ? "" : ok.error().message));
  return path.string();
}

}  // namespace

TEST_CASE("the shader's decoder equals the CPU decode on a grid of texels and directions, θ = 0 and 90° included") {
  auto kernel = passes::BtfDecodeKernel::create(device());
  REQUIRE_MESSAGE(kernel, (kernel ? "" : kernel.error().message));
  // Variants: the paper's shape (unrolled and generic shaders), clustered with scales, and an
  // odd shape (latent 5, widths not multiples of 4) through the generic shader.
  for (int variant = 0; variant < 4; ++variant) {
    const btf::NeuralBtf model =
        variant <= 1 ? btf::random_model({.width = 5, .height = 3, .seed = 5})
        : variant == 2
            ? btf::random_model({.width = 6, .height = 4, .clusters = 7, .scales = true, .output_scale = 2.5f, .seed = 6})
            : btf::random_model({.width = 3, .height = 3, .latent_size = 5, .hidden = {37, 9}, .clusters = 4, .seed = 8});
    auto buffer = passes::upload_model(device(), model, "test-model", variant != 1);
    REQUIRE_MESSAGE(buffer, (buffer ? "" : buffer.error().message));
    CHECK(buffer->paper_shape == (variant == 0 || variant == 2));
    std::vector<passes::DecodeQuery> queries;
    const float thetas[] = {0.0f, 1e-3f, 15.0f, 45.0f, 75.0f, 89.9f, 90.0f};
    const float phis[] = {0.0f, 70.0f, 200.0f};
    for (std::size_t t = 0; t < model.texels(); ++t)
      for (float ti : thetas)
        for (float to : thetas)
          for (float p : phis)
            queries.push_back({tangent_direction(ti, p), float(t), tangent_direction(to, 300.0f - p), 0.0f});
    queries.push_back({vec3(0.0f), 0.0f, vec3(0.0f, 0.0f, 3.0f), 0.0f});  // zero vector: stereo (0, 0) on both
    auto gpu = kernel->decode(device(), *buffer, queries);
    REQUIRE_MESSAGE(gpu, (gpu ? "" : gpu.error().message));
    double worst = 0.0, largest = 0.0;
    int nonzero = 0;
    for (std::size_t i = 0; i < queries.size(); ++i) {
      const auto& q = queries[i];
      const vec3 cpu = btf::decode(model, std::size_t(q.texel), q.light, q.view);
      const vec3 got((*gpu)[i]);
      for (int c = 0; c < 3; ++c) {
        REQUIRE(std::isfinite(got[c]));
        const double tolerance = 1e-4 * std::max(1.0, double(std::abs(cpu[c])));
        worst = std::max(worst, std::abs(double(got[c]) - cpu[c]) / std::max(1.0, double(std::abs(cpu[c]))));
        largest = std::max(largest, double(std::abs(cpu[c])));
        if (cpu[c] > 0.0f) ++nonzero;
        CHECK_MESSAGE(std::abs(got[c] - cpu[c]) <= tolerance, "query " << i << " channel " << c << ": gpu " << got[c]
                                                                        << " cpu " << cpu[c]);
      }
    }
    MESSAGE("variant " << variant << std::string(buffer->paper_shape ? " (unrolled)" : " (generic)") << ": " << queries.size() << " queries, worst relative difference " << worst
                       << ", largest output " << largest);
    CHECK(nonzero > int(queries.size()) / 4);  // not a comparison of zeros (ReLU-clamped outputs)
    // The batched decoder takes the paper's shape only, and refuses the others by name.
    auto tiled = kernel->decode(device(), *buffer, queries, passes::DecodeVariant::Tiled);
    if (variant == 3) {
      REQUIRE_FALSE(tiled);
      CHECK(tiled.error().message.find("paper's shape") != std::string::npos);
      continue;
    }
    REQUIRE_MESSAGE(tiled, (tiled ? "" : tiled.error().message));
    for (std::size_t i = 0; i < queries.size(); ++i) {
      const auto& q = queries[i];
      const vec3 cpu = btf::decode(model, std::size_t(q.texel), q.light, q.view);
      for (int c = 0; c < 3; ++c)
        CHECK_MESSAGE(std::abs((*tiled)[i][c] - cpu[c]) <= 1e-4f * std::max(1.0f, std::abs(cpu[c])),
                      "tiled, query " << i << " channel " << c);
    }
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("a straight-on quad through the renderer: every covered pixel is the CPU decode times the light") {
  const btf::NeuralBtf model = displayable_model(5, true);
  const std::string path = save_model(model, "quad.wbtf");
  const vec3 towards_light = glm::normalize(vec3(-0.4f, 0.3f, 1.0f));
  const std::string lights = weft::format(R"([{{"type": "directional", "direction": [{}, {}, {}], "intensity": 1}}])",
                                          -towards_light.x, -towards_light.y, -towards_light.z);
  for (const char* decoder : {"batched", "fragment"}) {
  CAPTURE(decoder);
  auto s = load(quad_scene(weft::format(R"({{"type": "neural_btf", "model": "{}", "ambient": false, "shadow": false,
                                            "decoder": "{}"}})", path, decoder),
                           lights));
  auto frame = shared_renderer().render(s, {.quality = Quality::Medium, .aces = false});
  REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
  const char* pass = std::string(decoder) == "batched" ? "neural_btf_decode" : "neural_btf_fragment";
  CHECK(std::find(frame->passes.begin(), frame->passes.end(), pass) != frame->passes.end());
  int checked = 0, lit = 0;
  for (std::uint32_t y = 0; y < 64; ++y)
    for (std::uint32_t x = 0; x < 64; ++x) {
      const PixelInputs in = pixel_inputs(s, x, y, 64, towards_light, {model.width, model.height}, 1.0f);
      if (!in.ok) continue;
      const vec3 expected = glm::clamp(btf::decode(model, in.texel, in.light, in.view), vec3(0.0f), vec3(1.0f));
      for (int c = 0; c < 3; ++c) {
        const double got = linear(frame->image, x, y, c);
        CHECK_MESSAGE(std::abs(got - expected[c]) <= 0.004 + 0.02 * expected[c],
                      "pixel (" << x << ", " << y << ") texel " << in.texel << " channel " << c << ": got " << got
                                << ", CPU decode " << expected[c]);
        if (expected[c] > 0.05f) ++lit;
      }
      ++checked;
    }
  CHECK(checked > 1500);
  CHECK(lit > 1500);
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("the ambient term alone: a constant sky c gives decode(ω_i = n, ω_o) times π c; tiling repeats texels") {
  const btf::NeuralBtf model = displayable_model(0, false);
  const std::string path = save_model(model, "ambient.wbtf");
  const float sky = 0.25f;
  auto s = load(quad_scene(weft::format(R"({{"type": "neural_btf", "model": "{}", "ambient": true, "uv_scale": [2, 2],
                                           "filter": "nearest"}})",
                                        path),
                           "[]", "[0.25, 0.25, 0.25]"));
  auto frame = shared_renderer().render(s, {.quality = Quality::Medium, .aces = false});
  REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
  int checked = 0;
  for (std::uint32_t y = 0; y < 64; ++y)
    for (std::uint32_t x = 0; x < 64; ++x) {
      const PixelInputs in = pixel_inputs(s, x, y, 64, vec3(0, 0, 1), {model.width, model.height}, 2.0f);
      if (!in.ok) continue;
      const vec3 expected = glm::clamp(btf::decode(model, in.texel, vec3(0, 0, 1), in.view) * (pi * sky), vec3(0.0f),
                                       vec3(1.0f));
      for (int c = 0; c < 3; ++c)
        CHECK_MESSAGE(std::abs(linear(frame->image, x, y, c) - expected[c]) <= 0.004 + 0.02 * expected[c],
                      "pixel (" << x << ", " << y << ") channel " << c);
      ++checked;
    }
  CHECK(checked > 1000);
  weft::test::expect_no_validation_messages();
}

// A 5 x 3 texel BTF at the UBO2003 directions whose samples are smooth in the directions and
// distinct per texel, all in (0.05, 0.95) so an 8-bit frame shows them.
btf::Btf displayable_btf() {
  btf::Btf b;
  b.width = 5, b.height = 3;
  b.lights = b.views = btf::ubo2003_directions();
  b.rgb.resize(b.texels() * b.abrdf_floats());
  for (std::size_t t = 0; t < b.texels(); ++t)
    for (std::size_t l = 0; l < b.lights.size(); ++l)
      for (std::size_t v = 0; v < b.views.size(); ++v) {
        const vec3 wl = btf::to_vector(b.lights[l]), wv = btf::to_vector(b.views[v]);
        for (std::size_t c = 0; c < 3; ++c)
          b.rgb[((t * b.lights.size() + l) * b.views.size() + v) * 3 + c] =
              0.5f + 0.4f * std::sin(1.7f * float(t) + 2.3f * float(c) + 1.9f * wl.x - 1.3f * wl.y + 2.1f * wv.x * wv.y + wv.z);
      }
  return b;
}

TEST_CASE("the reference mode: every covered pixel is the CPU sample_reference of the raw BTF times the light") {
  const btf::Btf data = displayable_btf();
  const auto path = temp_dir() / "reference.btfraw";
  REQUIRE(btf::save_btf(data, path));
  const vec3 towards_light = glm::normalize(vec3(0.5f, -0.2f, 1.0f));
  const std::string lights = weft::format(R"([{{"type": "directional", "direction": [{}, {}, {}], "intensity": 1}}])",
                                          -towards_light.x, -towards_light.y, -towards_light.z);
  auto s = load(quad_scene(weft::format(R"({{"type": "neural_btf", "mode": "reference", "btf": "{}", "ambient": false,
                                           "shadow": false, "filter": "nearest"}})",
                                        path.string()),
                           lights));
  auto frame = shared_renderer().render(s, {.quality = Quality::Medium, .aces = false});
  REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
  CHECK(std::find(frame->passes.begin(), frame->passes.end(), "neural_btf_fragment") != frame->passes.end());
  int checked = 0;
  double largest = 0.0;
  for (std::uint32_t y = 0; y < 64; ++y)
    for (std::uint32_t x = 0; x < 64; ++x) {
      const PixelInputs in = pixel_inputs(s, x, y, 64, towards_light, {data.width, data.height}, 1.0f);
      if (!in.ok) continue;
      const vec3 expected = glm::clamp(btf::sample_reference(data, in.texel, in.light, in.view), vec3(0.0f), vec3(1.0f));
      for (int c = 0; c < 3; ++c) {
        const double got = linear(frame->image, x, y, c);
        largest = std::max(largest, std::abs(got - expected[c]));
        CHECK_MESSAGE(std::abs(got - expected[c]) <= 0.004 + 0.01 * expected[c],
                      "pixel (" << x << ", " << y << ") texel " << in.texel << " channel " << c << ": got " << got
                                << ", CPU sample_reference " << expected[c]);
      }
      ++checked;
    }
  CHECK(checked > 1500);
  MESSAGE("largest |GPU - CPU| over " << checked << " pixels: " << largest);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("the reference mode's buffer: directions then samples; a BTF too large for it is cropped top-left") {
  const btf::Btf data = displayable_btf();
  auto whole = passes::pack_reference(data, std::uint64_t(1) << 30);
  REQUIRE(whole);
  CHECK_FALSE(whole->cropped);
  CHECK(whole->words[0] == 81);
  CHECK(whole->words[2] == 5);
  CHECK(whole->words[3] == 3);
  CHECK(whole->words.size() == 4 + 4 * 162 + data.rgb.size());
  const std::size_t per_texel = data.abrdf_floats() * 4, header = 16 + 16 * 162;
  auto cropped = passes::pack_reference(data, header + 6 * per_texel + 100);  // room for 6 of 15 texels
  REQUIRE(cropped);
  CHECK(cropped->cropped);
  CHECK(std::uint64_t(cropped->crop.width) * cropped->crop.height <= 6);
  CHECK(cropped->crop.width >= 1);
  CHECK(cropped->crop.height >= 1);
  // Texel (1, 0) of the crop is texel (1, 0) of the data.
  const std::size_t at = 4 + 4 * 162 + data.abrdf_floats();
  CHECK(std::bit_cast<float>(cropped->words[at + 7]) == data.abrdf(1)[7]);
  auto none = passes::pack_reference(data, header + per_texel - 1);
  REQUIRE_FALSE(none);
  CHECK(none.error().message.find("does not fit") != std::string::npos);
}

TEST_CASE("the batched (tiled) decoder equals the CPU decode on random queries: max |Δ| <= 1e-4") {
  auto kernel = passes::BtfDecodeKernel::create(device());
  REQUIRE_MESSAGE(kernel, (kernel ? "" : kernel.error().message));
  // The paper's shape, plain and clustered with per-texel scales; 4,001 queries (not a whole
  // number of 64-row batches), random texels and directions over the hemisphere and below it.
  for (int variant = 0; variant < 2; ++variant) {
    const btf::NeuralBtf model =
        variant == 0 ? btf::random_model({.width = 20, .height = 20, .seed = 21})
                     : btf::random_model({.width = 30, .height = 10, .clusters = 40, .scales = true, .output_scale = 1.7f,
                                          .seed = 22});
    auto buffer = passes::upload_model(device(), model, "test-model");
    REQUIRE_MESSAGE(buffer, (buffer ? "" : buffer.error().message));
    CHECK(buffer->tiled);
    std::mt19937 rng(7 + variant);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<passes::DecodeQuery> queries(4001);
    for (auto& q : queries)
      q = {vec3(u(rng), u(rng), u(rng)), float(rng() % model.texels()), vec3(u(rng), u(rng), std::abs(u(rng))), 0.0f};
    auto gpu = kernel->decode(device(), *buffer, queries, passes::DecodeVariant::Tiled);
    REQUIRE_MESSAGE(gpu, (gpu ? "" : gpu.error().message));
    double worst = 0.0, largest = 0.0;
    int nonzero = 0;
    for (std::size_t i = 0; i < queries.size(); ++i) {
      const auto& q = queries[i];
      const vec3 cpu = btf::decode(model, std::size_t(q.texel), q.light, q.view);
      for (int c = 0; c < 3; ++c) {
        const double d = std::abs(double((*gpu)[i][c]) - cpu[c]);
        worst = std::max(worst, d);
        largest = std::max(largest, double(std::abs(cpu[c])));
        if (cpu[c] > 0.0f) ++nonzero;
      }
    }
    MESSAGE("tiled decoder, model " << variant << ": max |gpu - cpu| " << worst << " over " << queries.size()
                                    << " queries (largest output " << largest << ")");
    CHECK(worst <= 1e-4);
    CHECK(largest > 0.5);
    CHECK(nonzero > int(queries.size()) / 4);  // not a comparison of zeros (ReLU-clamped outputs)
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("the cushion scene through the batched decoder equals the fragment decoder: RMSE <= 1e-3 (linear)") {
  const char* source = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE_MESSAGE(source, "WEFT_SOURCE_DIR is set by ctest");
  auto desc = scene::load_scene(std::filesystem::path(source) / "examples/scenes/neural_btf.json");
  REQUIRE_MESSAGE(desc, (desc ? "" : desc.error().message));
  // Medium (nearest + ambient) and high (bilinear: four texels a term), smaller than the
  // scene's 960 x 540 to keep the fragment path's time down.
  struct Case {
    Quality quality;
    std::uint32_t width, height;
  };
  for (const Case c : {Case{Quality::Medium, 480, 270}, Case{Quality::High, 240, 136}}) {
    CAPTURE(int(c.quality));
    auto render = [&](const char* decoder, bool black) {
      scene::Scene s = *desc;
      for (auto& m : s.materials)
        if (m.params.is_object() && m.params.contains("model")) {
          m.params["decoder"] = decoder;
          if (black) m.params["tint"] = {0.0, 0.0, 0.0};
        }
      auto frame = shared_renderer().render(
          s, {.width = c.width, .height = c.height, .quality = c.quality, .aces = false, .read_hdr = true});
      REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
      return std::move(*frame);
    };
    const auto batched = render("batched", false);
    const auto fragment = render("fragment", false);
    const auto black = render("batched", true);  // where the cloth is: the pixels that change
    CHECK(std::find(batched.passes.begin(), batched.passes.end(), "neural_btf_decode") != batched.passes.end());
    CHECK(std::find(fragment.passes.begin(), fragment.passes.end(), "neural_btf_fragment") != fragment.passes.end());
    // The batched path draws its G-buffer over the objects' rectangle (the viewport moved by
    // the rectangle's corner) and the objects again in its composite: the two can round a
    // vertex to neighbouring 1/256-pixel steps, so a pixel on a triangle's edge may take the
    // other triangle's (or a neighbour's) decode. Those pixels are counted and bounded; the
    // rest equal the fragment path to float rounding.
    double sum = 0.0, cloth_sum = 0.0, worst = 0.0, cloth_mean = 0.0;
    std::size_t n = 0, cloth = 0, edge_flips = 0;
    for (std::uint32_t y = 0; y < c.height; ++y)
      for (std::uint32_t x = 0; x < c.width; ++x) {
        bool is_cloth = false, flipped = false;
        for (std::uint32_t ch = 0; ch < 3; ++ch) {
          const double a = batched.hdr.at(x, y, ch), b = fragment.hdr.at(x, y, ch);
          REQUIRE(std::isfinite(a));
          sum += (a - b) * (a - b);
          ++n;
          is_cloth = is_cloth || std::abs(b - black.hdr.at(x, y, ch)) > 1e-3;
          flipped = flipped || std::abs(a - b) > 2e-3;
        }
        if (flipped) ++edge_flips;
        if (!is_cloth || flipped) continue;
        ++cloth;
        for (std::uint32_t ch = 0; ch < 3; ++ch) {
          const double a = batched.hdr.at(x, y, ch), b = fragment.hdr.at(x, y, ch);
          cloth_sum += (a - b) * (a - b);
          cloth_mean += b / 3.0;
          worst = std::max(worst, std::abs(a - b));
        }
      }
    const double rmse = std::sqrt(sum / double(n)), cloth_rmse = std::sqrt(cloth_sum / double(3 * std::max<std::size_t>(cloth, 1)));
    MESSAGE("batched vs fragment: RMSE " << rmse << " over the frame; " << edge_flips
                                         << " pixels differ by more than 2e-3; over the other " << cloth
                                         << " cloth pixels (mean " << cloth_mean / double(std::max<std::size_t>(cloth, 1))
                                         << ") RMSE " << cloth_rmse << ", max |Δ| " << worst);
    CHECK(cloth > c.width * c.height / 20);  // the cushion and the bolt cover a good part of the frame
    CHECK(edge_flips <= std::max<std::size_t>(3, cloth / 1000));  // about one edge pixel in 20,000 here
    CHECK(rmse <= 1e-3);
    CHECK(cloth_rmse <= 1e-4);
    CHECK(worst <= 2e-3);
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("an MSAA frame keeps the batched decode, composited per sample: inside the cloth it equals the single-sample frame") {
  const char* source = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE_MESSAGE(source, "WEFT_SOURCE_DIR is set by ctest");
  auto desc = scene::load_scene(std::filesystem::path(source) / "examples/scenes/neural_btf.json");
  REQUIRE_MESSAGE(desc, (desc ? "" : desc.error().message));
  auto base = pipeline::default_pipeline();
  REQUIRE(base);
  auto msaa = pipeline::with_options(*base, "scene", {{"msaa", 4}});
  REQUIRE_MESSAGE(msaa, (msaa ? "" : msaa.error().message));
  const std::uint32_t w = 240, h = 136;
  auto render = [&](const pipeline::Pipeline* p, bool black) {
    scene::Scene s = *desc;
    if (black)
      for (auto& m : s.materials)
        if (m.params.is_object() && m.params.contains("model")) m.params["tint"] = {0.0, 0.0, 0.0};
    renderer::RenderOptions o{.width = w, .height = h, .aces = false, .read_hdr = true};
    o.pipeline = p;
    auto frame = shared_renderer().render(s, o);
    REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
    return std::move(*frame);
  };
  const auto single = render(&*base, false), black = render(&*base, true), multi = render(&*msaa, false);
  auto has = [](const renderer::Frame& f, const char* pass) {
    return std::find(f.passes.begin(), f.passes.end(), pass) != f.passes.end();
  };
  CHECK(has(multi, "neural_btf_decode"));
  CHECK(has(multi, "neural_btf_composite"));
  CHECK_FALSE(has(multi, "neural_btf_fragment"));
  auto cloth = [&](std::uint32_t x, std::uint32_t y) {
    for (std::uint32_t c = 0; c < 3; ++c)
      if (std::abs(single.hdr.at(x, y, c) - black.hdr.at(x, y, c)) > 1e-3) return true;
    return false;
  };
  std::size_t inside = 0;
  double worst = 0.0;
  for (std::uint32_t y = 1; y + 1 < h; ++y)
    for (std::uint32_t x = 1; x + 1 < w; ++x) {
      bool all = true;
      for (int dy = -1; dy <= 1 && all; ++dy)
        for (int dx = -1; dx <= 1 && all; ++dx) all = cloth(x + dx, y + dy);
      if (!all) continue;
      ++inside;
      for (std::uint32_t c = 0; c < 3; ++c) {
        const double a = single.hdr.at(x, y, c);
        worst = std::max(worst, std::abs(multi.hdr.at(x, y, c) - a) / std::max(std::abs(a), 1e-2));
      }
    }
  MESSAGE("MSAA against single-sample inside the cloth: " << inside << " pixels, max relative |Δ| " << worst);
  CHECK(inside > w * h / 30);
  CHECK(worst <= 4e-3);  // the same decode in all four samples, through half floats
  weft::test::expect_no_validation_messages();
}

TEST_CASE("the batched path over two models and all four tap classes equals the fragment path; edge tiles partly off-frame") {
  // Four quads: taps per pixel 1 (nearest, no ambient), 2 (nearest + ambient), 4 (bilinear, no
  // ambient) and 8 (bilinear + ambient), so each of the decode's four lists is used; the paper-
  // shaped model goes through the tiled decoder, a narrower one through the generic per-row
  // decoder. 75 x 53 pixels: the 16 x 16 list tiles run off the frame's right and bottom edges.
  const std::string paper = save_model(displayable_model(3, true), "classes_paper.wbtf");
  btf::NeuralBtf narrow_model = btf::random_model({.width = 5, .height = 3, .hidden = {24, 20}, .seed = 29});
  for (float& b : narrow_model.decoder.layers.back().bias) b = 0.3f;
  const std::string narrow = save_model(narrow_model, "classes_narrow.wbtf");
  auto scene_json = [&](const char* decoder, float tint) {
    std::string materials, objects;
    const char* filters[] = {"nearest", "nearest", "bilinear", "bilinear"};
    const bool ambient[] = {false, true, false, true};
    const float at[][2] = {{-0.55f, 0.55f}, {0.55f, 0.55f}, {-0.55f, -0.55f}, {0.55f, -0.55f}};
    for (int i = 0; i < 4; ++i) {
      materials += weft::format(R"({0}"m{1}": {{"type": "neural_btf", "model": "{2}", "filter": "{5}", "ambient": {6},
                                    "shadow": false, "uv_scale": [2, 2], "tint": [{4}, {4}, {4}], "decoder": "{3}"}})",
                                i ? ", " : "", i, i % 2 ? narrow : paper, decoder, tint, filters[i], ambient[i]);
      objects += weft::format(R"({}{{"name": "q{}", "mesh": "quad", "material": "m{}",
                                  "transform": {{"translation": [{}, {}, 0], "rotation_degrees": [90, 0, 0]}}}})",
                              i ? ", " : "", i, i, at[i][0], at[i][1]);
    }
    return weft::format(R"({{"version": 1, "output": {{"width": 75, "height": 53}},
      "camera": {{"position": [0, 0, 40], "target": [0, 0, 0], "fov": 3.4, "near": 30, "far": 50}},
      "environment": {{"color": [0.3, 0.35, 0.4]}},
      "lights": [{{"type": "directional", "direction": [0.3, -0.2, -1], "intensity": 1.5}}],
      "meshes": {{"quad": {{"primitive": "plane", "size": 1, "subdivisions": 1}}}},
      "materials": {{{}}}, "objects": [{}]}})",
                        materials, objects);
  };
  auto render = [&](const char* decoder, float tint = 1.0f) {
    auto s = load(scene_json(decoder, tint));
    auto frame = shared_renderer().render(s, {.quality = Quality::Medium, .aces = false, .read_hdr = true});
    REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
    return std::move(*frame);
  };
  const auto batched = render("batched");
  const auto fragment = render("fragment");
  const auto black = render("batched", 0.0f);  // the background and nothing of the cloth
  for (const char* pass : {"neural_btf_list", "neural_btf_decode", "neural_btf_list_1", "neural_btf_decode_1"})
    CHECK_MESSAGE(std::find(batched.passes.begin(), batched.passes.end(), pass) != batched.passes.end(), pass);
  double sum = 0.0, worst = 0.0;
  int lit[4] = {};  // per quadrant: pixels whose cloth is visibly lit
  for (std::uint32_t y = 0; y < 53; ++y)
    for (std::uint32_t x = 0; x < 75; ++x)
      for (std::uint32_t ch = 0; ch < 3; ++ch) {
        const double a = batched.hdr.at(x, y, ch), b = fragment.hdr.at(x, y, ch);
        REQUIRE(std::isfinite(a));
        sum += (a - b) * (a - b);
        worst = std::max(worst, std::abs(a - b));
        if (ch == 0 && b - black.hdr.at(x, y, ch) > 0.05) ++lit[(y < 53 / 2 ? 0 : 2) + (x < 75 / 2 ? 0 : 1)];
      }
  const double rmse = std::sqrt(sum / (75.0 * 53.0 * 3.0));
  MESSAGE("two models, four tap classes: batched vs fragment RMSE " << rmse << ", max |Δ| " << worst);
  for (int q = 0; q < 4; ++q) CHECK_MESSAGE(lit[q] > 200, "quadrant " << q << " has " << lit[q] << " lit pixels");
  CHECK(rmse <= 1e-4);
  CHECK(worst <= 1e-3);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("the batched path's rectangle: objects off the frame's edge and a floor behind the camera decode as the fragment path does") {
  // The G-buffer, lists and radiance cover the rectangle the objects' bounds project to: a
  // quad half off the left edge clamps it to the frame; a floor that runs behind the camera
  // (a bound's corner not in front of it) makes it the whole frame.
  const std::string path = save_model(displayable_model(3, false), "rectangle.wbtf");
  auto scene_json = [&](const char* decoder, bool floor) {
    std::string objects = R"({"name": "edge", "mesh": "quad", "material": "cloth",
                              "transform": {"translation": [-2.7, 0.3, 0], "rotation_degrees": [90, 0, 0]}})";
    if (floor)
      objects += R"(, {"name": "floor", "mesh": "floor", "material": "cloth", "transform": {"translation": [0, -1, 0]}})";
    return weft::format(R"({{"version": 1, "output": {{"width": 96, "height": 64}},
      "camera": {{"position": [0, 0.5, 5], "target": [0, 0, 0], "fov": 60, "near": 0.1, "far": 100}},
      "environment": {{"color": [0.3, 0.35, 0.4]}},
      "lights": [{{"type": "directional", "direction": [0.3, -1, -0.5], "intensity": 1.5}}],
      "meshes": {{"quad": {{"primitive": "plane", "size": 1, "subdivisions": 1}},
                  "floor": {{"primitive": "plane", "size": 200, "subdivisions": 1}}}},
      "materials": {{"cloth": {{"type": "neural_btf", "model": "{}", "shadow": false, "uv_scale": [4, 4],
                                "decoder": "{}"}}}},
      "objects": [{}]}})",
                        path, decoder, objects);
  };
  for (const bool floor : {false, true}) {
    CAPTURE(floor);
    auto render = [&](const char* decoder) {
      auto s = load(scene_json(decoder, floor));
      auto frame = shared_renderer().render(s, {.quality = Quality::Medium, .aces = false, .read_hdr = true});
      REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().message));
      return std::move(*frame);
    };
    const auto batched = render("batched");
    const auto fragment = render("fragment");
    CHECK(std::find(batched.passes.begin(), batched.passes.end(), "neural_btf_composite") != batched.passes.end());
    std::size_t flips = 0, lit = 0;
    double sum = 0.0;
    for (std::uint32_t y = 0; y < 64; ++y)
      for (std::uint32_t x = 0; x < 96; ++x) {
        double worst = 0.0, pixel = 0.0;
        for (std::uint32_t ch = 0; ch < 3; ++ch) {
          const double a = batched.hdr.at(x, y, ch), b = fragment.hdr.at(x, y, ch);
          REQUIRE(std::isfinite(a));
          worst = std::max(worst, std::abs(a - b));
          pixel += (a - b) * (a - b);
        }
        if (fragment.hdr.at(x, y, 0) > 0.45) ++lit;  // brighter than the sky: the cloth
        if (worst > 2e-3) ++flips;
        else sum += pixel;
      }
    MESSAGE("floor " << floor << ": " << lit << " cloth pixels, " << flips << " edge pixels differ; the rest RMSE "
                     << std::sqrt(sum / (96.0 * 64.0 * 3.0)));
    CHECK(lit > (floor ? 1000u : 60u));  // the quad's visible half, and the floor
    CHECK(flips <= 3);
    CHECK(std::sqrt(sum / (96.0 * 64.0 * 3.0)) <= 1e-4);
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("the renderer adds the neural_btf pass only for scenes that use the material") {
  const std::string path = save_model(displayable_model(3, false), "culling.wbtf");
  const std::string light = R"([{"type": "directional", "direction": [0, 0, -1], "intensity": 1}])";
  auto with = load(quad_scene(weft::format(R"({{"type": "neural_btf", "model": "{}"}})", path), light));
  auto report = shared_renderer().describe(with, {.quality = Quality::Low});
  REQUIRE_MESSAGE(report, (report ? "" : report.error().message));
  CHECK(report->passes == std::vector<std::string>{"shadow_map", "forward", "neural_btf", "neural_btf_list_clear",
                                                   "neural_btf_list", "neural_btf_decode", "neural_btf_composite",
                                                   "background", "tonemap"});
  CHECK(report->dot.find("neural_btf_model") != std::string::npos);
  auto plain = load(quad_scene(R"({"type": "standard"})", light));
  auto other = shared_renderer().describe(plain, {.quality = Quality::Low});
  REQUIRE(other);
  CHECK(std::find(other->passes.begin(), other->passes.end(), "neural_btf") == other->passes.end());
  CHECK(other->dot.find("neural_btf") == std::string::npos);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("material errors name their JSON path; a corrupt model names the file and the material") {
  const std::string light = R"([{"type": "directional", "direction": [0, 0, -1], "intensity": 1}])";
  auto bad = load(quad_scene(
      R"({"type": "neural_btf", "model": "missing.wbtf", "uv_scale": -1, "mode": "fast", "tint": [1, 2], "colour": 1})",
      light));
  auto frame = shared_renderer().render(bad, {.quality = Quality::Low});
  REQUIRE_FALSE(frame);
  const std::string message = frame.error().message;
  CHECK(message.find("$.materials.cloth.model") != std::string::npos);
  CHECK(message.find("missing.wbtf") != std::string::npos);
  CHECK(message.find("$.materials.cloth.uv_scale") != std::string::npos);
  CHECK(message.find("$.materials.cloth.mode") != std::string::npos);
  CHECK(message.find("$.materials.cloth.tint") != std::string::npos);
  CHECK(message.find("colour") != std::string::npos);

  auto missing = load(quad_scene(R"({"type": "neural_btf", "uv_scale": 2})", light));
  auto no_model = shared_renderer().render(missing, {.quality = Quality::Low});
  REQUIRE_FALSE(no_model);
  CHECK(no_model.error().message.find("$.materials.cloth") != std::string::npos);
  CHECK(no_model.error().message.find("model") != std::string::npos);

  // The reference mode needs its raw BTF; a synthetic one is named by weave and size.
  auto no_btf = load(quad_scene(R"({"type": "neural_btf", "mode": "reference"})", light));
  auto no_btf_frame = shared_renderer().render(no_btf, {.quality = Quality::Low});
  REQUIRE_FALSE(no_btf_frame);
  CHECK(no_btf_frame.error().message.find("btf") != std::string::npos);
  auto bad_synthetic = load(quad_scene(R"({"type": "neural_btf", "mode": "reference", "btf": "synthetic:tweed:4x4"})", light));
  auto bad_synthetic_frame = shared_renderer().render(bad_synthetic, {.quality = Quality::Low});
  REQUIRE_FALSE(bad_synthetic_frame);
  CHECK(bad_synthetic_frame.error().message.find("$.materials.cloth.btf") != std::string::npos);
  CHECK(bad_synthetic_frame.error().message.find("synthetic:tweed:4x4") != std::string::npos);

  // A file that is not a .wbtf: the error names the material, its field and the file.
  const auto junk = temp_dir() / "junk.wbtf";
  {
    std::FILE* f = std::fopen(junk.string().c_str(), "wb");
    REQUIRE(f);
    std::fputs("not a model", f);
    std::fclose(f);
  }
  auto corrupt = load(quad_scene(weft::format(R"({{"type": "neural_btf", "model": "{}"}})", junk.string()), light));
  auto corrupt_frame = shared_renderer().render(corrupt, {.quality = Quality::Low});
  REQUIRE_FALSE(corrupt_frame);
  const std::string e = corrupt_frame.error().message;
  CHECK(e.find("neural_btf material 'cloth' ($.materials.cloth.model)") != std::string::npos);
  CHECK(e.find("junk.wbtf: not a weft neural BTF file") != std::string::npos);

  // Parsing alone: the quality presets set the knobs the material leaves out.
  const std::string path = save_model(displayable_model(3, false), "presets.wbtf");
  auto presets = load(quad_scene(weft::format(R"({{"type": "neural_btf", "model": "{}", "uv_scale": 3}})", path), light));
  const auto& material = presets.materials.at(presets.objects[0].material);
  auto low = btf::parse_neural_btf_material(material, Quality::Low);
  auto high = btf::parse_neural_btf_material(material, Quality::High);
  REQUIRE(low);
  REQUIRE(high);
  CHECK(low->uv_scale == vec2(3.0f));
  CHECK_FALSE(low->ambient);
  CHECK(low->filter == btf::TexelFilter::Nearest);
  CHECK(high->ambient);
  CHECK(high->filter == btf::TexelFilter::Bilinear);
  auto pinned = load(quad_scene(weft::format(R"({{"type": "neural_btf", "model": "{}", "filter": "nearest"}})", path), light));
  auto pinned_high = btf::parse_neural_btf_material(pinned.materials.at(pinned.objects[0].material), Quality::High);
  REQUIRE(pinned_high);
  CHECK(pinned_high->filter == btf::TexelFilter::Nearest);
  weft::test::expect_no_validation_messages();
}
