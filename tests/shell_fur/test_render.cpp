// ShellFurPass on lavapipe under validation + synchronization validation, in a frame of its
// own (FurFrame): the quad seen from straight above reproduces the photo for every layer
// count and both layouts, the extremes render finite with the limit behaviour asserted, the
// naive per-layer-texture method draws the same image, Kajiya-Kay matches its closed form,
// and fins thicken silhouettes. Images are 64x64.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <span>
#include <string>
#include <vector>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.image;
import weft.scene;
import weft.pass.shell_fur;
import weft.example.fur_frame;
import weft.test.gpu;

using namespace weft;
using namespace weft::passes;
using namespace weft::fur;

namespace {

constexpr std::uint32_t size = 64;

frame::MeshData mesh_data(const scene::Mesh& mesh) {
  frame::MeshData out{mesh.name, std::vector<frame::Vertex>(mesh.positions.size()), mesh.indices};
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    out.vertices[i].position = mesh.positions[i];
    out.vertices[i].normal = mesh.normals[i];
    out.vertices[i].tangent = mesh.tangents[i];
    if (mesh.has_uvs()) out.vertices[i].uv = mesh.uvs[i];
  }
  return out;
}

scene::Mesh unit_quad() {
  auto plane = scene::make_plane(1.0f, 1);  // XZ, facing +Y, u along +X, v along +Z
  REQUIRE(plane);
  return std::move(*plane);
}

// Straight down onto the unit quad, one pixel per texel of a size x size photo.
FurFrameSettings top_orthographic() {
  FurFrameSettings s;
  s.width = s.height = size;
  s.view = glm::lookAtRH(vec3(0, 2, 0), vec3(0), vec3(0, 0, -1));
  s.projection = glm::orthoRH_ZO(-0.5f, 0.5f, -0.5f, 0.5f, 0.1f, 10.0f);
  s.projection[1][1] *= -1.0f;
  s.camera_position = vec3(0, 2, 0);
  return s;
}

FurFrameSettings perspective(vec3 eye, vec3 target = vec3(0), float fov_degrees = 40.0f) {
  FurFrameSettings s;
  s.width = s.height = size;
  s.view = glm::lookAtRH(eye, target, vec3(0, 1, 0));
  s.projection = frame::perspective_vk(glm::radians(fov_degrees), 1.0f, 0.05f, 20.0f);
  s.camera_position = eye;
  return s;
}

struct FurCase {
  image::Image8 photo;
  std::optional<scene::Mesh> mesh;  // default: the unit quad
  std::uint32_t layers = 15;
  FurLayout layout = FurLayout::Strand;
  FurMethod method = FurMethod::SinglePhoto;
  FurShading shading{.thickness = 0.1f, .lighting = FurLighting::Lambert};
  bool fins = false;
  FurFrameSettings frame = top_orthographic();
};

ShellFurPass& shared_pass() {
  static auto pass = ShellFurPass::create(weft::test::gpu().device);
  REQUIRE_MESSAGE(pass, (pass ? "" : pass.error().what()));
  return *pass;
}

image::Image render(const FurCase& c) {
  auto& device = weft::test::gpu().device;
  auto photo = analyze_fur_photo(c.photo);
  REQUIRE_MESSAGE(photo, (photo ? "" : photo.error().what()));
  auto texture = upload_fur_photo(device, *photo, "test");
  REQUIRE(texture);
  auto table = make_band_table(photo->i_max, photo->i_min, c.layers, c.layout);
  REQUIRE(table);
  auto layers = upload_band_table(device, std::move(*table), "test",
                                  c.method == FurMethod::PerLayerTextures ? &*photo : nullptr);
  REQUIRE_MESSAGE(layers, (layers ? "" : layers.error().what()));
  const scene::Mesh mesh = c.mesh ? *c.mesh : unit_quad();
  auto gpu_mesh = frame::upload_mesh(device, mesh_data(mesh));
  REQUIRE(gpu_mesh);
  std::optional<FurFins> fins;
  if (c.fins) {
    auto uploaded = upload_fins(device, make_fin_edges(mesh.positions, mesh.normals, mesh.uvs, mesh.indices), "test");
    REQUIRE(uploaded);
    fins.emplace(std::move(*uploaded));
  }
  const ShellFurDraw draw{.mesh = &*gpu_mesh, .photo = &*texture, .layers = &*layers,
                          .fins = fins ? &*fins : nullptr, .shading = c.shading, .method = c.method};
  auto f = FurFrame::create(device, c.frame);
  REQUIRE(f);
  auto ok = f->set_draws(shared_pass(), std::span(&draw, 1));
  REQUIRE_MESSAGE(ok, (ok ? "" : ok.error().what()));
  auto stats = f->execute();
  REQUIRE_MESSAGE(stats, (stats ? "" : stats.error().what()));
  auto image = f->read_color();
  REQUIRE(image);
  if (const char* dump = std::getenv("WEFT_FUR_TEST_IMAGES")) {
    static int counter = 0;
    (void)image::save_image(std::string(dump) + "/render" + std::to_string(counter++) + ".png", *image);
  }
  weft::test::expect_no_validation_messages();
  return std::move(*image);
}

// The photo as the render should show it from above: sRGB-decoded colour.
image::Image expected_from_above(const image::Image8& photo) {
  image::Image out = image::Image::filled(photo.width, photo.height, 4, 1.0f);
  for (std::uint32_t y = 0; y < photo.height; ++y)
    for (std::uint32_t x = 0; x < photo.width; ++x)
      for (std::uint32_t k = 0; k < 3; ++k)
        out.at(x, y, k) = image::srgb_to_linear(photo.at(x, y, photo.channels >= 3 ? k : 0) / 255.0f);
  return out;
}

double max_difference(const image::Image& a, const image::Image& b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.pixels.size(); ++i) worst = std::max(worst, double(std::abs(a.pixels[i] - b.pixels[i])));
  return worst;
}

bool all_finite(const image::Image& img) {
  return std::all_of(img.pixels.begin(), img.pixels.end(), [](float v) { return std::isfinite(v); });
}

// How far a flat, fully lit texel of a uniform photo may read from its exact linear colour:
// the driver's 8-bit sRGB decode plus the RGBA16F target's rounding, nothing of the fur.
// lavapipe decodes sRGB8 with a cubic polynomial (Mesa's gallivm lp_build_srgb_to_linear,
// within 0.35 of a code); rendering every code from above measured at most 1.64e-3 (code
// 212; 1.41e-3 at 200, 7.8e-4 at 120, 6.0e-4 at 180), the rounding included. An exact
// decoder leaves the rounding alone: at most 2.4e-4 below 1.
constexpr double decode_tolerance = 2e-3;

// Every covered pixel of a uniform photo reads one colour: the same texel, undarkened, under
// the same light, whichever layer shows it. Independent of the driver's decode.
constexpr double one_colour_spread = 1e-4;

bool is_background(const image::Image& img, std::uint32_t x, std::uint32_t y) {
  return img.at(x, y, 0) == 0.0f && img.at(x, y, 1) == 0.0f && img.at(x, y, 2) == 0.0f;
}

image::Image8 fur_photo(std::uint32_t seed = 11) {
  return synthesize_fur_photo({.width = size, .height = size, .hair_length = 14.0f, .seed = seed});
}

image::Image8 solid(std::uint32_t w, std::uint32_t h, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  image::Image8 img = image::Image8::filled(w, h, 3);
  for (std::size_t i = 0; i < img.pixels.size(); i += 3) {
    img.pixels[i] = r;
    img.pixels[i + 1] = g;
    img.pixels[i + 2] = b;
  }
  return img;
}

}  // namespace

TEST_CASE("a quad seen from straight above reproduces the photo for every layer count, band and strand") {
  const image::Image8 photo = fur_photo();
  const image::Image expected = expected_from_above(photo);
  for (FurLayout layout : {FurLayout::Band, FurLayout::Strand})
    for (std::uint32_t layers : {1u, 2u, 15u, 64u, 256u}) {
      const image::Image got = render({.photo = photo, .layers = layers, .layout = layout});
      CHECK_MESSAGE(max_difference(got, expected) < 2e-3, to_string(layout) << " N=" << layers);
    }
}

TEST_CASE("h_b = 0: every layer lies on the skin and the fur collapses to the photo, seen from any angle") {
  const image::Image8 photo = fur_photo(12);
  const FurFrameSettings oblique = perspective(vec3(0.0f, 0.9f, 1.0f));
  const image::Image flat = render({.photo = photo, .layers = 1, .layout = FurLayout::Band,
                                    .shading = {.thickness = 0.0f, .lighting = FurLighting::Lambert}, .frame = oblique});
  CHECK(all_finite(flat));
  for (FurLayout layout : {FurLayout::Band, FurLayout::Strand}) {
    const image::Image got = render({.photo = photo, .layers = 15, .layout = layout,
                                     .shading = {.thickness = 0.0f, .lighting = FurLighting::Lambert}, .fins = true,
                                     .frame = oblique});
    CHECK_MESSAGE(max_difference(got, flat) < 2e-3, to_string(layout));
  }
  // With thickness the fur rises towards the camera: the image changes.
  const image::Image thick = render({.photo = photo, .shading = {.thickness = 0.15f, .lighting = FurLighting::Lambert},
                                     .frame = oblique});
  CHECK(max_difference(thick, flat) > 0.05);
}

TEST_CASE("a uniform photo (I_max = I_min) puts every texel in the top shell: one colour, no darkening") {
  const image::Image8 photo = solid(16, 16, 180, 150, 120);
  const vec3 colour{image::srgb_to_linear(180 / 255.0f), image::srgb_to_linear(150 / 255.0f),
                    image::srgb_to_linear(120 / 255.0f)};
  for (std::uint32_t layers : {1u, 15u, 256u}) {
    // From an angle the strand layers below the tips show along the quad's near edge; they
    // must not be darkened (I(n) = I_max for every n: the band tops are the texel's own
    // luminance, not half a code below it, which read 0.71 % dark, 3.2e-3 in red).
    const image::Image got = render({.photo = photo, .layers = layers, .frame = perspective(vec3(0.3f, 0.8f, 1.0f))});
    std::size_t covered = 0;
    vec3 lowest(1e9f), highest(-1e9f);
    for (std::uint32_t y = 0; y < size; ++y)
      for (std::uint32_t x = 0; x < size; ++x) {
        if (is_background(got, x, y)) continue;
        ++covered;
        for (int k = 0; k < 3; ++k) {
          const float v = got.at(x, y, std::uint32_t(k));
          lowest[k] = std::min(lowest[k], v);
          highest[k] = std::max(highest[k], v);
          CHECK(std::abs(v - colour[k]) < decode_tolerance);
        }
      }
    CHECK(covered > size * size / 8);
    for (int k = 0; k < 3; ++k) CHECK_MESSAGE(highest[k] - lowest[k] < one_colour_spread, "N=" << layers << " channel " << k);
  }
}

TEST_CASE("black pixels (I_min = 0): finite output, black texels stay black on the skin") {
  image::Image8 photo = fur_photo(13);
  for (std::uint32_t y = 0; y < size; ++y)
    for (std::uint32_t x = 0; x < size; x += 2)
      for (std::uint32_t k = 0; k < 3; ++k) photo.at(x, y, k) = 0;
  const image::Image top = render({.photo = photo, .layers = 15});
  CHECK(max_difference(top, expected_from_above(photo)) < 2e-3);
  for (FurLayout layout : {FurLayout::Band, FurLayout::Strand}) {
    const image::Image side = render({.photo = photo, .layout = layout, .fins = true,
                                      .frame = perspective(vec3(0.0f, 0.5f, 1.2f))});
    CHECK(all_finite(side));
  }
}

TEST_CASE("a 1x1 photo covers the quad in its one colour") {
  const image::Image8 photo = solid(1, 1, 90, 200, 40);
  const vec3 colour{image::srgb_to_linear(90 / 255.0f), image::srgb_to_linear(200 / 255.0f),
                    image::srgb_to_linear(40 / 255.0f)};
  for (const FurFrameSettings& frame : {top_orthographic(), perspective(vec3(0.0f, 0.7f, 1.0f))}) {
    const image::Image got = render({.photo = photo, .frame = frame});
    vec3 lowest(1e9f), highest(-1e9f);
    for (std::uint32_t y = 0; y < size; ++y)
      for (std::uint32_t x = 0; x < size; ++x) {
        if (is_background(got, x, y)) continue;
        for (int k = 0; k < 3; ++k) {
          const float v = got.at(x, y, std::uint32_t(k));
          lowest[k] = std::min(lowest[k], v);
          highest[k] = std::max(highest[k], v);
          CHECK(std::abs(v - colour[k]) < decode_tolerance);
        }
      }
    for (int k = 0; k < 3; ++k) CHECK(highest[k] - lowest[k] < one_colour_spread);
  }
}

TEST_CASE("zero-area triangles draw nothing and grow no fins: the image is unchanged, finite") {
  scene::Mesh quad = unit_quad();
  scene::Mesh degenerate = quad;
  const auto n = std::uint32_t(degenerate.positions.size());
  for (float t : {0.1f, 0.2f, 0.3f}) degenerate.positions.push_back(vec3(t, 0.0f, t));  // collinear
  for (int i = 0; i < 3; ++i) {
    degenerate.normals.push_back(vec3(0, 1, 0));
    degenerate.tangents.push_back(vec4(1, 0, 0, 1));
    degenerate.uvs.push_back(vec2(0.6f, 0.6f));
  }
  degenerate.indices.insert(degenerate.indices.end(), {0, 0, 1, 2, 2, 2, n, n + 1, n + 2});
  const image::Image8 photo = fur_photo(14);
  const FurFrameSettings frame = perspective(vec3(0.0f, 0.6f, 1.1f));
  const image::Image a = render({.photo = photo, .mesh = quad, .fins = true, .frame = frame});
  const image::Image b = render({.photo = photo, .mesh = degenerate, .fins = true, .frame = frame});
  CHECK(all_finite(b));
  CHECK(max_difference(a, b) < 1e-6);
}

TEST_CASE("the naive method (N+1 textures) draws what the single photo and band table draw") {
  const image::Image8 photo = fur_photo(15);
  for (FurLayout layout : {FurLayout::Band, FurLayout::Strand}) {
    // One texel per pixel: the same texels in the same layers, the same colours.
    const image::Image single = render({.photo = photo, .layers = 8, .layout = layout});
    const image::Image naive = render({.photo = photo, .layers = 8, .layout = layout, .method = FurMethod::PerLayerTextures});
    CHECK(max_difference(single, naive) < 2e-3);
  }
  // With one layer both keep the same texels at any magnification: identical from any view.
  // (With more layers and magnified, they differ in detail: the band test on bilinear
  // luminance slices a continuous height field, N binary textures draw texel columns.)
  const FurFrameSettings close = perspective(vec3(0.05f, 0.3f, 0.4f), vec3(0), 30.0f);
  const image::Image a = render({.photo = photo, .layers = 1, .frame = close});
  const image::Image b = render({.photo = photo, .layers = 1, .method = FurMethod::PerLayerTextures, .frame = close});
  CHECK(max_difference(a, b) < 2e-3);
}

TEST_CASE("Kajiya-Kay from above: hair lying flat reads albedo + specular x pi, hair along the normal is black") {
  const image::Image8 photo = solid(8, 8, 128, 128, 128);
  const float albedo = image::srgb_to_linear(128 / 255.0f);
  FurShading flat{.thickness = 0.1f, .lighting = FurLighting::KajiyaKay, .comb = vec2(1, 0), .lift_degrees = 0.0f,
                  .specular = 0.05f, .shininess = 20.0f};
  const image::Image lying = render({.photo = photo, .shading = flat});
  CHECK(lying.at(32, 32, 0) == doctest::Approx(albedo + 0.05f * pi).epsilon(3e-3));
  flat.lift_degrees = 90.0f;
  const image::Image upright = render({.photo = photo, .shading = flat});
  CHECK(std::abs(upright.at(32, 32, 0)) < 1e-3);
  // Lambert reads the albedo.
  const image::Image lambert = render({.photo = photo});
  CHECK(lambert.at(32, 32, 0) == doctest::Approx(albedo).epsilon(3e-3));
  // A constant sky adds albedo x sky radiance.
  FurCase sky{.photo = photo};
  sky.frame.light_radiance = vec3(0.0f);
  sky.frame.sky_radiance = vec3(0.5f);
  CHECK(render(sky).at(32, 32, 0) == doctest::Approx(albedo * 0.5f).epsilon(5e-3));
}

TEST_CASE("fins add fur beyond a sphere's silhouette at grazing angles") {
  auto sphere = scene::make_sphere(0.5f, 32);
  REQUIRE(sphere);
  const image::Image8 photo = fur_photo(16);
  FurCase c{.photo = photo, .mesh = *sphere, .layers = 8,
            .shading = {.thickness = 0.12f, .lighting = FurLighting::Lambert, .fin_threshold = 0.4f},
            .frame = perspective(vec3(0, 0, 3.0f), vec3(0), 30.0f)};
  c.frame.towards_light = vec3(0, 0, 1);
  c.frame.sky_radiance = vec3(0.3f);
  const image::Image without = render(c);
  c.fins = true;
  const image::Image with = render(c);
  auto covered = [](const image::Image& img) {
    std::size_t n = 0;
    for (std::uint32_t y = 0; y < size; ++y)
      for (std::uint32_t x = 0; x < size; ++x) n += is_background(img, x, y) ? 0 : 1;
    return n;
  };
  CHECK(all_finite(with));
  CHECK(covered(with) >= covered(without));
  MESSAGE("covered pixels without fins " << covered(without) << ", with fins " << covered(with));
}

