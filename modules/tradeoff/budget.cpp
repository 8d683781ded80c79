// Picking each feature's level to meet a frame-time budget at the least error, from a table
// a governor measured (tradeoff.cppm says what the model is).
module;
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>
module weft.tradeoff;
import weft.core;

namespace weft::tradeoff {

std::vector<Setting> budget_levels(const Study& study) {
  // A feature without preset_values follows the renderer's one quality: nothing to choose per feature.
  if (!study.preset_values) return {preset_setting(study, Quality::Medium)};
  std::vector<Setting> out;
  for (Quality q : {Quality::Low, Quality::Medium, Quality::High}) out.push_back(preset_setting(study, q));
  return out;
}

BudgetChoice evaluate(const BudgetTable& table, std::vector<std::size_t> level, double budget_ms) {
  BudgetChoice c;
  c.predicted_ms = table.base_ms;
  for (std::size_t f = 0; f < table.features.size(); ++f) {
    const auto& l = table.features[f].levels.at(level.at(f));
    c.predicted_ms += l.cost_ms;
    c.predicted_mse += l.mse;
  }
  c.level = std::move(level);
  c.fits = c.predicted_ms <= budget_ms;
  return c;
}

namespace {
// Better: fits and less error; among equal errors, less time.
bool better(const BudgetChoice& a, const BudgetChoice& b) {
  if (a.predicted_mse != b.predicted_mse) return a.predicted_mse < b.predicted_mse;
  return a.predicted_ms < b.predicted_ms;
}

std::vector<std::size_t> cheapest(const BudgetTable& table) { return std::vector<std::size_t>(table.features.size(), 0); }
}  // namespace

std::optional<BudgetChoice> step_down(const BudgetTable& table, const BudgetChoice& choice, double budget_ms) {
  std::optional<std::size_t> pick;
  double best_ratio = std::numeric_limits<double>::infinity();
  for (std::size_t f = 0; f < table.features.size(); ++f) {
    const std::size_t at = choice.level.at(f);
    if (at == 0) continue;
    const auto& now = table.features[f].levels[at];
    const auto& lower = table.features[f].levels[at - 1];
    const double saved = now.cost_ms - lower.cost_ms;
    const double added = lower.mse - now.mse;
    // Saving nothing is the worst trade; a level that saves time at no error is the best.
    const double ratio = saved > 0.0 ? added / saved : std::numeric_limits<double>::max();
    if (!pick || ratio < best_ratio) pick = f, best_ratio = ratio;
  }
  if (!pick) return std::nullopt;
  auto level = choice.level;
  --level[*pick];
  return evaluate(table, std::move(level), budget_ms);
}

BudgetChoice choose_within_budget(const BudgetTable& table, double budget_ms) {
  double combinations = 1.0;
  for (const auto& f : table.features) combinations *= double(std::max<std::size_t>(f.levels.size(), 1));
  for (const auto& f : table.features)
    if (f.levels.empty()) return evaluate(table, {}, budget_ms);  // nothing to choose: the caller's table is empty
  std::optional<BudgetChoice> best;
  if (combinations <= double(1u << 20)) {
    std::vector<std::size_t> level = cheapest(table);
    while (true) {
      auto c = evaluate(table, level, budget_ms);
      if (c.fits && (!best || better(c, *best))) best = std::move(c);
      std::size_t f = 0;  // the next combination, as an odometer
      for (; f < level.size(); ++f) {
        if (++level[f] < table.features[f].levels.size()) break;
        level[f] = 0;
      }
      if (f == level.size()) break;
    }
  } else {
    std::vector<std::size_t> top;
    for (const auto& f : table.features) top.push_back(f.levels.size() - 1);
    auto c = evaluate(table, std::move(top), budget_ms);
    while (!c.fits) {
      auto next = step_down(table, c, budget_ms);
      if (!next) break;
      c = std::move(*next);
    }
    if (c.fits) best = std::move(c);
  }
  if (best) return *best;
  return evaluate(table, cheapest(table), budget_ms);
}

}  // namespace weft::tradeoff
