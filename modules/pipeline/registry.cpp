// The process's pass-type registry (descriptors in a deque: pointers stay valid as types are
// added, e.g. by a plugin), the option helpers and a pass's slot bindings.
module;
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <deque>
#include <expected>
#include <memory>
#include <mutex>
#include <set>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <nlohmann/json.hpp>
module weft.pipeline;
import weft.core;

namespace weft::pipeline {

PassOption number_option(std::string name, double min, double max, double default_value, std::string meaning,
                         std::vector<nlohmann::json> sweep) {
  return {std::move(name), KnobKind::Number, min, max, {}, default_value, std::move(meaning), std::move(sweep)};
}
PassOption integer_option(std::string name, double min, double max, std::int64_t default_value, std::string meaning,
                          std::vector<nlohmann::json> sweep) {
  return {std::move(name), KnobKind::Integer, min, max, {}, default_value, std::move(meaning), std::move(sweep)};
}
PassOption boolean_option(std::string name, bool default_value, std::string meaning) {
  return {std::move(name), KnobKind::Boolean, 0, 1, {}, default_value, std::move(meaning)};
}
PassOption choice_option(std::string name, std::vector<std::string> choices, std::string default_value,
                         std::string meaning) {
  return {std::move(name), KnobKind::Choice, 0, 0, std::move(choices), std::move(default_value), std::move(meaning)};
}
PassOption with_extremes(PassOption option, std::optional<double> extreme_min, std::optional<double> extreme_max) {
  option.extreme_min = extreme_min;
  option.extreme_max = extreme_max;
  return option;
}
std::vector<nlohmann::json> extreme_values(const PassOption& o) {
  switch (o.kind) {
    case KnobKind::Integer:
      return {std::int64_t(o.extreme_min.value_or(o.min)), std::int64_t(o.extreme_max.value_or(o.max))};
    case KnobKind::Number: return {o.extreme_min.value_or(o.min), o.extreme_max.value_or(o.max)};
    case KnobKind::Boolean: return {false, true};
    case KnobKind::Choice: return {o.choices.begin(), o.choices.end()};
  }
  return {};
}

namespace {
// Options are read against their table before a pass sees them, so a missing or mistyped
// value here is a bug in the pass (it asked for an option its table does not have).
const nlohmann::json& option_value(const nlohmann::json& values, std::string_view name, bool (nlohmann::json::*is)() const) {
  const auto it = values.find(std::string(name));
  static const nlohmann::json none;
  if (it == values.end() || !((*it).*is)()) {
    log::error(weft::format("pass option '{}' was asked for but is not in the pass's options table", name));
    return none;
  }
  return *it;
}
}  // namespace

double PassOptions::number(std::string_view name) const {
  const auto& v = option_value(values_, name, &nlohmann::json::is_number);
  return v.is_number() ? v.get<double>() : 0.0;
}
std::int64_t PassOptions::integer(std::string_view name) const {
  const auto& v = option_value(values_, name, &nlohmann::json::is_number);
  return v.is_number() ? std::int64_t(std::llround(v.get<double>())) : 0;
}
bool PassOptions::boolean(std::string_view name) const {
  const auto& v = option_value(values_, name, &nlohmann::json::is_boolean);
  return v.is_boolean() && v.get<bool>();
}
std::string PassOptions::choice(std::string_view name) const {
  const auto& v = option_value(values_, name, &nlohmann::json::is_string);
  return v.is_string() ? v.get<std::string>() : std::string{};
}

bool operator==(const PassOptions& a, const PassOptions& b) { return a.values_ == b.values_; }

TextureHandle PassSlots::input(std::string_view slot) const {
  for (const auto& b : inputs_)
    if (b.slot == slot) return b.handle;
  return {};
}
TextureHandle PassSlots::target(std::string_view slot) const {
  for (const auto& b : targets_)
    if (b.slot == slot) return b.handle;
  return {};
}
void PassSlots::set_output(std::string_view slot, TextureHandle handle) {
  for (auto& b : outputs_)
    if (b.slot == slot) {
      b.handle = handle;
      return;
    }
  outputs_.push_back({std::string(slot), handle});
}
TextureHandle PassSlots::output(std::string_view slot) const {
  for (const auto& b : outputs_)
    if (b.slot == slot) return b.handle;
  return {};
}

const Slot* find_input(const PassTypeDescriptor& type, std::string_view slot) {
  for (const auto& s : type.inputs)
    if (s.name == slot) return &s;
  return nullptr;
}
const Slot* find_output(const PassTypeDescriptor& type, std::string_view slot) {
  for (const auto& s : type.outputs)
    if (s.name == slot) return &s;
  return nullptr;
}

struct PassTypeRegistry::State {
  mutable std::mutex mutex;
  std::deque<PassTypeDescriptor> types;
};

PassTypeRegistry::PassTypeRegistry() : state_(std::make_unique<State>()) {}
PassTypeRegistry::~PassTypeRegistry() = default;

namespace {
bool same_shape(const PassTypeDescriptor& a, const PassTypeDescriptor& b) {
  auto names = [](const auto& list) {
    std::vector<std::string> out;
    for (const auto& x : list) out.push_back(x.name);
    return out;
  };
  return a.create == b.create && names(a.inputs) == names(b.inputs) && names(a.outputs) == names(b.outputs) &&
         names(a.options) == names(b.options);
}

std::string check_descriptor(const PassTypeDescriptor& d) {
  const auto identifier = [](std::string_view s) {
    return !s.empty() && !std::isdigit(static_cast<unsigned char>(s[0])) &&
           std::all_of(s.begin(), s.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
  };
  if (!identifier(d.name)) return weft::format("pass type name '{}' must be letters, digits and '_'", d.name);
  if (!d.create) return weft::format("pass type '{}': the descriptor needs `create`", d.name);
  // An input and an output may share a name (a pass that updates "color"): a connection's
  // left side is always an output, its right side an input.
  for (const auto* list : {&d.inputs, &d.outputs}) {
    std::set<std::string> seen;
    for (const auto& slot : *list) {
      if (!identifier(slot.name)) return weft::format("pass type '{}': slot name '{}' must be letters, digits and '_'", d.name, slot.name);
      if (!seen.insert(slot.name).second) return weft::format("pass type '{}': slot '{}' is declared twice", d.name, slot.name);
      for (const gpu::Format f : slot.intended_formats)
        if (std::find(slot.formats.begin(), slot.formats.end(), f) == slot.formats.end())
          return weft::format("pass type '{}': slot '{}' is made for {}, which it does not accept (intended_formats "
                              "must be some of its formats)", d.name, slot.name, gpu::to_string(f));
    }
  }
  std::set<std::string> seen;
  for (const auto& out : d.outputs)
    if (!out.same_as.empty() && !find_input(d, out.same_as))
      return weft::format("pass type '{}': output '{}' is the same as input '{}', which it does not have", d.name, out.name,
                          out.same_as);
    else if (out.same_as.empty() && out.formats.size() != 1)
      return weft::format("pass type '{}': output '{}' needs exactly one format (or same_as an input)", d.name, out.name);
  for (const auto& o : d.options) {
    if (!seen.insert(o.name).second) return weft::format("pass type '{}': option '{}' is declared twice", d.name, o.name);
    const auto& v = o.default_value;
    bool ok = true;
    switch (o.kind) {
      case KnobKind::Number:
      case KnobKind::Integer: ok = v.is_number() && o.min <= o.max && v.get<double>() >= o.min && v.get<double>() <= o.max; break;
      case KnobKind::Boolean: ok = v.is_boolean(); break;
      case KnobKind::Choice:
        ok = v.is_string() && std::find(o.choices.begin(), o.choices.end(), v.get<std::string>()) != o.choices.end();
        break;
    }
    if (!ok) return weft::format("pass type '{}': option '{}' has a default outside its range or choices", d.name, o.name);
  }
  return {};
}
}  // namespace

Result<void> PassTypeRegistry::add(PassTypeDescriptor descriptor) {
  if (auto problem = check_descriptor(descriptor); !problem.empty()) return fail(ErrorKind::InvalidArgument, "{}", problem);
  std::lock_guard lock(state_->mutex);
  for (const auto& known : state_->types)
    if (known.name == descriptor.name) {
      if (same_shape(known, descriptor)) return {};
      return fail(ErrorKind::InvalidArgument, "pass type '{}' is registered already (by another descriptor)", descriptor.name);
    }
  state_->types.push_back(std::move(descriptor));
  return {};
}

const PassTypeDescriptor* PassTypeRegistry::find(std::string_view name) const {
  std::lock_guard lock(state_->mutex);
  for (const auto& d : state_->types)
    if (d.name == name) return &d;
  return nullptr;
}

std::vector<const PassTypeDescriptor*> PassTypeRegistry::all() const {
  std::lock_guard lock(state_->mutex);
  std::vector<const PassTypeDescriptor*> out;
  for (const auto& d : state_->types) out.push_back(&d);
  return out;
}

std::string PassTypeRegistry::names() const {
  std::string out;
  for (const auto* d : all()) out += (out.empty() ? "" : ", ") + d->name;
  return out.empty() ? "none" : out;
}

PassTypeRegistry& pass_type_registry() {
  static PassTypeRegistry registry;
  return registry;
}

}  // namespace weft::pipeline
