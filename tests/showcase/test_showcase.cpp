// The showcase (examples/scenes/showcase.json): all four features compose in one graph, each
// feature's pass once, sharing the frame's depth, shadow map and environment; switching a
// material off removes its pass; and the stability sweep — the showcase rendered at the
// minimum and maximum of every knob of every feature (weft.tradeoff's catalogue) — stays
// finite, non-negative and bounded, with no validation message.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.tradeoff;
import weft.test.gpu;

using namespace weft;
namespace to = weft::tradeoff;

namespace {

std::filesystem::path source_dir() {
  const char* dir = std::getenv("WEFT_SOURCE_DIR");
  return dir ? std::filesystem::path(dir) : std::filesystem::current_path();
}

scene::Scene showcase() {
  auto s = scene::load_scene(source_dir() / "examples/scenes/showcase.json");
  REQUIRE_MESSAGE(s, (s ? "" : s.error().what()));
  return std::move(*s);
}

renderer::Renderer& shared_renderer() {
  static renderer::Renderer r = [] {
    // Bakes go to a cache of the test's own, kept between runs, not the user's.
    const auto cache = std::filesystem::temp_directory_path() / "weft_test_showcase_ssdf";
    ::setenv("WEFT_SSDF_CACHE", cache.c_str(), 1);
    ::setenv("WEFT_SKIN_LUT_CACHE", "", 1);
    auto made = renderer::Renderer::create(test::gpu().device);
    REQUIRE(made);
    return std::move(*made);
  }();
  return r;
}

struct HdrStats {
  std::size_t non_finite = 0, negative = 0;
  float largest = 0.0f;
};
HdrStats inspect(const image::Image& hdr) {
  HdrStats s;
  for (std::size_t i = 0; i < hdr.pixels.size(); ++i) {
    if (i % 4 == 3) continue;  // alpha
    const float v = hdr.pixels[i];
    if (!std::isfinite(v)) ++s.non_finite;
    else if (v < 0.0f) ++s.negative;
    else s.largest = std::max(s.largest, v);
  }
  return s;
}

const renderer::RenderOptions kSmall{.width = 96, .height = 54, .read_hdr = true};

}  // namespace

TEST_CASE("read_hdr: the scene colour before tone mapping, here a constant sky exactly") {
  auto desc = scene::parse_scene(R"({"version": 1, "output": {"width": 16, "height": 8},
      "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov": 40},
      "environment": {"color": [0.25, 0.5, 2.0], "intensity": 1.5}, "meshes": {}, "materials": {}, "objects": []})",
                                 std::filesystem::temp_directory_path(), "hdr.json");
  REQUIRE_MESSAGE(desc, (desc ? "" : desc.error().what()));
  auto s = scene::load_scene(*desc);
  REQUIRE_MESSAGE(s, (s ? "" : s.error().what()));
  auto f = shared_renderer().render(*s, {.read_hdr = true});
  REQUIRE_MESSAGE(f, (f ? "" : f.error().what()));
  REQUIRE(f->hdr.width == 16);
  REQUIRE(f->hdr.height == 8);
  for (std::uint32_t y = 0; y < 8; ++y)
    for (std::uint32_t x = 0; x < 16; ++x) {
      CHECK(f->hdr.at(x, y, 0) == doctest::Approx(0.375).epsilon(2e-3));
      CHECK(f->hdr.at(x, y, 1) == doctest::Approx(0.75).epsilon(2e-3));
      CHECK(f->hdr.at(x, y, 2) == doctest::Approx(3.0).epsilon(2e-3));  // above 1: not clamped
    }
  test::expect_no_validation_messages();
}

TEST_CASE("the showcase composes the four features in one graph: each pass once, shared frame resources") {
  const scene::Scene s = showcase();
  auto report = shared_renderer().describe(s, kSmall);
  REQUIRE_MESSAGE(report, (report ? "" : report.error().what()));
  for (const char* pass : {"shell_fur", "skin_sss", "ssdf_lighting", "neural_btf", "shadow_map", "forward", "tonemap"}) {
    CAPTURE(pass);
    CHECK(std::count(report->passes.begin(), report->passes.end(), std::string(pass)) == 1);
  }
  // The features read the frame's shadow map and write the frame's colour and depth: one
  // node each in the DOT, not one per feature.
  for (const char* shared : {"\"shadow_map", "scene_depth", "scene_color", "environment"})
    CHECK_MESSAGE(report->dot.find(shared) != std::string::npos, shared);

  // Declared with no adapter (renderer::describe on a declaring device, no bake run): the same
  // frame as on this adapter -- passes, order, culling, resources and slots.
  auto declared = renderer::describe(s, kSmall);
  REQUIRE_MESSAGE(declared, (declared ? "" : declared.error().what()));
  CHECK(declared->passes == report->passes);
  CHECK(declared->culled_passes == report->culled_passes);
  CHECK(declared->resources == report->resources);
  CHECK(declared->slots == report->slots);

  // Switching the cloth to a standard material removes the neural BTF pass (and its model).
  scene::Scene without = s;
  for (auto& m : without.materials)
    if (m.type == "neural_btf") {
      m.type = scene::standard_material;
      m.standard = {};
    }
  auto fewer = shared_renderer().describe(without, kSmall);
  REQUIRE(fewer);
  CHECK(std::count(fewer->passes.begin(), fewer->passes.end(), std::string("neural_btf")) == 0);
  CHECK(std::count(fewer->passes.begin(), fewer->passes.end(), std::string("shell_fur")) == 1);

  auto f = shared_renderer().render(s, kSmall);
  REQUIRE_MESSAGE(f, (f ? "" : f.error().what()));
  const HdrStats st = inspect(f->hdr);
  CHECK(st.non_finite == 0);
  CHECK(st.negative == 0);
  test::expect_no_validation_messages();
}

TEST_CASE("stability sweep: every knob of every feature at its minimum and maximum renders finite and bounded") {
  const scene::Scene base = showcase();
  auto reference_frame = shared_renderer().render(base, kSmall);
  REQUIRE_MESSAGE(reference_frame, (reference_frame ? "" : reference_frame.error().what()));
  const HdrStats normal = inspect(reference_frame->hdr);
  REQUIRE(normal.non_finite == 0);
  // The sky's brightest texels bound the frame; a feature that blew up would exceed them.
  const float bound = std::max(4.0f * normal.largest, 16.0f);
  for (const auto* each : to::studies()) {
    const auto& study = *each;
    // The SSDF's other settings bake at 8 x 8 directions, so only the resolution's own
    // extremes pay for fine bakes.
    nlohmann::json cheap = nlohmann::json::object();
    if (study.feature == "ssdf_lighting") cheap = {{"bake.resolution", 8}};
    for (const auto& setting : to::extreme_settings(study, cheap)) {
      CAPTURE(study.feature);
      CAPTURE(setting.label);
      if (study.feature == "ssdf_lighting" && setting.is_reference) continue;  // 64 x 64 at full rank: the resolution maximum covers it
      // The raw 100 x 100 twill (787 MB, seconds to make); test_neural_btf_gpu renders the reference mode.
      if (study.feature == "neural_btf" && setting.is_reference) continue;
      scene::Scene s = base;
      REQUIRE(to::apply_setting(s, study, setting));
      renderer::RenderOptions options = kSmall;
      options.quality = setting.quality;
      auto f = shared_renderer().render(s, options);
      REQUIRE_MESSAGE(f, (f ? "" : f.error().what()));
      const HdrStats st = inspect(f->hdr);
      CHECK(st.non_finite == 0);
      CHECK(st.negative == 0);
      CHECK(st.largest <= bound);
      CHECK(std::count(f->passes.begin(), f->passes.end(), std::string(study.passes.front())) == 1);
      test::expect_no_validation_messages();
    }
  }
}
