// Plugins: shared libraries with the entry point of <weft/plugin.h>, opened with dlopen. They
// link the same libweft_*.so as this process, so what they register lands in its registries.
module;
#include <dlfcn.h>
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <mutex>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>
#include "weft/plugin.h"
module weft.pipeline;
import weft.core;
import weft.feature;

namespace weft::pipeline {
namespace {
std::mutex plugins_mutex;
std::vector<LoadedPlugin>& plugins() {
  static std::vector<LoadedPlugin> loaded;
  return loaded;
}
}  // namespace

Result<LoadedPlugin> load_plugin(const std::filesystem::path& path) {
  std::lock_guard lock(plugins_mutex);
  std::error_code ec;
  const std::string file = path.string();
  const auto canonical = std::filesystem::weakly_canonical(path, ec).string();
  for (const auto& p : plugins())
    if (p.path == canonical) return p;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) return fail(ErrorKind::NotFound, "plugin '{}': no such file", file);
  if (!std::filesystem::is_regular_file(status))
    return fail(ErrorKind::InvalidArgument, "plugin '{}': not a regular file", file);
  // A "regular file" that cannot be read without waiting (/proc/kmsg) blocked dlopen for ever
  // (issue 33); check_input_file reads an empty-looking file once, without waiting.
  if (auto readable = check_input_file(path, "plugin"); !readable) return std::unexpected(readable.error());
  // RTLD_NOW: a plugin missing a symbol fails here, not in the middle of a frame.
  void* handle = dlopen(canonical.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* why = dlerror();
    return fail(ErrorKind::InvalidArgument, "plugin '{}': cannot be loaded: {}", file, why ? why : "unknown reason");
  }
  const auto close_with = [&](Error e) -> Result<LoadedPlugin> {
    dlclose(handle);
    return std::unexpected(std::move(e));
  };
  auto* version = reinterpret_cast<std::uint32_t (*)()>(dlsym(handle, "weft_plugin_abi_version"));
  auto* entry = reinterpret_cast<void (*)(PluginRegistrar*)>(dlsym(handle, "weft_register_plugin"));
  if (!version || !entry)
    return close_with({ErrorKind::InvalidArgument,
                       weft::format("plugin '{}': no weft plugin entry point (weft_plugin_abi_version and "
                                    "weft_register_plugin; build it with WEFT_PLUGIN from <weft/plugin.h>)",
                                    file)});
  if (const std::uint32_t v = version(); v != WEFT_PLUGIN_ABI_VERSION)
    return close_with({ErrorKind::InvalidArgument,
                       weft::format("plugin '{}' was built for weft plugin ABI {}; this weft has ABI {} (rebuild the "
                                    "plugin against this weft)",
                                    file, v, WEFT_PLUGIN_ABI_VERSION)});
  PluginRegistrar registrar;
  entry(&registrar);
  std::vector<std::string> problems = registrar.errors_;
  // Check every name before registering any, so a collision leaves the registries as they were.
  for (const auto& d : registrar.pass_types_)
    if (const auto* known = pass_type_registry().find(d.name); known && known->create != d.create)
      problems.push_back(weft::format("pass type '{}' is registered already", d.name));
  for (const auto& d : registrar.features_) {
    const auto taken = [&](std::string_view n) { return feature_registry().find(n) != nullptr; };
    if (taken(d.name)) problems.push_back(weft::format("feature '{}' is registered already", d.name));
    for (const auto& a : d.aliases)
      if (taken(a)) problems.push_back(weft::format("feature '{}': the name '{}' is taken", d.name, a));
  }
  if (!problems.empty()) {
    std::string all;
    for (const auto& p : problems) all += (all.empty() ? "" : "; ") + p;
    return close_with({ErrorKind::InvalidArgument, weft::format("plugin '{}': {}; nothing of it was registered", file, all)});
  }
  LoadedPlugin loaded{canonical, {}, {}};
  for (auto& d : registrar.pass_types_) {
    loaded.pass_types.push_back(d.name);
    if (auto ok = register_pass_type(std::move(d)); !ok) return with_context(weft::format("plugin '{}'", file), ok.error());
  }
  for (auto& d : registrar.features_) {
    loaded.features.push_back(d.name);
    if (auto ok = register_feature(std::move(d)); !ok) return with_context(weft::format("plugin '{}'", file), ok.error());
  }
  // The library stays loaded for the life of the process: its descriptors and code are in use.
  plugins().push_back(loaded);
  log::info(weft::format("loaded plugin {} ({} pass types, {} features)", file, loaded.pass_types.size(), loaded.features.size()));
  return loaded;
}

std::vector<LoadedPlugin> loaded_plugins() {
  std::lock_guard lock(plugins_mutex);
  return plugins();
}

std::string loaded_plugin_names() {
  std::string out;
  for (const auto& p : loaded_plugins()) {
    std::string names;
    for (const auto& n : p.pass_types) names += (names.empty() ? "" : ", ") + n;
    for (const auto& n : p.features) names += (names.empty() ? "" : ", ") + n;
    out += (out.empty() ? "" : "; ") + std::filesystem::path(p.path).filename().string() + " (" + names + ")";
  }
  return out.empty() ? "none" : out;
}

std::vector<std::string> load_plugins_from_environment() {
  std::vector<std::string> warnings;
  const char* value = std::getenv("WEFT_PLUGIN_PATH");
  if (!value || !*value) return warnings;
  std::string_view rest(value);
  while (!rest.empty()) {
    const auto colon = rest.find(':');
    const std::filesystem::path entry(std::string(rest.substr(0, colon)));
    rest = colon == std::string_view::npos ? std::string_view{} : rest.substr(colon + 1);
    if (entry.empty()) continue;
    std::vector<std::filesystem::path> files;
    std::error_code ec;
    if (std::filesystem::is_directory(entry, ec)) {
      for (const auto& f : std::filesystem::directory_iterator(entry, ec))
        if (f.path().extension() == ".so") files.push_back(f.path());
      std::sort(files.begin(), files.end());
    } else {
      files.push_back(entry);
    }
    for (const auto& f : files)
      if (auto ok = load_plugin(f); !ok) warnings.push_back("WEFT_PLUGIN_PATH: " + ok.error().message);
  }
  return warnings;
}

}  // namespace weft::pipeline
