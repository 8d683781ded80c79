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
  // The factory the descriptor names: the graph pass first, then the feature around it.
  static Result<std::unique_ptr<FeaturePass>> create(gpu::Device& device) {
    WEFT_TRY(auto pass, ToonPass::create(device));
    return std::unique_ptr<FeaturePass>(std::make_unique<ToonFeature>(std::move(pass)));
  }

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

}  // namespace

Result<ToonMaterial> parse_toon_material(const scene::Material& material, Quality quality) {
  const auto& knobs = toon_feature().knobs;
  ToonMaterial m;
  m.bands = bands_for(quality);
  WEFT_TRY_VOID(read_material_fields(material, "toon", [&](scene::JsonReader& r) {
    m.base_color = r.vec3_of("base_color", m.base_color, {.min = 0.0, .max = 1.0});
    m.outline_color = r.vec3_of("outline_color", m.outline_color, {.min = 0.0, .max = 1.0});
    m.bands = std::uint32_t(read_integer_knob(r, *find_knob(knobs, "bands"), m.bands));
    m.outline_width = float(read_number_knob(r, *find_knob(knobs, "outline_width"), m.outline_width));
    m.shadows = r.boolean("shadows", m.shadows);
  }));
  return m;
}

const FeatureDescriptor& toon_feature() {
  static const FeatureDescriptor feature{
      .name = "toon", .doc = "docs/writing-a-pass.md#writing-a-feature",
      .summary = "cel shading in flat bands with an inverted-hull outline (the custom_feature example)",
      .check_material = check_by_parsing<&parse_toon_material>, .create = &ToonFeature::create,
      .passes = {"toon"},
      .knobs = {
          integer_knob("bands", 1, 64, {1, 2, 3, 4, 8}, "lit tones above the unlit one"),
          number_knob("outline_width", 0, 0.1, {0.0, 0.005, 0.01, 0.02}, "outline width in object units (0: none)"),
          boolean_knob("shadows", "the key light's shadow map darkens the bands"),
      },
      .preset_values = [](Quality q) -> nlohmann::json { return {{"bands", bands_for(q)}}; },
      // Toon shading has no ground truth; its limit is many bands: the smooth Lambert it stylises.
      .reference = {{"bands", 64}, {"shadows", true}},
      .reference_why = "64 bands: the quantised ramp closest to the smooth Lambert term it stylises",
      .grids = {{"bands", "outline_width"}},
  };
  return feature;
}

}  // namespace custom
