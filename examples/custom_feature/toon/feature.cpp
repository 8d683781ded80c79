// The toon feature's registration: its descriptor (name, knob table, presets, reference),
// its material parser (ranges read from the knob table) and its FeaturePass.
module;
#include <cstdint>
#include <expected>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <nlohmann/json.hpp>
#include <weft/try.h>
module custom.toon;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.scene;
import weft.feature;

namespace custom {

using namespace weft;

namespace {

std::uint32_t bands_for(Quality q) {
  switch (q) {
    case Quality::Low: return 2;
    case Quality::Medium: return 3;
    case Quality::High: return 4;
    case Quality::Reference: return 64;
  }
  return 3;
}

class ToonFeature final : public FeaturePass {
 public:
  explicit ToonFeature(ToonPass pass) : pass_(std::move(pass)) {}
  [[nodiscard]] std::string_view name() const override { return "toon"; }

  Result<void> prepare(const FeatureFrame& frame) override {
    draws_.clear();
    for (const std::uint32_t index : frame.objects) {
      const scene::Object& object = frame.scene.objects.at(index);
      WEFT_TRY(ToonMaterial material, parse_toon_material(frame.scene.materials.at(object.material), frame.quality));
      draws_.push_back({frame.meshes[object.mesh], object.transform, material});
    }
    return {};
  }
  Result<void> add_passes(RenderGraph& graph, const FeatureFrame&) override { return pass_.add(graph, draws_); }

 private:
  ToonPass pass_;
  std::vector<ToonDraw> draws_;  // alive until the graph has executed
};

Result<std::unique_ptr<FeaturePass>> create_feature(gpu::Device& device) {
  WEFT_TRY(auto pass, ToonPass::create(device));
  return std::unique_ptr<FeaturePass>(std::make_unique<ToonFeature>(std::move(pass)));
}

Result<void> check_material(const scene::Material& material) {
  WEFT_TRY_VOID(parse_toon_material(material));
  return {};
}

}  // namespace

Result<ToonMaterial> parse_toon_material(const scene::Material& material, Quality quality) {
  const auto& knobs = toon_feature().knobs;
  scene::JsonErrors errors;
  scene::JsonReader r(material.params, material.json_path.empty() ? "$.materials." + material.name : material.json_path,
                      errors, material.base_dir);
  ToonMaterial m;
  m.bands = bands_for(quality);
  m.base_color = r.vec3_of("base_color", m.base_color, {.min = 0.0, .max = 1.0});
  m.outline_color = r.vec3_of("outline_color", m.outline_color, {.min = 0.0, .max = 1.0});
  m.bands = std::uint32_t(read_integer_knob(r, *find_knob(knobs, "bands"), m.bands));
  m.outline_width = float(read_number_knob(r, *find_knob(knobs, "outline_width"), m.outline_width));
  m.shadows = r.boolean("shadows", m.shadows);
  r.finish();
  if (!errors.empty()) return std::unexpected(errors.to_error(weft::format("toon material '{}'", material.name)));
  return m;
}

const FeatureDescriptor& toon_feature() {
  static const FeatureDescriptor feature = [] {
    FeatureDescriptor d;
    d.name = "toon";
    d.summary = "cel shading in flat bands with an inverted-hull outline (the custom_feature example)";
    d.doc = "docs/writing-a-pass.md#writing-a-feature";
    d.check_material = &check_material;
    d.create = &create_feature;
    d.passes = {"toon"};
    d.knobs = {
        integer_knob("bands", 1, 64, {1, 2, 3, 4, 8}, "lit tones above the unlit one"),
        number_knob("outline_width", 0, 0.1, {0.0, 0.005, 0.01, 0.02}, "outline width in object units (0: none)"),
        boolean_knob("shadows", "the key light's shadow map darkens the bands"),
    };
    d.preset_values = [](Quality q) -> nlohmann::json { return {{"bands", bands_for(q)}}; };
    // Toon shading has no ground truth; its limit is many bands: the smooth Lambert it stylises.
    d.reference = {{"bands", 64}, {"shadows", true}};
    d.reference_why = "64 bands: the quantised ramp closest to the smooth Lambert term it stylises";
    d.grids = {{"bands", "outline_width"}};
    return d;
  }();
  return feature;
}

}  // namespace custom
