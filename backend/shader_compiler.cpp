// GLSL -> SPIR-V with glslang, with #include and a two-level cache (memory, then disk) keyed
// by the hash of the *preprocessed* source, so edits to included files invalidate entries.
module;
#include <expected>
#include <optional>
#include <span>
#include <utility>
#include <cstdint>
#include <string_view>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <regex>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>
#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>
module weft.gpu;
import weft.core;

namespace weft::gpu {

namespace {
namespace fs = std::filesystem;

struct Cache {
  std::mutex mutex;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> memory;
  ShaderCacheStats stats;
};
Cache& cache() {
  static Cache c;
  return c;
}

void init_glslang() {
  static std::once_flag once;
  std::call_once(once, [] {
    glslang::InitializeProcess();
    std::atexit([] { glslang::FinalizeProcess(); });
  });
}

fs::path disk_cache_dir() {
  if (const char* dir = std::getenv("WEFT_SHADER_CACHE")) return *dir ? fs::path(dir) : fs::path();
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return fs::path(xdg) / "weft" / "shaders";
  if (const char* home = std::getenv("HOME"); home && *home) return fs::path(home) / ".cache" / "weft" / "shaders";
  return {};
}

// Resolves #include "x" against the including file's folder, then the include dirs.
class Includer : public glslang::TShader::Includer {
 public:
  explicit Includer(std::vector<fs::path> dirs) : dirs_(std::move(dirs)) {}

  IncludeResult* includeLocal(const char* header, const char* includer, size_t depth) override {
    fs::path base = fs::path(includer ? includer : "").parent_path();
    if (auto r = try_open(base / header)) return r;
    return includeSystem(header, includer, depth);
  }
  IncludeResult* includeSystem(const char* header, const char*, size_t) override {
    for (const auto& d : dirs_)
      if (auto r = try_open(d / header)) return r;
    return nullptr;  // glslang reports "cannot find include file" with file and line
  }
  void releaseInclude(IncludeResult* result) override {
    if (!result) return;
    delete static_cast<std::string*>(result->userData);
    delete result;
  }

 private:
  IncludeResult* try_open(const fs::path& p) {
    // Not an include file when it is a FIFO or a device: glslang says it cannot find it.
    auto bytes = read_input_file(p, "shader include");
    if (!bytes) return nullptr;
    auto* text = new std::string(bytes->begin(), bytes->end());
    return new IncludeResult(p.string(), text->data(), text->size(), text);
  }
  std::vector<fs::path> dirs_;
};

EShLanguage to_glslang(ShaderStage s) {
  switch (s) {
    case ShaderStage::Vertex: return EShLangVertex;
    case ShaderStage::Fragment: return EShLangFragment;
    default: return EShLangCompute;
  }
}

// glslang logs look like "ERROR: path:12: 'x' : undeclared identifier"; keep the
// error lines only and prefix the shader's label.
std::string tidy_log(std::string_view label, const std::string& log) {
  std::istringstream lines(log);
  std::string line, out;
  while (std::getline(lines, line)) {
    if (line.rfind("ERROR: ", 0) == 0 && line.find("compilation errors") == std::string::npos) {
      if (!out.empty()) out += "\n  ";
      out += line.substr(7);
    }
  }
  if (out.empty()) out = log;
  return weft::format("shader '{}': {}", label, out);
}

std::vector<std::uint32_t> read_spirv(const fs::path& p) {
  auto read = read_input_file(p, "SPIR-V cache file");  // a miss (also for a FIFO planted in the cache)
  if (!read) return {};
  const std::vector<unsigned char>& bytes = *read;
  if (bytes.size() < 4 || bytes.size() % 4) return {};
  std::vector<std::uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), bytes.size());
  if (words[0] != 0x07230203u) return {};
  return words;
}

void write_spirv(const fs::path& p, const std::vector<std::uint32_t>& words) {
  std::error_code ec;
  fs::create_directories(p.parent_path(), ec);
  if (ec) return;
  const fs::path tmp = p.string() + weft::format(".{}.tmp", std::hash<std::thread::id>{}(std::this_thread::get_id()));
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) return;
    out.write(reinterpret_cast<const char*>(words.data()), std::streamsize(words.size() * 4));
  }
  fs::rename(tmp, p, ec);  // atomic: concurrent compilers never see half a file
}
}  // namespace

ShaderCacheStats shader_cache_stats() {
  std::lock_guard lock(cache().mutex);
  return cache().stats;
}

Result<std::vector<std::uint32_t>> compile_glsl(const ShaderModuleDescriptor& desc) {
  std::string source = desc.glsl;
  std::string name = desc.label.empty() ? std::string("<glsl>") : desc.label;
  std::vector<fs::path> include_dirs = desc.include_dirs;
  if (source.empty()) {
    if (desc.path.empty()) return fail(ErrorKind::InvalidArgument, "shader '{}': no GLSL source, path or SPIR-V", desc.label);
    auto text = read_input_file(desc.path, "shader file");
    if (!text) return with_context(weft::format("shader '{}'", desc.label), text.error());
    source.assign(text->begin(), text->end());
    name = desc.path.string();
    include_dirs.insert(include_dirs.begin(), desc.path.parent_path());
  }
  init_glslang();

  std::string preamble = "#extension GL_GOOGLE_include_directive : require\n";
  for (const auto& d : desc.defines) preamble += weft::format("#define {} {}\n", d.name, d.value);

  const EShLanguage stage = to_glslang(desc.stage);
  const auto messages = EShMessages(EShMsgSpvRules | EShMsgVulkanRules);
  Includer includer(include_dirs);
  const char* text = source.c_str();
  const char* names = name.c_str();

  // The same source, preamble and targets for preprocessing and for compiling.
  auto configure = [&](glslang::TShader& shader) {
    shader.setStringsWithLengthsAndNames(&text, nullptr, &names, 1);
    shader.setPreamble(preamble.c_str());
    shader.setEnvInput(glslang::EShSourceGlsl, stage, glslang::EShClientVulkan, 100);
    shader.setEnvClient(glslang::EShClientVulkan, glslang::EShTargetVulkan_1_3);
    shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_6);
  };

  // Preprocess first: its output (with includes expanded) is the cache key.
  std::string preprocessed;
  {
    glslang::TShader shader(stage);
    configure(shader);
    if (!shader.preprocess(GetDefaultResources(), 460, ECoreProfile, false, false, messages, &preprocessed, includer))
      return fail(ErrorKind::Shader, "{}", tidy_log(name, shader.getInfoLog()));
  }
  const std::uint64_t key = Hasher{}.str(preprocessed).value(std::uint32_t(desc.stage)).str("glslang12-vk13").digest();
  {
    std::lock_guard lock(cache().mutex);
    if (auto it = cache().memory.find(key); it != cache().memory.end()) {
      ++cache().stats.memory_hits;
      return it->second;
    }
  }
  const fs::path dir = disk_cache_dir();
  const fs::path cached = dir.empty() ? fs::path() : dir / (hex64(key) + ".spv");
  if (!cached.empty()) {
    if (auto words = read_spirv(cached); !words.empty()) {
      std::lock_guard lock(cache().mutex);
      ++cache().stats.disk_hits;
      cache().memory[key] = words;
      return words;
    }
  }

  glslang::TShader shader(stage);
  configure(shader);
  if (!shader.parse(GetDefaultResources(), 460, false, messages, includer))
    return fail(ErrorKind::Shader, "{}", tidy_log(name, shader.getInfoLog()));
  glslang::TProgram program;
  program.addShader(&shader);
  if (!program.link(messages)) return fail(ErrorKind::Shader, "{}", tidy_log(name, program.getInfoLog()));
  std::vector<std::uint32_t> spirv;
  glslang::SpvOptions options;
  options.generateDebugInfo = false;
  glslang::GlslangToSpv(*program.getIntermediate(stage), spirv, &options);
  if (!cached.empty()) write_spirv(cached, spirv);
  std::lock_guard lock(cache().mutex);
  ++cache().stats.compiles;
  cache().memory[key] = spirv;
  return spirv;
}

}  // namespace weft::gpu
