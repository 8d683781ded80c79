// The registry behind weft/shader_overrides.h: built-in shaders' sources, and SPIR-V that
// replaces them at run time. Thread-safe: the viewer compiles on its UI thread while its
// render thread creates pipelines.
#include "weft/shader_overrides.h"
#include <algorithm>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>

namespace weft::shaders {

namespace {
struct Registry {
  std::mutex mutex;
  std::map<std::string, Source, std::less<>> sources;
  std::map<std::string, std::shared_ptr<const std::vector<std::uint32_t>>, std::less<>> overrides;
  std::vector<std::shared_ptr<const std::vector<std::uint32_t>>> retired;  // kept: spans may point here
};
Registry& registry() {
  static Registry r;
  return r;
}
}  // namespace

void register_source(const char* name, const char* path, const char* include_dirs) {
  Source s{name, path, {}};
  std::stringstream dirs(include_dirs);
  for (std::string dir; std::getline(dirs, dir, ';');)
    if (!dir.empty()) s.include_dirs.emplace_back(dir);
  auto& r = registry();
  std::lock_guard lock(r.mutex);
  r.sources.try_emplace(s.name, std::move(s));
}

std::vector<Source> sources() {
  auto& r = registry();
  std::lock_guard lock(r.mutex);
  std::vector<Source> out;
  for (const auto& [name, s] : r.sources) out.push_back(s);
  return out;
}

void set_override(std::string_view name, std::vector<std::uint32_t> spirv) {
  auto& r = registry();
  std::lock_guard lock(r.mutex);
  auto words = std::make_shared<const std::vector<std::uint32_t>>(std::move(spirv));
  auto it = r.overrides.find(name);
  if (it == r.overrides.end()) {
    r.overrides.emplace(std::string(name), std::move(words));
  } else {
    r.retired.push_back(std::move(it->second));
    it->second = std::move(words);
  }
}

void clear_overrides() {
  auto& r = registry();
  std::lock_guard lock(r.mutex);
  for (auto& [name, words] : r.overrides) r.retired.push_back(std::move(words));
  r.overrides.clear();
}

std::span<const std::uint32_t> find_override(std::string_view name) {
  auto& r = registry();
  std::lock_guard lock(r.mutex);
  auto it = r.overrides.find(name);
  if (it == r.overrides.end()) return {};
  return {it->second->data(), it->second->size()};
}

}  // namespace weft::shaders
