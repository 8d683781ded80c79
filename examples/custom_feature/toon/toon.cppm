// custom.toon — a material feature written outside the engine, to show that one folder is
// all a new feature needs: cel shading (the key light in a few flat bands) with an outline
// (the inverted hull). Scene files use it as {"type": "toon", ...} once the application has
// registered toon_feature(); weft.frame's add_scene_color_pass does the frame plumbing, so
// the pass is a pipeline and a draw loop.
module;
#include <cstdint>
#include <expected>
#include <memory>
#include <span>
export module custom.toon;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.scene;
import weft.feature;

export namespace custom {

using weft::Quality;
using weft::Result;
using weft::mat4;
using weft::vec3;

// A "toon" material's fields; the knob table in feature.cpp gives the ranges.
struct ToonMaterial {
  vec3 base_color{0.8f};
  vec3 outline_color{0.0f};
  std::uint32_t bands = 3;       // lit tones above the unlit one
  float outline_width = 0.01f;   // object units along the normal; 0: no outline
  bool shadows = true;           // the key light's shadow map darkens the bands
};
// Reads material.params at material.json_path: one Parse error naming each bad field's path.
Result<ToonMaterial> parse_toon_material(const weft::scene::Material& material, Quality quality = Quality::Medium);

struct ToonDraw {
  const weft::frame::GpuMesh* mesh = nullptr;
  mat4 model{1.0f};
  ToonMaterial material;
};

// The graph pass "toon": the surfaces, then their outlines, into the frame's scene colour.
class ToonPass {
 public:
  static Result<ToonPass> create(weft::gpu::Device& device);
  // `draws` must outlive the graph's execution.
  Result<void> add(weft::RenderGraph& graph, std::span<const ToonDraw> draws) const;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// What the application registers: weft::register_feature(custom::toon_feature()).
const weft::FeatureDescriptor& toon_feature();

}  // namespace custom
