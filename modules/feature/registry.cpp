// The process's feature registry: descriptors in a deque (pointers stay valid as features
// are added), guarded by a mutex so a viewer thread may read while a plugin registers.
module;
#include <algorithm>
#include <deque>
#include <expected>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
module weft.feature;
import weft.core;
import weft.scene;

namespace weft {

struct FeatureRegistry::State {
  mutable std::mutex mutex;
  std::deque<FeatureDescriptor> features;
};

FeatureRegistry::FeatureRegistry() : state_(std::make_unique<State>()) {}
FeatureRegistry::~FeatureRegistry() = default;

namespace {
bool answers_to(const FeatureDescriptor& d, std::string_view name) {
  return d.name == name || std::find(d.aliases.begin(), d.aliases.end(), name) != d.aliases.end();
}
}  // namespace

Result<void> FeatureRegistry::add(FeatureDescriptor descriptor) {
  if (descriptor.name.empty()) return fail(ErrorKind::InvalidArgument, "a feature descriptor needs a name");
  if (!descriptor.create || !descriptor.check_material)
    return fail(ErrorKind::InvalidArgument, "feature '{}': the descriptor needs `create` and `check_material`",
                descriptor.name);
  for (const auto& knob : descriptor.knobs)
    if (knob.kind == KnobKind::Choice ? knob.choices.empty() : !(knob.min <= knob.max))
      return fail(ErrorKind::InvalidArgument, "feature '{}': knob '{}' has no values (empty choices or min > max)",
                  descriptor.name, knob.name);
  std::lock_guard lock(state_->mutex);
  for (const auto& known : state_->features) {
    if (known.name == descriptor.name && known.aliases == descriptor.aliases) return {};
    for (const auto& n : descriptor.aliases)
      if (answers_to(known, n)) return fail(ErrorKind::InvalidArgument, "feature '{}': the name '{}' is taken by '{}'",
                                            descriptor.name, n, known.name);
    if (answers_to(known, descriptor.name))
      return fail(ErrorKind::InvalidArgument, "feature '{}': the name is taken by '{}'", descriptor.name, known.name);
  }
  if (auto ok = scene::register_material_type(descriptor.name, descriptor.aliases); !ok) return ok;
  state_->features.push_back(std::move(descriptor));
  return {};
}

const FeatureDescriptor* FeatureRegistry::find(std::string_view name) const {
  std::lock_guard lock(state_->mutex);
  for (const auto& d : state_->features)
    if (answers_to(d, name)) return &d;
  return nullptr;
}

Result<const FeatureDescriptor*> FeatureRegistry::get(std::string_view name) const {
  if (const auto* d = find(name)) return d;
  return fail(ErrorKind::NotFound, "no feature '{}' is registered; registered: {}", name, names());
}

std::vector<const FeatureDescriptor*> FeatureRegistry::all() const {
  std::lock_guard lock(state_->mutex);
  std::vector<const FeatureDescriptor*> out;
  for (const auto& d : state_->features) out.push_back(&d);
  return out;
}

std::string FeatureRegistry::names() const {
  std::string out;
  for (const auto* d : all()) {
    out += (out.empty() ? "" : ", ") + d->name;
    if (!d->aliases.empty()) {
      std::string aliases;
      for (const auto& a : d->aliases) aliases += (aliases.empty() ? "" : ", ") + a;
      out += " (" + aliases + ")";
    }
  }
  return out.empty() ? "none registered" : out;
}

FeatureRegistry& feature_registry() {
  static FeatureRegistry registry;
  return registry;
}

}  // namespace weft
