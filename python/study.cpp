// weft.tradeoff (the speed/accuracy study as rows) and weft.compare (error over a mask).
// The study is the one `weft tradeoff` runs (tools/weft/tradeoff.cpp), step for step, on
// weft.tradeoff's planning, application, masks, metrics and Pareto marking: every setting of
// tradeoff::plan_sweep in a fresh renderer (the feature's process-wide caches cleared, so
// the first frame is timed cold), `frames` steady frames after it, the coverage mask from the
// feature's objects drawn black and white, error against the reference over that mask. The
// error columns are the CLI's numbers (tests/python compare them); the times are this
// process's measurements.
#include <pybind11/pybind11.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <nlohmann/json.hpp>
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <ctime>
#include <expected>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <string>
#include <utility>
#include <vector>
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.feature;
import weft.renderer;
import weft.tradeoff;
import weft.study;
#include "common.h"

namespace weft::python {
namespace {
namespace to = weft::tradeoff;

using Rendered = study::RenderedSetting;
using study::coverage_render;
using study::render_setting;

struct StudyResult {
  std::vector<to::Row> rows;
  to::ReportInfo info;
  image::Image8 reference;
};

// The study's environment variables (e.g. a bake cache turned off), set while it runs.
struct ScopedEnvironment {
  std::vector<std::pair<std::string, std::optional<std::string>>> saved;
  explicit ScopedEnvironment(const std::vector<std::pair<std::string, std::string>>& values) {
    for (const auto& [name, value] : values) {
      const char* old = std::getenv(name.c_str());
      saved.emplace_back(name, old ? std::optional<std::string>(old) : std::nullopt);
      ::setenv(name.c_str(), value.c_str(), 1);
    }
  }
  ~ScopedEnvironment() {
    for (const auto& [name, old] : saved) {
      if (old) ::setenv(name.c_str(), old->c_str(), 1);
      else ::unsetenv(name.c_str());
    }
  }
};

Result<StudyResult> run_study(PyDevice& dev, const scene::Scene& scene, const std::string& scene_name, const to::Study& study,
                              const std::vector<to::KnobValues>& overrides, renderer::RenderOptions options, unsigned frames,
                              const std::string& command) {
  if (!to::scene_uses(scene, study.material))
    return fail(ErrorKind::InvalidArgument, "'{}' has no \"{}\" material: nothing for the {} study to sweep", scene_name,
                study.material, study.feature);
  ScopedEnvironment environment(study.environment);
  const bool cpu_adapter = dev.adapter.info().type == gpu::AdapterType::Cpu;
  const auto plan = to::plan_sweep(study, overrides);
  std::vector<Rendered> rendered;
  for (std::size_t i = 0; i < plan.size(); ++i) {
    auto r = render_setting(dev.device, scene, study, plan[i], options, frames, cpu_adapter);
    if (!r) return std::unexpected(r.error());
    log::info(weft::format("[{}/{}] {}: frame {:.1f} ms", i + 1, plan.size(), plan[i].label, r->row.frame_ms));
    rendered.push_back(std::move(*r));
  }
  const image::Image8& reference = rendered.front().image;  // plan_sweep puts the reference first
  auto black = coverage_render(dev.device, scene, study, options, false);
  if (!black) return std::unexpected(black.error());
  auto white = coverage_render(dev.device, scene, study, options, true);
  if (!white) return std::unexpected(white.error());
  std::vector<const image::Image8*> images;
  for (const auto& r : rendered) images.push_back(&r.image);
  auto mask = to::coverage_mask(*black, *white, images, reference);
  if (!mask) return std::unexpected(mask.error());
  if (mask->count() == 0)
    return fail(ErrorKind::InvalidArgument, "the {} objects cover no pixel of '{}' from its camera", study.feature, scene_name);
  StudyResult out;
  for (auto& r : rendered) {
    auto e = to::compare(r.image, reference, *mask);
    if (!e) return std::unexpected(e.error());
    r.row.error = *e;
    out.rows.push_back(r.row);
  }
  to::mark_pareto(out.rows, study.cost);
  out.info.feature = study.feature;
  out.info.scene = scene_name;
  out.info.width = reference.width, out.info.height = reference.height, out.info.frames = frames;
  out.info.cost = study.cost;
  out.info.frame_clock = cpu_adapter ? "process CPU time" : "GPU timestamps";
  out.info.device = weft::format("{} ({})", dev.adapter.info().name, dev.adapter.info().driver);
  out.info.command = command;
  out.info.mask_note = weft::format("{} of {} pixels (the feature's objects, and every pixel any setting changes)", mask->count(),
                                    std::size_t(reference.width) * reference.height);
  out.reference = rendered.front().image;
  return out;
}

py::dict row_dict(const to::Row& r) {
  py::dict d;
  d["setting"] = r.setting.label;
  d["group"] = r.setting.group;
  d["quality"] = std::string(to_string(r.setting.quality));
  d["values"] = from_json(r.setting.values);
  d["is_reference"] = r.setting.is_reference;
  d["preset"] = r.setting.preset ? py::object(py::str(std::string(to_string(*r.setting.preset)))) : py::object(py::none());
  d["frame_ms"] = r.frame_ms;
  d["gpu_ms"] = r.gpu_ms;
  d["feature_gpu_ms"] = r.feature_gpu_ms;
  d["process_cpu_ms"] = r.process_cpu_ms;
  d["wall_ms"] = r.wall_ms;
  d["cold_frame_ms"] = r.cold_frame_ms;
  d["rmse"] = r.error.rmse;
  d["relative_rmse"] = r.error.relative_rmse;
  d["psnr_db"] = r.error.psnr_db;
  d["ssim"] = r.error.ssim;
  d["max_diff"] = r.error.max_diff;
  d["pixels"] = r.error.pixels;
  d["pareto"] = r.pareto;
  return d;
}

py::dict error_dict(const to::ImageError& e) {
  py::dict d;
  d["rmse"] = e.rmse;
  d["relative_rmse"] = e.relative_rmse;
  d["psnr_db"] = e.psnr_db;
  d["ssim"] = e.ssim;
  d["max_diff"] = e.max_diff;
  d["pixels"] = e.pixels;
  return d;
}

}  // namespace

void bind_study(py::module_& m) {
  m.def(
      "compare",
      [](const py::array& render, const py::array& reference, const py::object& mask) {
        const auto a = array_to_image8(render, "compare: render");
        const auto b = array_to_image8(reference, "compare: reference");
        to::Mask covered = to::full_mask(b.width, b.height);
        if (!mask.is_none()) {
          auto mk = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>::ensure(mask);
          if (!mk || mk.ndim() != 2 || mk.shape(0) != b.height || mk.shape(1) != b.width)
            raise(ErrorKind::InvalidArgument,
                  weft::format("compare: the mask must be an array of shape ({}, {}) (the reference's height, width)", b.height, b.width));
          for (py::ssize_t i = 0; i < mk.size(); ++i) covered.covered[std::size_t(i)] = mk.data()[i] ? 1 : 0;
        }
        return error_dict(unwrap(to::compare(a, b, covered)));
      },
      py::arg("render"), py::arg("reference"), py::arg("mask") = py::none(),
      R"(compare(render, reference, mask=None) -> dict

The error of an sRGB uint8 render (height, width, channels) against a reference of the same
shape over a mask ((height, width), nonzero = counted; None: every pixel), as `weft tradeoff`
measures it: {'rmse' (linear RGB, sRGB decoded), 'relative_rmse' (over the reference's RMS),
'psnr_db' (peak 1; inf when equal), 'ssim' (over the mask's bounding box), 'max_diff',
'pixels' (how many the mask counts)}.)");

  m.def(
      "tradeoff",
      [](const std::shared_ptr<PyScene>& scene, const std::string& feature, const py::object& size, unsigned frames,
         const py::object& values, float exposure, std::shared_ptr<PyDevice> device,
         const std::optional<std::filesystem::path>& out) {
        const to::Study* study = unwrap(to::find_study(feature));
        std::vector<to::KnobValues> overrides;
        std::string command = weft::format("weft.tradeoff(scene, '{}', frames={}", feature, frames);
        if (!values.is_none()) {
          for (auto [k, v] : values.cast<py::dict>()) {
            std::string text = k.cast<std::string>() + "=";
            bool first = true;
            for (auto item : v) {
              text += (first ? "" : ",") + to::value_text(to_json(item));
              first = false;
            }
            auto parsed = to::parse_knob_values(*study, text);
            if (!parsed) raise(parsed.error().kind, "values: " + parsed.error().message);
            overrides.push_back(std::move(*parsed));
            command += ", values " + text;
          }
        }
        if (frames < 1 || frames > 1000) raise(ErrorKind::InvalidArgument, weft::format("frames must be 1 to 1000, got {}", frames));
        if (!(exposure > 0.0f && exposure <= 1e6f))
          raise(ErrorKind::InvalidArgument, weft::format("exposure {} must be a number in (0, 1e6]", exposure));
        renderer::RenderOptions options;
        options.aces = false;  // clamp: decoded pixels are linear radiance (times the exposure) below 1
        options.exposure = exposure;
        const auto [w, h] = size_argument(size);
        options.width = w, options.height = h;
        if (w) command += weft::format(", size=({}, {})", w, h);
        command += ")";
        if (!device) device = make_device("", std::nullopt);
        const std::string scene_name =
            scene->scene.source.empty() ? std::string("(scene in code)") : scene->scene.source.filename().string();
        Result<StudyResult> result;
        {
          py::gil_scoped_release release;
          std::scoped_lock lock(device->mutex);
          std::shared_lock scene_lock(scene->mutex);
          result = run_study(*device, scene->scene, scene_name, *study, overrides, options, frames, command);
        }
        auto study_result = unwrap(std::move(result));
        if (out) {
          std::error_code ec;
          std::filesystem::create_directories(*out, ec);
          if (ec) raise(ErrorKind::Io, weft::format("cannot create '{}': {}", out->string(), ec.message()));
          const std::pair<const char*, std::string> files[] = {{"tradeoff.csv", to::csv(study_result.rows, study_result.info)},
                                                               {"tradeoff.md", to::markdown(study_result.rows, study_result.info)},
                                                               {"tradeoff.svg", to::svg(study_result.rows, study_result.info)}};
          for (const auto& [name, text] : files) {
            std::ofstream f(*out / name, std::ios::binary);
            f << text;
            if (!f) raise(ErrorKind::Io, weft::format("cannot write '{}'", (*out / name).string()));
          }
          unwrap(image::save_png(*out / "reference.png", study_result.reference));
        }
        py::list rows;
        for (const auto& r : study_result.rows) rows.append(row_dict(r));
        return rows;
      },
      py::arg("scene"), py::arg("feature"), py::arg("size") = py::none(), py::arg("frames") = 5u, py::arg("values") = py::none(),
      py::arg("exposure") = 1.0f, py::arg("device") = nullptr, py::arg("out") = py::none(),
      R"(tradeoff(scene, feature, size=None, frames=5, values=None, exposure=1.0, device=None, out=None) -> list[dict]

The speed/accuracy study of one feature on a scene that uses it -- what `weft tradeoff SCENE
--feature F` runs: the reference, the quality presets, each knob's sweep around the medium
preset ({knob: [v1, v2, ...]} in `values` replaces a knob's sweep, as --values does) and the
feature's grids, each in a fresh renderer (cold first frame) and then `frames` steady frames;
error against the reference over the feature's pixels; the Pareto front of cost against RMSE.
One dict per setting, the reference first:
  setting, group, quality, values (knob -> value), is_reference, preset
  frame_ms (the steady frame's cost: process CPU time on a CPU adapter, GPU time on a GPU),
  gpu_ms, feature_gpu_ms, process_cpu_ms, wall_ms, cold_frame_ms
  rmse, relative_rmse, psnr_db, ssim, max_diff, pixels (the mask's size), pareto (bool)
With out=DIR it also writes DIR/tradeoff.csv, .md, .svg and reference.png as the CLI does.
Renders with the plain clamp (aces off) so decoded pixels are linear radiance.)");
}

}  // namespace weft::python
