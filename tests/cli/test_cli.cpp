// The command line as a user meets it: bad input gives a one-line reason and a non-zero
// exit; good input writes the image. Runs the real binaries.
#include <doctest/doctest.h>
#include "../support/run_command.h"
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace {
using weft::test::run_command;

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::filesystem::path temp_dir() {
  auto dir = std::filesystem::temp_directory_path() / ("weft-cli-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

const std::string cli = WEFT_CLI;
const char* scene = R"({"version": 1, "output": {"width": 32, "height": 24},
  "camera": {"position": [0, 0, 3], "target": [0, 0, 0]},
  "environment": {"color": [0.2, 0.2, 0.2]},
  "meshes": {"ball": {"primitive": "sphere", "radius": 0.5}},
  "materials": {"m": {"type": "standard"}},
  "objects": [{"name": "ball", "mesh": "ball", "material": "m"}]})";
}  // namespace

TEST_CASE("weft render writes a PNG, and --profile prints the pass table") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  const auto r = run_command(cli + " render " + (dir / "s.json").string() + " -o " + (dir / "out.png").string() + " --profile");
  CHECK_MESSAGE(r.exit_code == 0, r.output);
  CHECK(std::filesystem::file_size(dir / "out.png") > 50);
  CHECK(contains(r.output, "| forward |"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("bad input: missing scene, malformed JSON, unknown field, unwritable output, bad size, bad quality") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  std::ofstream(dir / "broken.json") << "{\"version\": 1, \"objects\": [";
  std::ofstream(dir / "unknown.json") << R"({"version": 1, "colour": 3})";
  const std::string s = (dir / "s.json").string();
  struct Case {
    std::string args, expect;
  };
  for (const auto& c : {Case{"render " + (dir / "nope.json").string() + " -o x.png", "nope.json"},
                        Case{"render " + (dir / "broken.json").string() + " -o x.png", "broken.json"},
                        Case{"render " + (dir / "unknown.json").string() + " -o x.png", "$.colour"},
                        Case{"render " + s + " -o /nonexistent-dir/out.png", "/nonexistent-dir/out.png"},
                        Case{"render " + s + " -o x.png --size 0x5", "--size"},
                        Case{"render " + s + " -o x.png --quality ultra", "ultra"},
                        Case{"graph " + (dir / "nope.json").string(), "nope.json"}}) {
    const auto r = run_command(cli + " " + c.args);
    CHECK_MESSAGE(r.exit_code != 0, c.args);
    CHECK_MESSAGE(contains(r.output, c.expect), c.args << " -> " << r.output);
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("weft graph prints the passes and writes DOT") {
  const auto dir = temp_dir();
  std::ofstream(dir / "s.json") << scene;
  const auto r = run_command(cli + " graph " + (dir / "s.json").string() + " --dot " + (dir / "g.dot").string());
  CHECK_MESSAGE(r.exit_code == 0, r.output);
  CHECK(contains(r.output, "passes: forward background tonemap"));
  std::ifstream dot(dir / "g.dot");
  std::string first;
  std::getline(dot, first);
  CHECK(contains(first, "digraph"));
  std::filesystem::remove_all(dir);
}

TEST_CASE("weft info names the adapter; weft-triangle rejects a bad size and an unwritable path") {
  const auto info = run_command(cli + " info");
  CHECK(info.exit_code == 0);
  CHECK(contains(info.output, "chosen:"));
  const std::string triangle = WEFT_TRIANGLE;
  CHECK(run_command(triangle + " --size 12").exit_code != 0);
  const auto r = run_command(triangle + " -o /nonexistent-dir/t.png --size 16x16");
  CHECK(r.exit_code != 0);
  CHECK(contains(r.output, "/nonexistent-dir/t.png"));
}
