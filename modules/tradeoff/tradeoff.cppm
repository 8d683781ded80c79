// weft.tradeoff — the speed/accuracy study of the features (`weft tradeoff`, docs/tradeoffs.md):
// which quality knobs each feature has and what its reference is (read from the feature
// registry: each feature's descriptor is its catalogue entry), the settings a sweep renders, error against the reference
// over the feature's pixels, the Pareto front, and the CSV / SVG / markdown reports.
//
// Nothing here touches a GPU: the `weft tradeoff` command renders the settings with the
// renderer and hands the measurements back to this module, so the planning, the metrics
// and the reports are unit-tested without a device.
//
// A knob is a field of the feature's material in the scene file ("layers", "lut.size"), so
// a setting is applied by writing values into every material of the feature's type and the
// renderer and the feature see an ordinary scene: what the study measures is what a user
// gets by writing the same values into the scene file.
module;
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <nlohmann/json.hpp>
export module weft.tradeoff;
import weft.core;
import weft.image;
import weft.scene;
import weft.feature;
import weft.pipeline;

export namespace weft::tradeoff {

// ---- knobs and studies ---------------------------------------------------------------------
// The knob table is the feature's own (weft.feature's FeatureDescriptor); a study is the
// descriptor seen by the sweep.
using weft::CostAxis;
using weft::Knob;
using weft::KnobKind;
using weft::to_string;

// One point of a sweep: a quality preset and knob values written into the feature's materials.
struct Setting {
  std::string label;                          // "layers=32", "preset low", "reference"
  std::string group;                          // "preset", "reference", "default", or the knob's name
  Quality quality = Quality::Medium;
  nlohmann::json values = nlohmann::json::object();  // knob name -> value
  bool strip_knobs = false;  // presets: remove every knob from the materials, so the preset decides
  bool is_reference = false;
  std::optional<Quality> preset;              // set on the rows that are a preset
};

struct Study {
  std::string feature;                        // the feature's name, also its --feature and material type
  std::string material;                       // the material type the study writes into
  std::vector<std::string> passes;           // the feature's graph passes ("shell_fur"), for their GPU time
  std::vector<Knob> knobs;
  Setting reference;                          // the most accurate setting the feature has
  std::string reference_why;                  // one line; the feature's doc says more
  CostAxis cost = CostAxis::Frame;
  std::vector<std::pair<std::string, std::string>> grids;
  std::vector<std::pair<std::string, std::string>> environment;
  nlohmann::json (*preset_values)(Quality) = nullptr;
  void (*clear_caches)() = nullptr;
  const FeatureDescriptor* descriptor = nullptr;  // where all of this comes from
  // A study of a pipeline pass's options (pass_study) instead of a feature's materials: the
  // pass it sets options on; the settings go into the pipeline, not the scene.
  std::string pass;
};

// One study per registered feature (weft::feature_registry()), in registration order.
// Pointers stay valid; features registered later are added on the next call.
std::vector<const Study*> studies();
// By the feature's name or alias; NotFound naming the registered features otherwise.
Result<const Study*> find_study(std::string_view feature);
Result<const Knob*> find_knob(const Study& study, std::string_view name);
// The study of one pass of a pipeline (`weft tradeoff --pass NAME`): the options of its type
// that have sweep values, as knobs; its type's reference; no quality presets (a preset would
// change every feature too); the whole frame as its pixels. NotFound when the pipeline has no
// such pass (naming its passes); InvalidArgument when its type has no reference (the pass
// trades no accuracy for speed, as an effect such as bloom).
Result<Study> pass_study(const pipeline::Pipeline& pipeline, std::string_view pass);
// The pipeline with a setting of a pass study applied: the study's options back to their
// defaults when the setting strips knobs, then the setting's values (checked as the pipeline
// reader checks them).
Result<pipeline::Pipeline> apply_pass_setting(const pipeline::Pipeline& pipeline, const Study& study,
                                              const Setting& setting);

// "layers=1,2,4" -> the knob and its values, each checked against the knob (type, range,
// choices); InvalidArgument naming the knob and the value otherwise.
struct KnobValues {
  const Knob* knob = nullptr;
  std::vector<nlohmann::json> values;
};
Result<KnobValues> parse_knob_values(const Study& study, std::string_view text);
Result<nlohmann::json> parse_knob_value(const Knob& knob, std::string_view text);
Result<void> check_knob_value(const Knob& knob, const nlohmann::json& value);
std::string value_text(const nlohmann::json& value);  // 32, 0.35, true, adaptive

// ---- settings --------------------------------------------------------------------------------
// The settings a sweep renders, the reference first: the four presets, each knob's sweep
// one at a time around the medium preset (its values replaced by `overrides`), the grids;
// duplicates (same quality and values) are rendered once under the first label.
// A quality preset as the feature's knob values (the renderer's quality itself for a feature
// without preset_values).
Setting preset_setting(const Study& study, Quality quality);
std::vector<Setting> plan_sweep(const Study& study, std::span<const KnobValues> overrides = {});
// The same plan followed by every combination of the `crossed` knobs' values (the knobs not
// crossed left to the medium preset), group "a x b x ...", duplicates dropped as above.
std::vector<Setting> plan_sweep(const Study& study, std::span<const KnobValues> overrides,
                                std::span<const KnobValues> crossed);
// The stability sweep: the minimum and maximum of each knob (every choice, both booleans),
// one at a time on top of `base`, plus the reference.
std::vector<Setting> extreme_settings(const Study& study, const nlohmann::json& base = nlohmann::json::object());

// Writes the setting into every material of the study's type (removing the knobs first
// when the setting strips them). InvalidArgument when the scene has no such material.
Result<void> apply_setting(scene::Scene& scene, const Study& study, const Setting& setting);
bool scene_uses(const scene::Scene& scene, std::string_view material_type);

// ---- measuring -------------------------------------------------------------------------------
// The pixels the feature covers: where `covered_a` and `covered_b` (the feature's objects
// drawn as two different flat colours) differ, or where any of `renders` differs from
// `reference`. One byte per pixel, 1 = covered.
struct Mask {
  std::uint32_t width = 0, height = 0;
  std::vector<std::uint8_t> covered;
  [[nodiscard]] std::size_t count() const;
};
Result<Mask> coverage_mask(const image::Image8& covered_a, const image::Image8& covered_b,
                           std::span<const image::Image8* const> renders, const image::Image8& reference);
Mask full_mask(std::uint32_t width, std::uint32_t height);

struct ImageError {
  double rmse = 0.0;      // linear RGB (sRGB decoded) over the mask's pixels
  double relative_rmse = 0.0;  // rmse / the reference's RMS over the same pixels (0 when the reference is black)
  double psnr_db = 0.0;   // from that RMSE, peak 1; +inf when identical
  double ssim = 1.0;      // weft.image's SSIM over the mask's bounding box
  double max_diff = 0.0;  // largest linear difference in the mask
  std::size_t pixels = 0;
};
Result<ImageError> compare(const image::Image8& render, const image::Image8& reference, const Mask& mask);

// ---- the frame-time budget -------------------------------------------------------------------
// A governor (weft.governor) measures, at the current camera on this adapter, what each of the
// scene's features costs at each of its levels (its quality presets, cheapest first) and how
// far each level is from the feature's best level; this part picks the levels, and is tested
// without a device.
//
// The model: frame time = base + the sum of each feature's cost, where base is the frame with
// every feature at its cheapest level and a feature's cost at a level is the frame with that
// feature there and the others cheapest, minus base. A level's error is the mean squared
// difference (linear RGB, whole frame) from the same frame with the feature at its best level;
// the frame's error is the sum over features (their pixels mostly differ, so squared errors add).
struct BudgetLevel {
  Setting setting;       // what apply_setting writes into the feature's materials
  double cost_ms = 0.0;  // over base (the cheapest level's is 0)
  double mse = 0.0;      // against the feature's best level (the best level's is 0)
};
struct BudgetFeature {
  const Study* study = nullptr;
  std::vector<BudgetLevel> levels;  // cheapest first
};
struct BudgetTable {
  double base_ms = 0.0;
  std::vector<BudgetFeature> features;
};
struct BudgetChoice {
  std::vector<std::size_t> level;  // per feature of the table
  double predicted_ms = 0.0;
  double predicted_mse = 0.0;
  bool fits = false;  // predicted_ms <= the budget; false: every feature at its cheapest level
};
// The levels a governor chooses among: the feature's low, medium and high presets (reference
// settings can take minutes, e.g. skin's brute-force integration, so they are not offered); one
// level for a feature without preset_values (it follows the renderer's quality).
std::vector<Setting> budget_levels(const Study& study);
// The least predicted error whose predicted time is within the budget (every combination when
// there are at most 2^20 of them, else greedy steps down from the best levels); when none
// fits, every feature at its cheapest level, fits = false.
BudgetChoice choose_within_budget(const BudgetTable& table, double budget_ms);
// One level cheaper for the feature that gives up the least error per millisecond saved;
// nothing when every feature is already at its cheapest level. For when the measured frame
// of a choice is over the budget that its prediction met.
std::optional<BudgetChoice> step_down(const BudgetTable& table, const BudgetChoice& choice, double budget_ms);
BudgetChoice evaluate(const BudgetTable& table, std::vector<std::size_t> level, double budget_ms);

// ---- results and reports -----------------------------------------------------------------------
// Times are medians over the steady frames (those after the first).
struct Row {
  Setting setting;
  double frame_ms = 0.0;        // the steady frame's cost: gpu_ms on a GPU, process_cpu_ms on a CPU adapter
  double gpu_ms = 0.0;          // GPU timestamps, first pass to last
  double feature_gpu_ms = 0.0;  // GPU timestamps of the feature's own passes
  double process_cpu_ms = 0.0;  // CPU time of the process (every thread) per frame
  double wall_ms = 0.0;         // CPU wall clock: record + submit + wait (FrameStats::cpu_frame_ms)
  double cold_frame_ms = 0.0;   // wall time of the first frame with empty caches (bakes included)
  ImageError error;
  bool pareto = false;
  // Farm tasks (weft.farm) also render a baseline setting alternately with this one: the
  // median of this frame's cost over the baseline's (comparable across nodes), and the node.
  // NaN / empty for a serial run; the CSV and markdown get these columns only when set.
  double cost_ratio = std::numeric_limits<double>::quiet_NaN();
  std::string node;
  [[nodiscard]] double cost(CostAxis axis) const { return axis == CostAxis::Frame ? frame_ms : cold_frame_ms; }
};

struct Point {
  double cost = 0.0, error = 0.0;
};
// Indices of the points no other point dominates (no more cost and no more error, and less
// of one), sorted by cost then error. Points equal in both are all kept.
std::vector<std::size_t> pareto_front(std::span<const Point> points);
// Marks rows[i].pareto by cost(axis) against RMSE; the reference row (error 0) is on it.
void mark_pareto(std::span<Row> rows, CostAxis axis);

struct ReportInfo {
  std::string feature, scene, command, device;
  std::uint32_t width = 0, height = 0, frames = 0;
  CostAxis cost = CostAxis::Frame;
  std::string frame_clock;  // what frame_ms is: GPU timestamps, or process CPU time
  std::string mask_note;  // "1234 of 20000 pixels (the feature's coverage)"
};
// RFC 4180: quotes a field holding a comma, a quote, CR or LF, doubling the quotes.
std::string csv_field(std::string_view field);
std::string csv(std::span<const Row> rows, const ReportInfo& info);
std::string markdown(std::span<const Row> rows, const ReportInfo& info);
// Error (RMSE) against cost, log axes, the Pareto front joined and labelled, presets drawn
// as labelled squares, the reference as a vertical line (its error is zero).
std::string svg(std::span<const Row> rows, const ReportInfo& info);
// XML text escaping for labels (&, <, >, ", ').
std::string xml_escape(std::string_view text);

}  // namespace weft::tradeoff
