// weft.feature — how a material feature (fur, skin, SSDF, neural BTF, or one of yours) plugs
// into weft without the engine knowing it by name. A feature module exports one
// FeatureDescriptor: its material type name (and older aliases), a check of its material's
// fields, the factory of its FeaturePass, and its knob table. An application registers the
// features it links (register_feature; Falcor's registerPass is the model), and the renderer,
// `weft tradeoff`, the stability sweep and the viewer read the same registry.
module;
#include <cstdint>
#include <expected>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <nlohmann/json.hpp>
// A bake adds its options to a CLI11 command; only the name is needed here.
namespace CLI {
class App;
}
export module weft.feature;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.scene;

export namespace weft {

// Quality presets; each feature maps them to its own knobs (its descriptor's preset_values).
enum class Quality : std::uint8_t { Low, Medium, High, Reference };
std::string_view to_string(Quality quality);
Result<Quality> quality_from_string(std::string_view name);

// What a feature sees of the frame being built.
struct FeatureFrame {
  gpu::Device& device;
  const scene::Scene& scene;
  std::span<const std::uint32_t> objects;            // scene.objects using this feature's materials
  std::span<const frame::GpuMesh* const> meshes;     // the GPU mesh of each scene mesh, by index
  const frame::FrameUniforms& uniforms;
  Quality quality = Quality::Medium;
  std::uint32_t width = 0, height = 0;
};

// A feature's hook into the frame. add_passes() finds the frame's shared targets with
// frame::scene_targets() (or draws through frame::add_scene_color_pass, which does) and puts
// back the new versions of the scene colour and depth. Anything its execute callbacks use
// (draw lists, matrices) must live in the FeaturePass object.
class FeaturePass {
 public:
  virtual ~FeaturePass() = default;
  [[nodiscard]] virtual std::string_view name() const = 0;
  // Parses the materials' parameters (errors name their JSON path) and prepares assets.
  virtual Result<void> prepare(const FeatureFrame& frame) = 0;
  virtual Result<void> add_passes(RenderGraph& graph, const FeatureFrame& frame) = 0;
  // Messages for the user (clamped knobs, weak inputs), gathered after prepare().
  [[nodiscard]] virtual std::vector<std::string> warnings() const { return {}; }
};

using FeatureFactory = Result<std::unique_ptr<FeaturePass>> (*)(gpu::Device& device);

// Errors gathered while preparing a frame (one per bad material) as one Parse error, a line
// each, repeats dropped; success when there are none.
Result<void> join_problems(std::span<const std::string> problems);

// A FeaturePass's prepare() loop: each scene material its objects use is resolved once, with
// `resolve(const scene::Material&) -> Result<M>`, and kept in `materials` in first-use order;
// then `visit(object_index, slot)` sees each object of frame.objects whose material resolved,
// with that material's index in `materials`. A material that fails skips its objects, and
// every failure comes back at the end, one line each (so a scene's every bad material is
// named at once).
template <class M, class Resolve, class Visit>
Result<void> resolve_materials(const FeatureFrame& frame, std::vector<M>& materials, Resolve&& resolve, Visit&& visit) {
  constexpr std::uint32_t failed = ~0u;
  std::map<std::uint32_t, std::uint32_t> slot_of;  // scene material -> index in `materials`
  std::vector<std::string> problems;
  for (const std::uint32_t object_index : frame.objects) {
    const std::uint32_t material_index = frame.scene.objects.at(object_index).material;
    auto slot = slot_of.find(material_index);
    if (slot == slot_of.end()) {
      auto resolved = resolve(frame.scene.materials.at(material_index));
      if (!resolved) problems.push_back(resolved.error().message);
      slot = slot_of.emplace(material_index, resolved ? std::uint32_t(materials.size()) : failed).first;
      if (resolved) materials.push_back(std::move(*resolved));
    }
    if (slot->second != failed) visit(object_index, slot->second);
  }
  return join_problems(problems);
}

// ---- knobs: the one table of a feature's quality settings ---------------------------------

enum class KnobKind : std::uint8_t { Integer, Number, Boolean, Choice };

// A material field that trades speed for accuracy. The material parser reads its range from
// here (read_knob), the trade-off study sweeps it, the stability test renders its extremes.
struct Knob {
  std::string name;                    // the material field; '.' descends into objects: "lut.size"
  KnobKind kind = KnobKind::Integer;
  double min = 0.0, max = 0.0;         // Integer, Number: inclusive, what the material accepts
  std::vector<std::string> choices;    // Choice
  std::vector<nlohmann::json> sweep;   // the values a sweep tries, one at a time
  std::string meaning;                 // one line, for `--list`, the docs and the viewer
  // The bounds the stability sweep renders when `min` or `max` would take hours (a bake):
  // unset, it renders `min` and `max`. Why is said where the knob is written.
  std::optional<double> extreme_min, extreme_max;
};
Knob integer_knob(std::string name, double min, double max, std::vector<nlohmann::json> sweep, std::string meaning);
Knob number_knob(std::string name, double min, double max, std::vector<nlohmann::json> sweep, std::string meaning);
Knob boolean_knob(std::string name, std::string meaning);
Knob choice_knob(std::string name, std::vector<std::string> choices, std::string meaning);
// The knob with the bounds the stability sweep renders instead of its range (unset: the range).
Knob with_extremes(Knob knob, std::optional<double> extreme_min, std::optional<double> extreme_max);

// The knob called `name` of a table; nullptr when there is none.
const Knob* find_knob(std::span<const Knob> knobs, std::string_view name);
// A knob's range as the scene reader takes it.
scene::Range knob_range(const Knob& knob);
// Reads the field `field` of `reader` (the knob's last name part, e.g. "size" of "lut.size")
// with the knob's range or choices, so a range is written once: in the knob table.
std::int64_t read_integer_knob(scene::JsonReader& reader, const Knob& knob, std::int64_t fallback);
double read_number_knob(scene::JsonReader& reader, const Knob& knob, double fallback);
std::string read_choice_knob(scene::JsonReader& reader, const Knob& knob, std::string fallback);

// ---- materials ----------------------------------------------------------------------------

// Reads a feature material's fields: `read` gets a JsonReader on material.params at the
// material's JSON path ("$.materials.<name>" where the scene gave none), paths resolved
// against material.base_dir, and runs only when the params are an object; then fields nobody
// read are errors. Every problem is in one Parse error headed "<type> material '<name>'" that
// names each bad field's path; an exception thrown by `read` is a Parse error too.
Result<void> read_material_fields(const scene::Material& material, std::string_view type,
                                  const std::function<void(scene::JsonReader& reader)>& read);

// A descriptor's check_material made from the feature's material parser
// (Result<M> parse(const scene::Material&, Quality)): parse, keep the error, drop the value.
template <auto Parse>
Result<void> check_by_parsing(const scene::Material& material) {
  if (auto parsed = Parse(material, Quality::Medium); !parsed) return std::unexpected(std::move(parsed.error()));
  return {};
}

// What a setting of the knobs costs on the x axis of the trade-off plot.
enum class CostAxis : std::uint8_t {
  Frame,      // steady frame: median GPU time of the frames after the first
  ColdFrame,  // the first frame with empty caches: the feature's bakes (LUTs) plus one frame
};
std::string_view to_string(CostAxis axis);

// ---- the descriptor and the registry --------------------------------------------------------

// An offline precompute a feature offers as `weft bake <name>` (a LUT, a baked visibility, a
// trained model): `add` gives the CLI11 command weft made for it its options and returns what
// runs it (the exit code). `weft bake` lists the bakes of every registered feature -- plugins'
// too -- so a feature with a bake edits nothing under tools/.
struct BakeCommand {
  std::string name;     // "skin-lut"
  std::string summary;  // one line for `weft bake --help`
  std::function<int()> (*add)(CLI::App& command) = nullptr;
};
// What a bake's command returns when it fails: "weft bake <name>: <error>" on stderr, exit 1.
int bake_failed(std::string_view bake, const Error& error);

// Everything weft knows about a feature: one per feature module, registered by the application.
struct FeatureDescriptor {
  // The feature's one name: its folder under passes/, its material type in scene files, its
  // `weft tradeoff --feature` name ("shell_fur"). Older names keep working as aliases ("fur").
  std::string name;
  std::vector<std::string> aliases;
  std::string doc;                     // where it is documented: "docs/fur.md"
  std::string summary;                 // one line: what the feature draws
  // Checks a material of this type (its fields in material.params at material.json_path):
  // one Parse error naming every bad field's JSON path. Quality fills knobs left unset.
  // check_by_parsing<&parse_my_material> makes it from the feature's parser.
  Result<void> (*check_material)(const scene::Material& material) = nullptr;
  FeatureFactory create = nullptr;     // the FeaturePass the renderer adds for this type
  std::vector<std::string> passes;     // its graph passes, for their GPU times

  std::vector<Knob> knobs;
  // The knob values each quality preset gives (read from the feature, so the presets the
  // study measures are the ones `weft render --quality` uses). Null: no preset knobs.
  nlohmann::json (*preset_values)(Quality quality) = nullptr;
  nlohmann::json reference = nlohmann::json::object();  // knob values of the most accurate setting
  std::string reference_why;           // one line; the feature's doc says more
  CostAxis cost = CostAxis::Frame;
  std::vector<std::pair<std::string, std::string>> grids;  // knob pairs a sweep crosses
  // Environment variables set while a study runs (e.g. a bake cache switched off).
  std::vector<std::pair<std::string, std::string>> environment;
  void (*clear_caches)() = nullptr;    // drops process-wide caches so a bake is timed cold
  std::vector<BakeCommand> bakes;      // `weft bake <name>` commands
};

// The features of this process. Registration is explicit (an application registers what it
// links; weft's own tools call register_builtin_features from weft.features.builtin) and
// also registers the name and aliases as a material type with weft.scene. Descriptors live
// as long as the process; pointers to them stay valid.
class FeatureRegistry {
 public:
  // InvalidArgument when the name or an alias is taken, or the descriptor lacks its name,
  // factory or material check. Registering an equal name and aliases again is a no-op.
  Result<void> add(FeatureDescriptor descriptor);
  // By name or alias; nullptr when none.
  [[nodiscard]] const FeatureDescriptor* find(std::string_view name_or_alias) const;
  // NotFound listing the registered names.
  [[nodiscard]] Result<const FeatureDescriptor*> get(std::string_view name_or_alias) const;
  // In registration order.
  [[nodiscard]] std::vector<const FeatureDescriptor*> all() const;
  // "shell_fur (fur), skin_sss (skin)" or "none registered".
  [[nodiscard]] std::string names() const;

  FeatureRegistry();
  ~FeatureRegistry();
  FeatureRegistry(const FeatureRegistry&) = delete;
  FeatureRegistry& operator=(const FeatureRegistry&) = delete;

 private:
  struct State;
  std::unique_ptr<State> state_;
};
FeatureRegistry& feature_registry();
inline Result<void> register_feature(FeatureDescriptor descriptor) { return feature_registry().add(std::move(descriptor)); }

// Scene meshes in weft's vertex layout, and a key of their content for caches (the
// renderer's and the features' GPU copies of the same mesh agree on it).
std::uint64_t mesh_content_hash(const scene::Mesh& mesh);
frame::MeshData to_mesh_data(const scene::Mesh& mesh);

}  // namespace weft
