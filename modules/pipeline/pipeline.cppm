// weft.pipeline — the frame as data. Every pass a frame can contain (shadow map, scene colour,
// background, tone map, bloom, outlines, debug views, a user's pass) is a registered *pass
// type*: a descriptor with named input and output slots, an options table and a factory. A
// *pipeline* (a JSON file, docs/pipelines.md) names passes of those types with their options,
// wires output slots to input slots and names the frame's output; the renderer instantiates it.
// The engine's modules import no pass: base passes register here like a user's pass does.
module;
#include <cstdint>
#include <deque>
#include <expected>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <nlohmann/json.hpp>
export module weft.pipeline;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.frame;
import weft.scene;
export import weft.feature;

export namespace weft::pipeline {

// ---- options: one table per pass type ----------------------------------------------------

// One option of a pass type. The pipeline reader checks a pass's options against the table
// (kind, range, choices; unknown names are errors), the docs list it, the viewer's UI and
// `weft tradeoff` read it: a range is written once, here.
struct PassOption {
  std::string name;
  KnobKind kind = KnobKind::Number;
  double min = 0.0, max = 0.0;       // Integer, Number: inclusive
  std::vector<std::string> choices;  // Choice
  nlohmann::json default_value;
  std::string meaning;               // one line
  // The values `weft tradeoff --pass` tries, one at a time (empty: the option trades no
  // accuracy for speed and is not swept, e.g. an effect's strength).
  std::vector<nlohmann::json> sweep;
  // The bounds the stability sweep renders where `min` or `max` would cost too much to render
  // in a test (a 16384² shadow map is 1 GiB); unset: the range's own. Why is said where the
  // option is written.
  std::optional<double> extreme_min, extreme_max;
};
PassOption number_option(std::string name, double min, double max, double default_value, std::string meaning,
                         std::vector<nlohmann::json> sweep = {});
PassOption integer_option(std::string name, double min, double max, std::int64_t default_value, std::string meaning,
                          std::vector<nlohmann::json> sweep = {});
PassOption boolean_option(std::string name, bool default_value, std::string meaning);
PassOption choice_option(std::string name, std::vector<std::string> choices, std::string default_value,
                         std::string meaning);
// The option with the bounds the stability sweep renders instead of its range.
PassOption with_extremes(PassOption option, std::optional<double> extreme_min, std::optional<double> extreme_max);
// The values the stability sweep renders an option at: both ends of its range (or its
// extremes), both booleans, every choice.
std::vector<nlohmann::json> extreme_values(const PassOption& option);

// A pass's options after reading: every option of its table, given or defaulted.
class PassOptions {
 public:
  PassOptions() = default;
  explicit PassOptions(nlohmann::json values) : values_(std::move(values)) {}
  [[nodiscard]] double number(std::string_view name) const;
  [[nodiscard]] std::int64_t integer(std::string_view name) const;
  [[nodiscard]] bool boolean(std::string_view name) const;
  [[nodiscard]] std::string choice(std::string_view name) const;
  [[nodiscard]] const nlohmann::json& json() const { return values_; }
  // Out of line: comparing json inline in importers trips clang 19's modules over libstdc++'s
  // hidden-friend iterator operators (undefined references at link time).
  friend bool operator==(const PassOptions& a, const PassOptions& b);

 private:
  nlohmann::json values_ = nlohmann::json::object();
};

// ---- slots -----------------------------------------------------------------------------

// How large a slot's texture is.
enum class SlotSize : std::uint8_t {
  Frame,  // the frame's output size
  Any,    // anything (a shadow map's resolution, a 1x1 placeholder)
};

// A named input or output of a pass type. Inputs list the formats they accept (empty: any)
// and say whether they need the frame's size; an output has one format, or takes the format
// and size of the input named in `same_as`.
struct Slot {
  std::string name;
  std::vector<gpu::Format> formats;
  SlotSize size = SlotSize::Frame;
  bool optional = false;      // inputs: the pass runs without it
  std::string same_as;        // outputs: format and size of this input
  // Inputs: the linear (HDR) image this pass's result is made from; the renderer reads it
  // back for `RenderOptions::read_hdr` (`weft render -o x.exr`) when this pass makes the frame.
  bool linear_source = false;
  // Inputs: takes a multisampled texture as it is (the pass draws into it with pipelines of
  // its sample count: frame::PipelineSamples). Otherwise the runner resolves a multisampled
  // texture (frame::add_resolve_pass, one per texture version) before the pass sees it.
  bool multisampled = false;
  // Inputs: the formats the pass is made for among `formats`, and why. A connection that
  // brings another of `formats` is allowed and warned about (pipeline warnings), e.g. FXAA
  // on linear HDR colour: its thresholds are for display-encoded luma.
  std::vector<gpu::Format> intended_formats;
  std::string intended_why;
  std::string meaning;
};

// ---- the pass interface ----------------------------------------------------------------

// What a frame pass sees of the frame being built. Spans and references live until the
// frame's graph has executed.
struct PassFrame {
  gpu::Device* device = nullptr;
  const scene::Scene& scene;
  std::span<const frame::DrawItem> items;           // the standard-material objects (forward)
  std::span<const frame::DrawItem> shadow_casters;  // what the key light's shadow map draws
  const frame::FrameUniforms& uniforms;
  Quality quality = Quality::Medium;
  std::uint32_t width = 0, height = 0;
  bool key_light = false;  // the scene has a directional light (the first one casts the shadow map)
  // The caller's viewing settings (RenderOptions): a tone-mapping pass multiplies its own
  // exposure option by `exposure`; aces = false asks for the plain clamp (analytic tests).
  float exposure = 1.0f;
  bool aces = true;
  // Temporal accumulation (RenderOptions::sample_index): which sample of a still view this
  // frame is -- 0 starts afresh (an accumulating pass drops its history) -- and the sub-pixel
  // offset, in pixels within [-0.5, 0.5), the renderer moved the projection by (uniforms'
  // matrices include it).
  std::uint32_t sample_index = 0;
  vec2 jitter{0.0f};
  // The scene-colour stage: adds the passes of every feature the scene's materials use,
  // drawing into the frame::SceneTargets on the blackboard. Only the scene_color pass calls it.
  std::function<Result<void>(RenderGraph&)> add_feature_passes;
};

// A pass instance's connections in this frame.
class PassSlots {
 public:
  struct Binding {
    std::string slot;
    TextureHandle handle;
  };
  PassSlots(std::string_view pass, std::vector<Binding> inputs, std::vector<Binding> targets)
      : pass_(pass), inputs_(std::move(inputs)), targets_(std::move(targets)) {}
  // The pipeline's name of this pass: the graph pass name of a single-pass type, the prefix
  // of the graph passes of a type that adds several.
  [[nodiscard]] std::string_view pass_name() const { return pass_; }
  // The handle connected to an input, or an invalid handle when it is not connected.
  [[nodiscard]] TextureHandle input(std::string_view slot) const;
  // An imported texture this output should be written into (the frame's output target), or
  // an invalid handle: the pass creates the texture itself.
  [[nodiscard]] TextureHandle target(std::string_view slot) const;
  void set_output(std::string_view slot, TextureHandle handle);
  [[nodiscard]] TextureHandle output(std::string_view slot) const;

 private:
  std::string pass_;
  std::vector<Binding> inputs_, targets_, outputs_;
};

// One instance of a pass type in a pipeline, made once by the factory with its options and
// kept while the pipeline keeps the pass with the same options.
class FramePass {
 public:
  virtual ~FramePass() = default;
  // Creates or updates GPU objects (pipelines, samplers, placeholders) before add(); called
  // every frame, cheap when nothing changed.
  virtual Result<void> prepare(gpu::Device& device, const PassFrame& frame) = 0;
  // Declares this frame's graph passes: reads slots.input(...), sets every output it has.
  virtual Result<void> add(RenderGraph& graph, const PassFrame& frame, PassSlots& slots) = 0;
};
using FramePassFactory = Result<std::unique_ptr<FramePass>> (*)(const PassOptions& options);

// Everything weft knows about a pass type, in the shape of a FeatureDescriptor.
struct PassTypeDescriptor {
  std::string name;                  // the pipeline file's "type"
  std::string summary;               // one line: what the pass does
  std::string doc;                   // where it is documented: "docs/pipelines.md#bloom"
  std::vector<Slot> inputs, outputs;
  std::vector<PassOption> options;
  FramePassFactory create = nullptr;
  // For `weft tradeoff --pass` and the stability sweep: the option values of the pass's most
  // accurate setting, and why in one line. Empty: the pass trades no accuracy for speed (an
  // effect such as bloom), so it has no study.
  nlohmann::json reference = nlohmann::json::object();
  std::string reference_why;
  // The pass blends frames over time (PassFrame::sample_index counts them): one frame alone
  // shows only sample 0, which `weft render` says when it renders one (use --accumulate N).
  bool temporal = false;
};

// The pass types of this process, in registration order. Thread-safe; descriptors live as
// long as the process (pointers stay valid).
class PassTypeRegistry {
 public:
  // InvalidArgument when the name is taken by a different descriptor, or the descriptor
  // lacks its name or factory, repeats a slot or option name, or has a bad option.
  // Registering the same name with the same slots and options again is a no-op.
  Result<void> add(PassTypeDescriptor descriptor);
  [[nodiscard]] const PassTypeDescriptor* find(std::string_view name) const;
  [[nodiscard]] std::vector<const PassTypeDescriptor*> all() const;
  [[nodiscard]] std::string names() const;  // "background, bloom, ..." or "none registered"

  PassTypeRegistry();
  ~PassTypeRegistry();
  PassTypeRegistry(const PassTypeRegistry&) = delete;
  PassTypeRegistry& operator=(const PassTypeRegistry&) = delete;

 private:
  struct State;
  std::unique_ptr<State> state_;
};
PassTypeRegistry& pass_type_registry();
inline Result<void> register_pass_type(PassTypeDescriptor d) { return pass_type_registry().add(std::move(d)); }

// The slot of a descriptor by name, or null.
const Slot* find_input(const PassTypeDescriptor& type, std::string_view slot);
const Slot* find_output(const PassTypeDescriptor& type, std::string_view slot);

// ---- pipelines -------------------------------------------------------------------------

struct SlotRef {
  std::string pass, slot;
  [[nodiscard]] std::string text() const { return pass + "." + slot; }
  friend bool operator==(const SlotRef&, const SlotRef&) = default;
};
// "pass.slot" (the last '.' separates them); nothing when either side is empty.
std::optional<SlotRef> parse_slot_ref(std::string_view text);

struct PipelinePass {
  std::string name;
  const PassTypeDescriptor* type = nullptr;
  PassOptions options;
};
struct Connection {
  SlotRef from, to;
};

// A validated pipeline: passes in an order that respects every connection (file order where
// connections leave it free), their types resolved and options defaulted.
struct Pipeline {
  std::string source;             // the file, or "(default pipeline)"
  std::string description;
  std::vector<PipelinePass> passes;
  std::vector<Connection> connections;
  std::vector<SlotRef> outputs;   // outputs[0] is the frame's image
  std::vector<std::string> warnings;  // e.g. passes that reach no output (culled)
  std::uint64_t content_hash = 0;     // of the file's text

  [[nodiscard]] const PipelinePass* find(std::string_view pass) const;
  // What feeds an input, or nothing when it is not connected.
  [[nodiscard]] std::optional<SlotRef> source_of(const SlotRef& input) const;
  // The format an output slot carries (following `same_as` back through connections).
  [[nodiscard]] std::optional<gpu::Format> format_of(const SlotRef& output) const;
};

// Reads and validates a pipeline file's text against the registry. Every problem at once, in
// one Parse error; each line starts with its JSON path ("$.passes.bloom.options.intensity").
// `source` names the file in messages.
Result<Pipeline> parse_pipeline(std::string_view text, std::string_view source);
Result<Pipeline> load_pipeline(const std::filesystem::path& path);
// The pipeline every scene without one renders with (assets/pipelines/default.json, built
// into weft so it is there wherever weft runs).
std::string_view default_pipeline_text();
Result<Pipeline> default_pipeline();
// The pipeline as a file: what `weft graph --export-pipeline` writes (reads back equal).
std::string to_json(const Pipeline& pipeline);
// The pipeline with options of one pass replaced (`values`: option name -> value), checked as
// the file reader checks them (names, kinds, ranges, choices: errors at their JSON path).
// What the viewer's option widgets, `weft tradeoff --pass` and the stability sweep apply.
Result<Pipeline> with_options(const Pipeline& pipeline, std::string_view pass, const nlohmann::json& values);

// Markdown of every registered pass type: summary, slots and the options table (docs).
std::string pass_types_markdown();

// ---- plugins ---------------------------------------------------------------------------

struct LoadedPlugin {
  std::string path;
  std::vector<std::string> pass_types, features;  // what it registered
};

// What a plugin's entry point (WEFT_PLUGIN in <weft/plugin.h>) registers through. Nothing is
// registered until the entry point returns and every name is checked free: a plugin whose
// registration collides registers nothing.
class PluginRegistrar {
 public:
  void add_pass_type(const PassTypeDescriptor& descriptor) { pass_types_.push_back(descriptor); }
  void add_feature(const FeatureDescriptor& descriptor) { features_.push_back(descriptor); }
  // A problem the plugin found itself (a missing asset, say): the load fails with it.
  void error(std::string message) { errors_.push_back(std::move(message)); }

 private:
  std::vector<PassTypeDescriptor> pass_types_;
  std::vector<FeatureDescriptor> features_;
  std::vector<std::string> errors_;
  friend Result<LoadedPlugin> load_plugin(const std::filesystem::path& path);
};


// Loads a plugin and registers what it registers. Errors (one line each, naming the file):
// not loadable (not a shared library, missing libraries), no entry point, another ABI
// version, a name already taken, a bad descriptor. Loading the same file again is a no-op.
Result<LoadedPlugin> load_plugin(const std::filesystem::path& path);
// The plugins loaded so far, in load order.
std::vector<LoadedPlugin> loaded_plugins();
// "sobel.so (sobel_outline)" or "none".
std::string loaded_plugin_names();
// WEFT_PLUGIN_PATH: ':'-separated files and folders (every *.so in a folder, sorted). A bad
// plugin there is a warning (returned, one line each) and the rest still load.
std::vector<std::string> load_plugins_from_environment();

}  // namespace weft::pipeline
