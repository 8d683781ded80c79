// Small helpers shared by weft.scene's units: warnings, extensions. (Whole-file reads are
// weft.core's read_input_file, which every reader of a user's file shares.)
module;
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>
module weft.scene;
import weft.core;

namespace weft::scene::detail {

void warn(std::vector<std::string>& warnings, std::string message) {
  log::warn(message);
  warnings.push_back(std::move(message));
}

std::string lowercase_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

}  // namespace weft::scene::detail
