// weft.viewer — `weft view`: the renderer presenting to a window (GLFW, X11) with a camera
// that orbits, pans, zooms and flies, a Dear ImGui panel of the scene, its knobs, per-pass
// times and the compiled graph, scene hot reload and scripted sessions for tests. The scene
// is rendered only when something changed (at a lower resolution while the camera moves);
// every UI frame re-presents the last image under the UI, so the window stays responsive
// on a CPU adapter whose frames take seconds.
module;
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>
#include <map>
#include <utility>
#include <chrono>
#include <thread>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
struct GLFWwindow;
export module weft.viewer;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.scene;
import weft.image;
import weft.renderer;

export namespace weft::viewer {

// ---- camera --------------------------------------------------------------------------------
// Yaw, pitch and distance about a target (Y up), starting from a scene's camera. Pan and fly
// distances are fractions of the distance to the target, so input feels alike at any scale.
struct CameraPose {
  glm::vec3 position{0.0f, 1.0f, 5.0f};
  glm::vec3 target{0.0f};
  bool operator==(const CameraPose&) const = default;
};
class OrbitCamera {
 public:
  explicit OrbitCamera(CameraPose start);
  // Each move returns false and leaves the camera as it was when an argument is not finite,
  // or when the move would take the pose out of finite space (`pan 1e38 1e38`): the pose is
  // always finite, so a script or replay cannot hand the renderer a NaN camera.
  bool orbit(float yaw_degrees, float pitch_degrees);  // pitch stays within ±89°
  bool pan(float right, float up);
  bool zoom(float factor);  // distance *= factor (ignored unless finite and > 0)
  bool fly(float forward, float right, float up);
  void reset() { *this = OrbitCamera(start_); }
  [[nodiscard]] CameraPose pose() const;
  [[nodiscard]] float distance() const { return distance_; }

 private:
  [[nodiscard]] glm::vec3 forward() const;
  // Keeps the move when the pose it gives is finite; otherwise goes back to `before`.
  bool keep_if_finite(const OrbitCamera& before);
  CameraPose start_;
  glm::vec3 target_{0.0f};
  float distance_ = 1.0f, yaw_ = 0.0f, pitch_ = 0.0f;  // radians
};

// ---- scripted sessions -----------------------------------------------------------------------
// One command per line, '#' starts a comment:
//   orbit DYAW DPITCH | pan RIGHT UP | zoom FACTOR | fly FORWARD RIGHT UP | reset
//   knob MATERIAL FIELD VALUE   (VALUE is JSON: 32, 0.5, true, "adaptive")
//   quality low|medium|high|reference | ui on|off | resize W H | minimize | restore
//   wait FRAMES | refine | screenshot PATH | copy FROM TO | quit
//   compare MATERIAL (its feature's reference at this camera: RMSE, PSNR) | overlay on|off
//   budget MS   (the governor picks each feature's preset for this frame time; waits for it)
//   show NAME   (any resource of the frame instead of its image: a pass slot "scene.depth" or a
//                texture's name; `show frame` goes back)
//   (`copy` also makes the next frame poll the scene file and the shaders for hot reload)
struct ScriptCommand {
  std::string name;
  std::vector<std::string> args;
  int line = 0;
};
struct Script {
  std::filesystem::path path;
  std::vector<ScriptCommand> commands;
};
// Every line is checked up front; an error names the file, the line and what is wrong.
Result<Script> parse_script(const std::filesystem::path& path, const std::string& text);

// ---- the session -----------------------------------------------------------------------------
struct ViewOptions {
  std::filesystem::path scene;
  std::uint32_t width = 1280, height = 720;
  std::string quality = "medium";
  std::optional<std::filesystem::path> script;
  // Scene renders while the camera moves aim at this many milliseconds (dynamic resolution).
  double motion_budget_ms = 100.0;
  // Shader hot reload watches the built-in shaders' sources in the source tree; with a folder,
  // files of the same names there instead ("tonemap.frag"), compiled with it first on the path.
  std::optional<std::filesystem::path> shader_dir;
  // The frame's pipeline file (else the scene's, else the default); edits reload live.
  std::optional<std::filesystem::path> pipeline;
  // Where scene frames are rendered (docs/viewer.md#one-device-or-two):
  //  Shared: on the window's device, into a texture the window then shows (no CPU round trip);
  //  Own: on a device of their own, read back and uploaded to the window's (a CPU adapter runs
  //       one queue's work in order, so a long scene frame would hold the UI's frames back);
  //  Auto: Own on a CPU adapter, Shared on a GPU.
  enum class SceneDevice : std::uint8_t { Auto, Shared, Own } scene_device = SceneDevice::Auto;
  // While the camera rests, average this many frames jittered by sub-pixel Halton offsets
  // (an `accumulate` pass after the frame's image, unless the pipeline has one): the image
  // converges towards supersampling. 1: off. Unset: 16, or 1 in a scripted session (its
  // screenshots stay one frame each unless the script says `accumulate N`).
  std::optional<std::uint32_t> refine_samples;
};
// Runs until the window closes, Escape, or the script's `quit`; the exit code (non-zero with
// a one-line reason on stderr: no display, a bad scene or script, validation messages).
int run(const ViewOptions& options);

}  // namespace weft::viewer

// Shared by the implementation units (not exported).
namespace weft::viewer::detail {

// Dear ImGui's draw data drawn over `target` by a graph pass named "ui".
class UiRenderer {
 public:
  static Result<UiRenderer> create(gpu::Device& device, gpu::Format target);
  // `draw_data` is the ImDrawData of ImGui::GetDrawData() (opaque here: no ImGui in the interface).
  Result<TextureHandle> add_pass(RenderGraph& graph, TextureHandle target, const void* draw_data);

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// A knob as the UI shows it, read from the feature registry's knob tables (knobs.cpp).
enum class KnobKind : std::uint8_t { Integer, Number, Boolean, Choice };
struct UiKnob {
  std::string name;  // the material field; '.' descends: "lut.size"
  KnobKind kind = KnobKind::Integer;
  double min = 0.0, max = 0.0;
  std::vector<std::string> choices;
  std::string meaning;
  nlohmann::json preset;  // the value the quality preset gives when the material leaves it unset
};
std::vector<UiKnob> knobs_for(const scene::Material& material, Quality quality);
// The knob values of the feature's reference setting (null when it has none) and why.
nlohmann::json reference_values(const scene::Material& material, std::string* why = nullptr);

// compare.cpp: a copy of `source` whose materials of `type` take `values` (dotted fields).
std::shared_ptr<const scene::Scene> with_values(const scene::Scene& source, const std::string& type,
                                                const nlohmann::json& values);
struct ComparisonMetrics {
  double rmse = 0.0, psnr = 0.0;  // sRGB-encoded RGB in [0, 1], as shown
  image::Image8 overlay;          // false colour of the largest channel difference
};
Result<ComparisonMetrics> compare_images(const image::Image8& current, const image::Image8& reference);
// The feature whose reference is being compared with, and what came of it.
struct Comparison {
  std::size_t material = 0;
  std::string type, why;
  nlohmann::json reference;
  bool posted = false;                   // the reference job is with the render thread
  std::uint64_t job = 0;                 // that job's id: only its result is taken (an earlier
                                         // request's may still arrive, with the same view)
  std::uint64_t against = 0;             // posted_id of the refined image it compares with
  std::optional<ComparisonMetrics> metrics;
  bool overlay = false;
  std::optional<gpu::Texture> overlay_texture;
};
std::string material_type_name(const scene::Material& material);
bool is_standard(const scene::Material& material);

// Shader hot reload (shader_watch.cpp): polls the built-in shaders' sources, compiles a
// changed one with glslangValidator and replaces the built-in SPIR-V (weft/shader_overrides.h).
class ShaderWatch {
 public:
  explicit ShaderWatch(std::optional<std::filesystem::path> folder);
  struct Reload {
    std::vector<std::string> shaders;  // replaced, by file name
    std::string error;                 // one line naming the shader; nothing was replaced
  };
  // Nothing when no watched file changed since the last poll.
  std::optional<Reload> poll();
  [[nodiscard]] std::size_t watched_files() const { return files_.size(); }

 private:
  Result<std::vector<std::uint32_t>> compile(const std::string& name) const;
  struct File {
    std::filesystem::path path;
    std::optional<std::filesystem::file_time_type> time;
    std::vector<std::string> shaders;  // recompiled when this file changes
  };
  std::optional<std::filesystem::path> folder_;
  std::vector<File> files_;
  std::map<std::string, std::filesystem::path> compile_file_;
  std::map<std::string, std::vector<std::filesystem::path>> includes_;
};

// The window's native handles for gpu::Surface (window_x11.cpp: Xlib stays in that unit).
gpu::NativeWindow native_window(GLFWwindow* window);

using Clock = std::chrono::steady_clock;

// One scene frame to make: the scene (shared, immutable; a new pointer when it changed), the
// camera, the size (smaller while the camera moves) and the preset.
struct RenderJob {
  std::shared_ptr<const scene::Scene> scene;
  scene::Camera camera;
  std::uint32_t width = 0, height = 0;
  Quality quality = Quality::Medium;
  bool moving = false;
  bool describe = false;  // also compile the graph for the Graph panel
  bool reference = false;  // the comparison's reference image, not a frame to show
  double budget_ms = 0.0;  // > 0: fit the features to this frame time (weft.governor), many frames
  std::filesystem::path pipeline_file;  // ViewOptions::pipeline (empty: the scene's)
  // The pipeline with options edited in the Pipeline panel or by the script's `option`;
  // null: pipeline_file's (or the scene's, or the default) as it is.
  std::shared_ptr<const pipeline::Pipeline> pipeline;
  std::string show;        // a resource to show instead of the frame's image (its picture)
  // Temporal refinement of a still view: > 1 renders through a pipeline with an accumulate
  // pass (averaging this many samples), `sample_index` the sample (0 starts afresh).
  std::uint32_t refine_samples = 1;
  std::uint32_t sample_index = 0;
  std::uint64_t id = 0;
};
// What the governor chose: per feature (its material type), the preset's knob values.
struct BudgetOutcome {
  std::vector<std::pair<std::string, nlohmann::json>> values;
  std::string summary;  // weft::governor::BudgetResult::summary
  double measured_ms = 0.0;
  bool met = false;
};
struct RenderResult {
  std::uint64_t id = 0;
  bool moving = false;
  bool reference = false;
  double ms = 0.0;
  std::optional<renderer::Frame> frame;  // none when it failed: `error` says why
  // On a shared device, the frame's image as a texture of the window's device (frame->image is
  // then empty); hand it back with SceneRenderer::give_back once something else is shown.
  std::shared_ptr<gpu::Texture> texture;
  std::optional<renderer::GraphReport> graph;
  std::optional<BudgetOutcome> budget;
  std::string error;
};
// Renders jobs on its own thread (render_thread.cpp); the newest job wins. With `shared` (the
// window's device, which must outlive it) frames go into textures of that device; without, the
// thread makes a device of its own and frames come back as pixels.
class SceneRenderer {
 public:
  static Result<SceneRenderer> start(const gpu::Adapter& adapter, gpu::Device* shared);
  // A texture of RenderResult::texture the window no longer shows: the next frames reuse it.
  void give_back(std::shared_ptr<gpu::Texture> texture);
  SceneRenderer(SceneRenderer&&) noexcept;
  SceneRenderer& operator=(SceneRenderer&&) noexcept;
  ~SceneRenderer();
  void submit(RenderJob job);
  std::optional<RenderResult> take();
  [[nodiscard]] double busy_seconds() const;  // how long the current job has run (0 when idle)
  [[nodiscard]] bool idle() const;
  [[nodiscard]] std::string progress() const;  // the governor's last line while it measures
  // The next job starts with a new renderer: pipelines are made again from the shaders.
  void renew_renderer();

 private:
  SceneRenderer() = default;
  struct Shared;
  std::shared_ptr<Shared> shared_;
  std::thread thread_;
};

// Everything one viewer session owns. Members are declared in the order they must be built
// (and are destroyed in reverse): the window outlives the surface, the device the renderer.
struct Session {
  ViewOptions options;
  GLFWwindow* window = nullptr;
  std::optional<gpu::Instance> instance;
  std::optional<gpu::Surface> surface;
  std::optional<gpu::Adapter> adapter;
  std::optional<gpu::Device> device;
  std::optional<UiRenderer> ui;
  std::optional<SceneRenderer> scene_renderer;
  std::optional<RenderGraph> present_graph;
  gpu::Format surface_format = gpu::Format::BGRA8Unorm;

  scene::Scene scene;
  std::optional<std::filesystem::file_time_type> scene_time;
  std::optional<std::filesystem::file_time_type> pipeline_time;  // of the pipeline file in use, if any
  // The pipeline the Pipeline panel lists and edits: the loaded one (file, scene's or default),
  // and a copy with the options edited here (null: none edited). Saving the pipeline file, or
  // a scene naming another one, drops the edits: the file is the truth.
  std::shared_ptr<const pipeline::Pipeline> loaded_pipeline, edited_pipeline;
  std::string show;  // the resource shown instead of the frame's image (Graph panel, script `show`)
  std::optional<ShaderWatch> shader_watch;
  Clock::time_point last_shader_poll{};
  scene::Camera file_camera;  // the file's camera: a reload that changes it resets the view
  std::optional<OrbitCamera> camera;
  Quality quality = Quality::Medium;

  std::shared_ptr<const scene::Scene> snapshot;  // what the render thread sees; null: stale
  std::shared_ptr<gpu::Texture> last_frame;  // the last scene image (RGBA8, sRGB-encoded)
  bool shared_device = false;  // scene frames render on `device` (ViewOptions::SceneDevice)
  bool last_frame_pooled = false;  // last_frame is the render thread's: give it back when replaced
  // The last job handed to the render thread, to post a new one only when something changed.
  struct Wanted {
    const scene::Scene* scene = nullptr;
    CameraPose pose;
    int width = 0, height = 0;
    Quality quality = Quality::Medium;
    bool moving = false;
    std::string show;
    bool operator==(const Wanted&) const = default;
  };
  std::optional<Wanted> posted;
  std::uint64_t posted_id = 0;
  std::uint64_t reference_jobs = 0;  // ids of reference jobs: their own count, apart from posted_id
  bool refined = false;         // last_frame is the full-resolution image of what is wanted now
  std::uint32_t refine_samples = 16;  // ViewOptions::refine_samples, or the script's `accumulate`
  std::uint32_t accumulated = 0;      // the sample index of the still view's last job posted
  std::uint32_t shown_sample = 0;     // the sample index of the still view's image on screen
  bool waiting_settle = false;        // the script's `settle`: hold it until the accumulation is done
  bool waiting_refine = false;  // the script's `refine`: hold the script until refined
  bool waiting_compare = false;  // the script's `compare`: hold it until the metrics are in
  // The frame-time budget (Budget panel, script `budget`): the target, whether the governor
  // is working, and what it chose last.
  double budget_ms = 500.0;
  bool budget_running = false;
  std::string budget_summary;
  std::optional<image::Image8> refined_image;  // the last refined frame, for comparisons
  std::optional<Comparison> comparison;
  Clock::time_point last_motion = Clock::now() - std::chrono::hours(1);
  float motion_scale = 0.5f;                // dynamic resolution while the camera moves
  std::uint32_t rendered_w = 0, rendered_h = 0;
  double last_render_ms = 0.0;
  double scene_busy_s = 0.0;  // how long the render thread has worked on the current job
  Clock::time_point refine_requested{};     // for the time-to-refined measurement
  double last_refine_ms = -1.0;

  // Shown by the UI.
  bool show_ui = true;
  FrameStats stats;
  std::vector<std::string> passes, warnings;
  std::optional<renderer::GraphReport> graph;
  std::string error;  // the last failed reload or frame, one line; empty when all is well
  std::vector<float> frame_ms_history, ui_ms_history;
  double ui_fps = 0.0;
  std::uint64_t ui_frames = 0, scene_frames = 0;
  // While the camera moves: UI frames and their time, and the scene frames' times and sizes
  // (the numbers docs/viewer.md reports; printed when the session ends).
  std::uint64_t moving_ui_frames = 0;
  double moving_seconds = 0.0;
  std::vector<double> moving_scene_ms;
  std::uint64_t moving_pixels = 0, moving_window_pixels = 0;
  std::vector<double> refine_ms;

  // The script, if any.
  std::optional<Script> script;
  std::size_t script_next = 0;
  int script_wait = 0;
  bool script_hidden = false;
  bool quit = false;
  std::optional<std::filesystem::path> screenshot;
  int screenshots_taken = 0;

  Result<void> open();
  Result<void> load(bool first);
  void poll_reload();
  void poll_shaders();
  void handle_input(double dt);
  void step_script();
  void scene_changed();
  void request_comparison(std::size_t material);
  void request_budget();
  Result<void> update_comparison();  // posts the reference job once the view is refined  // a knob, material, preset or reload: a new snapshot, a new graph
  void post_job(const Wanted& want);
  // The next jittered sample of the still view just refined (temporal refinement).
  void post_refine_sample();
  Result<void> accept(RenderResult result, int window_w, int window_h);
  Result<void> present_frame();
  Result<void> save_screenshot(const gpu::Texture& texture, const std::filesystem::path& path);
  void draw_ui();  // panels.cpp
  void set_knob(std::size_t material, const std::string& field, const nlohmann::json& value);
  // The pipeline frames render with (edited, else loaded; loads it when needed); null when
  // it does not load (the frame then shows why).
  std::shared_ptr<const pipeline::Pipeline> current_pipeline();
  // One option of one pass, checked against its type's options table (pipeline::with_options).
  Result<void> set_pass_option(const std::string& pass, const std::string& option, const nlohmann::json& value);
  void drop_pipeline_edits();
  ~Session();
};

}  // namespace weft::viewer::detail
