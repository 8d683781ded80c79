// BinaryReader's reads that need no template, and its one error message.
module;
#include <cstddef>
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

}  // namespace weft
