// The catalogue: each feature's quality knobs and reference, in ONE place. To add a feature
// to `weft tradeoff` and to the stability sweep, add a `Study` to studies() below: its
// --feature name, its material type, its knobs (material fields with the range the
// material accepts and the values a sweep tries) and its reference setting. Nothing else
// changes: the command, the tests and the reports read this table. docs/tradeoffs.md says why
// each reference is the most accurate setting its feature has.
module;
#include <algorithm>
#include <expected>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <nlohmann/json.hpp>
module weft.tradeoff;
import weft.core;
import weft.scene;
import weft.feature;
import weft.pass.skin_sss;
import weft.pass.shell_fur;
import weft.pass.ssdf_lighting;
import weft.pass.neural_btf;

namespace weft::tradeoff {

using json = nlohmann::json;

namespace {

Knob integer(std::string name, double min, double max, std::vector<json> sweep, std::string meaning) {
  return {std::move(name), KnobKind::Integer, min, max, {}, std::move(sweep), std::move(meaning)};
}
Knob number(std::string name, double min, double max, std::vector<json> sweep, std::string meaning) {
  return {std::move(name), KnobKind::Number, min, max, {}, std::move(sweep), std::move(meaning)};
}
Knob boolean(std::string name, std::string meaning) {
  return {std::move(name), KnobKind::Boolean, 0, 1, {}, {false, true}, std::move(meaning)};
}
Knob choice(std::string name, std::vector<std::string> choices, std::string meaning) {
  std::vector<json> sweep(choices.begin(), choices.end());
  return {std::move(name), KnobKind::Choice, 0, 0, std::move(choices), std::move(sweep), std::move(meaning)};
}

// passes/shell_fur (docs/fur.md). Quality picks `layers` (8 / 15 / 32 / 64).
Study fur_study() {
  Study s;
  s.feature = "fur";
  s.material = scene::MaterialType::Fur;
  s.passes = {"shell_fur"};
  s.knobs = {
      integer("layers", 1, 256, {1, 2, 4, 8, 15, 32, 64, 128}, "shells N: the height field's depth resolution"),
      boolean("fins", "silhouette fins (Lengyel): one quad per edge near the silhouette"),
      number("fin_threshold", 0, 1, {0.1, 0.35, 0.7}, "|N.V| below which an edge grows a fin"),
  };
  // As N grows the strand shells converge to the continuous height field the photo
  // describes (the gap between shells, h_b / N, falls below a pixel); fins patch the gaps
  // of few shells at grazing angles, so the limit has none.
  s.reference = {.label = "reference", .group = "reference", .values = {{"layers", 256}, {"fins", false}},
                 .is_reference = true};
  s.reference_why = "256 shells (the most the material takes), no fins: the limit the shells converge to";
  s.cost = CostAxis::Frame;
  s.grids = {{"layers", "fins"}};
  s.preset_values = [](Quality q) -> json { return {{"layers", passes::fur_layers_for(q)}}; };
  return s;
}

// passes/skin_sss (docs/skin.md). Quality picks lut.size and lut.samples (64/128, 256/256,
// 512/512, 1024/1024) and, at reference, the brute-force mode.
Study skin_study() {
  Study s;
  s.feature = "skin";
  s.material = scene::MaterialType::Skin;
  s.passes = {"skin_sss"};
  s.knobs = {
      // Up to the reference preset's 1024: the material takes 4096 texels and 65,536 samples, a
      // bake of hours, which no sweep or stability run should start.
      integer("lut.size", 2, 1024, {8, 16, 32, 64, 128, 256, 512, 1024}, "LUT texels per side (N.L by 1/r)"),
      integer("lut.samples", 2, 1024, {4, 8, 16, 32, 64, 128, 256, 1024}, "ring samples per Gaussian when baking"),
      choice("lut.range", {"penner", "adaptive", "full"}, "integration range around the ring"),
      choice("lut.quadrature", {"per-gaussian", "uniform"}, "one grid per Gaussian, or Penner's single grid"),
      choice("curvature", {"vertex", "screen"}, "1/r from the mesh per vertex, or from screen derivatives"),
  };
  // The brute-force gather of d'Eon's profile over the mesh, per vertex, for the key light
  // (skin::mesh_reference): the scattering the LUT approximates, without the ring model.
  s.reference = {.label = "reference", .group = "reference", .values = {{"reference", true}}, .is_reference = true};
  s.reference_why = "\"reference\": true: brute-force scattering gathered over the mesh per vertex";
  // Every LUT costs the same per frame (one texture, the same fetches): the knobs trade
  // bake time, so the cost is the cold first frame with the LUT's disk cache off.
  s.cost = CostAxis::ColdFrame;
  s.environment = {{"WEFT_SKIN_LUT_CACHE", ""}};
  s.clear_caches = &skin::clear_lut_memory_cache;
  s.preset_values = [](Quality q) -> json {
    const auto p = skin::skin_quality_preset(q);
    return {{"lut.size", p.lut_size}, {"lut.samples", p.lut_samples}, {"reference", p.reference}};
  };
  return s;
}

// passes/ssdf_lighting (docs/ssdf.md). Quality picks bake.resolution and lobes (16/8, 32/16,
// 64/32, 64/48). The bake knobs' ranges stop where a bake of a showcase-sized mesh stays
// within minutes on two cores (the material takes resolution up to 256).
Study ssdf_study() {
  Study s;
  s.feature = "ssdf";
  s.material = scene::MaterialType::Ssdf;
  s.passes = {"ssdf_lighting"};
  s.knobs = {
      integer("lobes", 1, ssdf::max_lobes, {1, 4, 8, 16, 32, 48}, "spherical Gaussians the environment is fitted with"),
      choice("shading", {"vertex", "pixel"}, "sum the lobes per vertex, or interpolate the SSDF and shade per pixel"),
      integer("bake.resolution", 4, 64, {8, 16, 32, 64}, "SSDF directions per vertex: n x n (equal-area octahedral)"),
      integer("bake.clusters", 1, 256, {1, 8, 32, 128}, "CPCA clusters of triangles"),
      integer("bake.components", 0, 256, {0, 2, 8, 16, 48}, "principal components kept per cluster"),
      choice("bake.coefficients", {"fp32", "fp16", "8bit"}, "how the per-vertex coefficients are stored"),
  };
  // The finest bake the knobs reach, uncompressed in effect (components beyond the rank keep
  // every one), with the most lobes: what remains is the SG fit and the visibility
  // approximation themselves. The ray-traced Monte-Carlo reference (weft-bench-ssdf
  // --lighting) measures those; docs/ssdf.md has its numbers.
  s.reference = {.label = "reference",
                 .group = "reference",
                 .values = {{"lobes", ssdf::max_lobes}, {"shading", "pixel"}, {"bake.resolution", 64},
                            {"bake.clusters", 32}, {"bake.components", 256}, {"bake.coefficients", "fp32"}},
                 .is_reference = true};
  s.reference_why = "64 x 64 directions, 256 components (full rank), fp32, 48 lobes, per pixel: only the SG "
                    "fit and the visibility model remain";
  s.cost = CostAxis::Frame;
  s.grids = {{"lobes", "shading"}};
  s.preset_values = [](Quality q) -> json {
    const auto p = ssdf::ssdf_quality_preset(q);
    return {{"bake.resolution", p.resolution}, {"lobes", p.lobes}};
  };
  return s;
}

// passes/neural_btf (docs/neural-btf.md). The model's own knobs (clusters, latent size, fp16)
// are bake-time (weft bake btf) and measured against the raw BTF by weft-bench-btf-train; here
// the shading knobs: decodes per pixel. Quality: low = nearest, no ambient; medium = nearest +
// ambient; high and reference = bilinear + ambient.
Study btf_study() {
  Study s;
  s.feature = "btf";
  s.material = scene::MaterialType::NeuralBtf;
  s.passes = {"neural_btf"};
  s.knobs = {
      choice("filter", {"nearest", "bilinear"}, "texels decoded per light: 1, or 4 blended"),
      boolean("ambient", "one more decode (ω_i = n) times the environment's SH irradiance"),
      boolean("shadow", "the key light's shadow map (3x3 PCF)"),
  };
  s.reference = {.label = "reference",
                 .group = "reference",
                 .values = {{"filter", "bilinear"}, {"ambient", true}, {"shadow", true}},
                 .is_reference = true};
  s.reference_why = "bilinear texels, ambient and shadow: every decode the material can make (the model's "
                    "error against the raw BTF is weft-bench-btf-train's)";
  s.cost = CostAxis::Frame;
  s.grids = {{"filter", "ambient"}};
  s.preset_values = [](Quality q) -> json {
    const auto p = btf::neural_btf_quality_preset(q);
    return {{"filter", std::string(btf::to_string(p.filter))}, {"ambient", p.ambient}};
  };
  return s;
}

}  // namespace

std::string_view to_string(CostAxis axis) { return axis == CostAxis::Frame ? "frame" : "cold frame"; }

std::span<const Study> studies() {
  static const std::vector<Study> all = [] {
    std::vector<Study> v;
    v.push_back(fur_study());
    v.push_back(skin_study());
    v.push_back(ssdf_study());
    v.push_back(btf_study());
    return v;
  }();
  return all;
}

Result<const Study*> find_study(std::string_view feature) {
  std::string known;
  for (const auto& s : studies()) {
    if (s.feature == feature) return &s;
    known += (known.empty() ? "" : ", ") + s.feature;
  }
  return fail(ErrorKind::NotFound, "unknown feature '{}' for the trade-off study; known: {}", feature, known);
}

Result<const Knob*> find_knob(const Study& study, std::string_view name) {
  std::string known;
  for (const auto& k : study.knobs) {
    if (k.name == name) return &k;
    known += (known.empty() ? "" : ", ") + k.name;
  }
  return fail(ErrorKind::InvalidArgument, "{} has no knob '{}'; its knobs: {}", study.feature, name, known);
}

}  // namespace weft::tradeoff
