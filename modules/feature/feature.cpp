module;
#include <expected>
#include <string_view>
module weft.feature;
import weft.core;

namespace weft {

std::string_view to_string(Quality q) {
  switch (q) {
    case Quality::Low: return "low";
    case Quality::Medium: return "medium";
    case Quality::High: return "high";
    case Quality::Reference: return "reference";
  }
  return "?";
}

Result<Quality> quality_from_string(std::string_view name) {
  for (Quality q : {Quality::Low, Quality::Medium, Quality::High, Quality::Reference})
    if (to_string(q) == name) return q;
  return fail(ErrorKind::InvalidArgument, "unknown quality '{}' (low, medium, high, reference)", name);
}

}  // namespace weft
