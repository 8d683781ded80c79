// Numbers on the command line of weft's own programs (the benchmarks, the examples): digits only,
// within a stated range, finite. std::stoul, std::atoi and sscanf("%u") read "abc" as an
// exception that ended the program ("terminate called"), as 0, or "-1" as 4294967295 (a size
// that then allocated or ran for ever; issue 33). Header-only, so a program that imports no
// weft module can use it too.
//
//   if (auto n = weft::args::whole(text, 1, 1000)) runs = *n; else return usage("--runs ...");
#pragma once
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

namespace weft::args {

// A whole number lo..hi written in decimal digits ("+5", "-1", " 5", "5x", "1e3" and "" are not).
inline std::optional<std::uint64_t> whole(std::string_view text, std::uint64_t lo, std::uint64_t hi) {
  if (text.empty() || text.front() < '0' || text.front() > '9') return std::nullopt;
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || value < lo || value > hi) return std::nullopt;
  return value;
}

// A finite number in [lo, hi] ("nan", "inf", "1e999", "1,5" and "" are not).
inline std::optional<double> number(std::string_view text, double lo, double hi) {
  if (text.empty()) return std::nullopt;
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(value) || value < lo || value > hi)
    return std::nullopt;
  return value;
}

// "WxH", each side a whole number 1..max_side.
inline std::optional<std::pair<std::uint32_t, std::uint32_t>> size(std::string_view text, std::uint32_t max_side) {
  const auto x = text.find('x');
  if (x == std::string_view::npos) return std::nullopt;
  const auto w = whole(text.substr(0, x), 1, max_side), h = whole(text.substr(x + 1), 1, max_side);
  if (!w || !h) return std::nullopt;
  return std::pair{std::uint32_t(*w), std::uint32_t(*h)};
}

// size() into two variables; false (and both left as they were) when the text is not WxH.
inline bool size_into(std::string_view text, std::uint32_t max_side, std::uint32_t& width, std::uint32_t& height) {
  const auto s = size(text, max_side);
  if (!s) return false;
  width = s->first, height = s->second;
  return true;
}

// "a,b,c": whole numbers lo..hi, at least one, none empty.
inline std::optional<std::vector<std::uint64_t>> whole_list(std::string_view text, std::uint64_t lo, std::uint64_t hi) {
  std::vector<std::uint64_t> out;
  for (std::size_t pos = 0;;) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    const auto n = whole(text.substr(pos, comma - pos), lo, hi);
    if (!n) return std::nullopt;
    out.push_back(*n);
    if (comma == text.size()) return out;
    pos = comma + 1;
  }
}

}  // namespace weft::args
