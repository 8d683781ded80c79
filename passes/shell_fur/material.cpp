// The "shell_fur" material of the scene format, read with weft.scene's JsonReader so every bad
// field is reported at its JSON path, all at once.
module;
#include <cmath>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <glm/glm.hpp>
#include <weft/try.h>
#include <nlohmann/json.hpp>
module weft.pass.shell_fur;

namespace weft::fur {

std::string_view to_string(FurLighting lighting) { return lighting == FurLighting::Lambert ? "lambert" : "kajiya_kay"; }

std::uint32_t fur_layers_for(Quality quality) {
  switch (quality) {
    case Quality::Low: return 8;
    case Quality::Medium: return 15;
    case Quality::High: return 32;
    case Quality::Reference: return 64;
  }
  return 15;
}

float FurMaterial::thickness_for(float diagonal) const {
  if (thickness) return *thickness;
  if (spacing) return *spacing * float(layers);
  return 0.03f * (std::isfinite(diagonal) ? diagonal : 0.0f);
}

Result<FurMaterial> parse_fur_material(const scene::Material& material, Quality quality) {
  const std::string where = material.json_path.empty() ? "$.materials." + material.name : material.json_path;
  const FeatureDescriptor& feature = passes::shell_fur_feature();
  if (material.type != feature.name)
    return fail(ErrorKind::InvalidArgument, "material '{}' ({}) is a {} material, not {}", material.name, where,
                material.type, feature.name);
  constexpr double inf = std::numeric_limits<double>::infinity();
  const scene::Range non_negative{.min = 0.0}, positive{.min = 0.0, .min_exclusive = true}, unit{.min = 0.0, .max = 1.0};
  FurMaterial m;
  WEFT_TRY_VOID(read_material_fields(material, "fur", [&](scene::JsonReader& r) {
    if (r.require("photo")) m.photo = r.path("photo", true);
    if (r.has("layers")) {
      m.layers = std::uint32_t(read_integer_knob(r, *find_knob(feature.knobs, "layers"), 15));
      m.layers_from_quality = false;
    } else {
      m.layers = fur_layers_for(quality);
    }
    const bool has_thickness = r.has("thickness"), has_spacing = r.has("spacing");
    if (has_thickness && has_spacing)
      r.error_at("spacing", "give \"thickness\" (h_b) or \"spacing\" (h_b / layers), not both");
    if (has_thickness) m.thickness = float(r.number("thickness", 0.0, non_negative));
    if (has_spacing) m.spacing = float(r.number("spacing", 0.0, non_negative));
    m.tint = r.vec3_of("tint", m.tint, {.min = 0.0, .max = inf});
    m.layout = r.string("layout", "strand", {"band", "strand"}) == "band" ? FurLayout::Band : FurLayout::Strand;
    m.lighting = r.string("lighting", "kajiya_kay", {"lambert", "kajiya_kay"}) == "lambert" ? FurLighting::Lambert
                                                                                         : FurLighting::KajiyaKay;
    const vec2 percentiles = r.vec2_of("percentiles", vec2(0.01f, 0.99f), unit);
    if (!(percentiles.x < percentiles.y))
      r.error_at("percentiles", weft::format("low ({}) must be below high ({})", percentiles.x, percentiles.y));
    m.thresholds = {percentiles.x, percentiles.y};
    m.uv_scale = r.vec2_of("uv_scale", m.uv_scale, positive);
    m.wrap = r.string("wrap", "mirror", {"mirror", "repeat"}) == "repeat" ? FurWrap::Repeat : FurWrap::Mirror;
    const std::string mapping = r.string("uv_mapping", "auto", {"auto", "mesh", "planar", "spherical"});
    m.uv_mapping = mapping == "mesh"     ? FurUvMapping::Mesh
                   : mapping == "planar" ? FurUvMapping::Planar
                   : mapping == "spherical" ? FurUvMapping::Spherical
                                            : FurUvMapping::Auto;
    if (r.has("comb")) {
      const vec2 comb = r.vec2_of("comb", vec2(1.0f, 0.0f));
      if (!(glm::dot(comb, comb) > 0.0f))
        r.error_at("comb", "must be a non-zero direction in UV space, e.g. [1, 0]");
      else
        m.comb = comb;
    }
    m.lift_degrees = float(r.number("lift_degrees", m.lift_degrees, {.min = 0.0, .max = 90.0}));
    m.specular = float(r.number("specular", m.specular, non_negative));
    m.shininess = float(r.number("shininess", m.shininess, {.min = 1.0, .max = 10000.0}));
    m.fins = r.boolean("fins", m.fins);
    m.fin_threshold = float(read_number_knob(r, *find_knob(feature.knobs, "fin_threshold"), m.fin_threshold));
    m.per_sample_hair = read_choice_knob(r, *find_knob(feature.knobs, "msaa_hair"),
                                         quality >= Quality::High ? "per_sample" : "coverage") == "per_sample";
  }));
  return m;
}

}  // namespace weft::fur
