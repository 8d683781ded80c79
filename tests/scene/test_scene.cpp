#include <doctest/doctest.h>
import weft.scene;
TEST_CASE("placeholder") { CHECK(true); }
