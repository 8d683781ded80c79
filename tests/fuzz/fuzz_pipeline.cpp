// Fuzz harness: the pipeline file reader (weft::pipeline::parse_pipeline) with weft's built-in
// pass types registered, on text in memory: every input is a pipeline or a clean error.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include "fuzz_support.h"
import weft.core;
import weft.pipeline;
import weft.builtin_features;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool ready = [] {
    weft::log::set_level("off");
    if (!weft::register_builtin_pass_types()) std::abort();
    return true;
  }();
  (void)ready;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto parsed = weft::pipeline::parse_pipeline(text, "fuzz pipeline");
  // What a valid pipeline writes back reads back to itself.
  if (parsed) {
    const std::string text_out = weft::pipeline::to_json(*parsed);
    auto again = weft::pipeline::parse_pipeline(text_out, "fuzz pipeline (written back)");
    if (!again || weft::pipeline::to_json(*again) != text_out) {
      std::fprintf(stderr, "a pipeline written back does not read back to itself:\n%s\n", text_out.c_str());
      std::abort();
    }
  }
  weft_fuzz::expect_clean(parsed);
  return 0;
}
