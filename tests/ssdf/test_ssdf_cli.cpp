// `weft bake ssdf` as a user meets it: a small scene file baked to a .wssdf the loader
// reads back; contradictory or out-of-range knobs and a missing scene exit non-zero with a
// reason. Runs the real binary (no GPU needed for a bake).
#include <doctest/doctest.h>
#include "../support/run_command.h"
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
import weft.core;
import weft.ssdf;

namespace {
using weft::test::run_command;

const std::string cli = WEFT_CLI;
const char* scene = R"({"version": 1,
  "meshes": {"ball": {"primitive": "sphere", "radius": 0.5, "segments": 12},
             "floor": {"primitive": "plane", "size": 3, "subdivisions": 4}},
  "objects": [{"name": "ball", "mesh": "ball", "transform": {"translation": [0, 0.5, 0]}},
              {"name": "floor", "mesh": "floor"}]})";
}  // namespace

TEST_CASE("weft bake ssdf writes a .wssdf the loader reads; bad knobs are refused") {
  const auto dir = std::filesystem::temp_directory_path() / ("weft-ssdf-cli-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "s.json") << scene;
  const std::string base = cli + " bake ssdf " + (dir / "s.json").string() + " -o " + (dir / "s.wssdf").string();
  const auto r = run_command(base + " --resolution 8 --clusters 4 --components 3 --coefficients fp16");
  REQUIRE_MESSAGE(r.exit_code == 0, r.output);
  CHECK(r.output.find("smaller") != std::string::npos);
  auto asset = weft::ssdf::read_file(dir / "s.wssdf");
  REQUIRE_MESSAGE(asset, (asset ? "" : asset.error().what()));
  CHECK(asset->resolution == 8);
  CHECK(asset->cpca.clusters.size() == 4);
  CHECK(asset->cpca.total_components() <= 12);
  const auto energy = run_command(base + " --resolution 6 --energy 0.9 --seeding farthest --no-center --half-basis");
  CHECK_MESSAGE(energy.exit_code == 0, energy.output);
  auto half = weft::ssdf::read_file(dir / "s.wssdf");
  REQUIRE(half);
  CHECK(half->cpca.half_basis);
  for (const char* bad : {" --components 3 --energy 0.9", " --energy 1.5", " --resolution 0", " --seeding random",
                          " --coefficients fp8"}) {
    CAPTURE(bad);
    const auto e = run_command(base + bad);
    CHECK(e.exit_code != 0);
    CHECK(!e.output.empty());
  }
  const auto missing = run_command(cli + " bake ssdf " + (dir / "none.json").string() + " -o " + (dir / "x.wssdf").string());
  CHECK(missing.exit_code != 0);
  CHECK(missing.output.find("none.json") != std::string::npos);
  std::filesystem::remove_all(dir);
}
