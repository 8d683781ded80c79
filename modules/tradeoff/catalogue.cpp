// The catalogue: one study per registered feature, read from its descriptor (the knob table,
// the reference and why, the presets). A feature joins `weft tradeoff` and the stability
// sweep by being registered; nothing here names one.
module;
#include <deque>
#include <expected>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <nlohmann/json.hpp>
module weft.tradeoff;
import weft.core;
import weft.scene;
import weft.feature;
import weft.pipeline;

namespace weft::tradeoff {

namespace {

Study study_of(const FeatureDescriptor& d) {
  Study s;
  s.feature = d.name;
  s.material = d.name;
  s.passes = d.passes;
  s.knobs = d.knobs;
  s.reference = {.label = "reference", .group = "reference", .values = d.reference, .is_reference = true};
  s.reference_why = d.reference_why;
  s.cost = d.cost;
  s.grids = d.grids;
  s.environment = d.environment;
  s.preset_values = d.preset_values;
  s.clear_caches = d.clear_caches;
  s.descriptor = &d;
  return s;
}

}  // namespace

std::vector<const Study*> studies() {
  static std::mutex mutex;
  static std::deque<Study> known;  // deque: pointers stay valid as features are registered
  std::lock_guard lock(mutex);
  const auto registered = feature_registry().all();
  for (std::size_t i = known.size(); i < registered.size(); ++i) known.push_back(study_of(*registered[i]));
  std::vector<const Study*> out;
  for (const auto& s : known) out.push_back(&s);
  return out;
}

Result<const Study*> find_study(std::string_view feature) {
  auto descriptor = feature_registry().get(feature);
  if (!descriptor)
    return fail(ErrorKind::NotFound, "unknown feature '{}' for the trade-off study; known: {}", feature,
                feature_registry().names());
  for (const Study* s : studies())
    if (s->descriptor == *descriptor) return s;
  return fail(ErrorKind::Internal, "feature '{}' is registered but has no study", feature);
}

Result<Study> pass_study(const pipeline::Pipeline& pipeline, std::string_view pass) {
  const pipeline::PipelinePass* p = pipeline.find(pass);
  if (!p) {
    std::string names;
    for (const auto& q : pipeline.passes) names += (names.empty() ? "" : ", ") + q.name + " (" + q.type->name + ")";
    return fail(ErrorKind::NotFound, "{} has no pass '{}' to study; its passes: {}", pipeline.source, pass, names);
  }
  const pipeline::PassTypeDescriptor& type = *p->type;
  if (type.reference.empty())
    return fail(ErrorKind::InvalidArgument, "pass '{}' ({}) trades no accuracy for speed (its type names no reference "
                "setting), so there is nothing to study", pass, type.name);
  Study s;
  s.feature = weft::format("{} ({})", p->name, type.name);
  s.pass = p->name;
  s.passes = {p->name};
  for (const auto& o : type.options) {
    if (o.sweep.empty()) continue;
    Knob k{.name = o.name, .kind = o.kind, .min = o.min, .max = o.max, .choices = o.choices, .sweep = o.sweep,
           .meaning = o.meaning};
    s.knobs.push_back(std::move(k));
  }
  s.reference = {.label = "reference", .group = "reference", .values = type.reference, .is_reference = true};
  s.reference_why = type.reference_why;
  s.cost = CostAxis::Frame;
  return s;
}

Result<const Knob*> find_knob(const Study& study, std::string_view name) {
  if (const Knob* k = weft::find_knob(study.knobs, name)) return k;
  std::string known;
  for (const auto& k : study.knobs) known += (known.empty() ? "" : ", ") + k.name;
  return fail(ErrorKind::InvalidArgument, "{} has no knob '{}'; its knobs: {}", study.feature, name, known);
}

}  // namespace weft::tradeoff
