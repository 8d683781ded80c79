// `weft tradeoff SCENE --feature F [--out DIR] [--frames N] [--size WxH] [--values KNOB=V1,V2] [--cross KNOB=V1,V2]`:
// renders every setting weft.tradeoff plans for the feature (its presets, its knobs one at a
// time, its grids, its crossed knobs, its reference), each in a fresh renderer so the first
// frame bakes cold, then N more frames for the steady frame time; measures error against the
// reference over the feature's pixels and writes DIR/tradeoff.csv, DIR/tradeoff.svg and
// DIR/tradeoff.md.
//
// The same study as independent tasks (weft.farm, docs/farm.md): `--tasks FILE` writes the task
// list (one task per setting and per coverage frame, each this command with `--task ID`, its
// output CACHE/tradeoff/ID.{png,json} named by the hash of its inputs); `--farm local -j N`
// runs it as processes here and `--farm slurm` as a Slurm job array; `--from-cache CACHE` is
// the reduce step, which writes exactly the serial command's files from the tasks' outputs.
//
// `--pass NAME [--pipeline P]` studies a pass of the scene's pipeline instead: its options'
// sweeps (read from the pass type's options table) against its type's reference, over the
// whole frame, each setting a copy of the pipeline with the option set (serially only).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>
#include <unistd.h>
#include "commands.h"
#include <weft/text_input.h>
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.tradeoff;
import weft.study;
import weft.farm;
import weft.feature;

namespace weft::cli {
// farm.cpp: the runners shared by `weft tradeoff --farm` and `weft farm run`.
int run_farm(const farm::TaskList& list, const FarmOptions& options, const std::string& command_name);
Result<farm::TaskList> tradeoff_tasks_for(const farm::StudySpec& spec, const std::filesystem::path& cache);

namespace {
namespace to = weft::tradeoff;
using json = nlohmann::json;

struct Args {
  std::string scene_path, feature, out, size;
  unsigned frames = 5;
  float exposure = 1.0f;
  std::vector<std::string> values, cross;
  bool list = false;
  bool extremes = false;           // the stability sweep's settings instead of the trade-off plan
  std::vector<std::string> base;   // --base KNOB=V: under --extremes, values every extreme starts from
  unsigned batch = 1;  // settings per farm task
  std::string baseline = "medium";  // farm tasks: the preset rendered alternately for the cost ratio, or "none"
  // a pipeline pass's study instead of a feature's
  std::string pass, pipeline;
  // the farm
  std::string tasks_file, task, from_cache, cache;
  FarmOptions farm;
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

// What every mode (serial, task, reduce, planning) reads from the arguments, checked.
struct Study {
  const to::Study* study = nullptr;
  renderer::RenderOptions options;
  scene::Scene scene;
  std::vector<to::Setting> plan;
  std::filesystem::path out;
  std::uint64_t inputs = 0;  // hash of the scene file's bytes and the options every task shares
  std::optional<Quality> baseline;  // farm tasks' cost baseline (a preset), or none
  // A pass study (--pass): the pipeline its settings go into, and the study made from it.
  std::shared_ptr<const pipeline::Pipeline> pipeline;
  std::shared_ptr<const to::Study> pass_study;
};

Result<Study> prepare(const Args& a) {
  if (a.scene_path.empty()) return fail(ErrorKind::InvalidArgument, "a scene file is required");
  if (a.feature.empty() == a.pass.empty())
    return fail(ErrorKind::InvalidArgument, "give --feature F or --pass NAME, one of them (see --list)");
  if (!a.pipeline.empty() && a.pass.empty())
    return fail(ErrorKind::InvalidArgument, "--pipeline is for --pass studies (a feature study renders the scene's pipeline)");
  Study s;
  s.options.aces = false;  // clamp: decoded pixels are linear radiance (times the exposure) below 1
  if (auto problem = exposure_problem(a.exposure)) return fail(ErrorKind::InvalidArgument, "{}", *problem);
  s.options.exposure = a.exposure;
  if (!a.size.empty()) {
    const auto size = parse_size(a.size, scene::max_output_side);
    if (!size)
      return fail(ErrorKind::InvalidArgument, "--size expects WxH with each side 1 to {} (e.g. 640x360), got '{}'",
                  scene::max_output_side, a.size);
    s.options.width = size->width, s.options.height = size->height;
  }
  if (auto why = binary_text_input(a.scene_path, "scene file")) return fail(ErrorKind::Parse, "{}", *why);
  auto bytes = read_input_file(a.scene_path, "scene file");
  if (!bytes) return std::unexpected(bytes.error());
  auto scene = scene::load_scene(a.scene_path);
  if (!scene) return std::unexpected(scene.error());
  s.scene = std::move(*scene);
  Result<const to::Study*> study = nullptr;
  if (!a.pass.empty()) {
    // The pipeline a pass study sets options on: --pipeline, the scene's, or the default one.
    auto loaded = !a.pipeline.empty()       ? pipeline::load_pipeline(a.pipeline)
                  : !s.scene.pipeline.empty() ? pipeline::load_pipeline(s.scene.pipeline)
                                              : pipeline::default_pipeline();
    if (!loaded) return std::unexpected(loaded.error());
    s.pipeline = std::make_shared<const pipeline::Pipeline>(std::move(*loaded));
    auto made = to::pass_study(*s.pipeline, a.pass);
    if (!made) return std::unexpected(made.error());
    s.pass_study = std::make_shared<const to::Study>(std::move(*made));
    study = s.pass_study.get();
  } else {
    study = to::find_study(a.feature);
    if (!study) return std::unexpected(study.error());
    if (!to::scene_uses(s.scene, (*study)->material))
      return fail(ErrorKind::InvalidArgument, "'{}' has no \"{}\" material: nothing for the {} study to sweep", a.scene_path,
                  (*study)->material, (*study)->feature);
  }
  s.study = *study;
  std::vector<to::KnobValues> overrides, crossed;
  for (const auto& text : a.values) {
    auto v = to::parse_knob_values(**study, text);
    if (!v) return with_context("--values", v.error());
    overrides.push_back(std::move(*v));
  }
  for (const auto& text : a.cross) {
    auto v = to::parse_knob_values(**study, text);
    if (!v) return with_context("--cross", v.error());
    crossed.push_back(std::move(*v));
  }
  s.out = a.out.empty() ? "tradeoff-" + (a.pass.empty() ? (*study)->feature : a.pass) : a.out;
  if (a.extremes) {
    if (!a.values.empty() || !a.cross.empty())
      return fail(ErrorKind::InvalidArgument, "--extremes renders each knob's minimum and maximum: give --base, not --values or --cross");
    json base = json::object();
    for (const auto& text : a.base) {
      auto v = to::parse_knob_values(**study, text);
      if (!v) return with_context("--base", v.error());
      if (v->values.size() != 1) return fail(ErrorKind::InvalidArgument, "--base {}: one value per knob", text);
      base[v->knob->name] = v->values.front();
    }
    // each setting once (an extreme may equal the base)
    std::set<std::string> seen;
    for (auto& setting : to::extreme_settings(**study, base))
      if (seen.insert(weft::format("{}|{}|{}", int(setting.quality), setting.strip_knobs, setting.values.dump())).second)
        s.plan.push_back(std::move(setting));
  } else {
    if (!a.base.empty()) return fail(ErrorKind::InvalidArgument, "--base is for --extremes");
    s.plan = to::plan_sweep(**study, overrides, crossed);
  }
  if (a.baseline != "none") {
    auto q = quality_from_string(a.baseline);
    if (!q) return fail(ErrorKind::InvalidArgument, "--baseline '{}': expected low, medium, high, reference or none", a.baseline);
    s.baseline = *q;
  }
  Hasher h;
  h.str("weft tradeoff task 1").bytes(bytes->data(), bytes->size()).str((*study)->feature);
  h.value(s.options.width).value(s.options.height).value(s.options.exposure).value(a.frames);
  s.inputs = h.digest();
  return s;
}

// A setting's task id and a coverage frame's: the inputs' hash and what the task renders.
std::string setting_id(const Study& s, const to::Setting& setting) {
  return hex64(Hasher{s.inputs}.str("setting").str(s.baseline ? to::to_string(*s.baseline) : "no baseline").value(int(setting.quality)).value(setting.strip_knobs).str(setting.values.dump()).digest());
}
std::string coverage_id(const Study& s, bool white) {
  return hex64(Hasher{s.inputs}.str(white ? "coverage white" : "coverage black").digest());
}
std::string result_file(const std::string& id, const char* ext) { return "tradeoff/" + id + ext; }

// This command line again, with absolute paths, for a task or the reduce step.
std::vector<std::string> base_command(const Args& a) {
  std::vector<std::string> c = {self_path(), "tradeoff", std::filesystem::absolute(a.scene_path).string(), "--feature",
                                a.feature, "--frames", std::to_string(a.frames)};
  if (!a.size.empty()) c.insert(c.end(), {"--size", a.size});
  if (a.exposure != 1.0f) c.insert(c.end(), {"--exposure", weft::format("{}", a.exposure)});
  if (a.baseline != "medium") c.insert(c.end(), {"--baseline", a.baseline});
  if (a.batch != 1) c.insert(c.end(), {"--batch", std::to_string(a.batch)});
  if (a.extremes) c.push_back("--extremes");
  for (const auto& v : a.base) c.insert(c.end(), {"--base", v});
  for (const auto& v : a.values) c.insert(c.end(), {"--values", v});
  for (const auto& v : a.cross) c.insert(c.end(), {"--cross", v});
  return c;
}

Result<farm::TaskList> task_list(const Args& a, const Study& s, const std::filesystem::path& cache) {
  if (cache.empty())
    return fail(ErrorKind::InvalidArgument, "no cache folder: give --cache DIR or set WEFT_CACHE_DIR (a folder every node can reach)");
  farm::TaskList list;
  list.cache = std::filesystem::absolute(cache);
  list.what = weft::format("weft tradeoff {} --feature {}", a.scene_path, s.study->feature);
  // Units (a setting, a coverage frame) dealt round-robin into tasks of --batch units each, so
  // every task gets a share of the cheap and of the costly settings.
  std::vector<std::pair<std::string, std::string>> units;  // id, label
  for (const auto& setting : s.plan) units.emplace_back(setting_id(s, setting), setting.label);
  units.emplace_back(coverage_id(s, false), "coverage (black)");
  units.emplace_back(coverage_id(s, true), "coverage (white)");
  const std::size_t tasks = (units.size() + a.batch - 1) / a.batch;
  for (std::size_t t = 0; t < tasks; ++t) {
    std::string ids, label;
    std::vector<std::string> outputs;
    for (std::size_t i = t; i < units.size(); i += tasks) {
      ids += (ids.empty() ? "" : ",") + units[i].first;
      label += (label.empty() ? "" : ", ") + units[i].second;
      outputs.push_back(result_file(units[i].first, ".png"));
      outputs.push_back(result_file(units[i].first, ".json"));
    }
    const std::string id = a.batch == 1 ? ids : hex64(Hasher{}.str(ids).digest());
    auto command = base_command(a);
    command.insert(command.end(), {"--task", ids, "--cache", list.cache.string()});
    list.tasks.push_back({.id = id, .label = s.study->feature + " " + label, .command = std::move(command), .outputs = std::move(outputs)});
  }
  auto reduce = base_command(a);
  reduce.insert(reduce.end(), {"--from-cache", list.cache.string(), "-o", std::filesystem::absolute(s.out).string()});
  list.reduce.push_back(std::move(reduce));
  return list;
}

struct Device {
  gpu::Instance instance;
  gpu::Adapter adapter;
  gpu::Device device;
};

Result<std::unique_ptr<Device>> open_device(const to::Study& study) {
  for (const auto& [name, value] : study.environment) ::setenv(name.c_str(), value.c_str(), 1);
  auto instance = gpu::Instance::create({.application_name = "weft-tradeoff"});
  if (!instance) return std::unexpected(instance.error());
  auto adapter = instance->request_adapter();
  if (!adapter) return std::unexpected(adapter.error());
  auto device = adapter->request_device();
  if (!device) return std::unexpected(device.error());
  return std::make_unique<Device>(Device{std::move(*instance), std::move(*adapter), std::move(*device)});
}

std::string device_text(const gpu::Adapter& adapter) {
  return weft::format("{} ({})", adapter.info().name, adapter.info().driver);
}

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "unknown";
  return name;
}

// The serial run and the reduce step end here: the mask, the errors, the reports.
int write_reports(const Args& a, const Study& s, std::vector<Rendered>& rendered, const image::Image8& black,
                  const image::Image8& white, const std::string& device, const std::string& frame_clock) {
  std::error_code ec;
  std::filesystem::create_directories(s.out, ec);
  if (ec) return failed({ErrorKind::Io, weft::format("cannot create '{}': {}", s.out.string(), ec.message())});
  const image::Image8& reference = rendered.front().image;  // plan_sweep puts the reference first
  std::vector<const image::Image8*> images;
  for (const auto& r : rendered) images.push_back(&r.image);
  // A pass has no objects of its own: its error is over the whole frame.
  auto mask = s.pipeline ? Result<to::Mask>(to::full_mask(reference.width, reference.height))
                         : to::coverage_mask(black, white, images, reference);
  if (!mask) return failed(mask.error());
  if (mask->count() == 0)
    return failed({ErrorKind::InvalidArgument,
                   weft::format("the {} objects cover no pixel of '{}' from its camera", s.study->feature, a.scene_path)});
  std::vector<to::Row> rows;
  for (auto& r : rendered) {
    auto e = to::compare(r.image, reference, *mask);
    if (!e) return failed(e.error());
    r.row.error = *e;
    rows.push_back(r.row);
  }
  to::mark_pareto(rows, s.study->cost);

  to::ReportInfo info;
  info.feature = s.study->feature;
  info.scene = std::filesystem::path(a.scene_path).filename().string();
  info.width = reference.width, info.height = reference.height, info.frames = a.frames;
  info.cost = s.study->cost;
  info.frame_clock = frame_clock;
  info.device = device;
  info.command = weft::format("weft tradeoff {} {} --frames {}{}{}", a.scene_path,
                              a.pass.empty() ? "--feature " + a.feature
                                             : "--pass " + a.pass + (a.pipeline.empty() ? "" : " --pipeline " + a.pipeline),
                              a.frames,
                              a.size.empty() ? "" : " --size " + a.size,
                              a.exposure != 1.0f ? weft::format(" --exposure {}", a.exposure) : "");
  for (const auto& v : a.values) info.command += " --values " + v;
  for (const auto& v : a.cross) info.command += " --cross " + v;
  if (a.extremes) info.command += " --extremes";
  for (const auto& v : a.base) info.command += " --base " + v;
  info.mask_note = s.pipeline ? weft::format("all {} pixels (a pass study: the whole frame)", mask->count())
                              : weft::format("{} of {} pixels (the feature's objects, and every pixel any setting changes)",
                                             mask->count(), std::size_t(reference.width) * reference.height);
  const std::pair<const char*, std::string> files[] = {{"tradeoff.csv", to::csv(rows, info)},
                                                       {"tradeoff.md", to::markdown(rows, info)},
                                                       {"tradeoff.svg", to::svg(rows, info)}};
  for (const auto& [name, text] : files)
    if (auto ok = write_file_atomically(s.out / name, {std::as_bytes(std::span(text))}, "study report"); !ok)
      return failed(ok.error());
  if (auto ok = image::save_png(s.out / "reference.png", reference); !ok) return failed(ok.error());
  std::printf("%s\nwrote %s/tradeoff.{csv,md,svg} and reference.png (%zu settings)\n", to::markdown(rows, info).c_str(),
              s.out.string().c_str(), rows.size());
  return 0;
}

int run_serial(const Args& a, const Study& s) {
  auto dev = open_device(*s.study);
  if (!dev) return failed(dev.error());
  auto& device = (*dev)->device;
  // On a CPU adapter (lavapipe) the frame's work is CPU time on every core, and GPU timestamps
  // are wall time that other processes' load inflates: the process CPU time is the cost.
  const bool cpu_adapter = (*dev)->adapter.info().type == gpu::AdapterType::Cpu;
  std::vector<Rendered> rendered;
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < s.plan.size(); ++i) {
    // A pass study's setting is a pipeline: the base one with the setting's options.
    std::optional<pipeline::Pipeline> setting_pipeline;
    renderer::RenderOptions options = s.options;
    if (s.pipeline) {
      auto p = to::apply_pass_setting(*s.pipeline, *s.study, s.plan[i]);
      if (!p) return failed(with_context(weft::format("setting '{}'", s.plan[i].label), p.error()).error());
      setting_pipeline.emplace(std::move(*p));
      options.pipeline = &*setting_pipeline;
    }
    auto r = render_setting(device, s.scene, *s.study, s.plan[i], options, a.frames, cpu_adapter);
    if (!r) return failed(r.error());
    for (const auto& w : r->warnings) log::warn(weft::format("{}: {}", s.plan[i].label, w));
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double eta = elapsed / double(i + 1) * double(s.plan.size() - i - 1);
    log::info(weft::format("[{}/{} {:.0f}%] {}: frame {:.1f} ms GPU, {:.1f} ms process CPU, cold {:.0f} ms (ETA {:.0f} s)",
                           i + 1, s.plan.size(), 100.0 * double(i + 1) / double(s.plan.size()), s.plan[i].label,
                           r->row.frame_ms, r->row.process_cpu_ms, r->row.cold_frame_ms, eta));
    rendered.push_back(std::move(*r));
  }
  image::Image8 black, white;  // the feature's coverage (a pass study's error is over the whole frame)
  if (!s.pipeline) {
    auto b = coverage_render(device, s.scene, *s.study, s.options, false);
    if (!b) return failed(b.error());
    auto w = coverage_render(device, s.scene, *s.study, s.options, true);
    if (!w) return failed(w.error());
    black = std::move(*b), white = std::move(*w);
  }
  return write_reports(a, s, rendered, black, white, device_text((*dev)->adapter),
                       cpu_adapter ? "process CPU time" : "GPU timestamps");
}

// One task: settings (each rendered alternately with the baseline preset for its cost ratio)
// and coverage frames, `--task ID[,ID...]`; each one's image, then its measurements, written
// atomically into the cache as soon as it is rendered, and those already there skipped.
int run_task(const Args& a, const Study& s) {
  if (a.cache.empty()) return failed({ErrorKind::InvalidArgument, "--task needs --cache DIR (where its output goes)"});
  const std::filesystem::path cache = a.cache;
  struct Unit {
    std::string id;
    const to::Setting* setting = nullptr;
    bool white = false;
  };
  std::vector<Unit> units;
  for (std::size_t from = 0; from <= a.task.size();) {
    const std::size_t comma = std::min(a.task.find(',', from), a.task.size());
    Unit u{a.task.substr(from, comma - from)};
    from = comma + 1;
    for (const auto& p : s.plan)
      if (setting_id(s, p) == u.id) u.setting = &p;
    if (!u.setting && coverage_id(s, true) == u.id) u.white = true;
    if (!u.setting && !u.white && coverage_id(s, false) != u.id)
      return failed({ErrorKind::InvalidArgument,
                     weft::format("--task {}: no setting or coverage frame of this study has that id (the scene file or "
                                  "the options changed since the task list was made?)", u.id)});
    units.push_back(std::move(u));
  }
  std::error_code ec;
  std::filesystem::create_directories(cache / "tradeoff", ec);
  if (ec) return failed({ErrorKind::Io, weft::format("cannot create '{}': {}", (cache / "tradeoff").string(), ec.message())});
  std::unique_ptr<Device> dev;
  std::optional<study::Baseline> baseline;  // one baseline renderer for every setting of the task
  if (s.baseline) baseline.emplace(study::Baseline{to::preset_setting(*s.study, *s.baseline), std::nullopt});
  for (const Unit& u : units) {
    const auto png = cache / result_file(u.id, ".png"), meta = cache / result_file(u.id, ".json");
    if (std::filesystem::is_regular_file(png, ec) && std::filesystem::is_regular_file(meta, ec)) continue;
    if (!dev) {
      auto opened = open_device(*s.study);
      if (!opened) return failed(opened.error());
      dev = std::move(*opened);
    }
    auto& device = dev->device;
    const bool cpu_adapter = dev->adapter.info().type == gpu::AdapterType::Cpu;
    json result = {{"version", 1}, {"id", u.id}, {"node", host_name()}, {"adapter", device_text(dev->adapter)},
                   {"frame_clock", cpu_adapter ? "process CPU time" : "GPU timestamps"}};
    image::Image8 image;
    const auto record = [&](const to::Row& row, const std::vector<std::string>& warnings) {
      for (const auto& w : warnings) log::warn(weft::format("{}: {}", u.setting->label, w));
      result["label"] = u.setting->label;
      result["frame_ms"] = row.frame_ms;
      result["gpu_ms"] = row.gpu_ms;
      result["feature_gpu_ms"] = row.feature_gpu_ms;
      result["process_cpu_ms"] = row.process_cpu_ms;
      result["wall_ms"] = row.wall_ms;
      result["cold_frame_ms"] = row.cold_frame_ms;
      result["warnings"] = warnings;
    };
    if (!u.setting) {
      auto r = coverage_render(device, s.scene, *s.study, s.options, u.white);
      if (!r) return failed(r.error());
      image = std::move(*r);
      result["label"] = u.white ? "coverage white" : "coverage black";
    } else if (!s.baseline) {
      auto r = render_setting(device, s.scene, *s.study, *u.setting, s.options, a.frames, cpu_adapter);
      if (!r) return failed(r.error());
      record(r->row, r->warnings);
      log::info(weft::format("{}: frame {:.1f} ms", u.setting->label, r->row.frame_ms));
      image = std::move(r->image);
    } else {
      auto r = study::render_alternating(device, s.scene, *s.study, *u.setting, *baseline, s.options, a.frames, cpu_adapter);
      if (!r) return failed(r.error());
      record(r->setting.row, r->setting.warnings);
      result["baseline"] = baseline->setting.label;
      result["baseline_frame_ms"] = r->baseline_frame_ms;
      result["cost_ratio"] = r->cost_ratio;
      log::info(weft::format("{}: frame {:.1f} ms, {:.3f}x the {}", u.setting->label, r->setting.row.frame_ms, r->cost_ratio,
                             baseline->setting.label));
      image = std::move(r->setting.image);
    }
    // The image first, the measurements last: a unit is done once both are there.
    if (auto ok = image::save_png(png, image); !ok) return failed(ok.error());
    const std::string text = result.dump(2) + "\n";
    if (auto ok = write_file_atomically(meta, {std::as_bytes(std::span(text))}, "task result"); !ok) return failed(ok.error());
  }
  return 0;
}

// The reduce step: every task's output from the cache, or the list of what is missing.
int run_reduce(const Args& a, const Study& s) {
  auto list = task_list(a, s, a.from_cache);
  if (!list) return failed(list.error());
  const auto missing = farm::missing_tasks(*list);
  if (!missing.empty())
    return failed({ErrorKind::NotFound,
                   weft::format("{} of {} tasks have no output in '{}', so no table was written: {}", missing.size(),
                                list->tasks.size(), list->cache.string(), farm::describe_missing(*list, missing))});
  const auto load = [&](const std::string& id) -> Result<std::pair<image::Image8, json>> {
    auto image = image::load_png(list->cache / result_file(id, ".png"));
    if (!image) return std::unexpected(image.error());
    auto bytes = read_input_file(list->cache / result_file(id, ".json"), "task result");
    if (!bytes) return std::unexpected(bytes.error());
    json meta = json::parse(bytes->begin(), bytes->end(), nullptr, false);
    if (meta.is_discarded() || !meta.is_object() || meta.value("id", "") != id)
      return fail(ErrorKind::Parse, "task result '{}' is not a weft task result for task {}",
                  (list->cache / result_file(id, ".json")).string(), id);
    return std::pair{std::move(*image), std::move(meta)};
  };
  std::vector<Rendered> rendered;
  std::set<std::string> nodes, clocks;
  for (const auto& setting : s.plan) {
    auto r = load(setting_id(s, setting));
    if (!r) return failed(r.error());
    auto& [image, meta] = *r;
    Rendered out;
    out.image = std::move(image);
    out.row.setting = setting;
    const auto number = [&](const char* key) { return meta.contains(key) && meta[key].is_number() ? meta[key].get<double>() : 0.0; };
    out.row.frame_ms = number("frame_ms");
    out.row.gpu_ms = number("gpu_ms");
    out.row.feature_gpu_ms = number("feature_gpu_ms");
    out.row.process_cpu_ms = number("process_cpu_ms");
    out.row.wall_ms = number("wall_ms");
    out.row.cold_frame_ms = number("cold_frame_ms");
    out.row.cost_ratio = meta.contains("cost_ratio") && meta["cost_ratio"].is_number() ? meta["cost_ratio"].get<double>()
                                                                                      : std::nan("");
    out.row.node = meta.value("node", "") + " / " + meta.value("adapter", "");
    nodes.insert(out.row.node);
    clocks.insert(meta.value("frame_clock", ""));
    rendered.push_back(std::move(out));
  }
  auto black = load(coverage_id(s, false));
  if (!black) return failed(black.error());
  auto white = load(coverage_id(s, true));
  if (!white) return failed(white.error());
  std::string device = *nodes.begin(), clock = *clocks.begin();
  // Absolute times only where every task ran on one node type; otherwise the cost is the ratio.
  const bool ratios = std::all_of(rendered.begin(), rendered.end(), [](const Rendered& r) { return !std::isnan(r.row.cost_ratio); });
  if ((nodes.size() > 1 || clocks.size() > 1) && ratios) {
    for (auto& r : rendered) r.row.frame_ms = r.row.cost_ratio;
    device = weft::format("{} nodes", nodes.size());
    clock = "ratio to the medium preset rendered alternately in the same task (not ms: the tasks ran on different nodes)";
  } else if (nodes.size() > 1 || clocks.size() > 1) {
    device = weft::format("{} nodes: these absolute times are not comparable (--baseline none)", nodes.size());
  } else if (ratios) {
    clock += weft::format("; cost ratio: to the {} preset rendered alternately in the same task", a.baseline);
  }
  return write_reports(a, s, rendered, black->first, white->first, device, clock);
}

int run(const Args& a) {
  if (a.list) {
    print_list();
    return 0;
  }
  const int modes = int(!a.tasks_file.empty()) + int(!a.task.empty()) + int(!a.from_cache.empty()) + int(!a.farm.runner.empty());
  if (modes > 1) return failed({ErrorKind::InvalidArgument, "--tasks, --task, --from-cache and --farm are one each: give one"});
  if (auto problem = check_farm_options(a.farm)) return failed({ErrorKind::InvalidArgument, *problem});
  if (!a.pass.empty() && modes > 0)
    return failed({ErrorKind::InvalidArgument, "--pass studies run in this process; --tasks, --task, --from-cache and "
                                               "--farm take --feature studies (docs/farm.md)"});
  auto s = prepare(a);
  if (!s) return failed(s.error());
  if (!a.task.empty()) return run_task(a, *s);
  if (!a.from_cache.empty()) return run_reduce(a, *s);
  if (!a.tasks_file.empty() || !a.farm.runner.empty()) {
    auto list = task_list(a, *s, a.cache.empty() ? farm::default_cache_dir() : std::filesystem::path(a.cache));
    if (!list) return failed(list.error());
    if (!a.tasks_file.empty()) {
      const std::string text = farm::to_text(*list);
      if (auto ok = write_file_atomically(a.tasks_file, {std::as_bytes(std::span(text))}, "task list"); !ok) return failed(ok.error());
      std::printf("wrote %s: %zu tasks, reduce: %s\n", a.tasks_file.c_str(), list->tasks.size(),
                  list->reduce.empty() ? "none" : "weft tradeoff ... --from-cache");
      return 0;
    }
    return run_farm(*list, a.farm, "weft tradeoff");
  }
  return run_serial(a, *s);
}
}  // namespace

Result<farm::TaskList> tradeoff_tasks_for(const farm::StudySpec& spec, const std::filesystem::path& cache) {
  Args a;
  a.scene_path = spec.scene.string();
  a.feature = spec.feature;
  a.size = spec.size;
  a.frames = spec.frames;
  a.exposure = float(spec.exposure);
  a.values = spec.values;
  a.cross = spec.cross;
  a.out = spec.out.string();
  auto s = prepare(a);
  if (!s) return with_context(spec.json_path, s.error());
  return task_list(a, *s, cache);
}

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
  sub->add_option("--cross", a->cross, "Also render every combination of these knobs' values: KNOB=V1,V2,... (repeatable)");
  sub->add_flag("--list", a->list, "Print each feature's knobs and reference, and exit");
  sub->add_flag("--extremes", a->extremes,
                "Render the stability sweep's settings instead: each knob's minimum and maximum, one at a time, and the reference");
  sub->add_option("--base", a->base, "--extremes: a knob value every extreme starts from, KNOB=V (repeatable)");
  sub->add_option("--tasks", a->tasks_file, "Write the study as a task list (JSON, docs/farm.md) to this file and exit")
      ->type_name("FILE");
  sub->add_option("--task", a->task, "Run one task of the study (its id from the task list) into --cache")->type_name("ID");
  sub->add_option("--from-cache", a->from_cache, "The reduce step: write the reports from the tasks' outputs in this cache folder")
      ->type_name("DIR");
  sub->add_option("--cache", a->cache, "The cache folder of the tasks' outputs (default: $WEFT_CACHE_DIR, else ~/.cache/weft/farm)")
      ->type_name("DIR");
  sub->add_option("--baseline", a->baseline,
                  "Farm tasks: the preset each setting is rendered alternately with, for its cost ratio (comparable across "
                  "nodes), or none")
      ->capture_default_str();
  sub->add_option("--batch", a->batch,
                  "Farm tasks: settings per task (each process pays its start, scene load and device once per task)")
      ->check(CLI::Range(1u, 100000u))
      ->capture_default_str();
  add_farm_options(*sub, a->farm);
  return [a] { return run(*a); };
}

}  // namespace weft::cli
