// Fuzz harness: the BTF image-set loaders (UBO2003 and UTIA layouts, weft::btf::load_btf on
// a folder). The input's first line is a file name inside a fresh folder (a per-view
// subfolder may be part of it), the rest that file's bytes: name parsing, layout
// detection, the light x view grid and the image decoding all see fuzzed input.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include "fuzz_support.h"
import weft.core;
import weft.btf;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = (weft::log::set_level("off"), true);
  (void)quiet;
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const std::size_t newline = input.find('\n');
  if (newline == std::string_view::npos || newline == 0 || newline > 200) return 0;
  const std::string name(input.substr(0, newline));
  const std::filesystem::path relative(name);
  if (relative.has_root_path() || name.find('\0') != std::string::npos) return 0;
  for (const auto& part : relative)
    if (part == ".." || part == ".") return 0;
  const std::filesystem::path folder = weft_fuzz::scratch_dir() / "btf";
  std::error_code ec;
  std::filesystem::remove_all(folder, ec);
  const auto* bytes = data + newline + 1;
  if (weft_fuzz::write_input("btf/" + name, bytes, size - newline - 1).empty()) return 0;
  weft_fuzz::expect_clean(weft::btf::load_btf(folder));
  return 0;
}
