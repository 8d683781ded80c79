// Fuzz harness: the .wssdf decoder (weft::ssdf::decode), on bytes in memory. Every input is
// decoded twice: as it is, and with its checksums recomputed, so that the fuzzer also
// reaches the section parsing behind them.
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>
#include "fuzz_support.h"
import weft.core;
import weft.ssdf;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = (weft::log::set_level("off"), true);
  (void)quiet;
  std::vector<std::uint8_t> bytes(data, data + size);
  weft_fuzz::expect_clean(weft::ssdf::decode(std::as_bytes(std::span(bytes)), "fuzz"));
  weft_fuzz::fix_section_checksums(bytes, 64);
  weft_fuzz::expect_clean(weft::ssdf::decode(std::as_bytes(std::span(bytes)), "fuzz"));
  return 0;
}
