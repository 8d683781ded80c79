// The knobs the UI offers for a material: the feature's knob table and its preset values.
// One adapter, so that moving from weft.tradeoff's catalogue to the feature registry is an
// edit of this file alone.
module;
#include <algorithm>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>
module weft.viewer;
import weft.scene;
import weft.tradeoff;

namespace weft::viewer::detail {

std::string material_type_name(const scene::Material& material) { return std::string(scene::to_string(material.type)); }
bool is_standard(const scene::Material& material) { return material.type == scene::MaterialType::Standard; }

nlohmann::json reference_values(const scene::Material& material, std::string* why) {
  for (const auto& study : tradeoff::studies()) {
    if (study.material != material.type) continue;
    if (why) *why = study.reference_why;
    return study.reference.values;
  }
  return nullptr;
}

std::vector<UiKnob> knobs_for(const scene::Material& material, Quality quality) {
  std::vector<UiKnob> out;
  for (const auto& study : tradeoff::studies()) {
    if (study.material != material.type) continue;
    const nlohmann::json preset = study.preset_values ? study.preset_values(quality) : nlohmann::json::object();
    for (const auto& knob : study.knobs) {
      UiKnob k{knob.name, KnobKind(knob.kind), knob.min, knob.max, knob.choices, knob.meaning, nullptr};
      // Preset values are keyed by the knob's full name.
      if (preset.is_object() && preset.contains(knob.name)) k.preset = preset[knob.name];
      out.push_back(std::move(k));
    }
  }
  return out;
}

}  // namespace weft::viewer::detail
