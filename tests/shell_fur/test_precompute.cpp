// Shell fur's CPU side: luminance codes, histogram and robust thresholds, the band table of
// equation 4 against its closed form, the keep intervals the shader uses, the extremes of
// every input (black pixels, a uniform photo, 1 and 256 layers, h_b = 0, a 1x1 photo), hair
// orientation, fins, generated UVs and the material's JSON fields.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <numeric>
#include <string>
#include <vector>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
import weft.core;
import weft.image;
import weft.scene;
import weft.feature;
import weft.pass.shell_fur;

using namespace weft;
using namespace weft::passes;
using namespace weft::fur;

namespace {

image::Image8 grey_image(std::uint32_t w, std::uint32_t h, const std::vector<std::uint8_t>& codes) {
  image::Image8 img = image::Image8::filled(w, h, 1);
  for (std::size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = codes[i % codes.size()];
  return img;
}

FurPhoto analyze(const image::Image8& img, FurThresholds t = {}) {
  auto photo = analyze_fur_photo(img, t);
  REQUIRE_MESSAGE(photo, (photo ? "" : photo.error().what()));
  return std::move(*photo);
}

FurBandTable table(double i_max, double i_min, std::uint32_t layers, FurLayout layout = FurLayout::Band) {
  auto t = make_band_table(i_max, i_min, layers, layout);
  REQUIRE_MESSAGE(t, (t ? "" : t.error().what()));
  return std::move(*t);
}

// What the fragment shader decides for a texel of `code` in `layer` (float math, as on the GPU).
bool shader_keeps(const FurBandTable& t, std::uint32_t layer, std::uint8_t code) {
  const float a = float(code) / 255.0f;
  return a >= t.gpu[layer].keep_min && a < t.gpu[layer].keep_max;
}

// The fragment shader's colour factor for a texel of `code` drawn in `layer`: darkened to the
// band's top when it lies above it (float math, as on the GPU).
float shader_darkening(const FurBandTable& t, std::uint32_t layer, std::uint8_t code) {
  const auto luminance = [](float a) { return a <= 0.04045f ? a / 12.92f : std::pow((a + 0.055f) / 1.055f, 2.4f); };
  const float a = float(code) / 255.0f, top = t.gpu[layer].top;
  return a > top ? luminance(std::max(top, 0.0f)) / luminance(a) : 1.0f;
}

std::filesystem::path shared_data() {
  const char* env = std::getenv("WEFT_SHARED_DATA");
  return env ? std::filesystem::path(env) : std::filesystem::path("/work/shared/data");
}

}  // namespace

TEST_CASE("luminance codes: grey maps to itself, colours by Rec. 709 weights of linear values") {
  for (int c = 0; c < 256; ++c) CHECK(int(fur_luminance_code(std::uint8_t(c), std::uint8_t(c), std::uint8_t(c))) == c);
  // Pure green is far brighter than pure blue.
  CHECK(fur_luminance_code(0, 255, 0) > fur_luminance_code(255, 0, 0));
  CHECK(fur_luminance_code(255, 0, 0) > fur_luminance_code(0, 0, 255));
  CHECK(std::abs(fur_code_to_luminance(255) - 1.0) < 1e-12);
  CHECK(fur_code_to_luminance(0) == 0.0);
  CHECK(fur_luminance_floor() > 0.0);
  CHECK(fur_luminance_floor() < fur_code_to_luminance(1));
}

TEST_CASE("histogram and percentile thresholds ignore a few outlier pixels") {
  // 1000 texels: 5 black, 495 at 60, 495 at 180, 5 white.
  std::vector<std::uint8_t> codes;
  codes.insert(codes.end(), 5, 0);
  codes.insert(codes.end(), 495, 60);
  codes.insert(codes.end(), 495, 180);
  codes.insert(codes.end(), 5, 255);
  const FurPhoto p = analyze(grey_image(100, 10, codes));
  CHECK(p.histogram[0] == 5);
  CHECK(p.histogram[60] == 495);
  CHECK(p.histogram[180] == 495);
  CHECK(p.histogram[255] == 5);
  CHECK(std::accumulate(p.histogram.begin(), p.histogram.end(), std::uint64_t(0)) == 1000);
  CHECK(p.code_min == 60);
  CHECK(p.code_max == 180);
  CHECK(p.i_min == doctest::Approx(fur_code_to_luminance(60)));
  CHECK(p.i_max == doctest::Approx(fur_code_to_luminance(180)));
  // Percentiles 0 and 1 are the extremes; the black minimum is raised to the floor.
  const FurPhoto q = analyze(grey_image(100, 10, codes), {0.0, 1.0});
  CHECK(q.code_min == 0);
  CHECK(q.code_max == 255);
  CHECK(q.i_min == fur_luminance_floor());
  CHECK(!q.notes.empty());
  // The texture keeps the colour and puts the code in alpha.
  CHECK(p.rgba.size() == 4000);
  CHECK(p.rgba[3] == 0);
  CHECK(p.rgba[4 * 999 + 3] == 255);
}

TEST_CASE("the band table is equation 4, and equations 1-3 give the same boundaries") {
  const double i_max = 0.8, i_min = 0.02, h_b = 0.37;
  const std::uint32_t N = 15;
  const FurBandTable t = table(i_max, i_min, N);
  REQUIRE(t.boundaries.size() == N + 1);
  CHECK(t.boundaries.front() == i_max);
  CHECK(t.boundaries.back() == i_min);
  const double a = fur_attenuation(i_max, i_min, h_b);  // eq. 2
  CHECK(a == doctest::Approx(std::log(i_max / i_min) / h_b));
  for (std::uint32_t n = 0; n <= N; ++n) {
    const double h = h_b * double(n) / double(N);  // eq. 3
    CHECK(t.boundaries[n] == doctest::Approx(i_max * std::exp(-a * h)).epsilon(1e-12));  // eq. 1
    if (n > 0) CHECK(t.boundaries[n] / t.boundaries[n - 1] == doctest::Approx(std::pow(i_min / i_max, 1.0 / N)));
  }
  // Band tops: layer n darkens to exactly I(n-1), the model's luminance at its top (not to
  // the half-code keep threshold below it); the tips never darken.
  CHECK(t.gpu.front().top > 1.0f);
  for (std::uint32_t n = 1; n <= N; ++n)
    CHECK(fur_code_to_luminance(double(t.gpu[n].top) * 255.0) == doctest::Approx(t.boundaries[n - 1]).epsilon(1e-6));
  // Layer heights: tips at h_b above the skin, the skin at 0.
  CHECK(t.gpu.front().height == 1.0f);
  CHECK(t.gpu.back().height == 0.0f);
  CHECK(t.gpu[5].height == doctest::Approx(10.0 / 15.0));
}

TEST_CASE("every code sits in exactly the layer whose band holds its luminance; the GPU intervals agree") {
  for (FurLayout layout : {FurLayout::Band, FurLayout::Strand}) {
    for (std::uint32_t N : {1u, 2u, 8u, 15u, 64u, 256u}) {
      const double i_max = fur_code_to_luminance(230), i_min = fur_code_to_luminance(25);
      const FurBandTable t = table(i_max, i_min, N, layout);
      for (int c = 0; c < 256; ++c) {
        const double y = fur_code_to_luminance(c);
        const std::uint32_t d = t.depth_layer(std::uint8_t(c));
        // I(d) <= y < I(d-1), with layer 0 open above and the skin open below.
        if (d < N) CHECK_MESSAGE(y >= t.boundaries[d], "code " << c << " layer " << d << " N " << N);
        if (d > 0) CHECK_MESSAGE(y < t.boundaries[d - 1], "code " << c << " layer " << d << " N " << N);
        std::uint32_t drawn = 0;
        for (std::uint32_t n = 0; n <= N; ++n) {
          CHECK_MESSAGE(shader_keeps(t, n, std::uint8_t(c)) == t.keeps(n, std::uint8_t(c)),
                        "code " << c << " layer " << n << " N " << N << " " << to_string(layout));
          drawn += t.keeps(n, std::uint8_t(c)) ? 1 : 0;
          // Drawn in its own band a texel keeps its colour; below it, it is darkened.
          if (n == d) CHECK(float(c) / 255.0f <= t.gpu[n].top);
        }
        // Band: its own layer, plus the opaque skin. Strand: every layer from its own down.
        const std::uint32_t expected = layout == FurLayout::Band ? (d == N ? 1 : 2) : N + 1 - d;
        CHECK(drawn == expected);
      }
    }
  }
}

TEST_CASE("depth layer counts partition the photo; brighter texels sit higher") {
  const image::Image8 synthetic = synthesize_fur_photo({.width = 96, .height = 96, .seed = 7});
  const FurPhoto p = analyze(synthetic);
  const FurBandTable t = table(p.i_max, p.i_min, 15);
  const auto counts = depth_layer_counts(p, t);
  CHECK(std::accumulate(counts.begin(), counts.end(), std::uint64_t(0)) == p.texel_count());
  for (std::size_t i = 0; i < p.texel_count(); i += 37)
    for (std::size_t j = 0; j < p.texel_count(); j += 53)
      if (p.code(i) > p.code(j)) CHECK(t.depth_layer(p.code(i)) <= t.depth_layer(p.code(j)));
  // About 1% of texels are at or above the 99th percentile: the tips layer.
  CHECK(counts.front() >= p.texel_count() / 200);
  CHECK(counts.front() <= p.texel_count() / 20);
}

TEST_CASE("extremes: black pixels (I_min = 0) give a finite table; black texels sit on the skin") {
  std::vector<std::uint8_t> codes(64 * 64);
  for (std::size_t i = 0; i < codes.size(); ++i) codes[i] = i % 2 ? 0 : std::uint8_t(100 + i % 100);
  const FurPhoto p = analyze(grey_image(64, 64, codes));
  CHECK(p.i_min == fur_luminance_floor());
  CHECK(p.i_min > 0.0);
  CHECK(std::isfinite(fur_attenuation(p.i_max, p.i_min, 0.1)));
  for (std::uint32_t N : {1u, 15u, 256u}) {
    const FurBandTable t = table(p.i_max, p.i_min, N);
    for (double b : t.boundaries) CHECK(std::isfinite(b));
    for (const auto& g : t.gpu) {
      CHECK(std::isfinite(g.keep_min));
      CHECK(std::isfinite(g.keep_max));
      CHECK(std::isfinite(g.top));
    }
    CHECK(t.depth_layer(0) == N);
  }
  // An all-black photo: I_max = I_min = the floor; one layer (the skin) takes every texel.
  const FurPhoto black = analyze(grey_image(8, 8, {0}));
  CHECK(black.i_max == black.i_min);
  const FurBandTable t = table(black.i_max, black.i_min, 15);
  const auto counts = depth_layer_counts(black, t);
  CHECK(counts.back() == 64);
}

TEST_CASE("extremes: a uniform photo (I_max = I_min, a = 0) puts every texel in the top layer") {
  for (std::uint32_t N : {1u, 2u, 15u, 256u}) {
    for (FurLayout layout : {FurLayout::Band, FurLayout::Strand}) {
      const FurPhoto p = analyze(grey_image(16, 16, {140}));
      CHECK(p.i_max == p.i_min);
      CHECK(fur_attenuation(p.i_max, p.i_min, 0.2) == 0.0);
      const FurBandTable t = table(p.i_max, p.i_min, N, layout);
      const auto counts = depth_layer_counts(p, t);
      CHECK(counts.front() == 256);
      CHECK(std::accumulate(counts.begin() + 1, counts.end(), std::uint64_t(0)) == 0);
      for (double b : t.boundaries) CHECK(b == p.i_max);
      // No darkening in any layer that draws the texel (strand: all of them): every band's
      // top is the texel's own luminance. The naive textures hold its exact colour.
      const auto textures = make_shell_textures(p, t);
      for (std::uint32_t n = 0; n <= N; ++n) {
        if (!t.keeps(n, 140)) continue;
        CHECK_MESSAGE(shader_darkening(t, n, 140) == doctest::Approx(1.0f).epsilon(1e-6), "N=" << N << " layer " << n);
        CHECK(textures[n][0] == 140);
      }
    }
  }
}

TEST_CASE("extremes: one layer and 256 layers; 0 and 257 layers are errors") {
  const double i_max = fur_code_to_luminance(200), i_min = fur_code_to_luminance(20);
  const FurBandTable one = table(i_max, i_min, 1);
  CHECK(one.gpu.size() == 2);
  for (int c = 0; c < 256; ++c) CHECK(one.depth_layer(std::uint8_t(c)) == (c >= 200 ? 0u : 1u));
  const FurBandTable many = table(i_max, i_min, 256, FurLayout::Strand);
  CHECK(many.gpu.size() == 257);
  for (std::size_t n = 1; n < many.boundaries.size(); ++n) CHECK(many.boundaries[n] < many.boundaries[n - 1]);
  for (std::size_t n = 1; n < many.first_code.size(); ++n) CHECK(many.first_code[n] <= many.first_code[n - 1]);
  CHECK(!make_band_table(i_max, i_min, 0, FurLayout::Band));
  auto too_many = make_band_table(i_max, i_min, 257, FurLayout::Band);
  REQUIRE(!too_many);
  CHECK(too_many.error().message.find("257") != std::string::npos);
  CHECK(!make_band_table(i_max, 0.0, 15, FurLayout::Band));
  CHECK(!make_band_table(0.1, 0.2, 15, FurLayout::Band));
  CHECK(!make_band_table(std::numeric_limits<double>::quiet_NaN(), 0.1, 15, FurLayout::Band));
}

TEST_CASE("extremes: h_b = 0 makes a infinite but nothing else depends on it; a 1x1 photo is uniform") {
  CHECK(std::isinf(fur_attenuation(0.8, 0.1, 0.0)));
  CHECK(fur_attenuation(0.5, 0.5, 0.0) == 0.0);
  const FurPhoto p = analyze(grey_image(1, 1, {77}));
  CHECK(p.texel_count() == 1);
  CHECK(p.i_min == p.i_max);
  const FurBandTable t = table(p.i_max, p.i_min, 15);
  CHECK(depth_layer_counts(p, t).front() == 1);
  CHECK(p.orientation.size() == 2);
}

TEST_CASE("bad photos and percentiles are errors") {
  CHECK(!analyze_fur_photo(image::Image8{}));
  CHECK(!analyze_fur_photo(grey_image(4, 4, {9}), {0.5, 0.5}));
  CHECK(!analyze_fur_photo(grey_image(4, 4, {9}), {-0.1, 0.9}));
  CHECK(!analyze_fur_photo(grey_image(4, 4, {9}), {0.1, 1.5}));
}

TEST_CASE("hair orientation follows the streaks: along x for horizontal stripes, along y for vertical") {
  auto stripes = [](bool horizontal) {
    image::Image8 img = image::Image8::filled(32, 32, 1);
    for (std::uint32_t y = 0; y < 32; ++y)
      for (std::uint32_t x = 0; x < 32; ++x) img.at(x, y, 0) = ((horizontal ? y : x) / 2) % 2 ? 200 : 60;
    return analyze(img);
  };
  const FurPhoto h = stripes(true), v = stripes(false);
  const std::size_t centre = 16 * 32 + 16;
  // Double angle of the hair: (1, 0) for hair along x, (-1, 0) along y; encoded *0.5+0.5.
  CHECK(h.orientation[2 * centre] > 240);
  CHECK(std::abs(int(h.orientation[2 * centre + 1]) - 128) < 12);
  CHECK(v.orientation[2 * centre] < 15);
  CHECK(std::abs(int(v.orientation[2 * centre + 1]) - 128) < 12);
}

TEST_CASE("the naive method's per-layer textures hold exactly what the band table keeps") {
  const FurPhoto p = analyze(synthesize_fur_photo({.width = 40, .height = 30, .seed = 3}));
  for (FurLayout layout : {FurLayout::Band, FurLayout::Strand}) {
    const FurBandTable t = table(p.i_max, p.i_min, 8, layout);
    const auto layers = make_shell_textures(p, t);
    REQUIRE(layers.size() == 9);
    for (std::uint32_t n = 0; n <= 8; ++n)
      for (std::size_t i = 0; i < p.texel_count(); ++i) {
        const bool kept = layers[n][i * 4 + 3] == 255;
        CHECK(kept == t.keeps(n, p.code(i)));
        // Drawn in its own layer a texel keeps its exact colour; deeper, it is darkened.
        if (t.depth_layer(p.code(i)) == n) CHECK(layers[n][i * 4] == p.rgba[i * 4]);
        CHECK(layers[n][i * 4 + 1] <= p.rgba[i * 4 + 1]);
      }
  }
}

TEST_CASE("a synthetic fur photo is deterministic, has depth contrast and one population") {
  const image::Image8 a = synthesize_fur_photo({.width = 64, .height = 48, .seed = 5});
  const image::Image8 b = synthesize_fur_photo({.width = 64, .height = 48, .seed = 5});
  CHECK(a.pixels == b.pixels);
  CHECK(a.width == 64);
  CHECK(a.height == 48);
  const FurPhoto p = analyze(a);
  CHECK(p.i_max / p.i_min > 5.0);
  CHECK(p.bimodality < 0.85);
}

TEST_CASE("real fur photos (when ../shared/data is present): thresholds, one population vs two") {
  const auto cream = shared_data() / "fur" / "cream_long.jpg";
  const auto patches = shared_data() / "fur" / "black_white_patches.jpg";
  if (!std::filesystem::exists(cream) || !std::filesystem::exists(patches)) {
    MESSAGE("skipped: the real fur photos are not at " << (shared_data() / "fur").string()
                                                       << " (set WEFT_SHARED_DATA); they are not redistributable");
    return;
  }
  auto cream_image = image::load_ldr(cream);
  auto patches_image = image::load_ldr(patches);
  REQUIRE(cream_image);
  REQUIRE(patches_image);
  const FurPhoto c = analyze(*cream_image), p = analyze(*patches_image);
  for (const FurPhoto* photo : {&c, &p}) {
    CHECK(photo->i_min > 0.0);
    CHECK(photo->i_max > photo->i_min);
    CHECK(std::isfinite(std::log(photo->i_max / photo->i_min)));
  }
  MESSAGE("cream: codes " << int(c.code_min) << ".." << int(c.code_max) << ", separability " << c.bimodality
                          << "; patches: codes " << int(p.code_min) << ".." << int(p.code_max) << ", separability "
                          << p.bimodality);
  CHECK(c.bimodality < 0.85);
  CHECK(p.bimodality > 0.85);
}

TEST_CASE("fins: one per welded edge; zero-area triangles add none; boundary edges see one face") {
  // Two triangles of a unit quad, with the shared edge's vertices duplicated (a UV seam).
  const std::vector<vec3> positions{{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}, {0, 0, 0}, {1, 0, 1}};
  const std::vector<std::uint32_t> quad{0, 2, 1, 4, 3, 5};
  const auto edges = make_fin_edges(positions, {}, {}, quad);
  CHECK(edges.size() == 5);
  std::size_t boundary = 0;
  for (const auto& e : edges) {
    CHECK(glm::length(e.face_normal_0) == doctest::Approx(1.0f));
    CHECK(glm::dot(e.face_normal_0, e.face_normal_1) > 0.999f);  // a flat quad: one normal
    boundary += e.face_normal_0 == e.face_normal_1 ? 1 : 0;
  }
  CHECK(boundary >= 4);
  // Degenerate triangles: a repeated index, three collinear points, a zero-size one.
  std::vector<vec3> p2 = positions;
  p2.push_back({0.5f, 0, 0});
  std::vector<std::uint32_t> with_degenerate = quad;
  with_degenerate.insert(with_degenerate.end(), {0, 0, 1, 0, 6, 1, 2, 2, 2});
  CHECK(make_fin_edges(p2, {}, {}, with_degenerate).size() == 5);
  // A cube (24 split vertices): 12 edges + 6 face diagonals.
  auto cube = scene::make_cube(1.0f);
  REQUIRE(cube);
  const auto cube_edges = make_fin_edges(cube->positions, cube->normals, cube->uvs, cube->indices);
  CHECK(cube_edges.size() == 18);
  std::size_t creases = 0;
  for (const auto& e : cube_edges) creases += glm::dot(e.face_normal_0, e.face_normal_1) < 0.5f ? 1 : 0;
  CHECK(creases == 12);
}

TEST_CASE("generated UVs: planar for flat meshes, spherical (seam split) otherwise; 'mesh' asks for UVs") {
  auto sphere = scene::make_sphere(1.0f, 24);
  REQUIRE(sphere);
  sphere->uvs.clear();
  scene::Mesh copy = *sphere;
  auto refused = generate_fur_uvs(copy, FurUvMapping::Mesh);
  REQUIRE(!refused);
  CHECK(refused.error().message.find("uv_mapping") != std::string::npos);
  const std::size_t before = sphere->positions.size();
  REQUIRE(generate_fur_uvs(*sphere, FurUvMapping::Auto));
  CHECK(sphere->uvs.size() == sphere->positions.size());
  CHECK(sphere->tangents.size() == sphere->positions.size());
  CHECK(sphere->normals.size() == sphere->positions.size());
  CHECK(sphere->positions.size() > before);  // seam vertices were split
  for (std::size_t t = 0; t < sphere->indices.size(); t += 3) {
    float lo = 1e9f, hi = -1e9f;
    for (int k = 0; k < 3; ++k) {
      lo = std::min(lo, sphere->uvs[sphere->indices[t + std::size_t(k)]].x);
      hi = std::max(hi, sphere->uvs[sphere->indices[t + std::size_t(k)]].x);
    }
    CHECK(hi - lo <= 1.0f);
  }
  for (const vec2 uv : sphere->uvs) {
    CHECK(std::isfinite(uv.x));
    CHECK(uv.y >= 0.0f);
    CHECK(uv.y <= 1.0f);
  }
  auto plane = scene::make_plane(2.0f, 4);
  REQUIRE(plane);
  plane->uvs.clear();
  REQUIRE(generate_fur_uvs(*plane, FurUvMapping::Auto));
  for (const vec2 uv : plane->uvs) {
    CHECK(uv.x >= 0.0f);
    CHECK(uv.x <= 1.0f);
    CHECK(uv.y >= 0.0f);
    CHECK(uv.y <= 1.0f);
  }
  // A mesh that has UVs keeps them under auto.
  auto with_uvs = scene::make_plane(1.0f, 2);
  REQUIRE(with_uvs);
  const auto original = with_uvs->uvs;
  REQUIRE(generate_fur_uvs(*with_uvs, FurUvMapping::Auto));
  CHECK(with_uvs->uvs == original);
}

TEST_CASE("fur material: fields, defaults, layers by quality, all errors at their JSON paths") {
  const auto dir = std::filesystem::temp_directory_path();
  const auto photo = dir / "weft-fur-test-photo.png";
  REQUIRE(image::save_png(photo, synthesize_fur_photo({.width = 16, .height = 16})));
  scene::Material m;
  m.name = "fur";
  m.type = passes::shell_fur_feature().name;
  m.json_path = "$.materials.fur";
  m.base_dir = dir;
  m.params = {{"photo", photo.filename().string()}};
  auto defaults = parse_fur_material(m, Quality::High);
  REQUIRE_MESSAGE(defaults, (defaults ? "" : defaults.error().what()));
  CHECK(defaults->photo == photo);
  CHECK(defaults->layers == 32);
  CHECK(defaults->layers_from_quality);
  CHECK(defaults->layout == FurLayout::Strand);
  CHECK(defaults->lighting == FurLighting::KajiyaKay);
  CHECK(defaults->thickness_for(2.0f) == doctest::Approx(0.06f));
  CHECK(fur_layers_for(Quality::Low) == 8);
  CHECK(fur_layers_for(Quality::Medium) == 15);
  CHECK(fur_layers_for(Quality::Reference) == 64);
  // MSAA's hair test by quality: coverage up to medium, per sample from high.
  CHECK(defaults->per_sample_hair);
  auto medium = parse_fur_material(m, Quality::Medium);
  REQUIRE(medium);
  CHECK_FALSE(medium->per_sample_hair);

  m.params = nlohmann::json::parse(R"({"photo": ")" + photo.filename().string() + R"(", "layers": 15,
    "spacing": 0.002, "tint": [1, 0.9, 0.8], "layout": "band", "lighting": "lambert", "percentiles": [0.05, 0.95],
    "uv_scale": [2, 3], "wrap": "repeat", "uv_mapping": "spherical", "comb": [0, 1], "lift_degrees": 30,
    "specular": 0.2, "shininess": 60, "fins": false, "fin_threshold": 0.2, "msaa_hair": "coverage"})");
  auto full = parse_fur_material(m, Quality::High);
  REQUIRE_MESSAGE(full, (full ? "" : full.error().what()));
  CHECK(full->layers == 15);
  CHECK(!full->layers_from_quality);
  CHECK(full->thickness_for(100.0f) == doctest::Approx(0.03f));
  CHECK(full->layout == FurLayout::Band);
  CHECK(full->lighting == FurLighting::Lambert);
  CHECK(full->thresholds.low_percentile == doctest::Approx(0.05));
  CHECK(full->uv_scale == vec2(2, 3));
  CHECK(full->wrap == FurWrap::Repeat);
  CHECK(full->uv_mapping == FurUvMapping::Spherical);
  REQUIRE(full->comb);
  CHECK(*full->comb == vec2(0, 1));
  CHECK(!full->fins);
  CHECK_FALSE(full->per_sample_hair);  // asked for, whatever the quality

  m.params = nlohmann::json::parse(R"({"photo": "missing.jpg", "layers": 300, "thickness": 0.1, "spacing": 0.01,
    "layout": "wavy", "percentiles": [0.9, 0.1], "comb": [0, 0], "furriness": 1, "msaa_hair": "sometimes"})");
  auto bad = parse_fur_material(m);
  REQUIRE(!bad);
  const std::string& msg = bad.error().message;
  for (const char* field : {"$.materials.fur.photo", "$.materials.fur.layers", "$.materials.fur.spacing",
                            "$.materials.fur.layout", "$.materials.fur.percentiles", "$.materials.fur.comb",
                            "$.materials.fur.furriness", "$.materials.fur.msaa_hair"})
    CHECK_MESSAGE(msg.find(field) != std::string::npos, field << " not in:\n" << msg);
  m.params = nlohmann::json::object();
  auto no_photo = parse_fur_material(m);
  REQUIRE(!no_photo);
  CHECK(no_photo.error().message.find("$.materials.fur.photo") != std::string::npos);
  std::filesystem::remove(photo);
}
