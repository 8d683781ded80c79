// The viewer's loop: input and script -> camera and knobs -> (when something changed) a scene
// frame through weft.renderer -> a present graph that blits the last scene image into the
// window's texture and draws the UI over it -> present. Scene frames are skipped while
// nothing changes, made smaller while the camera moves, and refined once it stops.
module;
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <expected>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
#include <glm/glm.hpp>
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <nlohmann/json.hpp>
#include <weft/text_input.h>
module weft.viewer;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.image;
import weft.scene;
import weft.renderer;

namespace weft::viewer {
using namespace detail;

namespace {

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::string glfw_error_text;
void on_glfw_error(int, const char* description) { glfw_error_text = description ? description : "unknown"; }

int no_window(const std::string& why, const std::filesystem::path& scene) {
  std::fprintf(stderr, "weft view: %s; to render without a window: weft render %s -o out.png\n", why.c_str(),
               scene.string().c_str());
  return 2;
}

std::optional<std::filesystem::file_time_type> modified_time(const std::filesystem::path& path) {
  std::error_code ec;
  auto t = std::filesystem::last_write_time(path, ec);
  if (ec) return std::nullopt;
  return t;
}

}  // namespace

Session::~Session() {
  if (device) (void)device->queue().wait_idle();
  present_graph.reset();
  ui.reset();
  if (ImGui::GetCurrentContext()) {
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
  }
  scene_renderer.reset();  // joins the render thread
  last_frame.reset();
  surface.reset();
  device.reset();
  adapter.reset();
  instance.reset();
  if (window) glfwDestroyWindow(window);
  glfwTerminate();
}

Result<void> Session::load(bool first) {
  auto loaded = scene::load_scene(options.scene);
  scene_time = modified_time(options.scene);
  if (!loaded) return std::unexpected(loaded.error());
  const bool camera_changed = first || loaded->camera.position != file_camera.position ||
                              loaded->camera.target != file_camera.target;
  file_camera = loaded->camera;
  if (loaded->pipeline != scene.pipeline) drop_pipeline_edits();  // another pipeline: the edits were of the old one
  scene = std::move(*loaded);
  if (camera_changed) camera.emplace(CameraPose{scene.camera.position, scene.camera.target});
  scene_changed();
  return {};
}

void Session::poll_reload() {
  // The pipeline file (--pipeline, or the scene's "pipeline"): the renderer reads it again when
  // it changed; a new snapshot makes the render thread render with it. A bad edit is the
  // frame's error, and the last good image stays.
  const std::filesystem::path pipeline_file = options.pipeline.value_or(scene.pipeline);
  if (!pipeline_file.empty()) {
    const auto pipeline_now = modified_time(pipeline_file);
    if (pipeline_now != pipeline_time) {
      const bool first = !pipeline_time;
      pipeline_time = pipeline_now;
      if (!first) {
        log::info(weft::format("pipeline {} changed{}", pipeline_file.string(),
                               edited_pipeline ? "; the options edited in the viewer are replaced by the file's" : ""));
        drop_pipeline_edits();
        if (error.rfind("frame failed", 0) == 0) error.clear();
        scene_changed();
      }
    }
  }
  const auto now = modified_time(options.scene);
  if (!now || now == scene_time) return;
  if (auto ok = load(false); !ok) {
    error = weft::format("reload of {} failed: {}", options.scene.string(), ok.error().what());
    log::warn(error);
    return;  // the last good scene and frame stay
  }
  error.clear();
  log::info(weft::format("reloaded {}", options.scene.string()));
}

// Every half second: a saved shader is compiled and replaces the built-in; the render thread
// makes its pipelines again and the view is rendered anew. A bad shader keeps the last frame.
void Session::poll_shaders() {
  if (!shader_watch || seconds_since(last_shader_poll) < 0.5) return;
  last_shader_poll = Clock::now();
  auto reload = shader_watch->poll();
  if (!reload) return;
  if (!reload->error.empty()) {
    error = "shader reload failed: " + reload->error;
    log::warn(error);
    return;
  }
  std::string names;
  for (const auto& n : reload->shaders) names += (names.empty() ? "" : ", ") + n;
  log::info(weft::format("shaders reloaded: {}", names));
  if (error.rfind("shader reload failed", 0) == 0) error.clear();
  scene_renderer->renew_renderer();
  scene_changed();
}

Result<void> Session::open() {
  if (auto q = renderer::quality_from_string(options.quality); q)
    quality = *q;
  else
    return std::unexpected(q.error());
  if (options.script) {
    if (auto why = binary_text_input(*options.script, "script")) return fail(ErrorKind::Parse, "{}", *why);
    auto text = read_input_file(*options.script, "script");
    if (!text) return std::unexpected(text.error());
    auto parsed = parse_script(*options.script, std::string(text->begin(), text->end()));
    if (!parsed) return std::unexpected(parsed.error());
    script = std::move(*parsed);
  }
  // The pipeline file and the shader folder are named before the window opens, as the script
  // is (issue 33: a FIFO, a folder or a missing --pipeline surfaced only after the display).
  // Their contents are the live reload's: a pipeline that does not compile yet is shown in the UI.
  if (options.pipeline)
    if (auto ok = check_input_file(*options.pipeline, "pipeline file"); !ok) return ok;
  if (options.shader_dir && !std::filesystem::is_directory(*options.shader_dir))
    return fail(ErrorKind::InvalidArgument, "--shader-dir '{}' is not a folder", options.shader_dir->string());
  refine_samples = options.refine_samples.value_or(options.script ? 1u : 16u);
  return load(true);
}

void Session::set_knob(std::size_t material, const std::string& field, const nlohmann::json& value) {
  // "lut.size" descends into objects, as the knob tables name fields.
  nlohmann::json* at = &scene.materials.at(material).params;
  std::string rest = field;
  for (auto dot = rest.find('.'); dot != std::string::npos; dot = rest.find('.')) {
    at = &(*at)[rest.substr(0, dot)];
    rest.erase(0, dot + 1);
  }
  (*at)[rest] = value;
  scene_changed();
}

std::shared_ptr<const pipeline::Pipeline> Session::current_pipeline() {
  if (edited_pipeline) return edited_pipeline;
  if (!loaded_pipeline) {
    const std::filesystem::path file = options.pipeline.value_or(scene.pipeline);
    auto loaded = file.empty() ? pipeline::default_pipeline() : pipeline::load_pipeline(file);
    if (!loaded) return nullptr;  // the frame's error says why
    loaded_pipeline = std::make_shared<const pipeline::Pipeline>(std::move(*loaded));
  }
  return loaded_pipeline;
}

Result<void> Session::set_pass_option(const std::string& pass, const std::string& option, const nlohmann::json& value) {
  const auto base = current_pipeline();
  if (!base) return fail(ErrorKind::InvalidArgument, "the pipeline does not load, so its options cannot be set");
  auto changed = pipeline::with_options(*base, pass, nlohmann::json{{option, value}});
  if (!changed) return std::unexpected(changed.error());
  edited_pipeline = std::make_shared<const pipeline::Pipeline>(std::move(*changed));
  scene_changed();
  return {};
}

void Session::drop_pipeline_edits() {
  loaded_pipeline.reset();
  if (!edited_pipeline) return;
  edited_pipeline.reset();
  scene_changed();
}

void Session::scene_changed() {
  snapshot.reset();
  graph.reset();
}

void Session::handle_input(double dt) {
  ImGuiIO& io = ImGui::GetIO();
  bool moved = false;
  static double last_x = 0, last_y = 0;
  double x = 0, y = 0;
  glfwGetCursorPos(window, &x, &y);
  const double dx = x - last_x, dy = y - last_y;
  last_x = x;
  last_y = y;
  if (!io.WantCaptureMouse) {
    if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS && (dx != 0 || dy != 0)) {
      camera->orbit(float(-dx) * 0.3f, float(dy) * 0.3f);
      moved = true;
    }
    if ((glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS ||
         glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS) &&
        (dx != 0 || dy != 0)) {
      camera->pan(float(-dx) * 0.002f, float(dy) * 0.002f);
      moved = true;
    }
    if (io.MouseWheel != 0.0f) {
      camera->zoom(std::pow(0.9f, io.MouseWheel));
      moved = true;
    }
  }
  if (!io.WantCaptureKeyboard) {
    const float step = float(dt) * 0.8f;
    auto key = [&](int k) { return glfwGetKey(window, k) == GLFW_PRESS; };
    const float f = (key(GLFW_KEY_W) ? step : 0.0f) - (key(GLFW_KEY_S) ? step : 0.0f);
    const float r = (key(GLFW_KEY_D) ? step : 0.0f) - (key(GLFW_KEY_A) ? step : 0.0f);
    const float u = (key(GLFW_KEY_E) ? step : 0.0f) - (key(GLFW_KEY_Q) ? step : 0.0f);
    if (f != 0 || r != 0 || u != 0) {
      camera->fly(f, r, u);
      moved = true;
    }
    if (ImGui::IsKeyPressed(GLFW_KEY_R, false)) {
      camera->reset();
      moved = true;
    }
    if (ImGui::IsKeyPressed(GLFW_KEY_H, false) || ImGui::IsKeyPressed(GLFW_KEY_F1, false)) show_ui = !show_ui;
    if (ImGui::IsKeyPressed(GLFW_KEY_P, false) || ImGui::IsKeyPressed(GLFW_KEY_F12, false))
      screenshot = weft::format("weft-view-{}.png", screenshots_taken + 1);
    if (ImGui::IsKeyPressed(GLFW_KEY_ESCAPE, false)) quit = true;
  }
  if (moved) last_motion = Clock::now();
}

// Runs script commands until one that needs frames to pass (wait, resize, screenshot...).
void Session::step_script() {
  if (!script || quit) return;
  if (script_wait > 0) {
    --script_wait;
    return;
  }
  if (waiting_refine) {
    if (!refined) return;
    waiting_refine = false;
  }
  if (waiting_settle) {
    if (!refined || (refine_samples > 1 && shown_sample + 1 < refine_samples && !comparison && show.empty())) return;
    waiting_settle = false;
  }
  if (waiting_compare) {
    if (comparison && !comparison->metrics) return;
    waiting_compare = false;
  }
  if (budget_running) return;
  auto number = [](const std::string& s) { return std::stof(s); };
  while (script_next < script->commands.size()) {
    const ScriptCommand& c = script->commands[script_next++];
    const auto& a = c.args;
    // A move the camera refuses (it would leave finite space: `pan 1e38 1e38`) is a warning
    // naming the line; the view stays where it was.
    auto camera_moved = [&](bool applied) {
      last_motion = Clock::now();
      if (applied) return;
      std::string line = c.name;
      for (const auto& arg : a) line += " " + arg;
      error = weft::format("{}:{}: '{}' ignored: the camera would leave finite space", script->path.string(), c.line, line);
      log::warn(error);
    };
    if (c.name == "orbit") {
      camera_moved(camera->orbit(number(a[0]), number(a[1])));
      return;  // one camera step per frame, as a dragging user would
    } else if (c.name == "pan") {
      camera_moved(camera->pan(number(a[0]), number(a[1])));
      return;
    } else if (c.name == "zoom") {
      camera_moved(camera->zoom(number(a[0])));
      return;
    } else if (c.name == "fly") {
      camera_moved(camera->fly(number(a[0]), number(a[1]), number(a[2])));
      return;
    } else if (c.name == "reset") {
      camera->reset();
      camera_moved(true);
    } else if (c.name == "knob") {
      auto it = std::find_if(scene.materials.begin(), scene.materials.end(), [&](auto& m) { return m.name == a[0]; });
      if (it == scene.materials.end()) {
        error = weft::format("{}:{}: no material '{}' in the scene", script->path.string(), c.line, a[0]);
        log::warn(error);
        continue;
      }
      set_knob(std::size_t(it - scene.materials.begin()), a[1], nlohmann::json::parse(a[2]));
    } else if (c.name == "option") {
      if (auto ok = set_pass_option(a[0], a[1], nlohmann::json::parse(a[2])); !ok) {
        error = weft::format("{}:{}: {}", script->path.string(), c.line, ok.error().what());
        log::warn(error);
      }
    } else if (c.name == "quality") {
      if (auto q = renderer::quality_from_string(a[0]); q) {
        quality = *q;
        scene_changed();
      } else {
        error = weft::format("{}:{}: {}", script->path.string(), c.line, q.error().message);
        log::warn(error);
      }
    } else if (c.name == "ui") {
      show_ui = a[0] == "on";
    } else if (c.name == "overlay") {
      if (comparison) comparison->overlay = a[0] == "on";
    } else if (c.name == "resize") {
      glfwSetWindowSize(window, std::stoi(a[0]), std::stoi(a[1]));
      script_wait = 2;
      return;
    } else if (c.name == "minimize") {
      // Without a window manager (Xvfb) iconifying does nothing, so the window is also unmapped.
      glfwIconifyWindow(window);
      glfwHideWindow(window);
      script_hidden = true;
      script_wait = 2;
      return;
    } else if (c.name == "restore") {
      glfwShowWindow(window);
      glfwRestoreWindow(window);
      script_hidden = false;
      script_wait = 2;
      return;
    } else if (c.name == "wait") {
      script_wait = std::max(0, std::stoi(a[0]) - 1);
      return;
    } else if (c.name == "refine") {
      // Held until the full-resolution image of the current state arrives (0.25 s after the
      // last camera move, as for a user who let go of the mouse).
      waiting_refine = true;
      return;
    } else if (c.name == "accumulate") {
      // Temporal refinement of the still view from now on: N samples (1: off); the view
      // starts its accumulation again.
      refine_samples = std::uint32_t(std::stoi(a[0]));
      posted.reset();
      continue;
    } else if (c.name == "settle") {
      // Held until the still view's accumulation is complete (or at once when it is off).
      waiting_settle = true;
      return;
    } else if (c.name == "screenshot") {
      screenshot = a[0];
      return;
    } else if (c.name == "copy") {
      std::error_code ec;
      std::filesystem::copy_file(a[0], a[1], std::filesystem::copy_options::overwrite_existing, ec);
      if (ec) {
        error = weft::format("{}:{}: cannot copy '{}' to '{}': {}", script->path.string(), c.line, a[0], a[1],
                             ec.message());
        log::warn(error);
      } else {
        // Some file systems keep whole-second times: make the change visible to the poll.
        std::filesystem::last_write_time(a[1], std::filesystem::file_time_type::clock::now(), ec);
        last_shader_poll = {};  // and poll the shaders on the next frame, not in half a second
      }
      return;
    } else if (c.name == "compare") {
      auto it = std::find_if(scene.materials.begin(), scene.materials.end(), [&](auto& m) { return m.name == a[0]; });
      if (it == scene.materials.end() || reference_values(*it).is_null()) {
        error = weft::format("{}:{}: no material '{}' with a reference setting in the scene", script->path.string(),
                             c.line, a[0]);
        log::warn(error);
        continue;
      }
      request_comparison(std::size_t(it - scene.materials.begin()));
      waiting_compare = true;
      return;
    } else if (c.name == "budget") {
      budget_ms = std::stod(a[0]);
      request_budget();
      return;
    } else if (c.name == "show") {
      // The next frame shows this resource (or the frame's image again); a name the frame
      // does not have is that frame's error, named with what there is.
      show = a[0] == "frame" ? std::string() : a[0];
      posted.reset();
      continue;
    } else if (c.name == "quit") {
      quit = true;
      return;
    }
  }
  quit = true;  // the script ran out
}

void Session::post_job(const Wanted& want) {
  std::uint32_t w = std::uint32_t(want.width), h = std::uint32_t(want.height);
  if (want.moving) {
    w = std::max(16u, std::uint32_t(std::lround(want.width * motion_scale)));
    h = std::max(16u, std::uint32_t(std::lround(want.height * motion_scale)));
  }
  scene::Camera view = scene.camera;
  view.position = want.pose.position;
  view.target = want.pose.target;
  scene_renderer->submit({.scene = snapshot, .camera = view, .width = w, .height = h, .quality = want.quality,
                          .moving = want.moving, .describe = !want.moving && !graph,
                          .pipeline_file = options.pipeline.value_or(std::filesystem::path{}), .pipeline = edited_pipeline,
                          .show = want.show, .refine_samples = want.show.empty() ? refine_samples : 1,
                          .id = ++posted_id});
  if (posted && posted->moving && !want.moving && seconds_since(last_motion) < 3600) refine_requested = last_motion;
  posted = want;
  refined = false;
  accumulated = 0;
  if (comparison) {  // the view changed: compare again once it is refined
    comparison->posted = false;
    comparison->metrics.reset();
    comparison->overlay_texture.reset();
  }
}

void Session::post_refine_sample() {
  scene::Camera view = scene.camera;
  view.position = posted->pose.position;
  view.target = posted->pose.target;
  scene_renderer->submit({.scene = snapshot, .camera = view, .width = std::uint32_t(posted->width),
                          .height = std::uint32_t(posted->height), .quality = posted->quality,
                          .pipeline_file = options.pipeline.value_or(std::filesystem::path{}), .pipeline = edited_pipeline,
                          .refine_samples = refine_samples, .sample_index = ++accumulated, .id = ++posted_id});
}

// The governor runs on the render thread at the window's full size and the current camera: it
// renders many frames (each feature at each preset), so the window shows its progress.
void Session::request_budget() {
  if (budget_running) return;
  if (!posted) {
    budget_summary = "the budget is fitted once the first frame is on screen";
    log::warn(budget_summary);
    return;
  }
  scene::Camera view = scene.camera;
  view.position = posted->pose.position;
  view.target = posted->pose.target;
  if (!snapshot) snapshot = std::make_shared<const scene::Scene>(scene);
  scene_renderer->submit({.scene = snapshot, .camera = view, .width = std::uint32_t(posted->width),
                          .height = std::uint32_t(posted->height), .quality = posted->quality, .budget_ms = budget_ms,
                          .pipeline_file = options.pipeline.value_or(std::filesystem::path{}), .pipeline = edited_pipeline,
                          .id = ++posted_id});
  budget_running = true;
  budget_summary = weft::format("measuring the features for a {:.0f} ms budget...", budget_ms);
}

void Session::request_comparison(std::size_t material) {
  Comparison c;
  c.material = material;
  c.type = material_type_name(scene.materials.at(material));
  c.reference = reference_values(scene.materials[material], &c.why);
  const bool overlay = comparison && comparison->overlay;
  comparison = std::move(c);
  comparison->overlay = overlay;
}

Result<void> Session::update_comparison() {
  if (!comparison || comparison->posted || !refined || !posted) return {};
  if (!refined_image) {
    // On a shared device the refined frame is a texture only: its pixels are read once, here.
    if (!last_frame) return {};
    auto bytes = device->queue().read_texture(*last_frame);
    if (!bytes) return std::unexpected(bytes.error());
    image::Image8 pixels = image::Image8::filled(last_frame->size().width, last_frame->size().height, 4);
    std::memcpy(pixels.pixels.data(), bytes->data(), pixels.pixels.size());
    refined_image = std::move(pixels);
  }
  scene::Camera view = scene.camera;
  view.position = posted->pose.position;
  view.target = posted->pose.target;
  scene_renderer->submit({.scene = with_values(scene, comparison->type, comparison->reference), .camera = view,
                          .width = refined_image->width, .height = refined_image->height, .quality = posted->quality,
                          .reference = true, .pipeline_file = options.pipeline.value_or(std::filesystem::path{}),
                          .pipeline = edited_pipeline, .id = ++reference_jobs});
  comparison->posted = true;
  comparison->job = reference_jobs;
  comparison->against = posted_id;
  return {};
}

Result<void> Session::accept(RenderResult result, int window_w, int window_h) {
  if (budget_running && !result.reference && (result.budget || !result.error.empty()) && !result.frame) {
    budget_running = false;
    if (!result.budget) {
      budget_summary.clear();
      error = weft::format("budget failed: {}", result.error);
      log::warn(error);
    } else {
      // The chosen presets become the materials' knob values, as if set in the Scene panel.
      for (const auto& [type, values] : result.budget->values)
        for (std::size_t m = 0; m < scene.materials.size(); ++m)
          if (material_type_name(scene.materials[m]) == type)
            for (const auto& [field, value] : values.items()) set_knob(m, field, value);
      budget_summary = result.budget->summary;
      std::printf("budget: %s\n", budget_summary.c_str());
      std::fflush(stdout);
    }
    posted.reset();  // the view is posted again with the chosen settings
    scene_changed();
    return {};
  }
  if (result.reference) {
    // A reference of an earlier request (the view's automatic re-compare, then the script's or
    // the user's own) is dropped: taking it would print and store one comparison twice.
    if (!comparison || !comparison->posted || comparison->job != result.id || comparison->against != posted_id)
      return {};
    if (!result.frame) {
      error = weft::format("reference frame failed: {}", result.error);
      comparison.reset();
      return {};
    }
    auto metrics = compare_images(*refined_image, result.frame->image);
    if (!metrics) return std::unexpected(metrics.error());
    const auto& o = metrics->overlay;
    auto t = device->create_texture({.label = "viewer difference", .size = {o.width, o.height, 1},
                                     .format = gpu::Format::RGBA8Unorm,
                                     .usage = gpu::TextureUsage::CopySrc | gpu::TextureUsage::CopyDst});
    if (!t) return std::unexpected(t.error());
    if (auto ok = device->queue().write_texture(*t, std::as_bytes(std::span(o.pixels)), 0, gpu::Access::CopySrc); !ok)
      return ok;
    comparison->overlay_texture.emplace(std::move(*t));
    std::printf("compare %s (%s): RMSE %.6f, PSNR %.2f dB against its reference (%s)\n",
                scene.materials.at(comparison->material).name.c_str(), comparison->type.c_str(), metrics->rmse,
                metrics->psnr, comparison->reference.dump().c_str());
    std::fflush(stdout);
    comparison->metrics = std::move(*metrics);
    return {};
  }
  if (!result.frame) {
    error = weft::format("frame failed: {}", result.error);
    log::warn(error);
    if (result.id == posted_id) refined = !result.moving;  // nothing better is coming for this state
    return {};  // the last good image stays
  }
  auto& frame = *result.frame;
  // The window shows the render thread's texture (shared device), or its pixels uploaded into
  // a texture of the window's device. A texture from the render thread goes back to it once
  // another image is shown (this thread's frames that read it have completed by then).
  auto replace_frame = [&](std::shared_ptr<gpu::Texture> next, bool pooled) {
    if (last_frame_pooled) scene_renderer->give_back(std::move(last_frame));
    last_frame = std::move(next);
    last_frame_pooled = pooled;
  };
  std::uint32_t w = frame.image.width, h = frame.image.height;
  if (result.texture) {
    w = result.texture->size().width;
    h = result.texture->size().height;
    replace_frame(std::move(result.texture), true);
  } else {
    if (!last_frame || last_frame_pooled || last_frame->size().width != w || last_frame->size().height != h) {
      auto t = device->create_texture({.label = "viewer frame", .size = {w, h, 1}, .format = gpu::Format::RGBA8Unorm,
                                       .usage = gpu::TextureUsage::CopySrc | gpu::TextureUsage::CopyDst});
      if (!t) return std::unexpected(t.error());
      replace_frame(std::make_shared<gpu::Texture>(std::move(*t)), false);
    }
    if (auto ok = device->queue().write_texture(*last_frame, std::as_bytes(std::span(frame.image.pixels)), 0,
                                                gpu::Access::CopySrc);
        !ok)
      return ok;
  }
  last_render_ms = result.ms;
  rendered_w = w;
  rendered_h = h;
  ++scene_frames;
  if (result.moving) {
    moving_scene_ms.push_back(result.ms);
    moving_pixels += std::uint64_t(w) * h;
    moving_window_pixels += std::uint64_t(window_w) * std::uint64_t(window_h);
    // Aim the next moving frame at the budget: time grows about with the pixel count.
    const double ratio = std::sqrt(options.motion_budget_ms / std::max(result.ms, 1.0));
    motion_scale = float(std::clamp(double(motion_scale) * std::clamp(ratio, 0.5, 1.5), 0.1, 1.0));
  }
  if (error.rfind("frame failed", 0) == 0) error.clear();
  stats = std::move(frame.stats);
  passes = std::move(frame.passes);
  warnings = std::move(frame.warnings);
  if (result.graph) graph = std::move(result.graph);
  frame_ms_history.push_back(float(result.ms));
  if (frame_ms_history.size() > 120) frame_ms_history.erase(frame_ms_history.begin());
  if (result.id == posted_id && !result.moving) {
    refined = true;
    shown_sample = accumulated;
    // A still view refines: the next jittered sample, until the accumulation has them all
    // (not while a comparison or the budget uses the render thread, nor for a resource shown).
    if (refine_samples > 1 && accumulated + 1 < refine_samples && posted && !posted->moving && posted->show.empty() &&
        !budget_running && !comparison)
      post_refine_sample();
    if (frame.image.pixels.empty())
      refined_image.reset();  // read from the texture if a comparison needs it
    else
      refined_image = frame.image;
    if (refine_requested != Clock::time_point{}) {
      last_refine_ms = std::chrono::duration<double, std::milli>(Clock::now() - refine_requested).count();
      refine_ms.push_back(last_refine_ms);
      refine_requested = {};
    }
  }
  return {};
}

Result<void> Session::save_screenshot(const gpu::Texture& texture, const std::filesystem::path& path) {
  auto bytes = device->queue().read_texture(texture);
  if (!bytes) return std::unexpected(bytes.error());
  auto image = image::Image8::filled(texture.size().width, texture.size().height, 4);
  const bool bgra = texture.format() == gpu::Format::BGRA8Unorm;
  const auto* in = reinterpret_cast<const std::uint8_t*>(bytes->data());
  for (std::size_t i = 0; i < image.pixels.size(); i += 4) {
    image.pixels[i + 0] = in[i + (bgra ? 2 : 0)];
    image.pixels[i + 1] = in[i + 1];
    image.pixels[i + 2] = in[i + (bgra ? 0 : 2)];
    image.pixels[i + 3] = 255;
  }
  if (auto ok = image::save_png(path, image); !ok) return ok;
  std::printf("screenshot %s (%ux%u)\n", path.string().c_str(), image.width, image.height);
  std::fflush(stdout);
  ++screenshots_taken;
  return {};
}

Result<void> Session::present_frame() {
  auto current = surface->get_current_texture();
  if (!current) return std::unexpected(current.error());
  if (current->status == gpu::SurfaceStatus::Minimized) return {};
  const gpu::Texture& target = *current->texture;
  if (present_graph)
    present_graph->reset();
  else
    present_graph.emplace("present");
  RenderGraph& frame_graph = *present_graph;
  TextureHandle window_texture = frame_graph.import_texture("window", &target, gpu::Access::Undefined);
  if (last_frame) {
    struct Blit {
      TextureHandle src, dst;
    };
    const bool overlay = comparison && comparison->overlay && comparison->overlay_texture;
    const gpu::Texture& shown = overlay ? *comparison->overlay_texture : *last_frame;
    const TextureHandle image = frame_graph.import_texture("viewer frame", &shown, gpu::Access::CopySrc);
    const bool same_size = shown.size() == target.size();
    auto& blit = frame_graph.add_pass<Blit>(
        "present_blit",
        [&](PassBuilder& b, Blit& d) {
          d.src = b.read(image, TextureUse::CopySrc);
          d.dst = b.write(window_texture, TextureUse::CopyDst);
        },
        [same_size](const PassResources& res, const Blit& d, PassContext& ctx) {
          ctx.encoder().blit_texture(res.texture(d.src), res.texture(d.dst),
                                     same_size ? gpu::FilterMode::Nearest : gpu::FilterMode::Linear);
        });
    window_texture = blit.dst;
  } else {
    struct Clear {
      TextureHandle dst;
    };
    auto& clear = frame_graph.add_pass<Clear>(
        "clear", [&](PassBuilder& b, Clear& d) { d.dst = b.write(window_texture, TextureUse::ColorAttachment); },
        [](const PassResources& res, const Clear& d, PassContext& ctx) {
          auto pass = ctx.encoder().begin_render_pass(
              {.label = "clear", .color_attachments = {{.view = &res.view(d.dst), .clear_color = {0.1f, 0.1f, 0.1f, 1}}}});
          pass.end();
        });
    window_texture = clear.dst;
  }
  if (show_ui) {
    auto drawn = ui->add_pass(frame_graph, window_texture, ImGui::GetDrawData());
    if (!drawn) return std::unexpected(drawn.error());
    window_texture = *drawn;
  }
  frame_graph.mark_output(window_texture, gpu::Access::Present);
  auto compiled = frame_graph.compile({.output_extent = target.size(), .device = &*device});
  if (!compiled) return std::unexpected(compiled.error().to_error());
  auto ran = compiled->execute(*device, {.timestamps = false});
  if (!ran) return std::unexpected(ran.error());
  if (screenshot) {
    auto ok = save_screenshot(target, *screenshot);
    screenshot.reset();
    if (!ok) return ok;
  }
  return surface->present();
}

int run(const ViewOptions& options) {
  Session s;
  s.options = options;
  if (auto ok = s.open(); !ok) {
    std::fprintf(stderr, "weft view: %s\n", ok.error().what().c_str());
    return 1;
  }
  glfwSetErrorCallback(on_glfw_error);
  const char* display = std::getenv("DISPLAY");
  if (!display || !*display) return no_window("no display (DISPLAY is not set)", options.scene);
  if (!glfwInit()) return no_window("cannot open the display '" + std::string(display) + "': " + glfw_error_text, options.scene);

  auto instance = gpu::Instance::create({.application_name = "weft-view", .presentation = true});
  if (!instance) return no_window("no Vulkan presentation: " + instance.error().message, options.scene);
  s.instance.emplace(std::move(*instance));
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  const std::string title = "weft view - " + options.scene.filename().string();
  s.window = glfwCreateWindow(int(options.width), int(options.height), title.c_str(), nullptr, nullptr);
  if (!s.window) return no_window("cannot create a window: " + glfw_error_text, options.scene);
  auto surface = s.instance->create_surface(native_window(s.window));
  if (!surface) return no_window(surface.error().message, options.scene);
  s.surface.emplace(std::move(*surface));
  auto adapter = s.instance->request_adapter();
  if (!adapter) return no_window(adapter.error().message, options.scene);
  s.adapter.emplace(std::move(*adapter));
  auto device = s.adapter->request_device({.label = "weft view"});
  if (!device) return no_window(device.error().message, options.scene);
  s.device.emplace(std::move(*device));
  auto caps = s.surface->capabilities(*s.device);
  if (!caps) return no_window(caps.error().message, options.scene);
  // A UNORM target: the tone-mapped image is already sRGB-encoded, and so are ImGui's colours.
  for (auto f : {gpu::Format::BGRA8Unorm, gpu::Format::RGBA8Unorm})
    if (std::find(caps->formats.begin(), caps->formats.end(), f) != caps->formats.end()) {
      s.surface_format = f;
      break;
    }
  int fw = 0, fh = 0;
  glfwGetFramebufferSize(s.window, &fw, &fh);
  if (auto ok = s.surface->configure(*s.device, {.format = s.surface_format, .width = std::uint32_t(fw),
                                                 .height = std::uint32_t(fh),
                                                 .present_mode = gpu::PresentMode::Fifo});
      !ok)
    return no_window(ok.error().message, options.scene);

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini next to the user's files
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOther(s.window, true);
  auto ui = UiRenderer::create(*s.device, s.surface_format);
  if (!ui) {
    std::fprintf(stderr, "weft view: %s\n", ui.error().what().c_str());
    return 1;
  }
  s.ui.emplace(std::move(*ui));
  // One device or two (ViewOptions::scene_device): docs/viewer.md measures both.
  using SceneDevice = ViewOptions::SceneDevice;
  s.shared_device = options.scene_device == SceneDevice::Shared ||
                    (options.scene_device == SceneDevice::Auto && s.adapter->info().type != gpu::AdapterType::Cpu);
  auto scene_renderer = SceneRenderer::start(*s.adapter, s.shared_device ? &*s.device : nullptr);
  if (!scene_renderer) {
    std::fprintf(stderr, "weft view: %s\n", scene_renderer.error().what().c_str());
    return 1;
  }
  s.scene_renderer.emplace(std::move(*scene_renderer));
  if (options.shader_dir && !std::filesystem::is_directory(*options.shader_dir)) {
    std::fprintf(stderr, "weft view: --shader-dir '%s' is not a folder\n", options.shader_dir->string().c_str());
    return 1;
  }
  s.shader_watch.emplace(options.shader_dir);
  log::info(weft::format("shader hot reload: watching {} file(s){}", s.shader_watch->watched_files(),
                         options.shader_dir ? " in " + options.shader_dir->string() : std::string(" of the source tree")));
  log::info(weft::format("viewing {} on {} ({}; scene frames on {})", options.scene.string(), s.adapter->info().name,
                         gpu::to_string(s.surface->configuration().present_mode),
                         s.shared_device ? "the window's device" : "a device of their own"));

  auto last = Clock::now();
  auto fps_window = Clock::now();
  std::uint64_t fps_frames = 0;
  while (!s.quit && !glfwWindowShouldClose(s.window)) {
    const double dt = seconds_since(last);
    last = Clock::now();
    glfwPollEvents();
    s.step_script();
    s.poll_reload();
    s.poll_shaders();
    const bool hidden = s.script_hidden || glfwGetWindowAttrib(s.window, GLFW_ICONIFIED);
    glfwGetFramebufferSize(s.window, &fw, &fh);
    if (hidden || fw <= 0 || fh <= 0) {  // minimised: nothing to draw, keep the CPU idle
      glfwWaitEventsTimeout(0.02);
      continue;
    }
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    s.handle_input(dt);
    const bool moving = seconds_since(s.last_motion) < 0.25;
    if (!s.snapshot) s.snapshot = std::make_shared<const scene::Scene>(s.scene);
    const Session::Wanted want{s.snapshot.get(), s.camera->pose(), fw, fh, s.quality, moving, s.show};
    if (!s.posted || want != *s.posted) s.post_job(want);
    if (auto result = s.scene_renderer->take())
      if (auto ok = s.accept(std::move(*result), fw, fh); !ok) {
        std::fprintf(stderr, "weft view: %s\n", ok.error().what().c_str());
        return 1;
      }
    s.scene_busy_s = s.scene_renderer->busy_seconds();
    if (auto ok = s.update_comparison(); !ok) {
      std::fprintf(stderr, "weft view: %s\n", ok.error().what().c_str());
      return 1;
    }
    s.draw_ui();
    ImGui::Render();
    if (auto ok = s.present_frame(); !ok) {
      std::fprintf(stderr, "weft view: %s\n", ok.error().what().c_str());
      return 1;
    }
    ++s.ui_frames;
    ++fps_frames;
    if (moving) {
      ++s.moving_ui_frames;
      s.moving_seconds += seconds_since(last);
    }
    s.ui_ms_history.push_back(float(dt * 1000.0));
    if (s.ui_ms_history.size() > 120) s.ui_ms_history.erase(s.ui_ms_history.begin());
    if (seconds_since(fps_window) >= 1.0) {
      s.ui_fps = double(fps_frames) / seconds_since(fps_window);
      fps_window = Clock::now();
      fps_frames = 0;
    }
    // Idle (nothing moving, nothing rendering): wait for input instead of spinning.
    if (s.refined && !s.script && seconds_since(s.last_motion) > 1.0) glfwWaitEventsTimeout(0.05);
  }
  (void)s.device->queue().wait_idle();
  std::printf("weft view: %llu UI frames, %llu scene frames, %d screenshot(s)\n",
              static_cast<unsigned long long>(s.ui_frames), static_cast<unsigned long long>(s.scene_frames),
              s.screenshots_taken);
  if (!s.moving_scene_ms.empty()) {
    auto sorted = s.moving_scene_ms;
    std::sort(sorted.begin(), sorted.end());
    const double share = double(s.moving_pixels) / double(std::max<std::uint64_t>(s.moving_window_pixels, 1));
    std::printf("weft view: while the camera moved: %llu UI frames in %.2f s (%.1f fps); scene frames median %.0f ms "
                "at %.0f%% of the window's pixels on average\n",
                static_cast<unsigned long long>(s.moving_ui_frames), s.moving_seconds,
                s.moving_seconds > 0 ? double(s.moving_ui_frames) / s.moving_seconds : 0.0, sorted[sorted.size() / 2],
                100.0 * share);
  }
  if (!s.refine_ms.empty()) {
    auto sorted = s.refine_ms;
    std::sort(sorted.begin(), sorted.end());
    std::printf("weft view: refined full-resolution image %.0f ms (median of %zu) after the camera stopped "
                "(0.25 s of it waits to see that it stopped)\n",
                sorted[sorted.size() / 2], sorted.size());
  }
  if (s.instance->validation_enabled()) {
    const auto count = s.instance->validation_message_count();
    std::printf("weft view: %zu validation message(s)\n", count);
    if (count > 0) return 3;
  }
  return 0;
}

}  // namespace weft::viewer
