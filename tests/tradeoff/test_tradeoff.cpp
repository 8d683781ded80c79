// weft.tradeoff without a device: the catalogue (every feature, knobs inside what its
// material accepts, presets read from the passes), knob parsing and its errors, the sweep
// plan (reference first, no duplicates, grids crossed), the extremes, writing a setting into
// a scene's materials (and the material parsers accepting it), the masked error metrics on
// images with known differences, the Pareto front against brute force, and the reports.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>
import weft.core;
import weft.image;
import weft.scene;
import weft.feature;
import weft.tradeoff;
import weft.pipeline;
import weft.pass.skin_sss;
import weft.pass.shell_fur;
import weft.pass.ssdf_lighting;
import weft.pass.neural_btf;

using namespace weft;
namespace to = weft::tradeoff;
using json = nlohmann::json;

namespace {

const to::Study& study(std::string_view name) {
  auto s = to::find_study(name);
  REQUIRE_MESSAGE(s, (s ? "" : s.error().what()));
  return **s;
}

// A scene with one material of each feature's type (and a standard one that must not change).
scene::Scene scene_with_every_material() {
  scene::Scene s;
  auto add = [&](std::string name, std::string type, json params) {
    scene::Material m;
    m.name = std::move(name);
    m.type = type;
    m.params = std::move(params);
    m.json_path = "$.materials." + m.name;
    s.materials.push_back(std::move(m));
  };
  add("plain", "standard", json::object());
  add("fur", "shell_fur", {{"photo", "fur.png"}, {"layers", 15}});
  add("skin", "skin_sss", {{"lut", {{"size", 128}, {"range", "penner"}}}});
  add("ssdf", "ssdf_lighting", {{"albedo", {0.5, 0.5, 0.5}}, {"lobes", 4}});
  add("btf", "neural_btf", {{"model", "cloth.wbtf"}, {"btf", "synthetic:twill:4x4"}, {"filter", "nearest"}});
  // The parsers check that files exist (not what is in them).
  const auto dir = std::filesystem::temp_directory_path() / "weft_test_tradeoff";
  std::filesystem::create_directories(dir);
  for (const char* name : {"cloth.wbtf", "fur.png"}) std::ofstream(dir / name) << "x";
  for (auto& m : s.materials) m.base_dir = dir;
  return s;
}

// Does the feature's own check (its descriptor's) accept the material as the setting left it?
Result<void> parses(const scene::Material& m) {
  if (m.type == scene::standard_material) return {};
  auto feature = feature_registry().get(m.type);
  if (!feature) return std::unexpected(feature.error());
  return (*feature)->check_material(m);
}

image::Image8 flat(std::uint32_t w, std::uint32_t h, std::uint8_t v) {
  image::Image8 img = image::Image8::filled(w, h, 4, v);
  for (std::size_t i = 3; i < img.pixels.size(); i += 4) img.pixels[i] = 255;
  return img;
}

double srgb_to_linear(double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); }

}  // namespace

TEST_CASE("the catalogue has all four features; knobs and references are valid values of their knobs") {
  std::set<std::string> names;
  for (const auto* s : to::studies()) names.insert(s->feature);
  CHECK(names == std::set<std::string>{"shell_fur", "skin_sss", "ssdf_lighting", "neural_btf"});
  for (const auto* study : to::studies()) {
    const auto& s = *study;
    CAPTURE(s.feature);
    CHECK_FALSE(s.knobs.empty());
    CHECK_FALSE(s.passes.empty());
    CHECK(s.reference.is_reference);
    for (const auto& k : s.knobs) {
      CAPTURE(k.name);
      CHECK_FALSE(k.sweep.empty());
      CHECK_FALSE(k.meaning.empty());
      for (const auto& v : k.sweep) CHECK_MESSAGE(to::check_knob_value(k, v), v.dump());
    }
    for (const auto& [name, value] : s.reference.values.items())
      if (auto k = to::find_knob(s, name)) CHECK_MESSAGE(to::check_knob_value(**k, value), name, "=", value.dump());
    const bool has_presets = s.preset_values != nullptr;
    REQUIRE(has_presets);
    for (Quality q : {Quality::Low, Quality::Medium, Quality::High, Quality::Reference}) CHECK(s.preset_values(q).is_object());
  }
  // The presets the study measures are the ones the passes use.
  CHECK(study("fur").preset_values(Quality::High).at("layers") == fur::fur_layers_for(Quality::High));
  CHECK(study("skin").preset_values(Quality::Low).at("lut.size") == skin::skin_quality_preset(Quality::Low).lut_size);
  CHECK(study("ssdf").preset_values(Quality::Low).at("lobes") == ssdf::ssdf_quality_preset(Quality::Low).lobes);
  CHECK(study("btf").preset_values(Quality::High).at("filter") == "bilinear");
  CHECK(study("btf").preset_values(Quality::Low).at("ambient") == false);

  auto unknown = to::find_study("hair");
  REQUIRE_FALSE(unknown);
  CHECK(unknown.error().message.find("'hair'") != std::string::npos);
  CHECK(unknown.error().message.find("shell_fur (fur), skin_sss (skin), neural_btf (btf), ssdf_lighting (ssdf)") !=
        std::string::npos);
  // The old --feature names are aliases of the same study.
  CHECK(&study("fur") == &study("shell_fur"));
  CHECK(&study("btf") == &study("neural_btf"));
}

TEST_CASE("knob values from the command line: types, ranges, choices; errors name the knob and the value") {
  const auto& fur = study("fur");
  auto v = to::parse_knob_values(fur, "layers=1, 2,256");
  REQUIRE(v);
  CHECK(v->knob->name == "layers");
  CHECK(v->values == std::vector<json>{1, 2, 256});
  auto bad = to::parse_knob_values(fur, "layers=0");
  REQUIRE_FALSE(bad);
  CHECK(bad.error().message.find("layers") != std::string::npos);
  CHECK(bad.error().message.find("'0'") != std::string::npos);
  CHECK_FALSE(to::parse_knob_values(fur, "layers=2.5"));
  CHECK_FALSE(to::parse_knob_values(fur, "layers="));
  auto no_eq = to::parse_knob_values(fur, "layers");
  REQUIRE_FALSE(no_eq);
  CHECK(no_eq.error().message.find("KNOB=V1,V2") != std::string::npos);
  auto no_knob = to::parse_knob_values(fur, "hairs=3");
  REQUIRE_FALSE(no_knob);
  CHECK(no_knob.error().message.find("'hairs'") != std::string::npos);
  CHECK(no_knob.error().message.find("layers") != std::string::npos);  // lists the knobs there are
  auto fins = to::parse_knob_values(fur, "fins=on,false");
  REQUIRE(fins);
  CHECK(fins->values == std::vector<json>{true, false});
  CHECK_FALSE(to::parse_knob_values(fur, "fins=maybe"));
  CHECK_FALSE(to::parse_knob_values(fur, "fin_threshold=nan"));
  CHECK_FALSE(to::parse_knob_values(fur, "fin_threshold=1.5"));
  const auto& skin = study("skin");
  CHECK(to::parse_knob_values(skin, "lut.range=full,adaptive"));
  auto choice = to::parse_knob_values(skin, "lut.range=wide");
  REQUIRE_FALSE(choice);
  CHECK(choice.error().message.find("penner") != std::string::npos);  // names the choices
}

TEST_CASE("the sweep plan: the reference first, every preset, each knob's sweep, grids crossed, no duplicates") {
  for (const auto* study : to::studies()) {
    const auto& s = *study;
    CAPTURE(s.feature);
    const auto plan = to::plan_sweep(s);
    REQUIRE_FALSE(plan.empty());
    CHECK(plan.front().is_reference);
    CHECK(std::count_if(plan.begin(), plan.end(), [](const to::Setting& x) { return x.is_reference; }) == 1);
    CHECK(std::count_if(plan.begin(), plan.end(), [](const to::Setting& x) { return x.group == "preset"; }) >= 1);
    std::set<std::string> keys;
    for (const auto& x : plan) {
      CHECK(keys.insert(std::to_string(int(x.quality)) + x.values.dump()).second);  // no setting twice
      CHECK(x.strip_knobs);
    }
    // Every sweep value of every knob appears in some setting.
    for (const auto& k : s.knobs)
      for (const auto& v : k.sweep)
        CHECK_MESSAGE(std::any_of(plan.begin(), plan.end(),
                                  [&](const to::Setting& x) { return x.values.contains(k.name) && x.values[k.name] == v; }),
                      k.name, "=", v.dump());
    // A grid holds every pair.
    for (const auto& [a, b] : s.grids) {
      auto ka = to::find_knob(s, a), kb = to::find_knob(s, b);
      REQUIRE(ka);
      REQUIRE(kb);
      for (const auto& va : (*ka)->sweep)
        for (const auto& vb : (*kb)->sweep)
          CHECK(std::any_of(plan.begin(), plan.end(), [&](const to::Setting& x) {
            return x.values.size() == 2 && x.values.value(a, json()) == va && x.values.value(b, json()) == vb;
          }));
    }
  }
  // --values replaces one knob's sweep only.
  const auto& fur = study("fur");
  auto layers = to::parse_knob_values(fur, "layers=3,5");
  REQUIRE(layers);
  const auto plan = to::plan_sweep(fur, std::span<const to::KnobValues>(&*layers, 1));
  CHECK(std::none_of(plan.begin(), plan.end(), [](const to::Setting& x) { return x.group != "preset" && !x.is_reference && x.values.value("layers", 0) == 128; }));
  CHECK(std::any_of(plan.begin(), plan.end(), [](const to::Setting& x) { return x.values.value("layers", 0) == 5; }));
}

TEST_CASE("extremes: each knob's minimum and maximum (every choice, both booleans) on top of a base") {
  for (const auto* study : to::studies()) {
    const auto& s = *study;
    CAPTURE(s.feature);
    const auto ext = to::extreme_settings(s, {{"base_only", 1}});
    CHECK(ext.front().is_reference);
    std::size_t expected = 1;
    for (const auto& k : s.knobs) expected += k.kind == to::KnobKind::Choice ? k.choices.size() : 2;
    CHECK(ext.size() == expected);
    for (const auto& k : s.knobs) {
      if (k.kind != to::KnobKind::Integer) continue;
      for (double bound : {k.extreme_min.value_or(k.min), k.extreme_max.value_or(k.max)})
        CHECK(std::any_of(ext.begin(), ext.end(), [&](const to::Setting& x) {
          return x.values.contains(k.name) && x.values[k.name] == std::int64_t(bound) && x.values.value("base_only", 0) == 1;
        }));
    }
  }
}

TEST_CASE("a setting is written into every material of the feature's type, which its parser then accepts") {
  for (const auto* study : to::studies()) {
    const auto& s = *study;
    CAPTURE(s.feature);
    for (const auto& setting : to::extreme_settings(s)) {
      CAPTURE(setting.label);
      scene::Scene scene = scene_with_every_material();
      REQUIRE(to::apply_setting(scene, s, setting));
      for (const auto& m : scene.materials) {
        if (m.type == scene::standard_material) {
          CHECK(m.params == json::object());
          continue;
        }
        if (m.type != s.material) continue;
        for (const auto& [name, value] : setting.values.items()) {
          // "lut.size" -> params["lut"]["size"]
          const json* node = &m.params;
          std::string rest = name;
          for (std::size_t dot; (dot = rest.find('.')) != std::string::npos; rest = rest.substr(dot + 1))
            node = &node->at(rest.substr(0, dot));
          CHECK(node->at(rest) == value);
        }
        auto ok = parses(m);
        CHECK_MESSAGE(ok, (ok ? "" : ok.error().what()));
      }
    }
  }
  // Stripping removes a knob the scene set that the setting does not.
  scene::Scene scene = scene_with_every_material();
  const auto& skin = study("skin");
  REQUIRE(to::apply_setting(scene, skin, {.label = "x", .values = {{"lut.samples", 8}}, .strip_knobs = true}));
  const auto& params = scene.materials[2].params;
  CHECK_FALSE(params.at("lut").contains("size"));
  CHECK(params.at("lut").at("samples") == 8);
  // A scene without the material is an error naming the type.
  scene::Scene none;
  auto missing = to::apply_setting(none, study("ssdf"), {.label = "x"});
  REQUIRE_FALSE(missing);
  CHECK(missing.error().message.find("'ssdf_lighting'") != std::string::npos);
}

TEST_CASE("the feature registry: names and aliases are unique, a descriptor needs its factory and check") {
  FeatureRegistry registry;
  FeatureDescriptor d = passes::shell_fur_feature();
  REQUIRE(registry.add(d));
  CHECK(registry.add(d));  // the same name and aliases again: nothing changes
  CHECK(registry.all().size() == 1);
  CHECK(registry.find("fur") == registry.find("shell_fur"));
  CHECK(registry.find("hair") == nullptr);
  auto unknown = registry.get("hair");
  REQUIRE_FALSE(unknown);
  CHECK(unknown.error().message == "no feature 'hair' is registered; registered: shell_fur (fur)");

  FeatureDescriptor clash = passes::skin_sss_feature();
  clash.aliases = {"fur"};
  auto taken = registry.add(clash);
  REQUIRE_FALSE(taken);
  CHECK(taken.error().message == "feature 'skin_sss': the name 'fur' is taken by 'shell_fur'");

  FeatureDescriptor no_factory = passes::skin_sss_feature();
  no_factory.create = nullptr;
  auto incomplete = registry.add(no_factory);
  REQUIRE_FALSE(incomplete);
  CHECK(incomplete.error().message.find("needs `create`") != std::string::npos);

  FeatureDescriptor empty_knob = passes::skin_sss_feature();
  empty_knob.knobs.push_back(choice_knob("mode", {}, "nothing to choose"));
  auto bad_knob = registry.add(empty_knob);
  REQUIRE_FALSE(bad_knob);
  CHECK(bad_knob.error().message.find("knob 'mode'") != std::string::npos);
}

TEST_CASE("a knob's range is the material's: the parser reports a value outside it at its JSON path") {
  scene::Material m;
  m.name = "fur";
  m.type = "shell_fur";
  m.json_path = "$.materials.fur";
  m.params = {{"photo", "fur.png"}, {"layers", 257}, {"fin_threshold", 2}};
  m.base_dir = std::filesystem::temp_directory_path() / "weft_test_tradeoff";
  std::filesystem::create_directories(m.base_dir);
  std::ofstream(m.base_dir / "fur.png") << "x";
  auto bad = passes::shell_fur_feature().check_material(m);
  REQUIRE_FALSE(bad);
  CHECK(bad.error().message.find("$.materials.fur.layers: 257 is out of range [1, 256]") != std::string::npos);
  CHECK(bad.error().message.find("$.materials.fur.fin_threshold: 2 is out of range [0, 1]") != std::string::npos);
}

TEST_CASE("masked error metrics against analytic values") {
  const image::Image8 ref = flat(16, 16, 128);
  image::Image8 img = ref;
  // Two pixels differ by a known amount; the mask covers the top half.
  to::Mask mask = to::full_mask(16, 16);
  for (std::size_t p = 128; p < 256; ++p) mask.covered[p] = 0;
  CHECK(mask.count() == 128);
  auto same = to::compare(img, ref, mask);
  REQUIRE_MESSAGE(same, (same ? "" : same.error().what()));
  CHECK(same->rmse == 0.0);
  CHECK(std::isinf(same->psnr_db));
  CHECK(same->pixels == 128);
  for (int c = 0; c < 3; ++c) img.pixels[std::size_t(3 * 4 + c)] = 200;   // pixel 3, inside the mask
  for (int c = 0; c < 3; ++c) img.pixels[std::size_t(200 * 4 + c)] = 255;  // pixel 200, outside
  auto e = to::compare(img, ref, mask);
  REQUIRE(e);
  const double d = srgb_to_linear(200.0 / 255.0) - srgb_to_linear(128.0 / 255.0);
  CHECK(e->rmse == doctest::Approx(std::sqrt(d * d / 128.0)).epsilon(1e-6));
  CHECK(e->max_diff == doctest::Approx(d).epsilon(1e-6));
  // Relative: the error over the reference's RMS on the same pixels (a flat 128 reference).
  CHECK(e->relative_rmse == doctest::Approx(e->rmse / srgb_to_linear(128.0 / 255.0)).epsilon(1e-5));
  CHECK(e->psnr_db == doctest::Approx(-20.0 * std::log10(e->rmse)).epsilon(1e-9));
  CHECK(e->ssim < 1.0);
  // Coverage: where the two flat renders differ, or where a setting changed a pixel.
  image::Image8 a = flat(16, 16, 0), b = flat(16, 16, 0);
  b.pixels[0] = 255;
  const image::Image8* renders[] = {&img};
  auto m = to::coverage_mask(a, b, renders, ref);
  REQUIRE(m);
  CHECK(m->count() == 3);  // pixel 0 (coverage), pixels 3 and 200 (changed)
  CHECK(m->covered[0] == 1);
  CHECK(m->covered[3] == 1);
  CHECK(m->covered[200] == 1);
  // Sizes that differ are an error, not a read past the end.
  const image::Image8 small = flat(4, 4, 0);
  CHECK_FALSE(to::compare(small, ref, mask));
  CHECK_FALSE(to::coverage_mask(small, b, renders, ref));
}

TEST_CASE("the Pareto front equals brute force on random points, ties and duplicates included") {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<to::Point> pts(std::size_t(1 + rng() % 12));
    for (auto& p : pts) p = {double(rng() % 6), double(rng() % 6)};  // small ranges: many ties
    const auto front = to::pareto_front(pts);
    std::vector<std::size_t> brute;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      bool dominated = false;
      for (std::size_t j = 0; j < pts.size(); ++j)
        dominated |= pts[j].cost <= pts[i].cost && pts[j].error <= pts[i].error &&
                     (pts[j].cost < pts[i].cost || pts[j].error < pts[i].error);
      if (!dominated) brute.push_back(i);
    }
    std::vector<std::size_t> sorted = front;
    std::sort(sorted.begin(), sorted.end());
    CHECK(sorted == brute);
    for (std::size_t i = 1; i < front.size(); ++i) CHECK(pts[front[i - 1]].cost <= pts[front[i]].cost);
  }
  CHECK(to::pareto_front({}).empty());
}

TEST_CASE("reports: CSV quoting, markdown rows, SVG escaping") {
  CHECK(to::csv_field("plain") == "plain");
  CHECK(to::csv_field("a,b") == "\"a,b\"");
  CHECK(to::csv_field("say \"hi\"") == "\"say \"\"hi\"\"\"");
  CHECK(to::csv_field("two\nlines") == "\"two\nlines\"");
  CHECK(to::xml_escape("<a & 'b'>\"") == "&lt;a &amp; &apos;b&apos;&gt;&quot;");
  std::vector<to::Row> rows(3);
  rows[0].setting = {.label = "reference", .group = "reference", .is_reference = true};
  rows[0].frame_ms = 10.0;
  rows[1].setting = {.label = "layers=8 <&>", .group = "layers"};
  rows[1].frame_ms = 2.0;
  rows[1].error.rmse = 0.05;
  rows[2].setting = {.label = "fins=true, <x>", .group = "fins"};
  rows[2].frame_ms = 3.0;
  rows[2].error.rmse = 0.08;  // dominated by layers=8
  to::mark_pareto(rows, to::CostAxis::Frame);
  CHECK(rows[0].pareto);
  CHECK(rows[1].pareto);
  CHECK_FALSE(rows[2].pareto);
  to::ReportInfo info{.feature = "fur", .scene = "s.json", .command = "weft tradeoff s.json --feature fur", .device = "llvmpipe"};
  const std::string c = to::csv(rows, info);
  CHECK(c.find("\"fins=true, <x>\"") != std::string::npos);
  CHECK(std::count(c.begin(), c.end(), '\n') >= 4);  // a header and three rows
  const std::string md = to::markdown(rows, info);
  CHECK(md.find("layers=8") != std::string::npos);
  CHECK(md.find("weft tradeoff s.json --feature fur") != std::string::npos);
  const std::string svg = to::svg(rows, info);
  CHECK(svg.find("<svg") != std::string::npos);
  CHECK(svg.find("</svg>") != std::string::npos);
  CHECK(svg.find("layers=8 &lt;&amp;&gt;") != std::string::npos);  // the front is labelled, escaped
  CHECK(svg.find("<&>") == std::string::npos);
}

// ---- the frame-time budget's choice ------------------------------------------------------------

namespace {
// A table of `features` features with `levels` levels each: cost rising and error falling
// with the level (as presets do), random steps; the best level's error is 0.
to::BudgetTable random_table(std::mt19937& rng, std::size_t features, std::size_t levels) {
  std::uniform_real_distribution<double> step(0.5, 40.0), err(1e-5, 1e-2);
  to::BudgetTable t;
  t.base_ms = step(rng);
  for (std::size_t f = 0; f < features; ++f) {
    to::BudgetFeature feature;
    double cost = 0.0;
    std::vector<double> mse(levels, 0.0);
    for (std::size_t l = levels - 1; l-- > 0;) mse[l] = mse[l + 1] + err(rng);
    for (std::size_t l = 0; l < levels; ++l) {
      if (l > 0) cost += step(rng);
      feature.levels.push_back({.cost_ms = cost, .mse = mse[l]});
    }
    t.features.push_back(std::move(feature));
  }
  return t;
}
}  // namespace

TEST_CASE("budget: the choice is the least error that fits, as brute force finds it; none fits -> cheapest") {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const std::size_t features = 1 + std::size_t(trial % 4), levels = 1 + std::size_t(trial % 3);
    const auto table = random_table(rng, features, levels);
    double most = table.base_ms;
    for (const auto& f : table.features) most += f.levels.back().cost_ms;
    const double budget = std::uniform_real_distribution<double>(0.5 * table.base_ms, most * 1.1)(rng);
    const auto c = to::choose_within_budget(table, budget);
    // Brute force over every combination, written independently of the chooser.
    double best_mse = std::numeric_limits<double>::infinity();
    std::size_t combos = 1;
    for (std::size_t i = 0; i < features; ++i) combos *= levels;
    for (std::size_t code = 0; code < combos; ++code) {
      double ms = table.base_ms, mse = 0.0;
      for (std::size_t f = 0, rest = code; f < features; ++f, rest /= levels) {
        ms += table.features[f].levels[rest % levels].cost_ms;
        mse += table.features[f].levels[rest % levels].mse;
      }
      if (ms <= budget) best_mse = std::min(best_mse, mse);
    }
    CAPTURE(trial);
    CAPTURE(budget);
    if (std::isinf(best_mse)) {
      CHECK_FALSE(c.fits);
      CHECK(std::all_of(c.level.begin(), c.level.end(), [](std::size_t l) { return l == 0; }));
    } else {
      CHECK(c.fits);
      CHECK(c.predicted_ms <= budget);
      CHECK(c.predicted_mse == doctest::Approx(best_mse).epsilon(1e-12));
    }
  }
}

TEST_CASE("budget: a budget above everything takes every best level; stepping down walks to the cheapest") {
  std::mt19937 rng(11);
  const auto table = random_table(rng, 3, 3);
  auto c = to::choose_within_budget(table, 1e9);
  CHECK(c.fits);
  CHECK(c.level == std::vector<std::size_t>{2, 2, 2});
  CHECK(c.predicted_mse == 0.0);
  // Each step lowers exactly one feature by one level and costs less; six steps reach the cheapest.
  for (int steps = 0; steps < 6; ++steps) {
    auto next = to::step_down(table, c, 1e9);
    REQUIRE(next);
    int lowered = 0;
    for (std::size_t f = 0; f < 3; ++f) lowered += int(c.level[f] - next->level[f]);
    CHECK(lowered == 1);
    CHECK(next->predicted_ms <= c.predicted_ms);
    CHECK(next->predicted_mse >= c.predicted_mse);
    c = *next;
  }
  CHECK(c.level == std::vector<std::size_t>{0, 0, 0});
  CHECK_FALSE(to::step_down(table, c, 1e9));
}

TEST_CASE("budget: stepping down gives up the least error per millisecond saved") {
  to::BudgetTable t;
  t.base_ms = 10.0;
  // Feature 0's top level saves 10 ms for 1e-3 error; feature 1's saves 10 ms for 1e-4.
  t.features.push_back({.levels = {{.cost_ms = 0.0, .mse = 1e-3}, {.cost_ms = 10.0, .mse = 0.0}}});
  t.features.push_back({.levels = {{.cost_ms = 0.0, .mse = 1e-4}, {.cost_ms = 10.0, .mse = 0.0}}});
  const auto top = to::evaluate(t, {1, 1}, 25.0);
  CHECK_FALSE(top.fits);
  const auto next = to::step_down(t, top, 25.0);
  REQUIRE(next);
  CHECK(next->level == std::vector<std::size_t>{1, 0});
  CHECK(next->fits);
  CHECK(to::choose_within_budget(t, 25.0).level == std::vector<std::size_t>{1, 0});
  CHECK(to::choose_within_budget(t, 9.0).fits == false);
}

TEST_CASE("budget: many features are chosen greedily and still fit") {
  std::mt19937 rng(3);
  const auto table = random_table(rng, 24, 3);  // 3^24 combinations: too many to try
  double most = table.base_ms;
  for (const auto& f : table.features) most += f.levels.back().cost_ms;
  const auto c = to::choose_within_budget(table, 0.5 * (table.base_ms + most));
  CHECK(c.fits);
  CHECK(c.predicted_ms <= 0.5 * (table.base_ms + most));
  CHECK(c.predicted_mse > 0.0);
}

TEST_CASE("budget: each built-in feature offers its low, medium and high presets as levels") {
  for (const char* name : {"shell_fur", "skin_sss", "ssdf_lighting", "neural_btf"}) {
    const auto levels = to::budget_levels(study(name));
    REQUIRE(levels.size() == 3);
    CHECK(levels[0].preset == Quality::Low);
    CHECK(levels[2].preset == Quality::High);
    for (const auto& l : levels) CHECK(l.strip_knobs);
    CHECK(levels[0].values != levels[2].values);
  }
}

TEST_CASE("a pipeline pass's study: its options' sweeps from the options table, its type's reference, no presets") {
  auto pipeline = pipeline::default_pipeline();
  REQUIRE(pipeline);
  auto shadow = to::pass_study(*pipeline, "shadow_map");
  REQUIRE_MESSAGE(shadow, (shadow ? "" : shadow.error().what()));
  CHECK(shadow->pass == "shadow_map");
  CHECK(shadow->passes == std::vector<std::string>{"shadow_map"});
  REQUIRE(shadow->knobs.size() == 1);
  CHECK(shadow->knobs[0].name == "resolution");
  CHECK(shadow->knobs[0].max == 16384);
  CHECK(shadow->reference.values == json{{"resolution", 8192}});
  // Every value a sweep tries is one the pipeline reader accepts.
  for (const auto& v : shadow->knobs[0].sweep) CHECK(to::check_knob_value(shadow->knobs[0], v));

  const auto plan = to::plan_sweep(*shadow);
  REQUIRE(!plan.empty());
  CHECK(plan.front().is_reference);
  CHECK(plan.size() == 1 + shadow->knobs[0].sweep.size());  // the reference and the sweep: no presets
  for (const auto& setting : plan) CHECK(setting.group != "preset");

  // A setting goes into the pipeline, checked as the reader checks a file.
  auto with = to::apply_pass_setting(*pipeline, *shadow, plan[1]);
  REQUIRE_MESSAGE(with, (with ? "" : with.error().what()));
  CHECK(with->find("shadow_map")->options.integer("resolution") == plan[1].values.at("resolution").get<std::int64_t>());
  CHECK(pipeline->find("shadow_map")->options.integer("resolution") == 0);  // the base pipeline is untouched
  auto reference = to::apply_pass_setting(*pipeline, *shadow, plan.front());
  REQUIRE(reference);
  CHECK(reference->find("shadow_map")->options.integer("resolution") == 8192);
  const to::Setting too_big{.label = "too big", .values = {{"resolution", 20000}}};
  auto refused = to::apply_pass_setting(*pipeline, *shadow, too_big);
  REQUIRE(!refused);
  CHECK(refused.error().what().find("$.passes.shadow_map.options.resolution") != std::string::npos);
  // A scene is not touched by a pass study's setting.
  scene::Scene untouched;
  CHECK(to::apply_setting(untouched, *shadow, plan[1]));

  // A pass that trades nothing, and a pass the pipeline lacks, are named.
  auto tonemap = to::pass_study(*pipeline, "tonemap");
  REQUIRE(!tonemap);
  CHECK(tonemap.error().message.find("trades no accuracy") != std::string::npos);
  auto missing = to::pass_study(*pipeline, "bloom");
  REQUIRE(!missing);
  CHECK(missing.error().kind == ErrorKind::NotFound);
  CHECK(missing.error().message.find("shadow_map (shadow_map)") != std::string::npos);  // lists the passes
}
