// Small helpers shared by weft.scene's units: warnings, extensions, whole-file reads.
module;
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <fstream>
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

Result<std::vector<unsigned char>> read_file(const std::filesystem::path& path, std::string_view what) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) return fail(ErrorKind::NotFound, "{} '{}' not found", what, path.string());
  if (std::filesystem::is_directory(status)) return fail(ErrorKind::Io, "{} '{}' is a folder, not a file", what, path.string());
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(ErrorKind::Io, "cannot open {} '{}'", what, path.string());
  std::vector<unsigned char> bytes;
  in.seekg(0, std::ios::end);
  const auto size = in.tellg();
  if (size < 0) return fail(ErrorKind::Io, "cannot read {} '{}'", what, path.string());
  bytes.resize(static_cast<std::size_t>(size));
  in.seekg(0, std::ios::beg);
  if (!bytes.empty() && !in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()))) {
    return fail(ErrorKind::Io, "cannot read {} '{}'", what, path.string());
  }
  return bytes;
}

}  // namespace weft::scene::detail
