// weft.governor — a frame-time budget: on this adapter, at the scene's camera and size, it
// measures what each of the scene's features costs at each of its levels and how far each is
// from the feature's best, picks the levels with the least error that fit the budget
// (weft.tradeoff), then renders the choice and steps down until the measured frame fits.
module;
#include <functional>
#include <string>
#include <string_view>
#include <vector>
export module weft.governor;
import weft.core;
import weft.scene;
import weft.renderer;
import weft.tradeoff;

export namespace weft::governor {

struct BudgetOptions {
  double budget_ms = 0.0;
  unsigned frames = 3;  // timed frames per measurement (median), after one untimed frame
  std::function<void(std::string_view)> progress;  // one line per measurement
};

struct Measurement {
  std::string what;      // "shell_fur: preset high", "chosen"
  double frame_ms = 0.0;  // median wall time of Renderer::render (record, submit, wait, read back)
};

struct BudgetResult {
  tradeoff::BudgetTable table;
  tradeoff::BudgetChoice predicted;  // the table's choice
  tradeoff::BudgetChoice choice;     // after stepping down while the measured frame was over
  double measured_ms = 0.0;          // the final choice's frame
  bool met = false;                  // measured_ms <= budget_ms
  scene::Scene scene;                // the scene with the chosen levels written in
  renderer::Frame frame;             // its last measured frame
  std::vector<Measurement> measurements;
  // "shell_fur=preset high, skin_sss=preset low: 412 ms measured for a 500 ms budget"
  [[nodiscard]] std::string summary(double budget_ms) const;
  // name -> level label, per feature of the table
  [[nodiscard]] std::vector<std::pair<std::string, std::string>> chosen() const;
};

// InvalidArgument for a budget that is not a positive finite number. A scene with no feature
// material is measured once and meets the budget or not.
Result<BudgetResult> fit_budget(renderer::Renderer& renderer, const scene::Scene& scene,
                                const renderer::RenderOptions& options, const BudgetOptions& budget);

// The scene with each feature of the table at the choice's level.
Result<scene::Scene> apply_choice(const scene::Scene& scene, const tradeoff::BudgetTable& table,
                                  const tradeoff::BudgetChoice& choice);

}  // namespace weft::governor
