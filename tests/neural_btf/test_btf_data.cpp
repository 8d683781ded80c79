// weft.btf, the data side of the neural BTF: the UBO2003 sampling, the synthetic fabric
// against the microfacet formula written out here, the loaders on files this test writes
// in the databases' layouts (and every kind of bad file), reference sampling, the paper's
// preprocessing at its extremes and the clustering at k = 1, k = M and with duplicates.
// Tiny sizes: 8 x 8 texels, 13 directions.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <set>
#include <string>
#include <vector>
#include <glm/glm.hpp>
import weft.core;
import weft.image;
import weft.btf;

using namespace weft;
using namespace weft::btf;
namespace fs = std::filesystem;

namespace {

constexpr float kDeg = std::numbers::pi_v<float> / 180.0f;

// θ 0 (1), 30° (4), 60° (4), 75° (4 azimuths): 13 directions.
std::vector<Direction> small_directions() {
  std::vector<Direction> d{{0.0f, 0.0f}};
  for (float theta : {30.0f, 60.0f, 75.0f})
    for (int k = 0; k < 4; ++k) d.push_back({theta * kDeg, float(k) * 90.0f * kDeg});
  return d;
}

SyntheticOptions small_options(Weave weave = Weave::Twill) {
  SyntheticOptions o;
  o.width = o.height = 8;
  o.lights = o.views = small_directions();
  o.weave = weave;
  o.yarn_spacing = 4.0f;
  return o;
}

Btf make_synthetic(const SyntheticOptions& o) {
  auto b = synthetic_btf(o);
  REQUIRE_MESSAGE(b, (b ? "" : b.error().what()));
  return *b;
}

// A BTF with given sizes whose samples come from f(texel, l, v, c).
template <class F>
Btf make_btf(std::uint32_t w, std::uint32_t h, std::vector<Direction> lights, std::vector<Direction> views, F f) {
  Btf b{w, h, std::move(lights), std::move(views), {}};
  b.rgb.resize(b.texels() * b.abrdf_floats());
  for (std::size_t t = 0; t < b.texels(); ++t)
    for (std::size_t l = 0; l < b.lights.size(); ++l)
      for (std::size_t v = 0; v < b.views.size(); ++v)
        for (std::size_t c = 0; c < 3; ++c) b.rgb[((t * b.lights.size() + l) * b.views.size() + v) * 3 + c] = f(t, l, v, c);
  return b;
}

// The microfacet BRDF x cos θ_l on a flat surface, written out independently of the
// generator: GGX D, height-correlated Smith G2 with Λ(θ) = (−1 + sqrt(1 + α² tan² θ)) / 2,
// Schlick F, Lambert.
vec3 expected_flat(vec3 albedo, float roughness, float f0, vec3 l, vec3 v) {
  const double a = double(roughness) * roughness, a2 = a * a;
  const double cl = l.z, cv = v.z;
  if (cl <= 0 || cv <= 0) return vec3(0.0f);
  const glm::dvec3 h = glm::normalize(glm::dvec3(l) + glm::dvec3(v));
  const double nh = h.z;
  const double d = a2 / (std::numbers::pi * std::pow(nh * nh * (a2 - 1.0) + 1.0, 2.0));
  auto lambda = [&](double c) { return 0.5 * (-1.0 + std::sqrt(1.0 + a2 * (1.0 - c * c) / (c * c))); };
  const double g = 1.0 / (1.0 + lambda(cl) + lambda(cv));
  const double f = f0 + (1.0 - f0) * std::pow(1.0 - glm::dot(glm::dvec3(v), h), 5.0);
  const double spec = d * g * f / (4.0 * cl * cv);
  return vec3((glm::dvec3(albedo) / std::numbers::pi + glm::dvec3(spec)) * cl);
}

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("weft_btf_data_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string error_of(const Result<Btf>& r) {
  REQUIRE_FALSE(r);
  return r.error().message;
}

// An 8-bit code for a pixel of a test image, distinct per (light, view, pixel, channel).
std::uint8_t code_of(std::size_t l, std::size_t v, std::uint32_t x, std::uint32_t y, std::uint32_t c) {
  return static_cast<std::uint8_t>((l * 37 + v * 11 + x * 5 + y * 3 + c * 50) % 256);
}

struct SetAngles {
  int tl, pl, tv, pv;
};

// Writes a 3-light x 2-view image set of 5 x 4 pixels in `layout` ("ubo" or "utia").
std::vector<SetAngles> write_image_set(const fs::path& dir, const std::string& layout) {
  const int lights[3][2] = {{0, 0}, {30, 0}, {30, 90}}, views[2][2] = {{0, 0}, {45, 180}};
  std::vector<SetAngles> out;
  int index = 0;
  for (std::size_t v = 0; v < 2; ++v)
    for (std::size_t l = 0; l < 3; ++l) {
      image::Image8 img = image::Image8::filled(5, 4, 3);
      for (std::uint32_t y = 0; y < 4; ++y)
        for (std::uint32_t x = 0; x < 5; ++x)
          for (std::uint32_t c = 0; c < 3; ++c) img.at(x, y, c) = code_of(l, v, x, y, c);
      const auto [tl, pl] = std::pair(lights[l][0], lights[l][1]);
      const auto [tv, pv] = std::pair(views[v][0], views[v][1]);
      fs::path file;
      if (layout == "ubo") {
        file = dir / weft::format("{:05} tl{:03} pl{:03} tv{:03} pv{:03}.png", index++, tl, pl, tv, pv);
      } else {
        const fs::path sub = dir / weft::format("tv{:03}_pv{:03}", tv, pv);
        fs::create_directories(sub);
        file = sub / weft::format("tl{:03}_pl{:03}_tv{:03}_pv{:03}.png", tl, pl, tv, pv);
      }
      REQUIRE(image::save_png(file, img));
      out.push_back({tl, pl, tv, pv});
    }
  return out;
}

void check_image_set(const Btf& b, std::uint32_t x0 = 0, std::uint32_t y0 = 0) {
  REQUIRE(b.lights.size() == 3);
  REQUIRE(b.views.size() == 2);
  // Sorted by (θ, φ): (0, 0), (30, 0), (30, 90) and (0, 0), (45, 180).
  CHECK(b.lights[2].theta == doctest::Approx(30.0f * kDeg));
  CHECK(b.lights[2].phi == doctest::Approx(90.0f * kDeg));
  CHECK(b.views[1].phi == doctest::Approx(180.0f * kDeg));
  for (std::uint32_t y = 0; y < b.height; ++y)
    for (std::uint32_t x = 0; x < b.width; ++x)
      for (std::size_t l = 0; l < 3; ++l)
        for (std::size_t v = 0; v < 2; ++v) {
          const vec3 s = sample(b, std::size_t(y) * b.width + x, l, v);
          for (std::uint32_t c = 0; c < 3; ++c)
            CHECK(s[int(c)] == doctest::Approx(image::srgb_to_linear(float(code_of(l, v, x + x0, y + y0, c)) / 255.0f)).epsilon(1e-5));
        }
}

}  // namespace

TEST_CASE("UBO2003 directions: 81, rings of 1, 6, 12, 18, 20, 24 at θ = 0°, 15°, ..., 75°") {
  const auto d = ubo2003_directions();
  REQUIRE(d.size() == 81);
  const int rings[6] = {1, 6, 12, 18, 20, 24};
  std::size_t i = 0;
  for (int r = 0; r < 6; ++r)
    for (int k = 0; k < rings[r]; ++k, ++i) {
      CHECK(d[i].theta == doctest::Approx(float(r) * 15.0f * kDeg));
      CHECK(d[i].phi == doctest::Approx(float(k) * 2.0f * std::numbers::pi_v<float> / float(rings[r])));
      CHECK(glm::length(to_vector(d[i])) == doctest::Approx(1.0f));
      CHECK(to_vector(d[i]).z == doctest::Approx(std::cos(d[i].theta)));
    }
  // The azimuth steps are whole degrees (the databases' file names): 60, 30, 20, 18, 15.
  CHECK(d[1 + 6].phi / kDeg == doctest::Approx(0.0f));
  CHECK(d[1 + 6 + 1].phi / kDeg == doctest::Approx(30.0f));
  CHECK(d[80].phi / kDeg == doctest::Approx(345.0f));
}

TEST_CASE("synthetic BTF: deterministic for a seed and thread count independent, finite and >= 0") {
  for (Weave weave : {Weave::Plain, Weave::Twill, Weave::Knit}) {
    CAPTURE(to_string(weave));
    auto o = small_options(weave);
    o.threads = 1;
    const Btf a = make_synthetic(o);
    o.threads = 2;
    const Btf b = make_synthetic(o);
    CHECK(a.rgb == b.rgb);
    CHECK(validate(a, "synthetic"));
    CHECK(a.rgb.size() == 8 * 8 * 13 * 13 * 3);
    o.seed = 2;
    const Btf c = make_synthetic(o);
    CHECK(a.rgb != c.rgb);
    // Texture: the texels differ (yarns, gaps, colours), and nothing is blown out.
    const auto lum = mean_luminance(a);
    const auto [lo, hi] = std::ranges::minmax(lum);
    CHECK(hi > 1.5f * lo);
    CHECK(*std::ranges::max_element(a.rgb) < 10.0f);
  }
  CHECK(parse_weave("knit").value() == Weave::Knit);
  CHECK(parse_weave("satin").error().message.find("satin") != std::string::npos);
}

TEST_CASE("synthetic BTF: a flat, one-colour height field is the microfacet formula at every sample") {
  auto o = small_options(Weave::Plain);
  o.relief = 0.0f;
  o.color_jitter = o.albedo_noise = o.cavity_darkening = 0.0f;
  o.warp_color = o.weft_color = vec3(0.5f, 0.3f, 0.2f);
  o.roughness = 0.3f;
  o.specular = 0.05f;
  o.views.push_back({89.0f * kDeg, 0.3f});  // a grazing view
  const Btf b = make_synthetic(o);
  double worst = 0.0;
  for (std::size_t t = 0; t < b.texels(); ++t)
    for (std::size_t l = 0; l < b.lights.size(); ++l)
      for (std::size_t v = 0; v < b.views.size(); ++v) {
        const vec3 want = expected_flat(o.warp_color, o.roughness, o.specular, to_vector(b.lights[l]), to_vector(b.views[v]));
        const vec3 got = sample(b, t, l, v);
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(double(got[c]) - want[c]) / (1e-3 + want[c]));
        if (t == 0) {
          const vec3 direct = microfacet_reflectance(o.warp_color, o.roughness, o.specular, to_vector(b.lights[l]),
                                                     to_vector(b.views[v]));
          for (int c = 0; c < 3; ++c) CHECK(direct[c] == doctest::Approx(want[c]).epsilon(1e-4));
        }
      }
  CHECK(worst < 1e-4);
  // Reciprocity of the BRDF: f(l, v) = f(v, l), i.e. sample / cos θ_l is symmetric.
  for (std::size_t l = 0; l < 13; ++l)
    for (std::size_t v = 0; v < 13; ++v) {
      const vec3 a = sample(b, 0, l, v) / std::cos(b.lights[l].theta);
      const vec3 c = sample(b, 0, v, l) / std::cos(b.lights[v].theta);
      CHECK(a.g == doctest::Approx(c.g).epsilon(1e-4));
    }
  // The specular peak is where it should be: mirror pair brighter than off-mirror.
  CHECK(sample(b, 0, 5, 7).r > sample(b, 0, 5, 5).r);  // light (60°, 0°) and view (60°, 180°)
}

TEST_CASE("synthetic BTF: shadowing and masking darken grazing angles, leave normal incidence alone") {
  auto o = small_options(Weave::Twill);
  o.relief = 0.6f;
  const Btf shadowed = make_synthetic(o);
  o.shadowing = false;
  const Btf open = make_synthetic(o);
  auto mean_at = [](const Btf& b, std::size_t l, std::size_t v) {
    double sum = 0.0;
    for (std::size_t t = 0; t < b.texels(); ++t) sum += sample(b, t, l, v).g;
    return sum / double(b.texels());
  };
  // Index 0: θ 0; 1..4: θ 30°; 9..12: θ 75°, φ 0°, 90°, 180°, 270°.
  CHECK(mean_at(shadowed, 0, 0) == doctest::Approx(mean_at(open, 0, 0)).epsilon(1e-6));
  const double normal_ratio = mean_at(shadowed, 1, 2) / mean_at(open, 1, 2);
  const double grazing_ratio = mean_at(shadowed, 9, 10) / mean_at(open, 9, 10);
  CHECK(normal_ratio > 0.95);
  CHECK(grazing_ratio < 0.9);
  for (std::size_t i = 0; i < shadowed.rgb.size(); ++i) REQUIRE(shadowed.rgb[i] <= open.rgb[i] + 1e-6f);
}

TEST_CASE("synthetic BTF: bad options are named") {
  auto o = small_options();
  o.width = 0;
  CHECK(synthetic_btf(o).error().message.find("0 x 8") != std::string::npos);
  o = small_options();
  o.roughness = 0.0f;
  CHECK(synthetic_btf(o).error().message.find("roughness 0") != std::string::npos);
  o = small_options();
  o.lights[3].theta = 2.0f;
  CHECK(synthetic_btf(o).error().message.find("light 3") != std::string::npos);
}

TEST_CASE("validate names the source, texel, light, view and value of a bad sample") {
  auto o = small_options();
  Btf b = make_synthetic(o);
  CHECK(validate(b, "cloth"));
  b.rgb[((std::size_t(2 * 8 + 3) * 13 + 4) * 13 + 6) * 3 + 1] = std::numeric_limits<float>::quiet_NaN();
  const std::string m = validate(b, "cloth.btfraw").error().message;
  CHECK(m.find("cloth.btfraw") != std::string::npos);
  CHECK(m.find("nan") != std::string::npos);
  CHECK(m.find("texel (3, 2)") != std::string::npos);
  CHECK(m.find("light 4") != std::string::npos);
  CHECK(m.find("view 6") != std::string::npos);
  b.rgb[((std::size_t(2 * 8 + 3) * 13 + 4) * 13 + 6) * 3 + 1] = -0.5f;
  CHECK(validate(b, "x").error().message.find("-0.5") != std::string::npos);
  b.rgb.pop_back();
  CHECK(validate(b, "x").error().message.find("holds") != std::string::npos);
}

TEST_CASE("loaders: UTIA and UBO2003 image sets round-trip, with crops and layout detection") {
  for (std::string layout : {"utia", "ubo"}) {
    CAPTURE(layout);
    const fs::path dir = fresh_dir(layout);
    write_image_set(dir, layout);
    auto loaded = layout == "ubo" ? load_ubo2003(dir) : load_utia(dir);
    REQUIRE_MESSAGE(loaded, (loaded ? "" : loaded.error().what()));
    CHECK(loaded->width == 5);
    CHECK(loaded->height == 4);
    check_image_set(*loaded);
    auto detected = load_btf(dir, Crop{1, 2, 3, 2});
    REQUIRE(detected);
    CHECK(detected->width == 3);
    CHECK(detected->height == 2);
    check_image_set(*detected, 1, 2);
    // The other layout's loader finds nothing and says what it looked for.
    auto other = layout == "ubo" ? load_utia(dir) : load_ubo2003(dir);
    CHECK(error_of(other).find(layout == "ubo" ? "tl000_pl000" : "tl000 pl000") != std::string::npos);
    CHECK(error_of(load_btf(dir, Crop{4, 0, 2, 0})).find("does not fit") != std::string::npos);
    fs::remove_all(dir);
  }
}

TEST_CASE("loaders: missing, duplicate, corrupt, mismatched and non-finite files give clear errors") {
  const fs::path dir = fresh_dir("bad");
  write_image_set(dir, "utia");
  const fs::path victim = dir / "tv045_pv180" / "tl030_pl090_tv045_pv180.png";
  SUBCASE("a missing pair is named") {
    fs::remove(victim);
    const std::string m = error_of(load_utia(dir));
    CHECK(m.find("tl030_pl090_tv045_pv180") != std::string::npos);
    CHECK(m.find("missing") != std::string::npos);
  }
  SUBCASE("a corrupt image names its file") {
    std::ofstream(victim, std::ios::binary | std::ios::trunc) << "not a png at all";
    CHECK(error_of(load_utia(dir)).find("tl030_pl090_tv045_pv180.png") != std::string::npos);
  }
  SUBCASE("an image of another size names its file and both sizes") {
    REQUIRE(image::save_png(victim, image::Image8::filled(6, 4, 3, 9)));
    const std::string m = error_of(load_utia(dir));
    CHECK(m.find("tl030_pl090_tv045_pv180.png") != std::string::npos);
    CHECK(m.find("6 x 4") != std::string::npos);
  }
  SUBCASE("a duplicate pair names both files") {
    REQUIRE(image::save_png(dir / "tl030_pl090_tv045_pv180.png", image::Image8::filled(5, 4, 3, 9)));
    CHECK(error_of(load_utia(dir)).find("two images") != std::string::npos);
  }
  SUBCASE("NaN and negative samples in an OpenEXR file name the file and pixel") {
    fs::remove(victim);
    const fs::path exr = victim.parent_path() / "tl030_pl090_tv045_pv180.exr";
    auto img = image::Image::filled(5, 4, 3, 0.25f);
    img.at(3, 1, 2) = std::numeric_limits<float>::quiet_NaN();
    REQUIRE(image::save_exr(exr, img));
    std::string m = error_of(load_btf(dir));
    CHECK(m.find("tl030_pl090_tv045_pv180.exr") != std::string::npos);
    CHECK(m.find("pixel (3, 1)") != std::string::npos);
    CHECK(m.find("nan") != std::string::npos);
    img.at(3, 1, 2) = -2.0f;
    REQUIRE(image::save_exr(exr, img));
    m = error_of(load_btf(dir));
    CHECK(m.find("-2") != std::string::npos);
    // A valid XYZ file loads, converted to linear sRGB: XYZ of D65 white (0.9505, 1, 1.089) is RGB 1.
    img = image::Image::filled(5, 4, 3, 0.0f);
    for (std::size_t p = 0; p < 20; ++p) img.pixels[p * 3] = 0.9505f, img.pixels[p * 3 + 1] = 1.0f, img.pixels[p * 3 + 2] = 1.089f;
    REQUIRE(image::save_exr(exr, img));
    auto ok = load_btf(dir);
    REQUIRE(ok);
    const vec3 white = sample(*ok, 0, 2, 1);
    CHECK(white.r == doctest::Approx(1.0f).epsilon(2e-3));
    CHECK(white.g == doctest::Approx(1.0f).epsilon(2e-3));
    CHECK(white.b == doctest::Approx(1.0f).epsilon(2e-3));
  }
  SUBCASE("a missing folder or an unknown file") {
    CHECK(load_btf(dir / "nope").error().kind == ErrorKind::NotFound);
    CHECK(error_of(load_btf(victim)).find("neither") != std::string::npos);
  }
  fs::remove_all(dir);
}

TEST_CASE(".btfraw: exact round trip, crop, and every corruption named") {
  const fs::path dir = fresh_dir("raw");
  const fs::path file = dir / "cloth.btfraw";
  const Btf b = make_synthetic(small_options(Weave::Knit));
  REQUIRE(save_btf(b, file));
  CHECK_FALSE(fs::exists(dir / "cloth.btfraw.tmp"));
  auto back = load_btf(file);
  REQUIRE_MESSAGE(back, (back ? "" : back.error().what()));
  CHECK(back->rgb == b.rgb);
  CHECK(back->width == 8);
  REQUIRE(back->lights.size() == 13);
  CHECK(back->lights[7].phi == b.lights[7].phi);
  auto cropped = load_btf(file, Crop{2, 3, 4, 5});
  REQUIRE(cropped);
  CHECK(cropped->width == 4);
  CHECK(cropped->height == 5);
  CHECK(sample(*cropped, 1 * 4 + 2, 3, 4) == sample(b, (3 + 1) * 8 + 2 + 2, 3, 4));

  auto bytes = [&] {
    std::ifstream in(file, std::ios::binary);
    return std::vector<char>(std::istreambuf_iterator<char>(in), {});
  }();
  auto write = [&](const std::vector<char>& data) {
    std::ofstream(file, std::ios::binary | std::ios::trunc).write(data.data(), std::streamsize(data.size()));
  };
  auto corrupt = bytes;
  corrupt[corrupt.size() - 7] ^= 0x40;
  write(corrupt);
  CHECK(error_of(load_btf(file)).find("sample checksum") != std::string::npos);
  corrupt = bytes;
  corrupt[60] ^= 0x01;  // a direction in the header
  write(corrupt);
  CHECK(error_of(load_btf(file)).find("header checksum") != std::string::npos);
  corrupt = bytes;
  corrupt.resize(corrupt.size() - 100);
  write(corrupt);
  CHECK(error_of(load_btf(file)).find("truncated") != std::string::npos);
  corrupt = bytes;
  corrupt[0] = 'X';
  write(corrupt);
  CHECK(error_of(load_btf(file)).find("not a .btfraw") != std::string::npos);
  corrupt = bytes;
  corrupt[8] = 9;  // version
  write(corrupt);
  CHECK(error_of(load_btf(file)).find("version 9") != std::string::npos);
  // A non-finite sample saved (the cache takes anything) is refused on load, located.
  Btf bad = b;
  bad.rgb[((std::size_t(5) * 13 + 2) * 13 + 3) * 3] = std::numeric_limits<float>::infinity();
  REQUIRE(save_btf(bad, file));
  const std::string m = error_of(load_btf(file));
  CHECK(m.find("cloth.btfraw") != std::string::npos);
  CHECK(m.find("texel (5, 0), light 2") != std::string::npos);
  CHECK(m.find("inf") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("reference sampling: exact at measured directions, continuous and convex between") {
  const auto dirs = small_directions();
  // Samples a smooth function of the directions, so interpolation has something to follow.
  const Btf b = make_btf(2, 1, dirs, dirs, [&](std::size_t t, std::size_t l, std::size_t v, std::size_t c) {
    const vec3 a = to_vector(dirs[l]), d = to_vector(dirs[v]);
    return 0.2f + 0.3f * a.z + 0.2f * d.x * float(c + 1) + 0.1f * float(t);
  });
  for (std::size_t l = 0; l < dirs.size(); ++l)
    for (std::size_t v = 0; v < dirs.size(); ++v)
      CHECK(sample_reference(b, 1, to_vector(dirs[l]), to_vector(dirs[v])) == sample(b, 1, l, v));
  // Sweep the light once around at θ = 45° and the view from the pole to 80°, in small steps.
  float largest_step = 0.0f, lo = 1e9f, hi = -1e9f;
  vec3 previous = sample_reference(b, 0, to_vector({45.0f * kDeg, 0.0f}), to_vector({0.0f, 0.0f}));
  constexpr int kSteps = 4000;
  for (int i = 1; i <= kSteps; ++i) {
    const float s = float(i) / kSteps;
    const vec3 light = to_vector({45.0f * kDeg, s * 2.0f * std::numbers::pi_v<float>});
    const vec3 view = to_vector({s * 80.0f * kDeg, 1.0f});
    const vec3 value = sample_reference(b, 0, light, view);
    largest_step = std::max(largest_step, glm::length(value - previous));
    lo = std::min(lo, value.g), hi = std::max(hi, value.g);
    previous = value;
  }
  CHECK(hi - lo > 0.05f);         // it does vary ...
  CHECK(largest_step < 0.01f);    // ... without jumps
  // Convex weights: within the samples' range.
  float smin = 1e9f, smax = -1e9f;
  for (std::size_t i = 0; i < b.rgb.size() / 2; i += 3) smin = std::min(smin, b.rgb[i + 1]), smax = std::max(smax, b.rgb[i + 1]);
  CHECK(lo >= smin - 1e-6f);
  CHECK(hi <= smax + 1e-6f);
  const auto w = interpolation_weights(dirs, vec3(0.3f, 0.2f, 0.8f));
  CHECK(w.count == 3);
  CHECK(w.weight[0] + w.weight[1] + w.weight[2] == doctest::Approx(1.0f));
  CHECK(w.weight[2] >= 0.0f);
}

TEST_CASE("preprocessing: mean 0 and std 1 per dimension; constant, zero and huge ABRDFs stay finite") {
  const auto dirs = small_directions();
  SUBCASE("standardized inputs, targets over the global max") {
    const Btf b = make_synthetic(small_options());
    const Preprocessed p = preprocess(b);
    const std::size_t n = b.abrdf_floats(), m = b.texels();
    REQUIRE(p.inputs.size() == m * n);
    float max = 0.0f;
    for (float v : b.rgb) max = std::max(max, v);
    CHECK(p.constants.target_max == max);
    for (std::size_t d = 0; d < n; d += 7) {
      double sum = 0.0, sum2 = 0.0;
      for (std::size_t t = 0; t < m; ++t) sum += p.inputs[t * n + d], sum2 += double(p.inputs[t * n + d]) * p.inputs[t * n + d];
      CHECK(sum / double(m) == doctest::Approx(0.0).epsilon(1e-4).scale(1.0));
      CHECK(std::sqrt(sum2 / double(m)) == doctest::Approx(1.0).epsilon(1e-3));
      CHECK(p.targets[5 * n + d] == doctest::Approx(b.rgb[5 * n + d] / max));
      CHECK(p.inputs[5 * n + d] == doctest::Approx((std::log(b.rgb[5 * n + d] + 1.0f) - p.constants.mean[d]) / p.constants.std[d]));
    }
    // preprocess_input on one ABRDF is the same transform.
    std::vector<float> one(n);
    preprocess_input(p.constants, b.abrdf(9), one);
    for (std::size_t d = 0; d < n; ++d) REQUIRE(one[d] == p.inputs[9 * n + d]);
  }
  SUBCASE("every texel the same (std 0): inputs 0, std 1") {
    const Btf b = make_btf(4, 4, dirs, dirs, [](std::size_t, std::size_t l, std::size_t v, std::size_t c) {
      return 0.1f * float(l + v + c);
    });
    const Preprocessed p = preprocess(b);
    for (float v : p.inputs) REQUIRE(std::abs(v) < 1e-6f);
    for (float s : p.constants.std) REQUIRE(s == 1.0f);
  }
  SUBCASE("all zeros: inputs 0, targets 0, target_max 1") {
    const Btf b = make_btf(3, 3, dirs, dirs, [](auto...) { return 0.0f; });
    const Preprocessed p = preprocess(b);
    CHECK(p.constants.target_max == 1.0f);
    for (std::size_t i = 0; i < p.inputs.size(); ++i) REQUIRE((p.inputs[i] == 0.0f && p.targets[i] == 0.0f));
  }
  SUBCASE("huge values: finite") {
    const Btf b = make_btf(3, 3, dirs, dirs, [](std::size_t t, std::size_t l, std::size_t, std::size_t) {
      return t == 4 ? 3.0e38f : float(l) * 1e30f;
    });
    const Preprocessed p = preprocess(b);
    for (std::size_t i = 0; i < p.inputs.size(); ++i) REQUIRE((std::isfinite(p.inputs[i]) && std::isfinite(p.targets[i])));
    CHECK(p.constants.target_max == 3.0e38f);
    CHECK(*std::ranges::max_element(p.targets) == 1.0f);
  }
}

TEST_CASE("clustering: k = 1 is the element-wise median; k = M is every texel alone") {
  const Btf b = make_synthetic(small_options());
  const std::size_t n = b.abrdf_floats(), m = b.texels();
  ClusterOptions o;
  o.clusters = 1;
  o.pca_components = 4;
  auto one = cluster_abrdfs(b, o);
  REQUIRE_MESSAGE(one, (one ? "" : one.error().what()));
  REQUIRE(one->count() == 1);
  for (auto id : one->ids) REQUIRE(id == 0);
  for (std::size_t d = 0; d < n; d += 5) {
    std::vector<float> column;
    for (std::size_t t = 0; t < m; ++t) column.push_back(b.rgb[t * n + d]);
    std::ranges::sort(column);  // 64 texels: the mean of the 32nd and 33rd
    CHECK(one->medians[d] == doctest::Approx(0.5f * (column[31] + column[32])));
  }
  // The medoid is the member nearest to the median.
  auto distance = [&](std::size_t t) {
    double s = 0.0;
    for (std::size_t d = 0; d < n; ++d) s += std::pow(double(b.rgb[t * n + d]) - one->medians[d], 2.0);
    return s;
  };
  for (std::size_t t = 0; t < m; ++t) REQUIRE(distance(one->medoids[0]) <= distance(t));

  o.clusters = static_cast<std::uint32_t>(m);
  auto all = cluster_abrdfs(b, o);
  REQUIRE(all);
  REQUIRE(all->count() == m);
  CHECK(std::set<std::uint32_t>(all->ids.begin(), all->ids.end()).size() == m);
  for (std::size_t t = 0; t < m; ++t) {
    const std::uint32_t c = all->ids[t];
    REQUIRE(all->medoids[c] == t);
    REQUIRE(all->sizes[c] == 1);
    for (std::size_t d = 0; d < n; d += 11) REQUIRE(all->medians[c * n + d] == b.rgb[t * n + d]);
  }
  o.clusters = 0;
  CHECK(cluster_abrdfs(b, o).error().message.find("0 clusters") != std::string::npos);
  o.clusters = 65;
  CHECK(cluster_abrdfs(b, o).error().message.find("[1, 64]") != std::string::npos);
}

TEST_CASE("clustering: duplicate ABRDFs (all D² = 0), two materials, valid ids, deterministic") {
  const auto dirs = small_directions();
  SUBCASE("every texel the same") {
    const Btf b = make_btf(4, 4, dirs, dirs, [](std::size_t, std::size_t l, std::size_t v, std::size_t) {
      return 0.05f * float(l * 13 + v);
    });
    for (auto seeding : {ClusterSeeding::KMeansPlusPlus, ClusterSeeding::FarthestPoint}) {
      ClusterOptions o;
      o.clusters = 5;
      o.seeding = seeding;
      auto c = cluster_abrdfs(b, o);
      REQUIRE_MESSAGE(c, (c ? "" : c.error().what()));
      REQUIRE(c->count() == 1);  // the empty four are dropped
      for (auto id : c->ids) REQUIRE(id == 0);
      CHECK(c->sizes[0] == 16);
      CHECK(c->medians[14 * 3] == doctest::Approx(0.05f * 14));
    }
  }
  SUBCASE("two materials in halves, duplicated") {
    const Btf b = make_btf(8, 8, dirs, dirs, [](std::size_t t, std::size_t l, std::size_t v, std::size_t c) {
      const bool left = t % 8 < 4;
      return (left ? 0.5f : 0.1f) * float(c + 1) * (1.0f + 0.01f * float(l + v));
    });
    ClusterOptions o;
    o.clusters = 4;
    auto c = cluster_abrdfs(b, o);
    REQUIRE(c);
    REQUIRE(c->count() == 2);
    for (std::size_t t = 0; t < 64; ++t) REQUIRE((c->ids[t] == c->ids[0]) == (t % 8 < 4));
  }
  SUBCASE("synthetic fabric: ids in range, every cluster non-empty, same seed same answer") {
    const Btf b = make_synthetic(small_options(Weave::Plain));
    ClusterOptions o;
    o.clusters = 6;
    o.pca_components = 8;
    o.pca_sample_texels = 40;
    auto a = cluster_abrdfs(b, o);
    auto again = cluster_abrdfs(b, o);
    REQUIRE(a);
    REQUIRE(again);
    CHECK(a->ids == again->ids);
    CHECK(a->medians == again->medians);
    CHECK(a->pca_components == 8);
    CHECK(a->pca_energy > 0.5);
    std::vector<std::uint32_t> sizes(a->count(), 0);
    for (auto id : a->ids) {
      REQUIRE(id < a->count());
      ++sizes[id];
    }
    CHECK(sizes == a->sizes);
    for (std::size_t k = 0; k < a->count(); ++k) CHECK(a->ids[a->medoids[k]] == k);
  }
}

TEST_CASE("helpers: mean luminance, RMSE against a BTF and a callback, crops and direction subsets") {
  const auto dirs = small_directions();
  const Btf b = make_btf(3, 2, dirs, dirs, [](std::size_t t, std::size_t, std::size_t, std::size_t c) {
    return float(t) * (c == 1 ? 1.0f : 0.0f);
  });
  const auto lum = mean_luminance(b);
  CHECK(lum[4] == doctest::Approx(4.0f * 0.7152f));
  CHECK(abrdf_luminance(b.abrdf(4)) == lum[4]);
  // Green is the texel index 0..5 (variance 35/12 about 2.5), red and blue 0: the best
  // constant's RMSE over the three channels is sqrt(35/12 / 3); a constant BTF scores 0.
  CHECK(constant_rmse(b) == doctest::Approx(std::sqrt(35.0 / 12.0 / 3.0)));
  CHECK(constant_rmse(make_btf(2, 2, dirs, dirs, [](auto...) { return 0.7f; })) == doctest::Approx(0.0).epsilon(1e-9));
  CHECK(rmse(b, b).value() == 0.0);
  CHECK(rmse(b, [&](std::size_t t, const vec3&, const vec3&) { return vec3(0.0f, float(t), 0.5f); }) ==
        doctest::Approx(std::sqrt(0.25 / 3.0)));
  // The callback sees the measured directions, in the BTF's order.
  const Btf directional = make_btf(2, 2, dirs, dirs, [&](std::size_t, std::size_t l, std::size_t v, std::size_t) {
    return 1.0f + to_vector(dirs[l]).z + to_vector(dirs[v]).x;
  });
  CHECK(rmse(directional, [](std::size_t, const vec3& l, const vec3& v) { return vec3(1.0f + l.z + v.x); }) ==
        doctest::Approx(0.0).scale(1.0).epsilon(1e-6));
  CHECK(rmse(directional, [](std::size_t, const vec3& l, const vec3& v) { return vec3(1.0f + v.z + l.x); }) > 0.1);
  const std::size_t keep_l[] = {0, 5}, keep_v[] = {12};
  auto sub = select_directions(b, keep_l, keep_v);
  REQUIRE(sub);
  CHECK(sub->lights.size() == 2);
  CHECK(sub->views[0].phi == dirs[12].phi);
  CHECK(sample(*sub, 5, 1, 0) == sample(b, 5, 5, 12));
  const std::size_t bad[] = {13};
  CHECK(select_directions(b, bad, keep_v).error().message.find("light index 13") != std::string::npos);
  CHECK(crop(b, Crop{1, 1, 3, 1}).error().message.find("does not fit") != std::string::npos);
  Btf other = b;
  other.views.pop_back();
  CHECK_FALSE(rmse(b, other));
  const auto img = texel_image(b, 2, 3);
  CHECK(img.width == 3);
  CHECK(img.at(2, 1, 1) == 5.0f);
}
