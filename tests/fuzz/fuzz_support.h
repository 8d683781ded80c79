// Helpers for weft's fuzz harnesses (one reader each; see tests/fuzz/README.md). Plain C++,
// included before any `import`. Readers that take a path get the input through a file in
// a per-process temporary folder; logging is silenced, since warnings are expected.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>
#include <unistd.h>

namespace weft_fuzz {

// A folder for this process's files (in /dev/shm when present, else the temp folder),
// created on first use and removed when the process exits normally.
inline const std::filesystem::path& scratch_dir() {
  static const std::filesystem::path dir = [] {
    std::error_code ec;
    std::filesystem::path base = std::filesystem::exists("/dev/shm", ec) ? "/dev/shm" : std::filesystem::temp_directory_path();
    std::filesystem::path d = base / ("weft-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d, ec);
    return d;
  }();
  static const bool cleanup = (std::atexit([] {
                                 std::error_code ec;
                                 std::filesystem::remove_all(scratch_dir(), ec);
                               }) == 0);
  (void)cleanup;
  return dir;
}

// Writes the input to `name` inside scratch_dir() and returns its path; an empty path when
// the name cannot be a file here (a fuzzed name longer than the file system allows), which
// the harness skips: it is not the reader's input.
inline std::filesystem::path write_input(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = scratch_dir() / name;
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return {};
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

// A reader's contract: a value, or an error that says something. Anything else is a bug.
template <class R>
void expect_clean(const R& result) {
  if (!result && result.error().message.empty()) {
    std::fprintf(stderr, "reader returned an error without a message\n");
    std::abort();
  }
}

// 64-bit FNV-1a, the checksum of weft's binary files (weft::Hasher).
inline std::uint64_t fnv1a(const std::uint8_t* data, std::size_t size) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (std::size_t i = 0; i < size; ++i) h = (h ^ data[i]) * 0x100000001b3ull;
  return h;
}

// Recomputes the checksums of weft's sectioned files (.wssdf: 64-byte header, .wbtf: 72):
// the header's over its bytes before the last 8, stored there; then sections {u32 tag,
// u32 0, u64 size, u64 checksum of the payload, payload}. The fuzzer then reaches the
// parsing behind the checksums, which random bytes would almost never pass.
inline void fix_section_checksums(std::vector<std::uint8_t>& bytes, std::size_t header_bytes) {
  if (bytes.size() < header_bytes) return;
  const std::uint64_t header = fnv1a(bytes.data(), header_bytes - 8);
  std::memcpy(bytes.data() + header_bytes - 8, &header, 8);
  std::size_t at = header_bytes;
  while (bytes.size() - at >= 24) {
    std::uint64_t size = 0;
    std::memcpy(&size, bytes.data() + at + 8, 8);
    if (size > bytes.size() - at - 24) return;
    const std::uint64_t h = fnv1a(bytes.data() + at + 24, std::size_t(size));
    std::memcpy(bytes.data() + at + 16, &h, 8);
    at += 24 + std::size_t(size);
  }
}

}  // namespace weft_fuzz
