// weft.viewer's parts that need no window: the orbit camera and the script reader.
#include <doctest/doctest.h>
#include <cmath>
#include <string>
#include <vector>
#include <glm/glm.hpp>
import weft.core;
import weft.viewer;

using weft::viewer::CameraPose;
using weft::viewer::OrbitCamera;

namespace {
bool near(glm::vec3 a, glm::vec3 b, float eps = 1e-4f) { return glm::length(a - b) < eps; }
const CameraPose start{{2.6f, 1.5f, 3.4f}, {0.0f, 0.55f, 0.0f}};
}  // namespace

TEST_CASE("orbit camera starts at the scene's camera and comes back after a full turn") {
  OrbitCamera camera(start);
  CHECK(near(camera.pose().position, start.position));
  CHECK(near(camera.pose().target, start.target));
  const float distance = glm::length(start.position - start.target);
  for (int i = 0; i < 36; ++i) camera.orbit(10.0f, 0.0f);
  CHECK(near(camera.pose().position, start.position, 1e-3f));
  // Orbiting keeps the distance to the target.
  camera.orbit(33.0f, 20.0f);
  CHECK(glm::length(camera.pose().position - camera.pose().target) == doctest::Approx(distance).epsilon(1e-5));
}

TEST_CASE("orbit camera: pitch stops short of the poles, so the view never flips") {
  OrbitCamera camera(start);
  camera.orbit(0.0f, 500.0f);
  const glm::vec3 offset = camera.pose().position - camera.pose().target;
  const float elevation = glm::degrees(std::asin(offset.y / glm::length(offset)));
  CHECK(elevation == doctest::Approx(89.0f).epsilon(1e-4));
  camera.orbit(0.0f, -1000.0f);
  const glm::vec3 below = camera.pose().position - camera.pose().target;
  CHECK(glm::degrees(std::asin(below.y / glm::length(below))) == doctest::Approx(-89.0f).epsilon(1e-4));
}

TEST_CASE("orbit camera: zoom scales the distance, pan moves across the view, fly keeps the distance") {
  OrbitCamera camera(start);
  const float d = camera.distance();
  camera.zoom(0.5f);
  CHECK(camera.distance() == doctest::Approx(d * 0.5f));
  camera.zoom(0.0f);  // ignored: not > 0
  camera.zoom(NAN);   // ignored: not finite
  CHECK(camera.distance() == doctest::Approx(d * 0.5f));
  for (int i = 0; i < 100; ++i) camera.zoom(1e-3f);
  CHECK(camera.distance() > 0.0f);  // clamped away from zero, the pose stays defined
  CHECK(std::isfinite(camera.pose().position.x));

  OrbitCamera panned(start);
  const glm::vec3 view = glm::normalize(start.target - start.position);
  panned.pan(0.1f, 0.05f);
  const glm::vec3 moved = panned.pose().target - start.target;
  CHECK(glm::length(moved) > 0.0f);
  CHECK(std::abs(glm::dot(glm::normalize(moved), view)) < 1e-4f);  // across the view, not along it
  CHECK(near(panned.pose().position - panned.pose().target, start.position - start.target));

  OrbitCamera flown(start);
  flown.fly(0.25f, 0.0f, 0.0f);
  CHECK(near(flown.pose().target - start.target, view * 0.25f * d, 1e-4f));
  CHECK(glm::length(flown.pose().position - flown.pose().target) == doctest::Approx(d));
  flown.reset();
  CHECK(near(flown.pose().position, start.position));
}

TEST_CASE("a script is read whole: commands, comments, blank lines") {
  auto script = weft::viewer::parse_script("s.txt",
                                           "# a session\n"
                                           "orbit 10 -5\n"
                                           "\n"
                                           "knob skin lut.size 32   # a comment after a command\n"
                                           "knob skin lut.range \"full\"\n"
                                           "resize 64 48\n"
                                           "screenshot out.png\n"
                                           "quit\n");
  REQUIRE(script);
  REQUIRE(script->commands.size() == 6);
  CHECK(script->commands[0].name == "orbit");
  CHECK(script->commands[0].args == std::vector<std::string>{"10", "-5"});
  CHECK(script->commands[1].line == 4);
  CHECK(script->commands[2].args[2] == "\"full\"");
}

TEST_CASE("a bad script line is an error naming the file, the line and the fault") {
  auto error_of = [](const std::string& text) {
    auto script = weft::viewer::parse_script("session.txt", text);
    REQUIRE_FALSE(script);
    return script.error().message;
  };
  CHECK(error_of("orbit 1 2\norbitt 1 2\n").starts_with("session.txt:2: unknown command 'orbitt' (known: "));
  CHECK(error_of("zoom\n") == "session.txt:1: 'zoom' takes 1 argument(s): zoom FACTOR");
  CHECK(error_of("pan 1 up\n") == "session.txt:1: 'pan' expects numbers, got 'up': pan RIGHT UP");
  CHECK(error_of("zoom -2\n") == "session.txt:1: zoom factor must be > 0");
  CHECK(error_of("resize 0 10\n") == "session.txt:1: resize needs whole sizes within 1..16384");
  // Numbers past int's range were std::stoi's uncaught out_of_range (a crash).
  CHECK(error_of("resize 99999999999 5\n") == "session.txt:1: resize needs whole sizes within 1..16384");
  CHECK(error_of("resize 64.5 48\n") == "session.txt:1: resize needs whole sizes within 1..16384");
  CHECK(error_of("wait 1e12\n") == "session.txt:1: wait needs a whole number of frames within 0..1000000");
  CHECK(error_of("zoom 1e39\n") == "session.txt:1: 'zoom' expects finite numbers, got '1e39': zoom FACTOR");
  CHECK(error_of("show\n").find("'show' takes 1 argument(s)") != std::string::npos);
  CHECK(error_of("ui maybe\n") == "session.txt:1: ui takes on or off");
  CHECK(error_of("budget 0\n") == "session.txt:1: budget must be a positive number of milliseconds");
  CHECK(error_of("budget -5\n") == "session.txt:1: budget must be a positive number of milliseconds");
  CHECK(error_of("budget fast\n") == "session.txt:1: 'budget' expects numbers, got 'fast': budget MILLISECONDS");
  CHECK(error_of("budget\n") == "session.txt:1: 'budget' takes 1 argument(s): budget MILLISECONDS");
  CHECK(error_of("accumulate 0\n") == "session.txt:1: accumulate needs a whole number of samples within 1..4096 (1: off)");
  CHECK(error_of("accumulate 2.5\n") == "session.txt:1: accumulate needs a whole number of samples within 1..4096 (1: off)");
  CHECK(error_of("accumulate 5000\n") == "session.txt:1: accumulate needs a whole number of samples within 1..4096 (1: off)");
  CHECK(error_of("accumulate nan\n") == "session.txt:1: 'accumulate' expects finite numbers, got 'nan': accumulate SAMPLES");
  CHECK(error_of("settle now\n") == "session.txt:1: 'settle' takes 0 argument(s): settle");
  CHECK(error_of("knob skin lut.range full\n") ==
        "session.txt:1: knob value 'full' is not JSON (numbers, true/false, or \"quoted\" text)");
}

TEST_CASE("issue 33: a script's non-finite numbers are refused, naming the line (orbit nan nan hung the viewer)") {
  auto error_of = [](const std::string& text) {
    auto script = weft::viewer::parse_script("session.txt", text);
    REQUIRE_FALSE(script);
    return script.error().message;
  };
  CHECK(error_of("orbit 10 0\norbit nan nan\n") == "session.txt:2: 'orbit' expects finite numbers, got 'nan': orbit DYAW DPITCH");
  CHECK(error_of("pan inf -inf\n") == "session.txt:1: 'pan' expects finite numbers, got 'inf': pan RIGHT UP");
  CHECK(error_of("pan 0 -infinity\n") == "session.txt:1: 'pan' expects finite numbers, got '-infinity': pan RIGHT UP");
  CHECK(error_of("zoom nan\n") == "session.txt:1: 'zoom' expects finite numbers, got 'nan': zoom FACTOR");
  CHECK(error_of("fly 0 NaN 0\n") == "session.txt:1: 'fly' expects finite numbers, got 'NaN': fly FORWARD RIGHT UP");
  CHECK(error_of("budget inf\n") == "session.txt:1: 'budget' expects finite numbers, got 'inf': budget MILLISECONDS");
  CHECK(error_of("wait nan\n") == "session.txt:1: 'wait' expects finite numbers, got 'nan': wait FRAMES");
  // Huge but finite numbers are numbers; the camera decides what to do with them (below).
  CHECK(weft::viewer::parse_script("session.txt", "orbit 1e30 -1e30\npan 1e38 1e38\nfly 1e38 0 0\n"));
}

TEST_CASE("issue 33: the orbit camera's pose stays finite whatever it is asked") {
  const auto finite = [](const CameraPose& p) {
    return std::isfinite(p.position.x) && std::isfinite(p.position.y) && std::isfinite(p.position.z) &&
           std::isfinite(p.target.x) && std::isfinite(p.target.y) && std::isfinite(p.target.z);
  };
  OrbitCamera camera(start);
  const CameraPose before = camera.pose();
  // Non-finite arguments are refused and change nothing.
  CHECK_FALSE(camera.orbit(NAN, NAN));
  CHECK_FALSE(camera.orbit(0.0f, INFINITY));
  CHECK_FALSE(camera.pan(INFINITY, -INFINITY));
  CHECK_FALSE(camera.pan(NAN, 0.0f));
  CHECK_FALSE(camera.zoom(NAN));
  CHECK_FALSE(camera.zoom(INFINITY));
  CHECK_FALSE(camera.fly(NAN, 0.0f, 0.0f));
  CHECK_FALSE(camera.fly(0.0f, 0.0f, -INFINITY));
  CHECK(camera.pose() == before);
  // Finite arguments whose move would overflow are refused too: the pose stays finite.
  CHECK_FALSE(camera.pan(3e38f, 3e38f));
  CHECK_FALSE(camera.fly(3e38f, 0.0f, 0.0f));
  for (int i = 0; i < 100; ++i) camera.zoom(1e30f);  // refused once the distance would overflow
  CHECK(finite(camera.pose()));
  CHECK(std::isfinite(camera.distance()));
  // Huge finite orbits turn the camera and keep it finite and at its distance.
  OrbitCamera spun(start);
  CHECK(spun.orbit(1e30f, -1e30f));
  CHECK(finite(spun.pose()));
  CHECK(glm::length(spun.pose().position - spun.pose().target) == doctest::Approx(glm::length(start.position - start.target)).epsilon(1e-4));
  // The moves a user makes still work after a refused one.
  CHECK(camera.orbit(10.0f, 5.0f));
  CHECK(camera.pan(0.1f, 0.0f));
  CHECK(finite(camera.pose()));
  // A start that is not finite (a scene built in code) gives a finite camera, not a NaN view.
  OrbitCamera from_nan({{NAN, 0.0f, 1.0f}, {0.0f, INFINITY, 0.0f}});
  CHECK(finite(from_nan.pose()));
  CHECK(from_nan.orbit(30.0f, 10.0f));
  CHECK(finite(from_nan.pose()));
}
