// Fuzz harness: the glTF reader (weft::scene::load_gltf: the JSON checks, tinygltf, the
// converter, prepare_mesh). WEFT_FUZZ_EXTENSION is ".gltf" (JSON) or ".glb" (binary).
#include <cstddef>
#include <cstdint>
#include <string>
#include "fuzz_support.h"
import weft.core;
import weft.scene;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = (weft::log::set_level("off"), true);
  (void)quiet;
  const auto path = weft_fuzz::write_input(std::string("asset/input") + WEFT_FUZZ_EXTENSION, data, size);
  weft_fuzz::expect_clean(weft::scene::load_gltf(path));
  return 0;
}
