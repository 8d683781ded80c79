// Fuzz harness: the skin LUT disk cache (weft::skin::cached_lut). The input is stored as the
// cache file of a small LUT's key; whatever it holds, cached_lut must return a LUT of the
// right size with finite texels (read back when valid, regenerated otherwise).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include "fuzz_support.h"
import weft.core;
import weft.pass.skin_sss;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool setup = [] {
    weft::log::set_level("off");
    ::setenv("WEFT_SKIN_LUT_CACHE", (weft_fuzz::scratch_dir() / "skin-lut").c_str(), 1);
    return true;
  }();
  (void)setup;
  weft::skin::LutParams params;
  params.width = 4;
  params.height = 4;
  params.samples = 4;
  params.threads = 1;
  weft_fuzz::write_input("skin-lut/skin-lut-" + weft::hex64(params.hash()) + ".exr", data, size);
  weft::skin::clear_lut_memory_cache();
  auto lut = weft::skin::cached_lut(params);
  if (!lut || (*lut)->width != 4 || (*lut)->height != 4 || (*lut)->texels.size() != 16) {
    std::fprintf(stderr, "cached_lut: %s\n", lut ? "wrong size" : lut.error().what().c_str());
    std::abort();
  }
  for (const auto& t : (*lut)->texels)
    if (!std::isfinite(t.x + t.y + t.z + t.w)) std::abort();
  return 0;
}
