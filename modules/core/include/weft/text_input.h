// Whether a large input that should be text (a scene, a pipeline, a glTF's JSON, a viewer
// script, a sweep spec, a task list) is binary: a 3 GiB sparse file of zeros (or a disk image,
// a video) was read whole before the parser's "line 1, column 1", 10 s per 3 GiB on the 2-core
// VM and a minute for 20 GiB (issue 33). A file of 1 MiB or more has its first 4 KiB looked at
// first: a NUL byte there means it is not text. Smaller files go to their parser as before, so
// its messages stay what they were. Header-only: each reader calls it before read_input_file.
//
//   if (auto why = weft::binary_text_input(path, "scene file")) return fail(ErrorKind::Parse, "{}", *why);
#pragma once
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>

namespace weft {

// `also_accept` names a binary magic the reader takes too ("glTF" for a .glb).
inline std::optional<std::string> binary_text_input(const std::filesystem::path& path, std::string_view what,
                                                    std::string_view also_accept = {}) {
  std::error_code ec;
  // Only regular files: the readers name FIFOs, folders and devices without opening them.
  if (!std::filesystem::is_regular_file(path, ec) || ec) return std::nullopt;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec || size < (std::uintmax_t(1) << 20)) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  char head[4096];
  in.read(head, sizeof head);
  const std::streamsize n = in.gcount();
  if (!also_accept.empty() && std::size_t(n) >= also_accept.size() && std::string_view(head, also_accept.size()) == also_accept)
    return std::nullopt;
  for (std::streamsize i = 0; i < n; ++i)
    if (head[i] == '\0') {
      char size_text[32];
      std::snprintf(size_text, sizeof size_text, "%.1f MiB", double(size) / double(1 << 20));
      return std::string(what) + " '" + path.string() + "' is not a text file (" + size_text + ", a NUL byte at offset " +
             std::to_string(i) + "); is it the right file?";
    }
  return std::nullopt;
}

}  // namespace weft
