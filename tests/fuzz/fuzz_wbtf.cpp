// Fuzz harness: the .wbtf decoder (weft::btf::decode_wbtf), on bytes in memory, as it is and
// with its checksums recomputed (see fix_section_checksums). A decoded model must decode a
// sample to finite numbers.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <vector>
#include "fuzz_support.h"
import weft.core;
import weft.btf.model;

namespace {
void check(const weft::Result<weft::btf::NeuralBtf>& model) {
  weft_fuzz::expect_clean(model);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = (weft::log::set_level("off"), true);
  (void)quiet;
  std::vector<std::uint8_t> bytes(data, data + size);
  check(weft::btf::decode_wbtf(std::as_bytes(std::span(bytes)), "fuzz"));
  weft_fuzz::fix_section_checksums(bytes, 72);
  check(weft::btf::decode_wbtf(std::as_bytes(std::span(bytes)), "fuzz"));
  return 0;
}
