// Shader hot reload: the built-in shaders' sources (or files of the same names in
// --shader-dir) are polled; a changed file is compiled with glslangValidator, as the build
// does, and its SPIR-V replaces the built-in (weft/shader_overrides.h). A compile error is
// one line naming the shader; the built-in or the last good replacement stays.
module;
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <expected>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <system_error>
#include <vector>
#include <sys/wait.h>
#include <unistd.h>
#include "weft/shader_overrides.h"
module weft.viewer;
import weft.core;

namespace weft::viewer::detail {

namespace fs = std::filesystem;

namespace {

std::optional<fs::file_time_type> time_of(const fs::path& p) {
  std::error_code ec;
  auto t = fs::last_write_time(p, ec);
  if (ec) return std::nullopt;
  return t;
}

bool is_shader_file(const fs::path& p) {
  static const std::set<std::string> extensions = {".glsl", ".vert", ".frag", ".comp", ".geom", ".tesc", ".tese"};
  return extensions.contains(p.extension().string());
}

std::string quoted(const fs::path& p) {
  std::string out = "'";
  for (char c : p.string()) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// glslangValidator's first error line, shortened to what names the problem.
std::string first_error(const std::string& output) {
  std::size_t at = output.find("ERROR:");
  if (at == std::string::npos) at = 0;
  const std::size_t end = output.find('\n', at);
  std::string line = output.substr(at, end == std::string::npos ? std::string::npos : end - at);
  return line.empty() ? std::string("glslangValidator failed without a message") : line;
}

}  // namespace

ShaderWatch::ShaderWatch(std::optional<fs::path> folder) : folder_(std::move(folder)) {
  std::map<fs::path, std::set<std::string>> dependents;
  for (const auto& s : shaders::sources()) {
    fs::path main = s.path;
    if (folder_) {
      if (!fs::exists(*folder_ / s.name)) continue;  // --shader-dir: only the shaders copied there
      main = *folder_ / s.name;
    } else if (!fs::exists(main)) {
      continue;  // an installed weft without its sources: nothing to watch
    }
    compile_file_[s.name] = main;
    includes_[s.name] = s.include_dirs;
    dependents[main].insert(s.name);
    // Includes: every shader file in the folders it compiles with (its own, shaders/, --shader-dir).
    std::vector<fs::path> dirs = s.include_dirs;
    dirs.push_back(main.parent_path());
    for (const auto& dir : dirs) {
      std::error_code ec;
      for (const auto& entry : fs::directory_iterator(dir, ec))
        if (entry.is_regular_file() && entry.path().extension() == ".glsl") dependents[entry.path()].insert(s.name);
    }
  }
  for (auto& [path, names] : dependents)
    if (is_shader_file(path)) files_.push_back({path, time_of(path), {names.begin(), names.end()}});
}

std::optional<ShaderWatch::Reload> ShaderWatch::poll() {
  std::set<std::string> changed;
  for (auto& f : files_) {
    const auto now = time_of(f.path);
    if (now == f.time) continue;
    f.time = now;
    changed.insert(f.shaders.begin(), f.shaders.end());
  }
  if (changed.empty()) return std::nullopt;
  Reload reload;
  std::vector<std::pair<std::string, std::vector<std::uint32_t>>> compiled;
  for (const auto& name : changed) {
    auto spirv = compile(name);
    if (!spirv) {
      reload.error = weft::format("shader {}: {}", name, spirv.error().message);
      return reload;  // nothing replaced: every shader of this save compiles, or none is used
    }
    compiled.emplace_back(name, std::move(*spirv));
  }
  for (auto& [name, words] : compiled) {
    shaders::set_override(name, std::move(words));
    reload.shaders.push_back(name);
  }
  return reload;
}

Result<std::vector<std::uint32_t>> ShaderWatch::compile(const std::string& name) const {
  const fs::path source = compile_file_.at(name);
  // glslangValidator would wait forever on a shader saved as a FIFO, and the viewer with it.
  if (auto ok = check_input_file(source, "shader"); !ok) return std::unexpected(ok.error());
  const fs::path out = fs::temp_directory_path() / weft::format("weft-view-{}-{}.spv", ::getpid(), name);
  std::string command = weft::format("{} --quiet -V --target-env vulkan1.3", quoted(WEFT_GLSLANG_VALIDATOR));
  if (folder_) command += " -I" + quoted(*folder_);
  for (const auto& dir : includes_.at(name)) command += " -I" + quoted(dir);
  command += " -o " + quoted(out) + " " + quoted(source) + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return fail(ErrorKind::Io, "cannot run {}", WEFT_GLSLANG_VALIDATOR);
  std::string output;
  std::array<char, 1024> buffer{};
  while (std::fgets(buffer.data(), int(buffer.size()), pipe)) output += buffer.data();
  const int status = ::pclose(pipe);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::error_code ec;
    fs::remove(out, ec);
    return fail(ErrorKind::Parse, "{}", first_error(output));
  }
  std::ifstream in(out, std::ios::binary);
  std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  std::error_code ec;
  fs::remove(out, ec);
  if (bytes.empty() || bytes.size() % 4 != 0)
    return fail(ErrorKind::Parse, "glslangValidator wrote {} bytes of SPIR-V for {}", bytes.size(), source.string());
  std::vector<std::uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), bytes.size());
  return words;
}

}  // namespace weft::viewer::detail
