// weft.core — what every weft module shares: errors as values (Result/Error), logging,
// GLM math aliases, content hashing, bounds-checked binary reading and writing, and atomic
// file writes. Nothing
// here knows about GPUs, graphs or scenes.
module;
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <expected>
#include <filesystem>
#include <initializer_list>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <glm/glm.hpp>
export module weft.core;

export namespace weft {

// What kind of failure an Error is; callers branch on this, users read the message.
enum class ErrorKind : std::uint8_t {
  InvalidArgument,  // a bad descriptor or parameter: misuse of an API
  NotFound,         // a file, adapter, layer or named thing that is not there
  Io,               // reading or writing a file failed
  Parse,            // a file exists but its content is malformed
  Shader,           // GLSL did not compile or link
  Device,           // the Vulkan driver refused (out of memory, lost device, ...)
  Unsupported,      // the adapter or format cannot do what was asked
  Graph,            // the render graph is impossible (cycle, missing writer, ...)
  Internal,         // a bug in weft
};

constexpr std::string_view to_string(ErrorKind kind) {
  switch (kind) {
    case ErrorKind::InvalidArgument: return "invalid argument";
    case ErrorKind::NotFound: return "not found";
    case ErrorKind::Io: return "i/o error";
    case ErrorKind::Parse: return "parse error";
    case ErrorKind::Shader: return "shader error";
    case ErrorKind::Device: return "device error";
    case ErrorKind::Unsupported: return "unsupported";
    case ErrorKind::Graph: return "graph error";
    case ErrorKind::Internal: return "internal error";
  }
  return "error";
}

struct Error {
  ErrorKind kind = ErrorKind::Internal;
  std::string message;

  // "shader error: ..." — one line a user can act on.
  [[nodiscard]] std::string what() const { return std::string(to_string(kind)) + ": " + message; }
};

template <class T>
using Result = std::expected<T, Error>;

// libstdc++ 12 (Debian 12) has no <format>: weft::format is {fmt}'s, with the same syntax.
template <class... Args>
[[nodiscard]] std::string format(fmt::format_string<Args...> f, Args&&... args) {
  return fmt::vformat(f, fmt::make_format_args(args...));
}

// Builds an unexpected Error with a weft::format message:
//   return fail(ErrorKind::NotFound, "mesh '{}' not found", path);
template <class... Args>
[[nodiscard]] std::unexpected<Error> fail(ErrorKind kind, fmt::format_string<Args...> f, Args&&... args) {
  return std::unexpected(Error{kind, fmt::vformat(f, fmt::make_format_args(args...))});
}

// Adds context in front of an error as it travels up: "loading scene 'a.json': <inner>".
[[nodiscard]] inline std::unexpected<Error> with_context(std::string_view context, Error inner) {
  inner.message = std::string(context) + ": " + inner.message;
  return std::unexpected(std::move(inner));
}

// ---- math ----------------------------------------------------------------------------
using vec2 = glm::vec2;
using vec3 = glm::vec3;
using vec4 = glm::vec4;
using ivec2 = glm::ivec2;
using uvec2 = glm::uvec2;
using uvec3 = glm::uvec3;
using mat3 = glm::mat3;
using mat4 = glm::mat4;
using quat = glm::qua<float>;
inline constexpr float pi = 3.14159265358979323846f;

// ---- hashing -------------------------------------------------------------------------
// 64-bit FNV-1a: stable across runs and machines, so it can key on-disk caches.
struct Hasher {
  std::uint64_t state = 0xcbf29ce484222325ull;
  Hasher& bytes(const void* data, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
      state ^= p[i];
      state *= 0x100000001b3ull;
    }
    return *this;
  }
  Hasher& str(std::string_view s) {
    const std::uint64_t n = s.size();
    bytes(&n, sizeof n);
    return bytes(s.data(), s.size());
  }
  template <class T>
  Hasher& value(const T& v) { return bytes(&v, sizeof v); }
  [[nodiscard]] std::uint64_t digest() const { return state; }
};

inline std::uint64_t hash_bytes(std::span<const std::byte> data) {
  return Hasher{}.bytes(data.data(), data.size()).digest();
}
inline std::string hex64(std::uint64_t v) { return fmt::format("{:016x}", v); }

// ---- enum names ------------------------------------------------------------------------
// An enum's names in one table, so printing and parsing it cannot disagree:
//   constexpr EnumNames<Weave, 3> weave_names{{{Weave::Plain, "plain"}, {Weave::Twill, "twill"}, ...}};
//   to_string(w) = enum_name(weave_names, w);  parse = enum_from_name(weave_names, text, "weave")
template <class Enum, std::size_t N>
using EnumNames = std::array<std::pair<Enum, std::string_view>, N>;

template <class Enum, std::size_t N>
constexpr std::string_view enum_name(const EnumNames<Enum, N>& names, Enum value) {
  for (const auto& [v, name] : names)
    if (v == value) return name;
  return "?";
}

// InvalidArgument naming `what`, the text and the choices: "weave 'silk' is not one of plain, twill, knit".
template <class Enum, std::size_t N>
Result<Enum> enum_from_name(const EnumNames<Enum, N>& names, std::string_view text, std::string_view what) {
  std::string choices;
  for (const auto& [v, name] : names) {
    if (name == text) return v;
    choices += choices.empty() ? "" : ", ";
    choices += name;
  }
  return fail(ErrorKind::InvalidArgument, "{} '{}' is not one of {}", what, text, choices);
}

// ---- binary files --------------------------------------------------------------------
// weft's binary files (.wbtf, .wssdf) lay little-endian values end to end. Their encoders
// check that the host is little-endian, so values are copied as they lie in memory.

// Appends values' bytes; a format adds its own encodings (fp16, quantized) on top.
struct BinaryWriter {
  template <class T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::byte*>(&value);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  template <class T>
  void put_all(std::span<const T> values) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::byte*>(values.data());
    bytes.insert(bytes.end(), p, p + values.size_bytes());
  }
  std::vector<std::byte> bytes;
};

// Reads values in order from bytes a decoder does not trust: every read checks its size
// first, and one that runs past the end is a Parse error naming the source, the section
// (when not empty), what was being read, the bytes it needs, the offset and what remains:
//   "cloth.wbtf: section 'MLP': truncated: layer 2's input count needs 4 bytes at offset 96, but only 1 remain"
// `source` and `section` are viewed, not copied: they must outlive the reader.
class BinaryReader {
 public:
  BinaryReader(std::span<const std::byte> data, std::string_view source, std::string_view section = {})
      : data_(data), source_(source), section_(section) {}

  // A value copied out (the data need not be aligned).
  template <class T>
  Result<T> get(std::string_view what) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (remaining() < sizeof(T)) return truncated(what, sizeof(T));
    T value;
    std::memcpy(&value, data_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  // The next `count` bytes, as a view into the data.
  Result<std::span<const std::byte>> take(std::size_t count, std::string_view what);
  [[nodiscard]] std::size_t remaining() const { return data_.size() - at_; }

 private:
  [[nodiscard]] std::unexpected<Error> truncated(std::string_view what, std::size_t needed) const;
  std::span<const std::byte> data_;
  std::string_view source_, section_;
  std::size_t at_ = 0;
};

// The start every weft binary file shares: an 8-byte magic, a u32 version, and a header of
// header_bytes in all. Checked before the header is read, in this order, so the message says
// the most useful thing: not the magic -> Parse "not a weft <kind> file (the magic '<magic>' is
// missing)"; another version -> Unsupported, naming both; cut short -> Parse, naming the sizes.
// A prefix of the magic counts as truncated, not as another kind of file.
struct BinaryFileHeader {
  std::string_view magic;  // 8 characters
  std::string_view kind;   // "neural BTF", "SSDF"
  std::uint32_t version = 0;
  std::size_t header_bytes = 0;
};
[[nodiscard]] Result<void> check_file_header(std::span<const std::byte> bytes, std::string_view source,
                                             const BinaryFileHeader& expected);

// ---- files ---------------------------------------------------------------------------
// Writes `parts` end to end as `path`, atomically (files.cpp): a temporary unique to the
// call, fsync, rename. Readers never see half a file or two writers' bytes mixed; on
// failure (no space, no permission, a missing folder) nothing is left behind and the Io
// error names `what` and the path: "cannot write skin LUT cache 'x.exr': No space left on device".
[[nodiscard]] Result<void> write_file_atomically(const std::filesystem::path& path,
                                                 std::initializer_list<std::span<const std::byte>> parts,
                                                 std::string_view what);

// Reading a user's input file (files.cpp). Every weft reader of a path a user gives --
// scenes, meshes, textures, photos, environments, BTFs, caches, scripts, shaders -- goes
// through these, so none of them waits forever on a path that is not a file on disk: a FIFO
// (open() blocks until a writer comes), a folder, a device (/dev/zero never ends) or a
// procfs file that blocks (/proc/kmsg). The path is classified by stat() before it is
// opened (opening some devices has effects), opened non-blocking, checked again with
// fstat(), and read without ever waiting. Errors, naming `what` and the path:
//   NotFound "scene file 'x.json' not found"
//   Io       "mesh file 'm.obj' is a FIFO, not a regular file" (a folder, a character device, ...)
//   Io       "mesh file '/proc/kmsg' cannot be read without waiting (not a regular file on disk)"
//   Io       "cannot open texture 't.png': Permission denied"
[[nodiscard]] Result<std::vector<unsigned char>> read_input_file(const std::filesystem::path& path, std::string_view what);
// The same checks without keeping the bytes, for readers that open the path themselves
// (OpenMesh, glslangValidator): a regular file passes at the cost of a stat(); an empty-looking
// one (procfs reports size 0) is read through, without waiting, to prove it ends.
[[nodiscard]] Result<void> check_input_file(const std::filesystem::path& path, std::string_view what);

// ---- logging -------------------------------------------------------------------------
// Thin wrappers over spdlog so modules need not include it; the level comes from
// WEFT_LOG (trace, debug, info, warn, error, off), default info.
namespace log {
void info(std::string_view message);
void warn(std::string_view message);
void error(std::string_view message);
void debug(std::string_view message);
void set_level(std::string_view level);
}  // namespace log

}  // namespace weft
