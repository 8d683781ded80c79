// BinaryWriter and BinaryReader: a round trip, and a read past the end (at a get, at a
// take) is a Parse error naming source, section, what, the bytes needed, offset and rest.
#include <doctest/doctest.h>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>
import weft.core;

using namespace weft;

namespace {
std::vector<std::byte> sample() {
  BinaryWriter out;
  out.put(std::uint32_t{7});
  out.put(std::uint16_t{0xbeef});
  const std::vector<float> values{1.5f, -2.0f};
  out.put_all(std::span(values));
  return out.bytes;
}
}  // namespace

TEST_CASE("BinaryReader reads back what BinaryWriter wrote, in order") {
  const auto bytes = sample();
  REQUIRE(bytes.size() == 4 + 2 + 8);
  BinaryReader in(bytes, "t.bin");
  CHECK(in.get<std::uint32_t>("a count") == 7u);
  CHECK(in.get<std::uint16_t>("a tag") == std::uint16_t{0xbeef});
  CHECK(in.remaining() == 8);
  auto floats = in.take(8, "two floats");
  REQUIRE(floats);
  CHECK(floats->data() == bytes.data() + 6);
  CHECK(in.remaining() == 0);
  CHECK(in.take(0, "nothing"));
}

TEST_CASE("BinaryReader: reading past the end names source, section, what, offset and what remains") {
  const auto bytes = sample();
  SUBCASE("at a get, with a section") {
    BinaryReader in(std::span(bytes).first(5), "t.bin", "HDR");
    REQUIRE(in.get<std::uint32_t>("a count"));
    auto tag = in.get<std::uint16_t>("a tag");
    REQUIRE_FALSE(tag);
    CHECK(tag.error().kind == ErrorKind::Parse);
    CHECK(tag.error().message == "t.bin: section 'HDR': truncated: a tag needs 2 bytes at offset 4, but only 1 remain");
    CHECK(in.remaining() == 1);  // a failed read moves nothing
  }
  SUBCASE("at a take, without a section") {
    BinaryReader in(bytes, "t.bin");
    REQUIRE(in.take(6, "the head"));
    auto rest = in.take(9, "the floats");
    REQUIRE_FALSE(rest);
    CHECK(rest.error().kind == ErrorKind::Parse);
    CHECK(rest.error().message == "t.bin: truncated: the floats needs 9 bytes at offset 6, but only 8 remain");
    CHECK(in.remaining() == 8);
  }
  SUBCASE("an empty source") {
    BinaryReader in({}, "empty.bin");
    CHECK(in.get<std::uint8_t>("a byte").error().message ==
          "empty.bin: truncated: a byte needs 1 bytes at offset 0, but only 0 remain");
  }
}
