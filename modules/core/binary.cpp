// BinaryReader's reads that need no template, its one error message, and the check of the
// header every weft binary file starts with.
module;
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <expected>
#include <span>
#include <string>
#include <string_view>
module weft.core;

namespace weft {

Result<std::span<const std::byte>> BinaryReader::take(std::size_t count, std::string_view what) {
  if (remaining() < count) return truncated(what, count);
  auto span = data_.subspan(at_, count);
  at_ += count;
  return span;
}

std::unexpected<Error> BinaryReader::truncated(std::string_view what, std::size_t needed) const {
  return fail(ErrorKind::Parse, "{}: {}truncated: {} needs {} bytes at offset {}, but only {} remain", source_,
              section_.empty() ? std::string() : weft::format("section '{}': ", section_), what, needed, at_,
              remaining());
}

Result<void> check_file_header(std::span<const std::byte> bytes, std::string_view source,
                              const BinaryFileHeader& expected) {
  const std::size_t magic_bytes = std::min(bytes.size(), expected.magic.size());
  if (bytes.empty() || std::memcmp(bytes.data(), expected.magic.data(), magic_bytes) != 0)
    return fail(ErrorKind::Parse, "{}: not a weft {} file (the magic '{}' is missing)", source, expected.kind,
                expected.magic);
  if (bytes.size() >= expected.magic.size() + 4) {
    std::uint32_t version;
    std::memcpy(&version, bytes.data() + expected.magic.size(), 4);
    if (version != expected.version)
      return fail(ErrorKind::Unsupported, "{}: {} file version {} is not supported (this build reads version {})",
                  source, expected.kind, version, expected.version);
  }
  if (bytes.size() < expected.header_bytes)
    return fail(ErrorKind::Parse, "{}: truncated: the header needs {} bytes, the file has {}", source,
                expected.header_bytes, bytes.size());
  return {};
}

}  // namespace weft
