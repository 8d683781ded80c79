// weft.btf.model on the CPU: the stereographic projection at its extremes, the decoder on a
// hand-built network with a known answer, the paper's sizes, and the .wbtf file: exact fp32
// round trips, bounded fp16 / 8-bit error, and a clear error (file and section named) for
// every kind of corruption.
#include <doctest/doctest.h>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <span>
#include <string>
#include <vector>
#include <glm/glm.hpp>
import weft.core;
import weft.btf.model;

using namespace weft;
using namespace weft::btf;

namespace {

std::vector<std::byte> encoded(const NeuralBtf& m, const WbtfOptions& o = {}) {
  auto bytes = encode_wbtf(m, o);
  REQUIRE_MESSAGE(bytes, (bytes ? "" : bytes.error().message));
  return *bytes;
}

// The error decode gives for `bytes` (the test fails if it decodes).
std::string error_of(const std::vector<std::byte>& bytes) {
  auto m = decode_wbtf(bytes, "cloth.wbtf");
  REQUIRE_FALSE(m);
  return m.error().message;
}

constexpr std::size_t kHeader = 72, kSectionHeader = 24;

// Offset of section s's payload (0 MLP, 1 LAT, 2 IDS, 3 SCL) and its size.
std::pair<std::size_t, std::size_t> section(const std::vector<std::byte>& bytes, int s) {
  std::size_t at = kHeader;
  for (int i = 0;; ++i) {
    std::uint64_t size;
    std::memcpy(&size, bytes.data() + at + 8, 8);
    if (i == s) return {at + kSectionHeader, std::size_t(size)};
    at += kSectionHeader + size;
  }
}

void put_u32(std::vector<std::byte>& bytes, std::size_t at, std::uint32_t v) { std::memcpy(bytes.data() + at, &v, 4); }

// After editing a header field or a payload, make the checksums agree again so that the
// decoder's later checks are what the test exercises.
void fix_header_sum(std::vector<std::byte>& bytes) {
  const std::uint64_t sum = hash_bytes(std::span(bytes).first(kHeader - 8));
  std::memcpy(bytes.data() + kHeader - 8, &sum, 8);
}
void fix_section_sum(std::vector<std::byte>& bytes, int s) {
  const auto [at, size] = section(bytes, s);
  const std::uint64_t sum = hash_bytes(std::span(bytes).subspan(at, size));
  std::memcpy(bytes.data() + at - 8, &sum, 8);
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST_CASE("stereographic: θ = 0 is the origin, θ -> 90° the unit circle, tan(θ/2) between") {
  CHECK(stereographic(vec3(0, 0, 1)) == vec2(0.0f));
  CHECK(stereographic(vec3(0, 0, 5)) == vec2(0.0f));  // need not be normalised
  for (float theta_deg : {15.0f, 45.0f, 75.0f, 89.9f, 90.0f}) {
    for (float phi_deg : {0.0f, 100.0f, 250.0f}) {
      const float t = glm::radians(theta_deg), p = glm::radians(phi_deg);
      const vec2 s = stereographic(vec3(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)));
      // The paper's form: R = sin(π − θ) / (1 − cos(π − θ)) = tan(θ/2) ... measured from the other pole;
      // here the radius is tan(θ/2) (0 at the normal, 1 at the horizon).
      const float r = std::tan(t / 2.0f);
      CHECK(std::isfinite(s.x));
      CHECK(std::isfinite(s.y));
      CHECK(glm::length(s) == doctest::Approx(r).epsilon(1e-5));
      CHECK(s.x == doctest::Approx(r * std::cos(p)).epsilon(1e-4).scale(1.0));
    }
  }
  CHECK(stereographic(vec3(0.0f)) == vec2(0.0f));  // degenerate input: no NaN
}

TEST_CASE("decode: a hand-built decoder gives its analytic output, clamped, scaled per texel") {
  // latent 1, one hidden layer of 2 ReLUs: h0 = relu(latent + sx_i), h1 = relu(-latent);
  // rgb = (h0, h1, h0 + h1 - 1).
  NeuralBtf m;
  m.width = 2;
  m.height = 1;
  m.latent_size = 1;
  m.decoder.layers.push_back({5, 2, {1, 1, 0, 0, 0, -1, 0, 0, 0, 0}, {0, 0}});
  m.decoder.layers.push_back({2, 3, {1, 0, 0, 1, 1, 1}, {0, 0, -1}});
  m.latents = {0.25f, -2.0f};
  m.texel_scales = {2.0f, 1.0f};
  m.output_scale = 0.5f;
  REQUIRE(validate(m));
  const float t = glm::radians(60.0f);
  const vec3 light(std::sin(t), 0.0f, std::cos(t));  // stereo x = tan 30°
  const float sx = std::tan(t / 2.0f);
  const vec3 a = decode(m, 0, light, vec3(0, 0, 1));
  CHECK(a.x == doctest::Approx((0.25f + sx) * 2.0f * 0.5f));
  CHECK(a.y == doctest::Approx(0.0f));
  CHECK(a.z == doctest::Approx(0.0f));  // 0.25 + sx - 1 < 0: clamped
  const vec3 b = decode(m, 1, light, vec3(0, 0, 1));
  CHECK(b.x == doctest::Approx(0.0f));  // relu(-2 + 0.577) = 0
  CHECK(b.y == doctest::Approx(2.0f * 0.5f));
  CHECK(b.z == doctest::Approx(1.0f * 0.5f));
}

TEST_CASE("sizes: the paper's decoder has 24,383 parameters (95.2 KB); ids and scales shrink with storage") {
  const NeuralBtf plain = random_model({.width = 100, .height = 100});
  CHECK(plain.decoder.parameter_count() == 24383);
  CHECK(model_bytes(plain).decoder == 24383 * 4);
  CHECK(model_bytes(plain).latents == 10000 * 8 * 4);  // 313 KB
  CHECK(model_bytes(plain).ids == 0);
  const NeuralBtf clustered = random_model({.width = 100, .height = 100, .clusters = 200, .scales = true});
  CHECK(model_bytes(clustered).ids == 10000);  // auto: 8-bit for k <= 256
  CHECK(model_bytes(clustered, {.ids = IdStorage::U32}).ids == 40000);
  CHECK(model_bytes(clustered, kCompactWbtf).total() == 24383 * 2 + 200 * 8 * 2 + 10000 + 8 + 10000);
  const NeuralBtf big = random_model({.width = 100, .height = 100, .hidden = {4}, .clusters = 1000});
  CHECK(model_bytes(big).ids == 20000);  // 16-bit
  // The file is the payloads plus the fixed framing.
  const auto bytes = encoded(clustered, kCompactWbtf);
  CHECK(bytes.size() == model_bytes(clustered, kCompactWbtf).total() + 72 + 4 * 24 + 4 * 8);
}

TEST_CASE(".wbtf round trip: fp32 is exact, fp16 and 8-bit within their quantisation") {
  const auto dir = std::filesystem::temp_directory_path() / "weft-test-btf-model";
  std::filesystem::create_directories(dir);
  for (bool clustered : {false, true}) {
    const NeuralBtf m = random_model({.width = 5, .height = 3, .hidden = {16, 16}, .clusters = clustered ? 4u : 0u,
                                      .scales = clustered, .output_scale = 3.5f, .seed = 7});
    const auto path = dir / (clustered ? "clustered.wbtf" : "plain.wbtf");
    REQUIRE(save_wbtf(m, path));
    auto back = load_wbtf(path);
    REQUIRE_MESSAGE(back, (back ? "" : back.error().message));
    CHECK(back->width == m.width);
    CHECK(back->height == m.height);
    CHECK(back->latent_size == m.latent_size);
    CHECK(back->output_scale == m.output_scale);
    CHECK(back->latents == m.latents);
    CHECK(back->cluster_ids == m.cluster_ids);
    CHECK(back->texel_scales == m.texel_scales);
    REQUIRE(back->decoder.layers.size() == m.decoder.layers.size());
    for (std::size_t i = 0; i < m.decoder.layers.size(); ++i) {
      CHECK(back->decoder.layers[i].inputs == m.decoder.layers[i].inputs);
      CHECK(back->decoder.layers[i].outputs == m.decoder.layers[i].outputs);
      CHECK(back->decoder.layers[i].weights == m.decoder.layers[i].weights);
      CHECK(back->decoder.layers[i].bias == m.decoder.layers[i].bias);
    }
  }
  // Compact storage: fp16 has an 11-bit significand (relative error <= 2^-11); 8-bit scales
  // are within half a step of (max - min) / 255.
  const NeuralBtf m = random_model({.width = 6, .height = 6, .hidden = {32, 32}, .clusters = 5, .scales = true, .seed = 3});
  auto back = decode_wbtf(encoded(m, kCompactWbtf), "compact");
  REQUIRE_MESSAGE(back, (back ? "" : back.error().message));
  CHECK(back->cluster_ids == m.cluster_ids);
  for (std::size_t i = 0; i < m.latents.size(); ++i)
    CHECK(std::abs(back->latents[i] - m.latents[i]) <= std::abs(m.latents[i]) * 0x1p-11f + 1e-7f);
  for (std::size_t l = 0; l < m.decoder.layers.size(); ++l)
    for (std::size_t i = 0; i < m.decoder.layers[l].weights.size(); ++i)
      CHECK(std::abs(back->decoder.layers[l].weights[i] - m.decoder.layers[l].weights[i]) <=
            std::abs(m.decoder.layers[l].weights[i]) * 0x1p-11f + 1e-7f);
  float lo = 1e9f, hi = -1e9f;
  for (float s : m.texel_scales) lo = std::min(lo, s), hi = std::max(hi, s);
  for (std::size_t t = 0; t < m.texel_scales.size(); ++t)
    CHECK(std::abs(back->texel_scales[t] - m.texel_scales[t]) <= (hi - lo) / 510.0f + 1e-6f);
  // The decoded colour moves by about the storage error, not more.
  for (std::size_t t = 0; t < m.texels(); ++t) {
    const vec3 a = decode(m, t, vec3(0.3f, 0.1f, 0.9f), vec3(-0.2f, 0.4f, 0.8f));
    const vec3 b = decode(*back, t, vec3(0.3f, 0.1f, 0.9f), vec3(-0.2f, 0.4f, 0.8f));
    CHECK(glm::length(a - b) <= 0.02f * (1.0f + glm::length(a)));
  }
}

TEST_CASE(".wbtf encode refuses models it cannot store faithfully") {
  NeuralBtf m = random_model({.width = 20, .height = 20, .hidden = {8}, .clusters = 300});
  auto u8 = encode_wbtf(m, {.ids = IdStorage::U8});
  REQUIRE_FALSE(u8);
  CHECK(contains(u8.error().message, "300 clusters do not fit u8"));
  m.latents[5] = 1e6f;
  auto half = encode_wbtf(m, {.latents = FloatStorage::Fp16});
  REQUIRE_FALSE(half);
  CHECK(contains(half.error().message, "does not fit fp16"));
  m.latents[5] = std::numeric_limits<float>::quiet_NaN();
  auto nan = encode_wbtf(m);
  REQUIRE_FALSE(nan);
  CHECK(contains(nan.error().message, "latent value 5"));
  NeuralBtf bad = random_model({.width = 2, .height = 2, .hidden = {8}, .clusters = 3});
  bad.cluster_ids[1] = 3;
  auto range = save_wbtf(bad, std::filesystem::temp_directory_path() / "weft-never-written.wbtf");
  REQUIRE_FALSE(range);
  CHECK(contains(range.error().message, "texel 1 has cluster id 3"));
  CHECK(contains(range.error().message, "weft-never-written.wbtf"));
  NeuralBtf chain = random_model({.width = 2, .height = 2, .hidden = {8}});
  chain.decoder.layers[1].inputs = 7;
  CHECK_FALSE(validate(chain));
}

TEST_CASE(".wbtf decode: every corruption is an error naming the file and what is wrong") {
  const NeuralBtf m = random_model({.width = 4, .height = 4, .hidden = {8, 8}, .clusters = 3, .scales = true});
  const auto good = encoded(m);
  REQUIRE(decode_wbtf(good, "cloth.wbtf"));

  SUBCASE("truncated anywhere") {
    for (std::size_t n : {std::size_t(0), std::size_t(5), std::size_t(40), kHeader, kHeader + 10, good.size() / 2,
                          good.size() - 1}) {
      const std::string e = error_of(std::vector<std::byte>(good.begin(), good.begin() + std::ptrdiff_t(n)));
      CAPTURE(n);
      CHECK(contains(e, "cloth.wbtf"));
      CHECK((contains(e, "truncated") || contains(e, "magic")));
    }
    // Every prefix fails cleanly (no crash, no success).
    for (std::size_t n = 0; n < good.size(); n += 7) CHECK_FALSE(decode_wbtf(std::span(good).first(n), "x"));
  }
  SUBCASE("bad magic") {
    auto b = good;
    b[3] = std::byte{'X'};
    CHECK(contains(error_of(b), "cloth.wbtf: not a weft neural BTF file"));
  }
  SUBCASE("wrong version") {
    auto b = good;
    put_u32(b, 8, 2);
    auto r = decode_wbtf(b, "cloth.wbtf");
    REQUIRE_FALSE(r);
    CHECK(r.error().kind == ErrorKind::Unsupported);
    CHECK(contains(r.error().message, "version 2 is not supported"));
  }
  SUBCASE("header checksum") {
    auto b = good;
    put_u32(b, 16, 5);  // width
    CHECK(contains(error_of(b), "header checksum mismatch"));
  }
  SUBCASE("section checksums") {
    for (int s = 0; s < 4; ++s) {
      auto b = good;
      const auto [at, size] = section(b, s);
      REQUIRE(size > 0);
      b[at + size / 2] ^= std::byte{0x40};
      const std::string e = error_of(b);
      const char* names[] = {"'MLP'", "'LAT'", "'IDS'", "'SCL'"};
      CHECK(contains(e, std::string("section ") + names[s] + " checksum mismatch"));
    }
  }
  SUBCASE("sizes that do not add up") {
    auto b = good;
    put_u32(b, 28, 4);  // latent count 3 -> 4: LAT is too short
    fix_header_sum(b);
    CHECK(contains(error_of(b), "section 'LAT' has 96 bytes, 4 latents of 8 fp32 values need 128"));
    b = good;
    put_u32(b, 20, 8);  // height 4 -> 8: IDS and SCL too short
    fix_header_sum(b);
    CHECK(contains(error_of(b), "section 'IDS' has 16 bytes"));
    b = good;
    put_u32(b, 24, 6);  // latent size 8 -> 6: the first layer's 12 inputs no longer chain
    fix_header_sum(b);
    CHECK(contains(error_of(b), "section 'MLP': layer 0 is 12 -> 8, but its input must be 10"));
    b = good;
    put_u32(b, 32, 2);  // 2 layers of 3: the last has 8 outputs
    fix_header_sum(b);
    CHECK(contains(error_of(b), "the last layer has 8 outputs"));
    b = good;
    put_u32(b, 36, 0);  // not clustered, but 3 latents for 16 texels
    fix_header_sum(b);
    CHECK(contains(error_of(b), "3 latents for 4 x 4 texels"));
    b = good;
    b.push_back(std::byte{0});
    CHECK(contains(error_of(b), "1 unexpected bytes after the last section"));
  }
  SUBCASE("ids out of range") {
    auto b = good;
    const auto [at, size] = section(b, 2);
    REQUIRE(size == 16);  // 8-bit ids
    b[at + 9] = std::byte{3};
    fix_section_sum(b, 2);
    CHECK(contains(error_of(b), "section 'IDS': texel 9 has cluster id 3, but there are 3 latents"));
  }
  SUBCASE("non-finite numbers") {
    auto b = good;
    auto [at, size] = section(b, 0);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::memcpy(b.data() + at + 8 + 4 * 17, &nan, 4);  // layer 0's weight 17
    fix_section_sum(b, 0);
    CHECK(contains(error_of(b), "section 'MLP': layer 0 has a non-finite weight (nan at index 17)"));
    b = good;
    std::tie(at, size) = section(b, 1);
    const float inf = std::numeric_limits<float>::infinity();
    std::memcpy(b.data() + at + 4 * 10, &inf, 4);  // latent 1, value 2
    fix_section_sum(b, 1);
    CHECK(contains(error_of(b), "section 'LAT': latent 1 value 2 is inf"));
    b = good;
    std::tie(at, size) = section(b, 3);
    std::memcpy(b.data() + at + 4 * 6, &nan, 4);
    fix_section_sum(b, 3);
    CHECK(contains(error_of(b), "section 'SCL': texel 6's scale is nan"));
    b = good;
    std::memcpy(b.data() + 56, &inf, 4);  // output scale
    fix_header_sum(b);
    CHECK(contains(error_of(b), "output scale inf"));
  }
  SUBCASE("missing and unreadable files") {
    auto missing = load_wbtf("/nonexistent/cloth.wbtf");
    REQUIRE_FALSE(missing);
    CHECK(missing.error().kind == ErrorKind::NotFound);
    CHECK(contains(missing.error().message, "/nonexistent/cloth.wbtf"));
    auto unwritable = save_wbtf(m, "/nonexistent/dir/cloth.wbtf");
    REQUIRE_FALSE(unwritable);
    CHECK(unwritable.error().kind == ErrorKind::Io);
  }
}
