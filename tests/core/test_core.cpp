#include <doctest/doctest.h>
#include <string>
import weft.core;

using namespace weft;

namespace {
Result<int> parse_positive(int v) {
  if (v <= 0) return fail(ErrorKind::InvalidArgument, "value {} is not positive", v);
  return v;
}
}  // namespace

TEST_CASE("Result carries a value or an Error with kind and message") {
  auto ok = parse_positive(3);
  REQUIRE(ok);
  CHECK(*ok == 3);
  auto bad = parse_positive(-2);
  REQUIRE(!bad);
  CHECK(bad.error().kind == ErrorKind::InvalidArgument);
  CHECK(bad.error().message == "value -2 is not positive");
  CHECK(bad.error().what() == "invalid argument: value -2 is not positive");
}

TEST_CASE("with_context prefixes where the error happened") {
  auto e = with_context("loading 'a.json'", Error{ErrorKind::Parse, "line 3: unexpected '}'"});
  CHECK(e.error().message == "loading 'a.json': line 3: unexpected '}'");
  CHECK(e.error().kind == ErrorKind::Parse);
}

TEST_CASE("Hasher is FNV-1a 64 and stable") {
  // Reference values of FNV-1a 64: "" and "a".
  CHECK(Hasher{}.digest() == 0xcbf29ce484222325ull);
  CHECK(Hasher{}.bytes("a", 1).digest() == 0xaf63dc4c8601ec8cull);
  CHECK(Hasher{}.str("ab").digest() != Hasher{}.str("ba").digest());
  // Length-prefixed strings: ("a","bc") and ("ab","c") differ.
  CHECK(Hasher{}.str("a").str("bc").digest() != Hasher{}.str("ab").str("c").digest());
  CHECK(hex64(0xabcull) == "0000000000000abc");
}

TEST_CASE("weft::format formats like std::format") {
  CHECK(weft::format("{} + {} = {:.2f}", 1, 2, 3.0) == "1 + 2 = 3.00");
  CHECK(weft::format("'{}'", std::string("label")) == "'label'");
}
