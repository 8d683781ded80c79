// The knobs the UI offers for a material: its feature's knob table and preset values, read
// from the feature registry (weft.feature) — the table the material parser, `weft tradeoff`
// and the stability sweep read too.
module;
#include <algorithm>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>
module weft.viewer;
import weft.scene;
import weft.feature;

namespace weft::viewer::detail {

std::string material_type_name(const scene::Material& material) { return material.type; }
bool is_standard(const scene::Material& material) { return material.type == scene::standard_material; }

nlohmann::json reference_values(const scene::Material& material, std::string* why) {
  const FeatureDescriptor* feature = feature_registry().find(material.type);
  if (!feature) return nullptr;
  if (why) *why = feature->reference_why;
  return feature->reference;
}

std::vector<UiKnob> knobs_for(const scene::Material& material, Quality quality) {
  std::vector<UiKnob> out;
  const FeatureDescriptor* feature = feature_registry().find(material.type);
  if (!feature) return out;
  const nlohmann::json preset = feature->preset_values ? feature->preset_values(quality) : nlohmann::json::object();
  for (const auto& knob : feature->knobs) {
    UiKnob k{knob.name, KnobKind(knob.kind), knob.min, knob.max, knob.choices, knob.meaning, nullptr};
    // Preset values are keyed by the knob's full name.
    if (preset.is_object() && preset.contains(knob.name)) k.preset = preset[knob.name];
    out.push_back(std::move(k));
  }
  return out;
}

}  // namespace weft::viewer::detail
