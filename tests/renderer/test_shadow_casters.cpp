// Which objects the key light's shadow map leaves out (renderer::shadows_nothing_visible): a
// flat object with nothing visible behind it, seen from the light. Cases that must keep it
// (something under it, the eye under it, the light grazing or below it, a curved object),
// and an image rendered with the floor left out equal to the same frame with the floor drawn
// into the shadow map (the floor made not quite flat, so the rule keeps it). And
// select_shadow_casters, the renderer's selection of every object at once, against the
// object-by-object answer on random scenes, with its work bounded on 20,000 floor tiles.
#include <doctest/doctest.h>
#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <variant>
#include <vector>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
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

// ---- select_shadow_casters: every object at once (issue 33: 30,000 lit objects took 48 s) ----

namespace {

// What the renderer did before: each object asked on its own, against every other.
std::vector<bool> object_by_object(const scene::Scene& s, glm::vec3 towards_light) {
  std::vector<bool> casts(s.objects.size());
  for (std::uint32_t i = 0; i < s.objects.size(); ++i) casts[i] = !renderer::shadows_nothing_visible(s, i, towards_light);
  return casts;
}

// A random scene of floors, tiles, cards tilted in their own space, cubes and balls above,
// on and under the floor, some sunk into it, with standard and feature materials, the eye
// above or below and the sun from any side: the cases of the rule, mixed.
scene::Scene random_scene(std::mt19937& rng, std::uint32_t objects) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f), sym(-1.0f, 1.0f);
  scene::Scene s;
  s.meshes.push_back(*scene::make_plane(4.0f, 2));
  s.meshes.push_back(*scene::make_plane(0.5f, 1));
  s.meshes.push_back(*scene::make_cube(0.4f));
  s.meshes.push_back(*scene::make_sphere(0.2f, 8));
  scene::Mesh card = *scene::make_plane(0.6f, 1);  // flat, but tilted in its own space: a 3-D box
  card.bounds = {};
  for (glm::vec3& p : card.positions) {
    p = glm::vec3(p.x, 0.5f * p.x + 0.25f * p.z, p.z);
    card.bounds.extend(p);
  }
  s.meshes.push_back(card);
  s.materials.push_back(scene::Material{.name = "standard"});
  s.materials.push_back(scene::Material{.name = "feature", .type = "some_feature"});
  for (std::uint32_t i = 0; i < objects; ++i) {
    const std::uint32_t mesh = i == 0 ? 0u : std::uint32_t(rng() % s.meshes.size());
    const float height = unit(rng) < 0.3f ? 0.0f : unit(rng) < 0.5f ? sym(rng) * 0.15f : sym(rng) * 2.0f;
    scene::Transform t{.translation = {sym(rng) * 3.0f, height, sym(rng) * 3.0f}};
    if (unit(rng) < 0.3f) t.rotation = scene::Transform::rotation_from_euler_degrees({sym(rng) * 30.0f, sym(rng) * 180.0f, 0.0f});
    s.objects.push_back({.name = "o" + std::to_string(i), .mesh = mesh, .material = unit(rng) < 0.85f ? 0u : 1u,
                         .transform = t.matrix()});
  }
  s.camera.position = {sym(rng) * 4.0f, unit(rng) < 0.8f ? 1.0f + 3.0f * unit(rng) : -2.0f, 4.0f + unit(rng)};
  s.camera.target = {0.0f, 0.0f, 0.0f};
  return s;
}

}  // namespace

TEST_CASE("select_shadow_casters gives the object-by-object answer on random scenes") {
  std::mt19937 rng(33);
  std::uniform_real_distribution<float> sym(-1.0f, 1.0f);
  int left_out = 0, kept_flat = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    const scene::Scene s = random_scene(rng, 1 + std::uint32_t(rng() % 60));
    glm::vec3 sun(sym(rng), -1.0f + 0.3f * sym(rng), sym(rng));
    if (trial % 7 == 0) sun = -sun;  // from below
    if (trial % 11 == 0) sun = {1.0f, 0.0f, 0.0f};  // grazing the floors
    const glm::vec3 towards = -sun;
    CAPTURE(trial);
    const std::vector<bool> reference = object_by_object(s, towards);
    renderer::ShadowCasterStats stats;
    const std::vector<bool> casts = renderer::select_shadow_casters(s, towards, &stats);
    REQUIRE(casts.size() == s.objects.size());
    for (std::size_t i = 0; i < casts.size(); ++i) {
      CAPTURE(i);
      CHECK(casts[i] == reference[i]);
      left_out += !casts[i];
    }
    kept_flat += int(stats.flat_objects) - int(std::count(casts.begin(), casts.end(), false));
  }
  // Both answers came up often, so the comparison says something.
  MESSAGE("left out " << left_out << ", flat and kept " << kept_flat);
  CHECK(left_out > 100);
  CHECK(kept_flat > 100);
}

TEST_CASE("select_shadow_casters agrees with the reference on the rule's own cases (a sunk ball hidden, or not)") {
  struct Case {
    glm::vec3 ball, eye, sun;
    std::string rotation;
  };
  const glm::vec3 sun{-0.4f, -1.0f, -0.3f};
  for (const Case& c : {Case{{0.0f, 0.5f, 0.0f}, {0.0f, 2.0f, 3.0f}, sun, "[0, 0, 0]"},
                        Case{{0.0f, 0.1f, 0.0f}, {0.0f, 2.0f, 3.0f}, sun, "[0, 0, 0]"},    // sunk, hidden by the floor
                        Case{{0.0f, 0.1f, 0.0f}, {0.0f, -2.0f, 3.0f}, sun, "[0, 0, 0]"},   // seen from below
                        Case{{3.0f, -0.5f, 0.0f}, {0.0f, 2.0f, 3.0f}, sun, "[0, 0, 0]"},   // past the floor's edge
                        Case{{0.0f, 0.5f, 0.0f}, {0.0f, 2.0f, 3.0f}, {0.2f, 1.0f, 0.1f}, "[0, 0, 0]"},
                        Case{{0.0f, 0.5f, 0.0f}, {0.0f, 2.0f, 3.0f}, {1.0f, 0.0f, 0.0f}, "[0, 0, 0]"},
                        Case{{0.0f, 0.5f, 0.0f}, {0.0f, 2.0f, 3.0f}, sun, "[20, 0, 0]"}}) {
    const scene::Scene s = test::load(floor_and_ball(c.ball, c.eye, c.sun, c.rotation));
    CAPTURE(c.ball.y);
    CAPTURE(c.eye.y);
    const std::vector<bool> casts = renderer::select_shadow_casters(s, towards(s));
    REQUIRE(casts.size() == 2);
    CHECK(casts[0] == !renderer::shadows_nothing_visible(s, 0, towards(s)));
    CHECK(casts[1]);  // the ball is not flat
  }
  // The sunk ball seen from above: left out although the ball dips under the floor.
  const scene::Scene sunk = test::load(floor_and_ball({0.0f, 0.1f, 0.0f}, {0.0f, 2.0f, 3.0f}));
  renderer::ShadowCasterStats stats;
  CHECK_FALSE(renderer::select_shadow_casters(sunk, towards(sunk), &stats)[0]);
  CHECK(stats.boxes_tested == 1);  // the ball's box was given the hiding test
}

TEST_CASE("select_shadow_casters: an empty scene, boxes that are empty or not finite, as the reference says") {
  scene::Scene s;
  CHECK(renderer::select_shadow_casters(s, {0.0f, 1.0f, 0.0f}).empty());
  s.meshes.push_back(*scene::make_plane(4.0f, 1));
  s.meshes.push_back(*scene::make_cube(0.5f));
  scene::Mesh empty;  // no vertices: an empty box, no obstacle
  s.meshes.push_back(empty);
  s.materials.push_back(scene::Material{.name = "standard"});
  s.camera.position = {0.0f, 2.0f, 3.0f};
  s.objects.push_back({.name = "floor", .mesh = 0, .material = 0});
  s.objects.push_back({.name = "cube", .mesh = 1, .material = 0, .transform = glm::translate(glm::mat4(1.0f), {0.0f, 1.0f, 0.0f})});
  s.objects.push_back({.name = "nothing", .mesh = 2, .material = 0});
  const glm::vec3 towards{0.3f, 1.0f, 0.2f};
  CHECK(renderer::select_shadow_casters(s, towards) == std::vector<bool>{false, true, true});
  CHECK(renderer::select_shadow_casters(s, towards) == object_by_object(s, towards));
  // A box with a NaN corner is tested on its own, exactly (it keeps the floor).
  scene::Object broken{.name = "broken", .mesh = 1, .material = 0, .transform = glm::mat4(1.0f)};
  broken.transform[3][1] = std::nanf("");
  s.objects.push_back(broken);
  CHECK(renderer::select_shadow_casters(s, towards) == object_by_object(s, towards));
}

TEST_CASE("select_shadow_casters tests a box per flat object or so, not every other box (20,000 floor tiles)") {
  // A floor of 20,000 tiles with a cube over every tenth: each tile shadows nothing. Asked
  // object by object that is 20,000 x 21,999 box tests; the hierarchy skips the boxes above
  // the floor a node at a time.
  scene::Scene s;
  s.meshes.push_back(*scene::make_plane(1.0f, 1));
  s.meshes.push_back(*scene::make_cube(0.3f));
  s.materials.push_back(scene::Material{.name = "standard"});
  const std::uint32_t side = 200, tiles = side * 100;
  for (std::uint32_t i = 0; i < tiles; ++i) {
    const glm::vec3 at(float(i % side) - 100.0f, 0.0f, float(i / side) - 50.0f);
    s.objects.push_back({.name = "tile", .mesh = 0, .material = 0, .transform = glm::translate(glm::mat4(1.0f), at)});
    if (i % 10 == 0)
      s.objects.push_back({.name = "cube", .mesh = 1, .material = 0,
                           .transform = glm::translate(glm::mat4(1.0f), at + glm::vec3(0.0f, 0.5f, 0.0f))});
  }
  s.camera.position = {0.0f, 30.0f, 80.0f};
  renderer::ShadowCasterStats stats;
  const std::vector<bool> casts = renderer::select_shadow_casters(s, {0.3f, 1.0f, 0.2f}, &stats);
  CHECK(stats.flat_objects == tiles);
  CHECK(stats.boxes_tested <= 64ull * tiles);
  for (std::uint32_t i = 0; i < s.objects.size(); ++i) {
    if (casts[i] != (s.objects[i].name == "cube")) {
      CHECK_MESSAGE(false, "object " << i << " (" << s.objects[i].name << ") casts: " << casts[i]);
      break;
    }
  }
  // A sample of the tiles, asked one by one, agrees.
  for (std::uint32_t i = 0; i < s.objects.size(); i += 997)
    CHECK(casts[i] == !renderer::shadows_nothing_visible(s, i, {0.3f, 1.0f, 0.2f}));
}
