// Shader hot reload. Built-in shaders are SPIR-V embedded at build time
// (cmake/WeftShaders.cmake); each generated accessor asks here first, so a program that
// recompiled a shader's source (weft view) replaces it by its file name without a rebuild.
// A header, not part of the weft.core module, because the generated accessor units are
// plain C++.
#pragma once
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace weft::shaders {

// A built-in shader linked into this program: its file name ("tonemap.frag"), the source it
// was compiled from and the include folders it was compiled with.
struct Source {
  std::string name;
  std::filesystem::path path;
  std::vector<std::filesystem::path> include_dirs;
};

// Called by each generated accessor unit at start-up; `include_dirs` is ';'-separated.
void register_source(const char* name, const char* path, const char* include_dirs);
// Every registered shader, sorted by name; one entry per name.
std::vector<Source> sources();

// SPIR-V that replaces the built-in `name` until clear_overrides(). Earlier replacements stay
// allocated, so spans handed out keep pointing at valid words (pipelines made from them live on).
void set_override(std::string_view name, std::vector<std::uint32_t> spirv);
void clear_overrides();
// The replacement's words, or an empty span when there is none.
std::span<const std::uint32_t> find_override(std::string_view name);

}  // namespace weft::shaders
