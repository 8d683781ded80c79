// The "skin" material's fields as a scene file gives them: defaults, quality presets, LUT
// conventions, and every problem reported at its JSON path in one error.
#include <doctest/doctest.h>
#include <filesystem>
#include <string>
import weft.core;
import weft.scene;
import weft.feature;
import weft.pass.skin_sss;

using namespace weft;

namespace {
Result<skin::SkinMaterial> parse(const std::string& material, Quality q = Quality::Medium) {
  const std::string json = R"({"version": 1, "meshes": {"m": {"primitive": "cube"}}, "materials": {"face": )" + material +
                           R"(}, "objects": [{"mesh": "m", "material": "face"}]})";
  auto desc = scene::parse_scene(json, std::filesystem::temp_directory_path());
  REQUIRE_MESSAGE(desc, (desc ? "" : desc.error().message));
  const auto& m = desc->materials.at(0);
  REQUIRE(m.type == "skin_sss");
  return skin::parse_skin_material(m, q);
}
}  // namespace

TEST_CASE("defaults: d'Eon's skin, the adaptive range, ring normalisation with Penner's 1.414, metres") {
  auto m = parse(R"({"type": "skin"})");
  REQUIRE_MESSAGE(m, (m ? "" : m.error().message));
  CHECK(m->roughness == doctest::Approx(0.3f));
  CHECK(m->specular == doctest::Approx(0.18f));
  CHECK(m->mm_per_unit == 1000.0f);
  CHECK(m->curvature == skin::CurvatureSource::Vertex);
  CHECK(m->transmittance);
  CHECK(m->lut.range == skin::IntegrationRange::Adaptive);
  CHECK(m->lut.convention == skin::default_convention);
  CHECK(m->lut.width == 256);
  CHECK(m->lut.samples == 256);
  CHECK(m->debug_view == skin::DebugView::None);
}

TEST_CASE("quality picks the LUT size and samples unless the material sets them") {
  CHECK(parse(R"({"type": "skin"})", Quality::Low)->lut.width == 64);
  CHECK(parse(R"({"type": "skin"})", Quality::High)->lut.height == 512);
  CHECK(parse(R"({"type": "skin"})", Quality::Reference)->lut.samples == 1024);
  auto m = parse(R"({"type": "skin", "lut": {"size": 32, "height": 16, "samples": 48}})", Quality::High);
  REQUIRE(m);
  CHECK(m->lut.width == 32);
  CHECK(m->lut.height == 16);
  CHECK(m->lut.samples == 48);
}

TEST_CASE("every field reads, conventions by preset or by parts") {
  auto m = parse(R"({"type": "skin", "albedo": [0.9, 0.5, 0.4], "normal_blur": [1, 0.5, 0], "normal_strength": 2,
      "roughness": 0.45, "specular": 0.3, "mm_per_unit": 10, "curvature_scale": 2, "curvature": "screen",
      "transmittance": false, "transmittance_scale": 3, "transmittance_shrink_mm": 0.1, "shadow_scatter_mm": 5,
      "debug_view": "thickness",
      "lut": {"range": "penner", "convention": "thesis", "max_curvature": 2, "quadrature": "uniform"}})");
  REQUIRE_MESSAGE(m, (m ? "" : m.error().message));
  CHECK(m->albedo.y == doctest::Approx(0.5f));
  CHECK(m->normal_blur.x == 1.0f);
  CHECK(m->curvature == skin::CurvatureSource::Screen);
  CHECK(!m->transmittance);
  CHECK(m->shadow_scatter_mm == 5.0f);
  CHECK(m->debug_view == skin::DebugView::Thickness);
  CHECK(m->lut.range == skin::IntegrationRange::Penner);
  CHECK(m->lut.convention == skin::thesis_convention);
  CHECK(m->lut.max_curvature == 2.0);
  CHECK(m->lut.quadrature == skin::Quadrature::Uniform);
  auto parts = parse(R"({"type": "skin", "lut": {"normalization": "planar", "variance_scale": 2}})");
  REQUIRE(parts);
  CHECK(parts->lut.convention.normalization == skin::Normalization::Planar);
  CHECK(parts->lut.convention.variance_scale == 2.0);
}

TEST_CASE("problems come back together, each at its JSON path") {
  auto m = parse(R"({"type": "skin", "albedo": [2, 0, 0], "roughness": 0, "mm_per_unit": -1, "curvature": "pixel",
      "lut": {"size": 1, "range": "wide", "max_curvature": 0, "extra": true}, "colour": [1, 1, 1]})");
  REQUIRE(!m);
  const std::string e = m.error().message;
  CHECK(m.error().kind == ErrorKind::Parse);
  for (const char* path : {"$.materials.face.albedo", "$.materials.face.roughness", "$.materials.face.mm_per_unit",
                           "$.materials.face.curvature", "$.materials.face.lut.size", "$.materials.face.lut.range",
                           "$.materials.face.lut.max_curvature", "$.materials.face.lut.extra", "$.materials.face.colour"}) {
    CAPTURE(path);
    CHECK(e.find(path) != std::string::npos);
  }
  auto missing = parse(R"({"type": "skin", "normal_texture": "no/such/file.png"})");
  REQUIRE(!missing);
  CHECK(missing.error().message.find("normal_texture") != std::string::npos);
}
