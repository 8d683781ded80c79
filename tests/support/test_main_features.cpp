// The doctest main of suites that render or parse feature materials: it registers weft's
// built-in features first, as the `weft` tool does.
#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>
#include <cstdio>
import weft.core;
import weft.builtin_features;

int main(int argc, char** argv) {
  if (auto ok = weft::register_builtins(); !ok) {
    std::fprintf(stderr, "registering the built-in features: %s\n", ok.error().what().c_str());
    return 1;
  }
  return doctest::Context(argc, argv).run();
}
