// Fuzz harness: the .btfraw reader (weft::btf::load_btf on a file), as it is and with its
// header and sample checksums recomputed.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>
#include "fuzz_support.h"
import weft.core;
import weft.btf;

namespace {
// Sample checksum at byte 40 over the samples after the header; header checksum in the
// header's last 8 bytes (its size is the u32 at byte 12).
void fix_checksums(std::vector<std::uint8_t>& bytes) {
  if (bytes.size() < 48) return;
  std::uint32_t header_size = 0;
  std::memcpy(&header_size, bytes.data() + 12, 4);
  if (header_size < 56 || header_size > bytes.size()) return;
  const std::uint64_t samples = weft_fuzz::fnv1a(bytes.data() + header_size, bytes.size() - header_size);
  std::memcpy(bytes.data() + 40, &samples, 8);
  const std::uint64_t header = weft_fuzz::fnv1a(bytes.data(), header_size - 8);
  std::memcpy(bytes.data() + header_size - 8, &header, 8);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool quiet = (weft::log::set_level("off"), true);
  (void)quiet;
  std::vector<std::uint8_t> bytes(data, data + size);
  weft_fuzz::expect_clean(weft::btf::load_btf(weft_fuzz::write_input("input.btfraw", bytes.data(), bytes.size())));
  fix_checksums(bytes);
  weft_fuzz::expect_clean(weft::btf::load_btf(weft_fuzz::write_input("input.btfraw", bytes.data(), bytes.size())));
  return 0;
}
