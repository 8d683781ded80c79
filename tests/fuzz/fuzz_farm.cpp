// Fuzz harness: the farm's two readers on text in memory -- the sweep spec
// (weft::farm::parse_sweep_spec, knobs checked against the built-in features' tables) and the
// task list (weft::farm::parse_task_list, whose accepted lists must write back to text that
// reads back to the same text). Every input is a result or a clean error.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include "fuzz_support.h"
import weft.core;
import weft.builtin_features;
import weft.farm;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool ready = (weft::log::set_level("off"), (void)weft::register_builtins(), true);
  (void)ready;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  weft_fuzz::expect_clean(weft::farm::parse_sweep_spec(text, "fuzz spec", weft_fuzz::scratch_dir()));
  auto list = weft::farm::parse_task_list(text, "fuzz list");
  weft_fuzz::expect_clean(list);
  if (list) {
    const std::string once = weft::farm::to_text(*list);
    auto back = weft::farm::parse_task_list(once, "fuzz list written back");
    if (!back || weft::farm::to_text(*back) != once) {
      std::fprintf(stderr, "a task list did not read back to itself\n");
      std::abort();
    }
  }
  return 0;
}
