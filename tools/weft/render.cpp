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
#include <string>
#include <string_view>
#include "commands.h"
import weft.core;
import weft.gpu;
import weft.graph;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.governor;

namespace weft::cli {

namespace {
struct Common {
  std::string scene_path;
  std::string quality = "medium";
  std::string size;
};

void add_common(CLI::App* sub, Common& c) {
  sub->add_option("scene", c.scene_path, "Scene file (.json, or a .gltf/.glb)")->required();
  sub->add_option("-q,--quality", c.quality, "low | medium | high | reference")->capture_default_str();
  sub->add_option("-s,--size", c.size, "Output size WxH (default: the scene's)");
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
  auto profile = std::make_shared<bool>(false);
  auto exposure = std::make_shared<float>(1.0f);
  add_common(sub, *c);
  sub->add_option("-o,--output", *output,
                  "Output image: .png or .jpg (tone-mapped), .exr or .hdr (linear float scene colour times the exposure)")
      ->capture_default_str();
  sub->add_option("--exposure", *exposure, "Exposure multiplier before tone mapping, (0, 1e6]")->capture_default_str();
  auto frames = std::make_shared<unsigned>(1);
  auto serial = std::make_shared<bool>(false);
  sub->add_flag("--profile", *profile, "Print a per-pass timing table");
  sub->add_flag("--serial-passes", *serial,
                "Submit and wait after every pass and time each alone (with --profile: a 'wall ms' column; on CPU "
                "adapters GPU timestamps leave out vertex work)");
  sub->add_option("--frames", *frames, "Render this many frames; --profile then reports medians of frames 2..N")
      ->check(CLI::Range(1u, 10000u));
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
    const auto kind = output_kind(*output);
    if (!kind) return fail_with("render", kind.error());
    options->read_hdr = *kind == OutputKind::Exr || *kind == OutputKind::Hdr;
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
    auto frame = r->render(*scene, *options);
    if (!frame) return fail_with("render", frame.error());
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
    if (auto ok = save_frame(*output, *kind, *frame, *exposure); !ok) return fail_with("render", ok.error());
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
    std::printf("wrote %s (%ux%u) in %.2f s\n", output->c_str(), frame->image.width, frame->image.height, seconds);
    return 0;
  };
}

Command add_graph(CLI::App& app) {
  auto* sub = app.add_subcommand("graph", "Compile a scene's render graph and print or save it");
  auto c = std::make_shared<Common>();
  auto dot = std::make_shared<std::string>();
  auto dump = std::make_shared<bool>(false);
  add_common(sub, *c);
  sub->add_option("--dot", *dot, "Write Graphviz DOT here ('-' for stdout)");
  sub->add_flag("--dump", *dump, "Print order, lifetimes, memory and barriers");
  return [=] {
    auto options = options_from(*c);
    if (!options) return fail_with("graph", options.error());
    auto scene = scene::load_scene(c->scene_path);
    if (!scene) return fail_with("graph", scene.error());
    auto session = open_session("weft-graph");
    if (!session) return fail_with("graph", session.error());
    auto r = renderer::Renderer::create(session->device);
    if (!r) return fail_with("graph", r.error());
    auto report = r->describe(*scene, *options);
    if (!report) return fail_with("graph", report.error());
    if (*dot == "-") {
      std::printf("%s", report->dot.c_str());
    } else if (!dot->empty()) {
      std::ofstream out(*dot);
      out << report->dot;
      if (!out) return fail_with("graph", Error{ErrorKind::Io, weft::format("cannot write '{}'", *dot)});
      std::printf("wrote %s\n", dot->c_str());
    }
    if (*dump) std::printf("%s", report->dump.c_str());
    std::printf("passes:");
    for (const auto& p : report->passes) std::printf(" %s", p.c_str());
    std::printf("\nculled:");
    for (const auto& p : report->culled_passes) std::printf(" %s", p.c_str());
    std::printf("%s\n", report->culled_passes.empty() ? " (none)" : "");
    return 0;
  };
}

}  // namespace weft::cli
