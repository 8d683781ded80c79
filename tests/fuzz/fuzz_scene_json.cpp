// Fuzz harness: the JSON scene file reader (weft::scene::parse_scene), on text in memory.
#include <cstddef>
#include <cstdint>
#include <string_view>
#include "fuzz_support.h"
import weft.core;
import weft.scene;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = (weft::log::set_level("off"), true);
  (void)quiet;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  weft_fuzz::expect_clean(weft::scene::parse_scene(text, weft_fuzz::scratch_dir(), "fuzz scene"));
  return 0;
}
