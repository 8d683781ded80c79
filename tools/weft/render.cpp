// `weft render SCENE.json -o out.png [--quality q] [--size WxH] [--profile] [--budget-ms N]` and
// `weft graph SCENE.json [--dot out.dot] [--dump]`.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <vector>
#include <cstdio>
#include <expected>
#include <fstream>
#include <memory>
#include <optional>
#include <span>
#include <utility>
#include <string>
#include <string_view>
#include <nlohmann/json.hpp>
#include "commands.h"
import weft.core;
import weft.gpu;
import weft.graph;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.pipeline;
import weft.governor;

namespace weft::cli {

namespace {
struct Common {
  std::string scene_path;
  std::string quality = "medium";
  std::string size;
  std::string pipeline;
};

void add_common(CLI::App* sub, Common& c, bool scene_required = true) {
  auto* scene = sub->add_option("scene", c.scene_path, "Scene file (.json, or a .gltf/.glb)");
  if (scene_required) scene->required();
  sub->add_option("-q,--quality", c.quality, "low | medium | high | reference")->capture_default_str();
  sub->add_option("-s,--size", c.size, "Output size WxH (default: the scene's)");
  sub->add_option("--pipeline", c.pipeline,
                  "Pipeline file: the frame's passes and connections (docs/pipelines.md); default: the scene's "
                  "\"pipeline\", else weft's default pipeline");
}

// The --pipeline file, or nothing (the scene's own or the default).
Result<std::optional<pipeline::Pipeline>> pipeline_from(const Common& c) {
  if (c.pipeline.empty()) return std::optional<pipeline::Pipeline>{};
  auto p = pipeline::load_pipeline(c.pipeline);
  if (!p) return std::unexpected(p.error());
  return std::optional<pipeline::Pipeline>(std::move(*p));
}

int fail_with(const char* command, const Error& e) {
  std::fprintf(stderr, "weft %s: %s\n", command, e.what().c_str());
  return 1;
}

struct Session {
  gpu::Instance instance;
  gpu::Adapter adapter;
  gpu::Device device;
};

Result<Session> open_session(const char* name) {
  auto instance = gpu::Instance::create({.application_name = name});
  if (!instance) return std::unexpected(instance.error());
  auto adapter = instance->request_adapter();
  if (!adapter) return std::unexpected(adapter.error());
  auto device = adapter->request_device();
  if (!device) return std::unexpected(device.error());
  return Session{std::move(*instance), std::move(*adapter), std::move(*device)};
}

// With the validation layer on (WEFT_VALIDATION=1), any message it reported fails the
// command: exit 3 after printing them, so scripts and tests can demand a clean frame.
int validation_failures(const gpu::Instance& instance) {
  if (!instance.validation_enabled()) return 0;
  const auto messages = instance.take_validation_messages();
  if (messages.empty()) return 0;
  for (const auto& m : messages) std::fprintf(stderr, "validation: %s\n", m.c_str());
  std::fprintf(stderr, "weft: the validation layer reported %zu message(s)\n", messages.size());
  return 3;
}

// Per-pass medians over frames with the same passes (a steady frame, not the first).
FrameStats median_stats(const std::vector<FrameStats>& frames) {
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
  };
  FrameStats out = frames.front();
  for (std::size_t p = 0; p < out.passes.size(); ++p) {
    std::vector<double> gpu, cpu, wall;
    for (const auto& f : frames) {
      gpu.push_back(f.passes.at(p).gpu_ms);
      cpu.push_back(f.passes.at(p).cpu_record_us);
      wall.push_back(f.passes.at(p).wall_ms);
    }
    out.passes[p].gpu_ms = median(gpu);
    out.passes[p].cpu_record_us = median(cpu);
    out.passes[p].wall_ms = median(wall);
  }
  std::vector<double> total, record, frame;
  for (const auto& f : frames) {
    total.push_back(f.gpu_total_ms);
    record.push_back(f.cpu_record_total_us);
    frame.push_back(f.cpu_frame_ms);
  }
  out.gpu_total_ms = median(total);
  out.cpu_record_total_us = median(record);
  out.cpu_frame_ms = median(frame);
  return out;
}

Result<renderer::RenderOptions> options_from(const Common& c) {
  renderer::RenderOptions o;
  auto q = renderer::quality_from_string(c.quality);
  if (!q) return std::unexpected(q.error());
  o.quality = *q;
  if (!c.size.empty()) {
    const auto size = parse_size(c.size, scene::max_output_side);
    if (!size)
      return fail(ErrorKind::InvalidArgument, "--size expects WxH with each side 1 to {} (e.g. 1280x720), got '{}'",
                  scene::max_output_side, c.size);
    o.width = size->width;
    o.height = size->height;
  }
  return o;
}

// What `-o` writes, from its extension: the tone-mapped image (.png, .jpg) or the linear
// scene colour times the exposure (.exr, .hdr).
enum class OutputKind { Png, Jpeg, Exr, Hdr };
Result<OutputKind> output_kind(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  if (ext == ".png") return OutputKind::Png;
  if (ext == ".jpg" || ext == ".jpeg") return OutputKind::Jpeg;
  if (ext == ".exr") return OutputKind::Exr;
  if (ext == ".hdr") return OutputKind::Hdr;
  return fail(ErrorKind::InvalidArgument, "-o '{}': unknown image extension '{}' (weft writes .png, .jpg, .exr and .hdr)", path,
              ext);
}

Result<void> save_frame(const std::string& path, OutputKind kind, const renderer::Frame& frame, float exposure) {
  switch (kind) {
    case OutputKind::Png: return image::save_png(path, frame.image);
    case OutputKind::Jpeg: return image::save_jpeg(path, frame.image);
    case OutputKind::Exr:
    case OutputKind::Hdr: {
      image::Image linear = frame.hdr;
      for (float& v : linear.pixels) v *= exposure;
      return kind == OutputKind::Exr ? image::save_exr(path, linear) : image::save_hdr(path, linear);
    }
  }
  return {};
}
// `--output NAME -o FILE`: one resource of the frame. Float files get its values as they are;
// PNG/JPEG get a picture (docs/pipelines.md#debug-outputs): 8-bit formats their bytes, float
// colour clamped to [0, 1] and sRGB-encoded, depth as grey from white (nearest drawn) to dark
// (farthest drawn) over the drawn texels' range, black where nothing was drawn (depth 1).
Result<void> save_resource(const std::string& path, OutputKind kind, const renderer::Readback& r) {
  if (kind == OutputKind::Exr) return image::save_exr(path, r.pixels);
  if (kind == OutputKind::Hdr) return image::save_hdr(path, r.pixels);
  const image::Image8 out = renderer::picture(r);
  return kind == OutputKind::Png ? image::save_png(path, out) : image::save_jpeg(path, out);
}

// --budget-ms: the governor measures the features' levels, chooses, checks; the chosen frame is saved.
int render_within_budget(renderer::Renderer& r, const scene::Scene& scene, const renderer::RenderOptions& options,
                         double budget_ms, const std::string& output, OutputKind kind, float exposure) {
  governor::BudgetOptions budget{.budget_ms = budget_ms};
  budget.progress = [](std::string_view line) { log::info(std::string(line)); };
  auto result = governor::fit_budget(r, scene, options, budget);
  if (!result) return fail_with("render", result.error());
  const auto& table = result->table;
  std::printf("| feature | level | frame over base ms | MSE vs best level |\n|:--|:--|--:|--:|\n");
  for (const auto& f : table.features)
    for (const auto& l : f.levels)
      std::printf("| %s | %s | %.1f | %.3g |\n", f.study->feature.c_str(), l.setting.label.c_str(), l.cost_ms, l.mse);
  std::printf("base (every feature cheapest): %.1f ms; predicted %.1f ms for the choice\n", table.base_ms,
              result->predicted.predicted_ms);
  std::printf("budget: %s\n", result->summary(budget_ms).c_str());
  if (auto ok = save_frame(output, kind, result->frame, exposure); !ok) return fail_with("render", ok.error());
  std::printf("wrote %s (%ux%u)\n", output.c_str(), result->frame.image.width, result->frame.image.height);
  return 0;
}
}  // namespace

Command add_render(CLI::App& app) {
  auto* sub = app.add_subcommand("render", "Render a scene to an image");
  auto c = std::make_shared<Common>();
  auto output = std::make_shared<std::string>("out.png");
  auto resource = std::make_shared<std::string>();
  auto profile = std::make_shared<bool>(false);
  auto exposure = std::make_shared<float>(1.0f);
  add_common(sub, *c);
  sub->add_option("-o,--image", *output,
                  "Output image: .png or .jpg (tone-mapped), .exr or .hdr (linear float scene colour times the "
                  "exposure); with --output, that resource")
      ->capture_default_str();
  sub->add_option("--output", *resource,
                  "Write this resource of the frame to -o instead of the frame's image: a pass slot (shadow_map.depth, "
                  "scene.depth, background.color) or any texture's name (weft graph lists them)");
  sub->add_option("--exposure", *exposure, "Exposure multiplier before tone mapping, (0, 1e6]")->capture_default_str();
  auto frames = std::make_shared<unsigned>(1);
  auto serial = std::make_shared<bool>(false);
  sub->add_flag("--profile", *profile, "Print a per-pass timing table");
  sub->add_flag("--serial-passes", *serial,
                "Submit and wait after every pass and time each alone (with --profile: a 'wall ms' column; on CPU "
                "adapters GPU timestamps leave out vertex work)");
  sub->add_option("--frames", *frames, "Render this many frames; --profile then reports medians of frames 2..N")
      ->check(CLI::Range(1u, 10000u));
  auto accumulate = std::make_shared<unsigned>(0);
  sub->add_option("--accumulate", *accumulate,
                  "Render samples 0..N-1 of the still view, each jittered by a Halton sub-pixel offset, and write the "
                  "last: the pipeline's accumulate pass averages them (examples/pipelines/accumulate.json)")
      ->check(CLI::Range(1u, 4096u));
  auto budget_ms = std::make_shared<double>(0.0);
  sub->add_option("--budget-ms", *budget_ms,
                  "Pick each feature's preset (low/medium/high) for the least error within this frame time, "
                  "measured on this adapter at the scene's camera (docs/viewer.md#the-frame-time-budget)")
      ->check(CLI::Range(1e-3, 1e7));
  return [=] {
    auto options = options_from(*c);
    if (!options) return fail_with("render", options.error());
    if (auto problem = exposure_problem(*exposure)) return fail_with("render", Error{ErrorKind::InvalidArgument, *problem});
    options->exposure = *exposure;
    options->serial_passes = *serial;
    // `--output out.png` (before -o meant the file and --output the resource) keeps working.
    if (output_kind(*resource) && sub->count("-o") == 0) *output = std::exchange(*resource, std::string());
    const auto kind = output_kind(*output);
    if (!kind) return fail_with("render", kind.error());
    if (!resource->empty() && *budget_ms > 0.0)
      return fail_with("render", Error{ErrorKind::InvalidArgument, "--output and --budget-ms cannot be combined"});
    if (!resource->empty()) options->outputs.push_back(*resource);
    else options->read_hdr = *kind == OutputKind::Exr || *kind == OutputKind::Hdr;
    auto pipeline = pipeline_from(*c);
    if (!pipeline) return fail_with("render", pipeline.error());
    if (*pipeline) options->pipeline = &**pipeline;
    const auto t0 = std::chrono::steady_clock::now();
    log::info(weft::format("loading {}", c->scene_path));
    auto scene = scene::load_scene(c->scene_path);
    if (!scene) return fail_with("render", scene.error());
    auto session = open_session("weft-render");
    if (!session) return fail_with("render", session.error());
    auto r = renderer::Renderer::create(session->device);
    if (!r) return fail_with("render", r.error());
    log::info(weft::format("rendering on {}", session->adapter.info().name));
    if (*budget_ms > 0.0) return render_within_budget(*r, *scene, *options, *budget_ms, *output, *kind, *exposure);
    // The pipeline's passes that blend frames over time (accumulate, taa: PassTypeDescriptor::temporal).
    auto chosen = r->pipeline_for(*scene, *options);
    if (!chosen) return fail_with("render", chosen.error());
    std::string temporal;
    bool has_accumulate = false;
    for (const auto& pass : (*chosen)->passes) {
      if (!pass.type || !pass.type->temporal) continue;
      temporal += weft::format("{}'{}' ({})", temporal.empty() ? "" : ", ", pass.name, pass.type->name);
      has_accumulate |= pass.type->name == "accumulate";
    }
    if (*accumulate > 0) {
      if (*frames > 1)
        return fail_with("render", Error{ErrorKind::InvalidArgument, "--accumulate and --frames cannot be combined"});
      // Jittered samples that nothing averages would only move the image: say so before rendering.
      if (!has_accumulate)
        return fail_with("render", Error{ErrorKind::InvalidArgument,
                                         "--accumulate: the pipeline has no pass of type 'accumulate' to average the "
                                         "samples (--pipeline examples/pipelines/accumulate.json has one)"});
    } else if (!temporal.empty() && *frames == 1) {
      log::warn(weft::format("the pipeline's {} blend{} frames over time, and one frame shows sample 0 only: "
                             "render with --accumulate N to see them converge",
                             temporal, temporal.find(',') == std::string::npos ? "s" : ""));
    }
    auto frame = r->render(*scene, *options);
    if (!frame) return fail_with("render", frame.error());
    for (unsigned sample = 1; sample < *accumulate; ++sample) {
      if (sample % 16 == 0) log::info(weft::format("accumulated {} of {} samples", sample, *accumulate));
      options->sample_index = sample;
      auto next = r->render(*scene, *options);
      if (!next) return fail_with("render", next.error());
      frame = std::move(next);
    }
    std::vector<FrameStats> later;  // frames after the first reuse every cache
    std::vector<double> render_ms;  // each later frame's render() call: prepare, graph, execute, readback
    for (unsigned i = 1; i < *frames; ++i) {
      const auto f0 = std::chrono::steady_clock::now();
      auto again = r->render(*scene, *options);
      if (!again) return fail_with("render", again.error());
      render_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - f0).count());
      later.push_back(std::move(again->stats));
    }
    std::sort(render_ms.begin(), render_ms.end());
    if (!later.empty()) frame->stats = median_stats(later);
    for (const auto& w : frame->warnings) log::warn(w);
    if (!resource->empty()) {
      if (auto ok = save_resource(*output, *kind, frame->outputs.front()); !ok) return fail_with("render", ok.error());
    } else if (auto ok = save_frame(*output, *kind, *frame, *exposure); !ok) {
      return fail_with("render", ok.error());
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (*profile) {
      if (!later.empty()) std::printf("median of frames 2..%u:\n", *frames);
      std::printf("%s", frame->stats.format_table().c_str());
      std::printf("transient memory: %.1f MiB aliased (%.1f MiB without aliasing); CPU frame %.2f ms\n",
                  double(frame->stats.transient_bytes) / (1 << 20),
                  double(frame->stats.transient_bytes_unaliased) / (1 << 20), frame->stats.cpu_frame_ms);
      if (!render_ms.empty())
        std::printf("whole frame (render call: prepare, graph, execute, readback): median %.2f ms, min %.2f ms\n",
                    render_ms[render_ms.size() / 2], render_ms.front());
    }
    const auto& written = resource->empty() ? frame->image.width : frame->outputs.front().pixels.width;
    const auto& written_h = resource->empty() ? frame->image.height : frame->outputs.front().pixels.height;
    if (auto bad = validation_failures(session->instance)) return bad;
    std::printf("wrote %s%s%s (%ux%u) in %.2f s\n", resource->empty() ? "" : (resource->c_str()), resource->empty() ? "" : " to ",
                output->c_str(), written, written_h, seconds);
    return 0;
  };
}

Command add_graph(CLI::App& app) {
  auto* sub = app.add_subcommand("graph", "Compile a scene's render graph and print or save it; `graph check` validates a frame");
  auto c = std::make_shared<Common>();
  auto dot = std::make_shared<std::string>();
  auto export_pipeline = std::make_shared<std::string>();
  auto dump = std::make_shared<bool>(false);
  auto pass_types = std::make_shared<bool>(false);
  add_common(sub, *c, false);
  sub->add_option("--dot", *dot, "Write Graphviz DOT here ('-' for stdout)");
  sub->add_option("--export-pipeline", *export_pipeline, "Write the pipeline the scene renders with here ('-' for stdout)");
  sub->add_flag("--dump", *dump, "Print order, lifetimes, memory and barriers");
  sub->add_flag("--pass-types", *pass_types, "Print every registered pass type (slots, options) as Markdown, and exit");
  auto* check = sub->add_subcommand("check", "Exit 0 when the scene's frame (with --pipeline P) compiles; otherwise "
                                             "print every problem and exit 1");
  auto cc = std::make_shared<Common>();
  add_common(check, *cc);
  auto describe = [](const Common& common) -> Result<renderer::GraphReport> {
    auto options = options_from(common);
    if (!options) return std::unexpected(options.error());
    auto pipeline = pipeline_from(common);
    if (!pipeline) return std::unexpected(pipeline.error());
    if (*pipeline) options->pipeline = &**pipeline;
    auto scene = scene::load_scene(common.scene_path);
    if (!scene) return std::unexpected(scene.error());
    // No adapter, no Vulkan driver: the frame is declared and compiled on a declaring device
    // (gpu::Device::create_declaring), so a machine without a GPU stack can check frames.
    return renderer::describe(*scene, *options);
  };
  return [=] {
    if (check->parsed()) {
      auto report = describe(*cc);
      if (!report) return fail_with("graph check", report.error());
      for (const auto& w : report->warnings) std::printf("warning: %s\n", w.c_str());
      std::printf("ok: %zu passes run, %zu culled\n", report->passes.size(), report->culled_passes.size());
      return 0;
    }
    if (*pass_types) {
      std::printf("%s", pipeline::pass_types_markdown().c_str());
      return 0;
    }
    if (c->scene_path.empty())
      return fail_with("graph", Error{ErrorKind::InvalidArgument, "a scene file is required (weft graph SCENE ...)"});
    auto report = describe(*c);
    if (!report) return fail_with("graph", report.error());
    // Through write_file_atomically, as images are: a full disk, a FIFO (which an ofstream waited
    // on forever), a read-only file or a device is an error and leaves no half file (issue 33).
    const auto write = [](const std::string& path, const std::string& text, std::string_view what) -> Result<void> {
      if (path == "-") {
        std::printf("%s", text.c_str());
        return {};
      }
      if (auto ok = write_file_atomically(path, {std::as_bytes(std::span(text))}, what); !ok) return ok;
      std::printf("wrote %s\n", path.c_str());
      return {};
    };
    if (!dot->empty())
      if (auto ok = write(*dot, report->dot, "DOT graph"); !ok) return fail_with("graph", ok.error());
    if (!export_pipeline->empty())
      if (auto ok = write(*export_pipeline, report->pipeline, "pipeline"); !ok) return fail_with("graph", ok.error());
    if (*dump) std::printf("%s", report->dump.c_str());
    for (const auto& w : report->warnings) std::printf("warning: %s\n", w.c_str());
    std::printf("passes:");
    for (const auto& p : report->passes) std::printf(" %s", p.c_str());
    std::printf("\nculled:");
    for (const auto& p : report->culled_passes) std::printf(" %s", p.c_str());
    std::printf("%s\n", report->culled_passes.empty() ? " (none)" : "");
    std::printf("slots:");
    for (const auto& p : report->slots) std::printf(" %s", p.c_str());
    std::printf("\nresources:");
    for (const auto& p : report->resources) std::printf(" %s", p.c_str());
    std::printf("\n");
    return 0;
  };
}

}  // namespace weft::cli
