// Knob tables: building them, and reading a material field with its knob's range, so the
// range a scene file may give and the range a sweep explores are written once.
module;
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <nlohmann/json.hpp>
module weft.feature;
import weft.core;
import weft.scene;

namespace weft {

using json = nlohmann::json;

Knob integer_knob(std::string name, double min, double max, std::vector<json> sweep, std::string meaning) {
  return {std::move(name), KnobKind::Integer, min, max, {}, std::move(sweep), std::move(meaning)};
}
Knob number_knob(std::string name, double min, double max, std::vector<json> sweep, std::string meaning) {
  return {std::move(name), KnobKind::Number, min, max, {}, std::move(sweep), std::move(meaning)};
}
Knob boolean_knob(std::string name, std::string meaning) {
  return {std::move(name), KnobKind::Boolean, 0, 1, {}, {false, true}, std::move(meaning)};
}
Knob choice_knob(std::string name, std::vector<std::string> choices, std::string meaning) {
  std::vector<json> sweep(choices.begin(), choices.end());
  return {std::move(name), KnobKind::Choice, 0, 0, std::move(choices), std::move(sweep), std::move(meaning)};
}

Knob with_extremes(Knob knob, std::optional<double> extreme_min, std::optional<double> extreme_max) {
  knob.extreme_min = extreme_min;
  knob.extreme_max = extreme_max;
  return knob;
}

const Knob* find_knob(std::span<const Knob> knobs, std::string_view name) {
  for (const auto& k : knobs)
    if (k.name == name) return &k;
  return nullptr;
}

scene::Range knob_range(const Knob& knob) { return {.min = knob.min, .max = knob.max}; }

namespace {
std::string_view field_of(const Knob& knob) {
  const auto dot = knob.name.rfind('.');
  return dot == std::string::npos ? std::string_view(knob.name) : std::string_view(knob.name).substr(dot + 1);
}
}  // namespace

std::int64_t read_integer_knob(scene::JsonReader& reader, const Knob& knob, std::int64_t fallback) {
  return reader.integer(field_of(knob), fallback, knob_range(knob));
}

double read_number_knob(scene::JsonReader& reader, const Knob& knob, double fallback) {
  return reader.number(field_of(knob), fallback, knob_range(knob));
}

std::string read_choice_knob(scene::JsonReader& reader, const Knob& knob, std::string fallback) {
  const std::string_view field = field_of(knob);
  const nlohmann::json* value = reader.value(field);
  if (!value) return fallback;
  std::string list;
  for (const auto& c : knob.choices) list += (list.empty() ? "" : ", ") + c;
  if (!value->is_string()) {
    reader.error_at(field, weft::format("expected a string, got {}", scene::json_type_name(*value)));
    return fallback;
  }
  const auto text = value->get<std::string>();
  for (const auto& c : knob.choices)
    if (c == text) return text;
  reader.error_at(field, weft::format("'{}' is not one of: {}", text, list));
  return fallback;
}

std::string_view to_string(CostAxis axis) { return axis == CostAxis::Frame ? "frame" : "cold frame"; }

}  // namespace weft
