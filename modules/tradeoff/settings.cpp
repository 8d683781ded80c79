// Knob values from the command line, the settings a sweep renders, and writing a setting
// into the scene's materials.
module;
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <expected>
#include <set>
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

using json = nlohmann::json;

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view s, char separator) {
  std::vector<std::string_view> parts;
  for (;;) {
    const auto at = s.find(separator);
    parts.push_back(trim(s.substr(0, at)));
    if (at == std::string_view::npos) return parts;
    s.remove_prefix(at + 1);
  }
}

std::string range_text(const Knob& knob) {
  switch (knob.kind) {
    case KnobKind::Integer: return weft::format("an integer in [{}, {}]", knob.min, knob.max);
    case KnobKind::Number: return weft::format("a number in [{}, {}]", knob.min, knob.max);
    case KnobKind::Boolean: return "true or false";
    case KnobKind::Choice: {
      std::string s = "one of:";
      for (const auto& c : knob.choices) s += " " + c;
      return s;
    }
  }
  return "?";
}

// The material field at a dotted path: "lut.size" -> params["lut"]["size"].
std::vector<std::string> path_of(std::string_view name) {
  std::vector<std::string> keys;
  for (auto part : split(name, '.')) keys.emplace_back(part);
  return keys;
}

void set_at(json& params, std::string_view name, const json& value) {
  json* node = &params;
  const auto keys = path_of(name);
  for (std::size_t i = 0; i + 1 < keys.size(); ++i) {
    json& child = (*node)[keys[i]];
    if (!child.is_object()) child = json::object();
    node = &child;
  }
  (*node)[keys.back()] = value;
}

void erase_at(json& params, std::string_view name) {
  json* node = &params;
  const auto keys = path_of(name);
  for (std::size_t i = 0; i + 1 < keys.size(); ++i) {
    if (!node->is_object() || !node->contains(keys[i])) return;
    node = &(*node)[keys[i]];
  }
  if (node->is_object()) node->erase(keys.back());
}

std::string setting_key(const Setting& s) {
  return weft::format("{}|{}|{}", int(s.quality), s.strip_knobs, s.values.dump());
}

std::string label_of(const json& values) {
  std::string label;
  for (const auto& [k, v] : values.items()) label += (label.empty() ? "" : " ") + k + "=" + value_text(v);
  return label;
}

}  // namespace

std::string value_text(const json& value) {
  if (value.is_string()) return value.get<std::string>();
  if (value.is_number_float()) return weft::format("{}", value.get<double>());
  return value.dump();
}

Result<void> check_knob_value(const Knob& knob, const json& value) {
  const auto bad = [&] {
    return fail(ErrorKind::InvalidArgument, "knob '{}': {} is not {}", knob.name, value.dump(), range_text(knob));
  };
  switch (knob.kind) {
    case KnobKind::Integer:
      if (!value.is_number_integer()) return bad();
      if (double(value.get<std::int64_t>()) < knob.min || double(value.get<std::int64_t>()) > knob.max) return bad();
      return {};
    case KnobKind::Number: {
      if (!value.is_number()) return bad();
      const double v = value.get<double>();
      if (!std::isfinite(v) || v < knob.min || v > knob.max) return bad();
      return {};
    }
    case KnobKind::Boolean:
      if (!value.is_boolean()) return bad();
      return {};
    case KnobKind::Choice:
      if (!value.is_string() ||
          std::find(knob.choices.begin(), knob.choices.end(), value.get<std::string>()) == knob.choices.end())
        return bad();
      return {};
  }
  return bad();
}

Result<json> parse_knob_value(const Knob& knob, std::string_view text) {
  text = trim(text);
  const auto bad = [&](std::string_view why) {
    return fail(ErrorKind::InvalidArgument, "knob '{}': '{}' {}; expected {}", knob.name, text, why, range_text(knob));
  };
  if (text.empty()) return bad("is empty");
  json value;
  switch (knob.kind) {
    case KnobKind::Integer: {
      std::int64_t v = 0;
      const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
      if (ec != std::errc{} || end != text.data() + text.size()) return bad("is not an integer");
      value = v;
      break;
    }
    case KnobKind::Number: {
      const std::string s(text);
      char* end = nullptr;
      const double v = std::strtod(s.c_str(), &end);
      if (end != s.c_str() + s.size() || !std::isfinite(v)) return bad("is not a finite number");
      value = v;
      break;
    }
    case KnobKind::Boolean:
      if (text == "true" || text == "on" || text == "1")
        value = true;
      else if (text == "false" || text == "off" || text == "0")
        value = false;
      else
        return bad("is not a boolean");
      break;
    case KnobKind::Choice: value = std::string(text); break;
  }
  if (auto ok = check_knob_value(knob, value); !ok) return bad("is out of range");
  return value;
}

Result<KnobValues> parse_knob_values(const Study& study, std::string_view text) {
  const auto eq = text.find('=');
  if (eq == std::string_view::npos)
    return fail(ErrorKind::InvalidArgument, "'{}': expected KNOB=V1,V2,... (e.g. {}=1,2,4)", text,
                study.knobs.empty() ? std::string("knob") : study.knobs.front().name);
  auto knob = find_knob(study, trim(text.substr(0, eq)));
  if (!knob) return std::unexpected(knob.error());
  KnobValues out{*knob, {}};
  for (auto part : split(text.substr(eq + 1), ',')) {
    auto v = parse_knob_value(**knob, part);
    if (!v) return std::unexpected(v.error());
    out.values.push_back(std::move(*v));
  }
  return out;
}

std::vector<Setting> plan_sweep(const Study& study, std::span<const KnobValues> overrides) {
  auto sweep_of = [&](const Knob& knob) {
    for (const auto& o : overrides)
      if (o.knob && o.knob->name == knob.name) return o.values;
    return knob.sweep;
  };
  std::vector<Setting> plan;
  std::set<std::string> seen;
  auto add = [&](Setting s) {
    if (seen.insert(setting_key(s)).second) plan.push_back(std::move(s));
  };
  Setting reference = study.reference;
  reference.strip_knobs = true;
  reference.is_reference = true;
  add(reference);
  // A preset as the feature's knob values at the renderer's medium quality, so the rows differ
  // only in the feature (--quality also changes the renderer's shadow map resolution); a
  // feature without preset_values is rendered at the quality itself.
  if (study.pass.empty())  // a pass study has no presets: a quality preset changes every feature too
    for (Quality q : {Quality::Low, Quality::Medium, Quality::High, Quality::Reference}) add(preset_setting(study, q));
  std::set<std::string> in_grid;
  for (const auto& [a, b] : study.grids) {
    auto ka = find_knob(study, a), kb = find_knob(study, b);
    if (!ka || !kb) continue;
    in_grid.insert(a);
    in_grid.insert(b);
    for (const auto& va : sweep_of(**ka))
      for (const auto& vb : sweep_of(**kb)) {
        const json values = {{a, va}, {b, vb}};
        add({.label = label_of(values), .group = a + " x " + b, .values = values, .strip_knobs = true});
      }
  }
  for (const auto& knob : study.knobs) {
    if (in_grid.contains(knob.name)) continue;
    for (const auto& v : sweep_of(knob)) {
      const json values = {{knob.name, v}};
      add({.label = label_of(values), .group = knob.name, .values = values, .strip_knobs = true});
    }
  }
  return plan;
}

std::vector<Setting> plan_sweep(const Study& study, std::span<const KnobValues> overrides,
                                std::span<const KnobValues> crossed) {
  std::vector<Setting> plan = plan_sweep(study, overrides);
  std::set<std::string> seen;
  for (const auto& s : plan) seen.insert(setting_key(s));
  std::vector<const KnobValues*> knobs;
  std::string group;
  for (const auto& c : crossed)
    if (c.knob && !c.values.empty()) {
      knobs.push_back(&c);
      group += (group.empty() ? "" : " x ") + c.knob->name;
    }
  if (knobs.empty()) return plan;
  std::vector<std::size_t> at(knobs.size(), 0);
  for (;;) {
    json values = json::object();
    for (std::size_t k = 0; k < knobs.size(); ++k) values[knobs[k]->knob->name] = knobs[k]->values[at[k]];
    Setting s{.label = label_of(values), .group = group, .values = values, .strip_knobs = true};
    if (seen.insert(setting_key(s)).second) plan.push_back(std::move(s));
    std::size_t k = knobs.size();
    while (k > 0 && ++at[k - 1] == knobs[k - 1]->values.size()) at[--k] = 0;
    if (k == 0) break;
  }
  return plan;
}

Setting preset_setting(const Study& study, Quality q) {
  Setting s{.label = weft::format("preset {}", to_string(q)), .group = "preset", .strip_knobs = true, .preset = q};
  if (study.preset_values)
    s.values = study.preset_values(q);
  else
    s.quality = q;
  return s;
}

std::vector<Setting> extreme_settings(const Study& study, const json& base) {
  std::vector<Setting> out;
  auto with = [&](const json& extra) {
    json values = base.is_object() ? base : json::object();
    for (const auto& [k, v] : extra.items()) values[k] = v;
    return values;
  };
  Setting reference = study.reference;
  reference.values = with(study.reference.values);
  reference.strip_knobs = true;
  reference.is_reference = true;
  out.push_back(reference);
  for (const auto& knob : study.knobs) {
    std::vector<json> extremes;
    switch (knob.kind) {
      case KnobKind::Integer:
        extremes = {std::int64_t(knob.extreme_min.value_or(knob.min)), std::int64_t(knob.extreme_max.value_or(knob.max))};
        break;
      case KnobKind::Number: extremes = {knob.extreme_min.value_or(knob.min), knob.extreme_max.value_or(knob.max)}; break;
      case KnobKind::Boolean: extremes = {false, true}; break;
      case KnobKind::Choice: extremes.assign(knob.choices.begin(), knob.choices.end()); break;
    }
    for (const auto& v : extremes) {
      const json one = {{knob.name, v}};
      out.push_back({.label = label_of(one), .group = knob.name, .values = with(one), .strip_knobs = true});
    }
  }
  return out;
}

bool scene_uses(const scene::Scene& scene, std::string_view type) {
  return std::any_of(scene.materials.begin(), scene.materials.end(),
                     [&](const scene::Material& m) { return m.type == type; });
}

Result<pipeline::Pipeline> apply_pass_setting(const pipeline::Pipeline& pipeline, const Study& study,
                                              const Setting& setting) {
  const pipeline::PipelinePass* p = pipeline.find(study.pass);
  if (!p) return fail(ErrorKind::NotFound, "{} has no pass '{}' for the {} study", pipeline.source, study.pass, study.feature);
  json values = json::object();
  if (setting.strip_knobs) {
    for (const auto& knob : study.knobs)
      for (const auto& o : p->type->options)
        if (o.name == knob.name) values[o.name] = o.default_value;
    for (const auto& [name, value] : study.reference.values.items())
      for (const auto& o : p->type->options)
        if (o.name == name) values[o.name] = o.default_value;
  }
  for (const auto& [name, value] : setting.values.items()) values[name] = value;
  return pipeline::with_options(pipeline, study.pass, values);
}

Result<void> apply_setting(scene::Scene& scene, const Study& study, const Setting& setting) {
  if (!study.pass.empty()) return {};  // a pass study's settings go into the pipeline (apply_pass_setting)
  if (!scene_uses(scene, study.material))
    return fail(ErrorKind::InvalidArgument, "the scene has no '{}' material, so there is nothing for the {} study to sweep",
                study.material, study.feature);
  for (auto& material : scene.materials) {
    if (material.type != study.material) continue;
    if (!material.params.is_object()) material.params = json::object();
    if (setting.strip_knobs) {  // the knobs and the reference's fields: the setting alone decides
      for (const auto& knob : study.knobs) erase_at(material.params, knob.name);
      for (const auto& [name, value] : study.reference.values.items()) erase_at(material.params, name);
    }
    for (const auto& [name, value] : setting.values.items()) set_at(material.params, name, value);
  }
  return {};
}

}  // namespace weft::tradeoff
