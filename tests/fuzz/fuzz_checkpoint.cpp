// Fuzz harness: the neural BTF training checkpoint reader
// (weft::btf::training_detail::load_checkpoint), as it is and with its trailing checksum
// recomputed.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>
#include "fuzz_support.h"
import weft.core;
import weft.btf.training;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = (weft::log::set_level("off"), true);
  (void)quiet;
  std::vector<std::uint8_t> bytes(data, data + size);
  namespace td = weft::btf::training_detail;
  weft_fuzz::expect_clean(td::load_checkpoint(weft_fuzz::write_input("input.ckpt", bytes.data(), bytes.size())));
  if (bytes.size() >= 8) {
    const std::uint64_t sum = weft_fuzz::fnv1a(bytes.data(), bytes.size() - 8);
    std::memcpy(bytes.data() + bytes.size() - 8, &sum, 8);
    weft_fuzz::expect_clean(td::load_checkpoint(weft_fuzz::write_input("input.ckpt", bytes.data(), bytes.size())));
  }
  return 0;
}
