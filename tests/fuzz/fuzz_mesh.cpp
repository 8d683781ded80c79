// Fuzz harness: a mesh file reader (weft::scene::load_mesh: the grammar checks, then
// OpenMesh, then prepare_mesh). WEFT_FUZZ_EXTENSION (".obj", ".ply", ".off", ".stl") picks
// the reader, as the file's extension does for users.
#include <cstddef>
#include <cstdint>
#include <string>
#include "fuzz_support.h"
import weft.core;
import weft.scene;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = (weft::log::set_level("off"), true);
  (void)quiet;
  const auto path = weft_fuzz::write_input(std::string("input") + WEFT_FUZZ_EXTENSION, data, size);
  weft_fuzz::expect_clean(weft::scene::load_mesh(path));
  return 0;
}
