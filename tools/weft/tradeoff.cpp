// `weft tradeoff SCENE --feature F [--out DIR] [--frames N] [--size WxH] [--values KNOB=V1,V2]`:
// renders every setting weft.tradeoff plans for the feature (its presets, its knobs one at a
// time, its grids, its reference), each in a fresh renderer so the first frame bakes cold,
// then N more frames for the steady frame time; measures error against the reference over
// the feature's pixels and writes DIR/tradeoff.csv, DIR/tradeoff.svg and DIR/tradeoff.md.
// `--pass NAME` studies a pass of the scene's pipeline instead: its options' sweeps (read from
// the pass type's options table) against its type's reference, over the whole frame.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>
#include "commands.h"
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.pipeline;
import weft.tradeoff;
import weft.study;

namespace weft::cli {

namespace {
namespace to = weft::tradeoff;

struct Args {
  std::string scene_path, feature, pass, pipeline, out, size;
  unsigned frames = 5;
  float exposure = 1.0f;
  std::vector<std::string> values;
  bool list = false;
};

int failed(const Error& e) {
  std::fprintf(stderr, "weft tradeoff: %s\n", e.what().c_str());
  return 1;
}

using Rendered = study::RenderedSetting;
using study::coverage_render;
using study::render_setting;

void print_list() {
  for (const to::Study* study : to::studies()) {
    const to::Study& s = *study;
    std::string aliases;
    for (const auto& a : s.descriptor->aliases) aliases += (aliases.empty() ? " (also " : ", ") + a;
    if (!aliases.empty()) aliases += ")";
    std::printf("%s%s: %s; %s (cost: %s)\n  reference: %s\n", s.feature.c_str(), aliases.c_str(),
                s.descriptor->summary.c_str(), s.descriptor->doc.c_str(), std::string(to::to_string(s.cost)).c_str(),
                s.reference_why.c_str());
    for (const auto& k : s.knobs) {
      std::string sweep;
      for (const auto& v : k.sweep) sweep += (sweep.empty() ? "" : ",") + to::value_text(v);
      std::printf("  %-16s %s; sweep %s\n", k.name.c_str(), k.meaning.c_str(), sweep.c_str());
    }
  }
  auto pipeline = pipeline::default_pipeline();
  if (!pipeline) return;
  std::printf("passes of the default pipeline with a study (--pass NAME; any pipeline's pass whose type names a reference):\n");
  for (const auto& p : pipeline->passes) {
    auto s = to::pass_study(*pipeline, p.name);
    if (!s) continue;
    std::printf("%s: %s\n  reference: %s\n", s->feature.c_str(), p.type->summary.c_str(), s->reference_why.c_str());
    for (const auto& k : s->knobs) {
      std::string sweep;
      for (const auto& v : k.sweep) sweep += (sweep.empty() ? "" : ",") + to::value_text(v);
      std::printf("  %-16s %s; sweep %s\n", k.name.c_str(), k.meaning.c_str(), sweep.c_str());
    }
  }
}

// The pipeline a pass study sets options on: --pipeline, the scene's, or the default one.
Result<pipeline::Pipeline> study_pipeline(const Args& a, const scene::Scene& scene) {
  if (!a.pipeline.empty()) return pipeline::load_pipeline(a.pipeline);
  if (!scene.pipeline.empty()) return pipeline::load_pipeline(scene.pipeline);
  return pipeline::default_pipeline();
}

int run(const Args& a) {
  if (a.list) {
    print_list();
    return 0;
  }
  if (a.scene_path.empty()) return failed({ErrorKind::InvalidArgument, "a scene file is required"});
  if (a.feature.empty() == a.pass.empty())
    return failed({ErrorKind::InvalidArgument, "give --feature F or --pass NAME, one of them (see --list)"});
  if (!a.pipeline.empty() && a.pass.empty())
    return failed({ErrorKind::InvalidArgument, "--pipeline is for --pass studies (a feature study renders the scene's pipeline)"});
  auto scene = scene::load_scene(a.scene_path);
  if (!scene) return failed(scene.error());
  std::optional<pipeline::Pipeline> base_pipeline;
  to::Study pass_study;
  Result<const to::Study*> study = &pass_study;
  if (!a.pass.empty()) {
    auto loaded = study_pipeline(a, *scene);
    if (!loaded) return failed(loaded.error());
    base_pipeline.emplace(std::move(*loaded));
    auto made = to::pass_study(*base_pipeline, a.pass);
    if (!made) return failed(made.error());
    pass_study = std::move(*made);
  } else {
    study = to::find_study(a.feature);
  }
  if (!study) return failed(study.error());
  std::vector<to::KnobValues> overrides;
  for (const auto& text : a.values) {
    auto v = to::parse_knob_values(**study, text);
    if (!v) return failed(with_context("--values", v.error()).error());
    overrides.push_back(std::move(*v));
  }
  renderer::RenderOptions options;
  options.aces = false;  // clamp: decoded pixels are linear radiance (times the exposure) below 1
  if (auto problem = exposure_problem(a.exposure)) return failed({ErrorKind::InvalidArgument, *problem});
  options.exposure = a.exposure;
  if (!a.size.empty()) {
    const auto size = parse_size(a.size, scene::max_output_side);
    if (!size)
      return failed({ErrorKind::InvalidArgument, weft::format("--size expects WxH with each side 1 to {} (e.g. 640x360), got '{}'",
                                                              scene::max_output_side, a.size)});
    options.width = size->width, options.height = size->height;
  }
  if ((*study)->pass.empty() && !to::scene_uses(*scene, (*study)->material))
    return failed({ErrorKind::InvalidArgument,
                   weft::format("'{}' has no \"{}\" material: nothing for the {} study to sweep", a.scene_path,
                                (*study)->material, (*study)->feature)});
  const std::filesystem::path out = a.out.empty() ? "tradeoff-" + (a.pass.empty() ? (*study)->feature : a.pass) : a.out;
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) return failed({ErrorKind::Io, weft::format("cannot create '{}': {}", out.string(), ec.message())});
  for (const auto& [name, value] : (*study)->environment) ::setenv(name.c_str(), value.c_str(), 1);

  auto instance = gpu::Instance::create({.application_name = "weft-tradeoff"});
  if (!instance) return failed(instance.error());
  auto adapter = instance->request_adapter();
  if (!adapter) return failed(adapter.error());
  auto device = adapter->request_device();
  if (!device) return failed(device.error());

  // On a CPU adapter (lavapipe) the frame's work is CPU time on every core, and GPU timestamps
  // are wall time that other processes' load inflates: the process CPU time is the cost.
  const bool cpu_adapter = adapter->info().type == gpu::AdapterType::Cpu;
  const auto plan = to::plan_sweep(**study, overrides);
  std::vector<Rendered> rendered;
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < plan.size(); ++i) {
    // A pass study's setting is a pipeline: the base one with the setting's options.
    std::optional<pipeline::Pipeline> setting_pipeline;
    renderer::RenderOptions setting_options = options;
    if (base_pipeline) {
      auto p = to::apply_pass_setting(*base_pipeline, **study, plan[i]);
      if (!p) return failed(with_context(weft::format("setting '{}'", plan[i].label), p.error()).error());
      setting_pipeline.emplace(std::move(*p));
      setting_options.pipeline = &*setting_pipeline;
    }
    auto r = render_setting(*device, *scene, **study, plan[i], setting_options, a.frames, cpu_adapter);
    if (!r) return failed(r.error());
    for (const auto& w : r->warnings) log::warn(weft::format("{}: {}", plan[i].label, w));
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double eta = elapsed / double(i + 1) * double(plan.size() - i - 1);
    log::info(weft::format("[{}/{} {:.0f}%] {}: frame {:.1f} ms GPU, {:.1f} ms process CPU, cold {:.0f} ms (ETA {:.0f} s)",
                           i + 1, plan.size(), 100.0 * double(i + 1) / double(plan.size()), plan[i].label,
                           r->row.frame_ms, r->row.process_cpu_ms, r->row.cold_frame_ms, eta));
    rendered.push_back(std::move(*r));
  }
  const image::Image8& reference = rendered.front().image;  // plan_sweep puts the reference first
  Result<to::Mask> mask = to::full_mask(reference.width, reference.height);  // a pass: the whole frame
  if (!base_pipeline) {
    auto black = coverage_render(*device, *scene, **study, options, false);
    if (!black) return failed(black.error());
    auto white = coverage_render(*device, *scene, **study, options, true);
    if (!white) return failed(white.error());
    std::vector<const image::Image8*> images;
    for (const auto& r : rendered) images.push_back(&r.image);
    mask = to::coverage_mask(*black, *white, images, reference);
    if (!mask) return failed(mask.error());
  }
  if (mask->count() == 0)
    return failed({ErrorKind::InvalidArgument,
                   weft::format("the {} objects cover no pixel of '{}' from its camera", (*study)->feature, a.scene_path)});
  std::vector<to::Row> rows;
  for (auto& r : rendered) {
    auto e = to::compare(r.image, reference, *mask);
    if (!e) return failed(e.error());
    r.row.error = *e;
    rows.push_back(r.row);
  }
  to::mark_pareto(rows, (*study)->cost);

  to::ReportInfo info;
  info.feature = (*study)->feature;
  info.scene = std::filesystem::path(a.scene_path).filename().string();
  info.width = reference.width, info.height = reference.height, info.frames = a.frames;
  info.cost = (*study)->cost;
  info.frame_clock = cpu_adapter ? "process CPU time" : "GPU timestamps";
  info.device = weft::format("{} ({})", adapter->info().name, adapter->info().driver);
  info.command = weft::format("weft tradeoff {} {} --frames {}{}{}", a.scene_path,
                              a.pass.empty() ? "--feature " + a.feature
                                             : "--pass " + a.pass + (a.pipeline.empty() ? "" : " --pipeline " + a.pipeline),
                              a.frames,
                              a.size.empty() ? "" : " --size " + a.size,
                              a.exposure != 1.0f ? weft::format(" --exposure {}", a.exposure) : "");
  for (const auto& v : a.values) info.command += " --values " + v;
  info.mask_note = base_pipeline ? weft::format("all {} pixels (a pass study: the whole frame)", mask->count())
                                 : weft::format("{} of {} pixels (the feature's objects, and every pixel any setting changes)",
                                                mask->count(), std::size_t(reference.width) * reference.height);
  const std::pair<const char*, std::string> files[] = {{"tradeoff.csv", to::csv(rows, info)},
                                                       {"tradeoff.md", to::markdown(rows, info)},
                                                       {"tradeoff.svg", to::svg(rows, info)}};
  for (const auto& [name, text] : files) {
    std::ofstream f(out / name, std::ios::binary);
    f << text;
    if (!f) return failed({ErrorKind::Io, weft::format("cannot write '{}'", (out / name).string())});
  }
  if (auto ok = image::save_png(out / "reference.png", reference); !ok) return failed(ok.error());
  std::printf("%s\nwrote %s/tradeoff.{csv,md,svg} and reference.png (%zu settings)\n", to::markdown(rows, info).c_str(),
              out.string().c_str(), rows.size());
  return 0;
}
}  // namespace

Command add_tradeoff(CLI::App& app) {
  auto* sub = app.add_subcommand("tradeoff", "Sweep a feature's quality knobs (or a pipeline pass's options): error "
                                             "against frame time, Pareto front");
  auto a = std::make_shared<Args>();
  sub->add_option("scene", a->scene_path, "Scene file using the feature's material");
  sub->add_option("-f,--feature", a->feature, "fur | skin | ssdf | btf (see --list)");
  sub->add_option("--pass", a->pass, "Study a pass of the scene's pipeline instead (its options' sweeps against its "
                                     "type's reference, whole frame), e.g. shadow_map");
  sub->add_option("--pipeline", a->pipeline, "With --pass: the pipeline file whose pass is studied (default: the "
                                             "scene's, or the default pipeline)");
  sub->add_option("-o,--out", a->out, "Output folder (default: tradeoff-FEATURE)");
  sub->add_option("--frames", a->frames, "Steady frames per setting (median)")->check(CLI::Range(1u, 1000u))->capture_default_str();
  sub->add_option("-s,--size", a->size, "Frame size WxH (default: the scene's)");
  sub->add_option("--exposure", a->exposure, "Exposure before the clamp (keep the feature below 1)")->capture_default_str();
  sub->add_option("--values", a->values, "Replace a knob's sweep: KNOB=V1,V2,... (repeatable)");
  sub->add_flag("--list", a->list, "Print each feature's knobs and reference, and exit");
  return [a] { return run(*a); };
}

}  // namespace weft::cli
