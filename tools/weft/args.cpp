// Argument parsing shared by the sub-commands.
#include <charconv>
#include <optional>
#include <string>
#include <system_error>
#include "commands.h"

namespace weft::cli {

std::optional<Size> parse_size(const std::string& text, std::uint32_t max_side) {
  const auto x = text.find('x');
  if (x == std::string::npos) return std::nullopt;
  // Digits only: sscanf's %u and stoul read "-1" as 4294967295.
  const auto side = [&](std::size_t begin, std::size_t end) -> std::optional<std::uint32_t> {
    std::uint32_t value = 0;
    const char* first = text.data() + begin;
    const char* last = text.data() + end;
    if (first == last || *first < '0' || *first > '9') return std::nullopt;
    const auto [ptr, ec] = std::from_chars(first, last, value);
    if (ec != std::errc() || ptr != last || value == 0 || value > max_side) return std::nullopt;
    return value;
  };
  const auto w = side(0, x), h = side(x + 1, text.size());
  if (!w || !h) return std::nullopt;
  return Size{*w, *h};
}

std::optional<std::string> exposure_problem(float exposure) {
  // NaN, 0 and negative exposures drew black images, infinity a magenta one.
  if (exposure > 0.0f && exposure <= 1e6f) return std::nullopt;
  return "--exposure " + std::to_string(exposure) + " must be a number in (0, 1e6]";
}

}  // namespace weft::cli
