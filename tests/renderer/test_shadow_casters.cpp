// Which objects the key light's shadow map leaves out (renderer::shadows_nothing_visible): a
// flat object with nothing visible behind it, seen from the light. Cases that must keep it
// (something under it, the eye under it, the light grazing or below it, a curved object),
// and an image rendered with the floor left out equal to the same frame with the floor drawn
// into the shadow map (the floor made not quite flat, so the rule keeps it).
#include <doctest/doctest.h>
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <variant>
#include <glm/glm.hpp>
import weft.core;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.test.gpu;
#include "renderer_support.h"

using namespace weft;

namespace {

// A 4 x 4 floor at y = 0 (object 0) and a ball (object 1) at `ball`, the sun along `sun`.
std::string floor_and_ball(glm::vec3 ball, glm::vec3 eye, glm::vec3 sun = {-0.4f, -1.0f, -0.3f},
                           const std::string& floor_rotation = "[0, 0, 0]") {
  return weft::format(R"({{"version": 1, "output": {{"width": 64, "height": 48}},
    "camera": {{"position": [{}, {}, {}], "target": [0, 0.3, 0], "fov": 45}},
    "lights": [{{"type": "directional", "direction": [{}, {}, {}], "intensity": 3}}],
    "meshes": {{"floor": {{"primitive": "plane", "size": 4, "subdivisions": 8}},
                "ball": {{"primitive": "sphere", "radius": 0.3, "segments": 24}}}},
    "materials": {{"grey": {{"base_color": [0.5, 0.5, 0.5]}}, "red": {{"base_color": [0.8, 0.1, 0.1]}}}},
    "objects": [{{"name": "floor", "mesh": "floor", "material": "grey", "transform": {{"rotation_degrees": {}}}}},
                {{"name": "ball", "mesh": "ball", "material": "red", "transform": {{"translation": [{}, {}, {}]}}}}]}})",
                      eye.x, eye.y, eye.z, sun.x, sun.y, sun.z, floor_rotation, ball.x, ball.y, ball.z);
}

glm::vec3 towards(const scene::Scene& s) {
  return -std::get<scene::DirectionalLight>(s.lights.at(0)).direction;
}

}  // namespace

TEST_CASE("a floor under everything shadows nothing; the ball above it does") {
  const scene::Scene s = test::load(floor_and_ball({0.0f, 0.5f, 0.0f}, {0.0f, 2.0f, 3.0f}));
  CHECK(renderer::shadows_nothing_visible(s, 0, towards(s)));
  CHECK_FALSE(renderer::shadows_nothing_visible(s, 1, towards(s)));  // not flat
}

TEST_CASE("a floor with something under it is kept, unless the floor hides that part from the eye") {
  SUBCASE("a ball sunk into the floor, seen from above: the part below is hidden") {
    const scene::Scene s = test::load(floor_and_ball({0.0f, 0.1f, 0.0f}, {0.0f, 2.0f, 3.0f}));
    CHECK(renderer::shadows_nothing_visible(s, 0, towards(s)));
  }
  SUBCASE("the same ball seen from under the floor") {
    const scene::Scene s = test::load(floor_and_ball({0.0f, 0.1f, 0.0f}, {0.0f, -2.0f, 3.0f}));
    CHECK_FALSE(renderer::shadows_nothing_visible(s, 0, towards(s)));
  }
  SUBCASE("a ball under the floor but beside it, where the eye sees it past the floor's edge") {
    const scene::Scene s = test::load(floor_and_ball({3.0f, -0.5f, 0.0f}, {0.0f, 2.0f, 3.0f}));
    CHECK_FALSE(renderer::shadows_nothing_visible(s, 0, towards(s)));
  }
  SUBCASE("a floor that is not opaque by the standard material's rules is not trusted to hide") {
    scene::Scene s = test::load(floor_and_ball({0.0f, 0.1f, 0.0f}, {0.0f, 2.0f, 3.0f}));
    s.materials.at(s.objects[0].material).type = "some_feature";
    CHECK_FALSE(renderer::shadows_nothing_visible(s, 0, towards(s)));
  }
}

TEST_CASE("the light's side decides: light from below, or grazing the floor, keeps it") {
  const scene::Scene below = test::load(floor_and_ball({0.0f, 0.5f, 0.0f}, {0.0f, 2.0f, 3.0f}, {0.2f, 1.0f, 0.1f}));
  CHECK_FALSE(renderer::shadows_nothing_visible(below, 0, towards(below)));
  const scene::Scene grazing = test::load(floor_and_ball({0.0f, 0.5f, 0.0f}, {0.0f, 2.0f, 3.0f}, {1.0f, 0.0f, 0.0f}));
  CHECK_FALSE(renderer::shadows_nothing_visible(grazing, 0, towards(grazing)));
}

TEST_CASE("a tilted floor is a plane like any other") {
  // Tilted 20 degrees about x: the ball 0.5 above the origin is still on its lit side.
  const scene::Scene s = test::load(floor_and_ball({0.0f, 0.5f, 0.0f}, {0.0f, 2.0f, 3.0f}, {-0.4f, -1.0f, -0.3f}, "[20, 0, 0]"));
  CHECK(renderer::shadows_nothing_visible(s, 0, towards(s)));
}

TEST_CASE("leaving the floor out of the shadow map changes no pixel") {
  const scene::Scene flat = test::load(floor_and_ball({0.2f, 0.45f, 0.1f}, {0.0f, 2.0f, 3.0f}));
  REQUIRE(renderer::shadows_nothing_visible(flat, 0, towards(flat)));
  // The same floor with a corner lifted by 1e-3, far from the ball's shadow (a lifted vertex
  // under a shadow's edge moves its penumbra): not flat, so it is drawn into the map.
  scene::Scene bumpy = flat;
  scene::Mesh& floor = bumpy.meshes.at(bumpy.objects[0].mesh);
  floor.positions.at(0).y += 1e-3f;
  REQUIRE_FALSE(renderer::shadows_nothing_visible(bumpy, 0, towards(bumpy)));
  auto a = test::shared_renderer().render(flat);
  REQUIRE(a);
  auto b = test::shared_renderer().render(bumpy);
  REQUIRE(b);
  REQUIRE(a->image.pixels.size() == b->image.pixels.size());
  int worst = 0;
  for (std::size_t i = 0; i < a->image.pixels.size(); ++i)
    worst = std::max(worst, std::abs(int(a->image.pixels[i]) - int(b->image.pixels[i])));
  CHECK(worst <= 1);  // rounding, at most
  // And the ball does cast its shadow: without it the floor is brighter somewhere.
  scene::Scene no_ball = flat;
  no_ball.objects.pop_back();
  auto c = test::shared_renderer().render(no_ball);
  REQUIRE(c);
  int brighter = 0;  // over grey pixels of the frame with the ball (the red ball's own pixels left out)
  for (std::uint32_t y = 0; y < 48; ++y)
    for (std::uint32_t x = 0; x < 64; ++x)
      if (std::abs(test::channel(a->image, x, y, 0) - test::channel(a->image, x, y, 2)) < 10)
        brighter = std::max(brighter, test::channel(c->image, x, y, 1) - test::channel(a->image, x, y, 1));
  CHECK(brighter > 20);
}
