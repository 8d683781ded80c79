// The "skin" material's fields, read with scene::JsonReader so every problem names its JSON
// path; quality presets pick the LUT size and sample count when the material does not.
module;
#include <cstdint>
#include <expected>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <glm/glm.hpp>
#include <weft/try.h>
#include <nlohmann/json.hpp>
module weft.pass.skin_sss;

namespace weft::skin {

std::string_view to_string(CurvatureSource c) { return c == CurvatureSource::Vertex ? "vertex" : "screen"; }

std::string_view to_string(DebugView d) {
  switch (d) {
    case DebugView::None: return "none";
    case DebugView::Curvature: return "curvature";
    case DebugView::Diffuse: return "diffuse";
    case DebugView::Transmittance: return "transmittance";
    case DebugView::Thickness: return "thickness";
  }
  return "?";
}

namespace {

void read_lut(scene::JsonReader& r, LutParams& lut) {
  const auto& knobs = passes::skin_sss_feature().knobs;
  const Knob& size_knob = *find_knob(knobs, "lut.size");
  const scene::Range texels = knob_range(size_knob);
  const auto size = static_cast<std::uint32_t>(read_integer_knob(r, size_knob, lut.width));
  lut.width = static_cast<std::uint32_t>(r.integer("width", size, texels));
  lut.height = static_cast<std::uint32_t>(r.integer("height", size, texels));
  const std::string range = read_choice_knob(r, *find_knob(knobs, "lut.range"), std::string(to_string(lut.range)));
  if (auto parsed = integration_range_from_string(range)) lut.range = *parsed;
  const std::string convention = r.string("convention", "default", {"default", "thesis", "penner"});
  if (convention == "thesis") lut.convention = thesis_convention;
  if (convention == "penner") lut.convention = penner_convention;
  const std::string normalization = r.string("normalization", std::string(to_string(lut.convention.normalization)),
                                             {"ring", "planar"});
  lut.convention.normalization = normalization == "planar" ? Normalization::Planar : Normalization::Ring;
  lut.convention.variance_scale = r.number("variance_scale", lut.convention.variance_scale, {.min = 0.01, .max = 100});
  lut.max_curvature = r.number("max_curvature", lut.max_curvature, {.min = 0, .max = 10, .min_exclusive = true});
  lut.samples = static_cast<std::uint32_t>(read_integer_knob(r, *find_knob(knobs, "lut.samples"), lut.samples));
  const std::string quadrature =
      read_choice_knob(r, *find_knob(knobs, "lut.quadrature"), std::string(to_string(lut.quadrature)));
  lut.quadrature = quadrature == "uniform" ? Quadrature::Uniform : Quadrature::PerGaussian;
  r.finish();
}

}  // namespace

SkinQualityPreset skin_quality_preset(Quality q) {
  switch (q) {
    case Quality::Low: return {64, 128, false};
    case Quality::Medium: return {256, 256, false};
    case Quality::High: return {512, 512, false};
    case Quality::Reference: return {1024, 1024, true};
  }
  return {};
}

Result<SkinMaterial> parse_skin_material(const scene::Material& material, Quality quality) {
  SkinMaterial m;
  const SkinQualityPreset q = skin_quality_preset(quality);
  m.lut.width = m.lut.height = q.lut_size;
  m.lut.samples = q.lut_samples;
  m.reference = q.reference;
  WEFT_TRY_VOID(read_material_fields(material, "skin", [&](scene::JsonReader& r) {
    const scene::Range unit{.min = 0, .max = 1};
    m.albedo = r.vec3_of("albedo", m.albedo, unit);
    m.albedo_texture = r.path("albedo_texture");
    m.normal_texture = r.path("normal_texture");
    m.specular_texture = r.path("specular_texture");
    m.normal_strength = float(r.number("normal_strength", m.normal_strength, {.min = 0, .max = 10}));
    m.normal_blur = r.vec3_of("normal_blur", m.normal_blur, unit);
    m.roughness = float(r.number("roughness", m.roughness, {.min = 0, .max = 1, .min_exclusive = true}));
    m.specular = float(r.number("specular", m.specular, {.min = 0, .max = 10}));
    m.mm_per_unit = float(r.number("mm_per_unit", m.mm_per_unit, {.min = 0, .max = 1e9, .min_exclusive = true}));
    m.curvature_scale = float(r.number("curvature_scale", m.curvature_scale, {.min = 0, .max = 1000}));
    m.curvature = read_choice_knob(r, *find_knob(passes::skin_sss_feature().knobs, "curvature"), "vertex") == "screen"
                      ? CurvatureSource::Screen
                      : CurvatureSource::Vertex;
    m.transmittance = r.boolean("transmittance", m.transmittance);
    m.transmittance_scale = float(r.number("transmittance_scale", m.transmittance_scale, {.min = 0, .max = 1000}));
    m.transmittance_shrink_mm =
        float(r.number("transmittance_shrink_mm", m.transmittance_shrink_mm, {.min = 0, .max = 1000}));
    m.shadow_scatter_mm = float(r.number("shadow_scatter_mm", m.shadow_scatter_mm, {.min = 0, .max = 1000}));
    const std::string debug =
        r.string("debug_view", "none", {"none", "curvature", "diffuse", "transmittance", "thickness"});
    for (DebugView d : {DebugView::None, DebugView::Curvature, DebugView::Diffuse, DebugView::Transmittance,
                        DebugView::Thickness})
      if (to_string(d) == debug) m.debug_view = d;
    m.reference = r.boolean("reference", m.reference);
    if (auto lut = r.object("lut")) read_lut(*lut, m.lut);
  }));
  if (auto ok = validate(m.lut); !ok) {
    const std::string path = material.json_path.empty() ? "$.materials." + material.name : material.json_path;
    return with_context(weft::format("skin material '{}' ({}.lut)", material.name, path), ok.error());
  }
  return m;
}

}  // namespace weft::skin
