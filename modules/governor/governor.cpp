// The measuring half of the budget governor: renders the scene with one feature at a time
// moved off its cheapest level, fills weft.tradeoff's table and checks the choice by rendering it.
module;
#include <algorithm>
#include <chrono>
#include <cmath>
#include <expected>
#include <string>
#include <string_view>
#include <vector>
#include "weft/try.h"
module weft.governor;
import weft.core;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.tradeoff;

namespace weft::governor {

namespace to = weft::tradeoff;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

struct Timed {
  double ms = 0.0;
  renderer::Frame frame;
};

// One untimed frame (bakes, uploads, pipelines), then the median of `frames` timed ones.
Result<Timed> time_frames(renderer::Renderer& r, const scene::Scene& scene, const renderer::RenderOptions& options,
                          unsigned frames) {
  auto first = r.render(scene, options);
  if (!first) return std::unexpected(first.error());
  Timed out{.frame = std::move(*first)};
  std::vector<double> ms;
  for (unsigned i = 0; i < frames; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    auto f = r.render(scene, options);
    if (!f) return std::unexpected(f.error());
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    out.frame = std::move(*f);
  }
  out.ms = median(std::move(ms));
  return out;
}

Result<double> mse(const image::Image8& a, const image::Image8& b) {
  WEFT_TRY(auto e, to::compare(a, b, to::full_mask(a.width, a.height)));
  return e.rmse * e.rmse;
}

}  // namespace

Result<scene::Scene> apply_choice(const scene::Scene& scene, const to::BudgetTable& table, const to::BudgetChoice& choice) {
  scene::Scene out = scene;
  for (std::size_t f = 0; f < table.features.size(); ++f) {
    const auto& feature = table.features[f];
    WEFT_TRY_VOID(to::apply_setting(out, *feature.study, feature.levels.at(choice.level.at(f)).setting));
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> BudgetResult::chosen() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (std::size_t f = 0; f < table.features.size(); ++f)
    out.emplace_back(table.features[f].study->feature, table.features[f].levels.at(choice.level.at(f)).setting.label);
  return out;
}

std::string BudgetResult::summary(double budget_ms) const {
  std::string text;
  for (const auto& [feature, level] : chosen()) text += (text.empty() ? "" : ", ") + feature + "=" + level;
  if (text.empty()) text = "no feature to choose for";
  text += weft::format(": {:.0f} ms measured for a {:.0f} ms budget", measured_ms, budget_ms);
  if (!met) {
    const bool cheapest = std::all_of(choice.level.begin(), choice.level.end(), [](std::size_t l) { return l == 0; });
    text += cheapest ? " (cannot be met: every feature is at its cheapest level)" : " (over the budget)";
  }
  return text;
}

Result<BudgetResult> fit_budget(renderer::Renderer& r, const scene::Scene& scene, const renderer::RenderOptions& options,
                                const BudgetOptions& budget) {
  if (!std::isfinite(budget.budget_ms) || budget.budget_ms <= 0.0)
    return fail(ErrorKind::InvalidArgument, "the frame-time budget must be a positive number of milliseconds, got {}",
                budget.budget_ms);
  const unsigned frames = std::max(budget.frames, 1u);
  BudgetResult result;
  auto note = [&](std::string what, double ms) {
    if (budget.progress)
      budget.progress(weft::format("[budget {}] {}: {:.1f} ms", result.measurements.size() + 1, what, ms));
    result.measurements.push_back({std::move(what), ms});
  };
  for (const to::Study* study : to::studies()) {
    if (!to::scene_uses(scene, study->material)) continue;
    to::BudgetFeature feature{.study = study};
    for (auto& setting : to::budget_levels(*study)) feature.levels.push_back({.setting = std::move(setting)});
    result.table.features.push_back(std::move(feature));
  }
  auto& table = result.table;
  const to::BudgetChoice cheapest = to::evaluate(table, std::vector<std::size_t>(table.features.size(), 0), budget.budget_ms);
  WEFT_TRY(auto base_scene, apply_choice(scene, table, cheapest));
  WEFT_TRY(auto base, time_frames(r, base_scene, options, frames));
  table.base_ms = base.ms;
  note("every feature at its cheapest level", base.ms);

  // Each feature alone off its cheapest level; its error against its own best level.
  for (std::size_t f = 0; f < table.features.size(); ++f) {
    auto& feature = table.features[f];
    std::vector<image::Image8> images{base.frame.image};
    for (std::size_t l = 1; l < feature.levels.size(); ++l) {
      auto level = cheapest.level;
      level[f] = l;
      WEFT_TRY(auto s, apply_choice(scene, table, to::evaluate(table, level, budget.budget_ms)));
      WEFT_TRY(auto t, time_frames(r, s, options, frames));
      feature.levels[l].cost_ms = std::max(0.0, t.ms - base.ms);
      note(weft::format("{}: {}", feature.study->feature, feature.levels[l].setting.label), t.ms);
      images.push_back(std::move(t.frame.image));
    }
    for (std::size_t l = 0; l + 1 < feature.levels.size(); ++l) {
      WEFT_TRY(feature.levels[l].mse, mse(images[l], images.back()));
    }
  }

  result.predicted = to::choose_within_budget(table, budget.budget_ms);
  result.choice = result.predicted;
  // The model is additive and measured under whatever else the machine is doing: render the
  // choice and step down while its frame is over the budget.
  while (true) {
    WEFT_TRY(result.scene, apply_choice(scene, table, result.choice));
    WEFT_TRY(auto t, time_frames(r, result.scene, options, frames));
    note("chosen", t.ms);
    result.measured_ms = t.ms;
    result.frame = std::move(t.frame);
    result.met = t.ms <= budget.budget_ms;
    if (result.met) break;
    auto lower = to::step_down(table, result.choice, budget.budget_ms);
    if (!lower) break;
    result.choice = std::move(*lower);
  }
  return result;
}

}  // namespace weft::governor
