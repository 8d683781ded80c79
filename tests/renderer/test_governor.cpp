// weft.governor on a device: a fur ball (shell_fur's presets: 8, 16 and 32 shells) fitted to
// budgets. Whatever the machine's speed, the governor's own measured frame must be within the
// budget it reports as met, the cheapest levels must be taken when nothing fits, and a budget
// above everything must take the best levels. The time it measures is wall time, so the test
// asserts only what holds at any speed (docs/viewer.md has the numbers).
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <vector>
import weft.core;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.tradeoff;
import weft.governor;
import weft.test.gpu;

using namespace weft;

namespace {

std::filesystem::path source_dir() {
  const char* dir = std::getenv("WEFT_SOURCE_DIR");
  return dir ? std::filesystem::path(dir) : std::filesystem::current_path();
}

scene::Scene fur_ball() {
  const auto photo = (source_dir() / "examples/fur/synthetic_fur.png").string();
  const std::string json = weft::format(R"({{
    "version": 1, "output": {{"width": 96, "height": 96}},
    "camera": {{"position": [0, 0.4, 1.8], "target": [0, 0, 0], "fov": 40}},
    "lights": [{{"type": "directional", "direction": [-0.6, -0.5, -0.6], "intensity": 3}}],
    "meshes": {{"ball": {{"primitive": "sphere", "radius": 0.5, "segments": 24}}}},
    "materials": {{"fur": {{"type": "shell_fur", "photo": "{}", "thickness": 0.08}},
                   "floor": {{"type": "standard", "base_color": [0.5, 0.5, 0.5]}}}},
    "objects": [{{"name": "ball", "mesh": "ball", "material": "fur"}}]
  }})", photo);
  auto desc = scene::parse_scene(json, std::filesystem::temp_directory_path());
  REQUIRE_MESSAGE(desc, (desc ? "" : desc.error().what()));
  auto s = scene::load_scene(*desc);
  REQUIRE_MESSAGE(s, (s ? "" : s.error().what()));
  return std::move(*s);
}

renderer::Renderer& shared_renderer() {
  static auto r = renderer::Renderer::create(weft::test::gpu().device);
  REQUIRE(r);
  return *r;
}

governor::BudgetResult fit(double budget_ms) {
  std::vector<std::string> lines;
  governor::BudgetOptions options{.budget_ms = budget_ms, .frames = 1};
  options.progress = [&](std::string_view line) { lines.emplace_back(line); };
  auto r = governor::fit_budget(shared_renderer(), fur_ball(), {}, options);
  REQUIRE_MESSAGE(r, (r ? "" : r.error().what()));
  CHECK(lines.size() == r->measurements.size());  // progress: one line per measurement
  return std::move(*r);
}

bool all_cheapest(const governor::BudgetResult& r) {
  return std::all_of(r.choice.level.begin(), r.choice.level.end(), [](std::size_t l) { return l == 0; });
}

}  // namespace

TEST_CASE("governor: the table has the scene's one feature at three levels, errors falling to 0 at the best") {
  const auto r = fit(1e6);
  REQUIRE(r.table.features.size() == 1);
  const auto& fur = r.table.features[0];
  CHECK(fur.study->feature == "shell_fur");
  REQUIRE(fur.levels.size() == 3);
  CHECK(fur.levels[0].cost_ms == 0.0);
  CHECK(fur.levels[2].mse == 0.0);
  CHECK(fur.levels[0].mse > 0.0);  // 8 shells do not look like 32
  CHECK(r.table.base_ms > 0.0);
  // A budget above everything: the best level, measured within it.
  CHECK(r.choice.level == std::vector<std::size_t>{2});
  CHECK(r.met);
  CHECK(r.measured_ms <= 1e6);
  CHECK(r.frame.image.width == 96);
  CHECK(r.summary(1e6).find("shell_fur=preset high") != std::string::npos);
}

TEST_CASE("governor: a budget nothing meets takes the cheapest levels and says it cannot be met") {
  const auto r = fit(1e-3);
  CHECK_FALSE(r.met);
  CHECK(all_cheapest(r));
  CHECK(r.summary(1e-3).find("cannot be met") != std::string::npos);
  // The chosen scene really carries the cheapest preset's knob values.
  const auto* study = r.table.features.at(0).study;
  const auto low = tradeoff::budget_levels(*study).front().values;
  for (const auto& m : r.scene.materials)
    if (m.type == "shell_fur") CHECK(m.params.at("layers") == low.at("layers"));
}

TEST_CASE("governor: a budget between the cheapest and the best frame is met by what it measured, or stepped to the cheapest") {
  // Halfway between the frame with the cheapest and with the best level, as measured here.
  const auto probe = fit(1e6);
  const double budget = probe.table.base_ms + 0.5 * probe.table.features[0].levels.back().cost_ms;
  const auto r = fit(budget);
  CAPTURE(r.summary(budget));
  // The prediction is made from this run's own table (the probe's times may differ under load).
  CHECK(r.predicted.fits == (r.predicted.predicted_ms <= budget));
  if (r.met)
    CHECK(r.measured_ms <= budget);
  else
    CHECK(all_cheapest(r));  // stepped down as far as it goes
  // The final measurement is the chosen frame's.
  REQUIRE_FALSE(r.measurements.empty());
  CHECK(r.measurements.back().what == "chosen");
  CHECK(r.measurements.back().frame_ms == r.measured_ms);
}

TEST_CASE("governor: a budget that is not a positive number is an error naming it") {
  for (double bad : {0.0, -5.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    auto r = governor::fit_budget(shared_renderer(), fur_ball(), {}, {.budget_ms = bad});
    REQUIRE_FALSE(r);
    CHECK(r.error().what().find("frame-time budget") != std::string::npos);
  }
}
