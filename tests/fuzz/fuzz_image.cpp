// Fuzz harness: an image decoder behind weft.image's loaders. WEFT_FUZZ_EXTENSION picks
// it: ".png" (load_png), ".jpg" (load_ldr: stb_image's JPEG and the rest), ".hdr"
// (load_hdr) or ".exr" (load_exr, tinyexr). A decoded image must be consistent.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include "fuzz_support.h"
import weft.core;
import weft.image;

namespace {
template <class R>
void check(const R& image) {
  weft_fuzz::expect_clean(image);
  if (image && image->pixels.size() != std::size_t(image->width) * image->height * image->channels) {
    std::fprintf(stderr, "decoded image has %zu samples for %ux%ux%u\n", image->pixels.size(), image->width,
                 image->height, image->channels);
    std::abort();
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = (weft::log::set_level("off"), true);
  (void)quiet;
  constexpr std::string_view ext = WEFT_FUZZ_EXTENSION;
  const auto path = weft_fuzz::write_input(std::string("input") + WEFT_FUZZ_EXTENSION, data, size);
  if (ext == ".png") check(weft::image::load_png(path));
  else if (ext == ".jpg") check(weft::image::load_ldr(path));
  else if (ext == ".hdr") check(weft::image::load_hdr(path));
  else check(weft::image::load_exr(path));
  return 0;
}
