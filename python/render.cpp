// weft.adapters, weft.Device, weft.Renderer and weft.Pipeline: weft.gpu's instance, adapter and
// device, weft.renderer's Renderer (its caches live as long as the Python object), and
// weft.pipeline's pipelines. Rendering releases the GIL; one Renderer is used by one thread
// at a time (its own lock), renderers sharing a Device take turns on its queue.
#include <pybind11/pybind11.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <nlohmann/json.hpp>
#include <cmath>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <string>
#include <utility>
#include <variant>
#include <vector>
import weft.core;
import weft.gpu;
import weft.graph;
import weft.image;
import weft.scene;
import weft.feature;
import weft.pipeline;
import weft.renderer;
#include "common.h"

namespace weft::python {

std::shared_ptr<PyDevice> make_device(const std::string& adapter, std::optional<bool> validation) {
  Result<std::shared_ptr<PyDevice>> made;
  {
    py::gil_scoped_release release;
    made = [&]() -> Result<std::shared_ptr<PyDevice>> {
      gpu::InstanceDescriptor desc{.application_name = "weft-python"};
      if (validation) desc.validation = desc.synchronization_validation = *validation;
      auto instance = gpu::Instance::create(desc);
      if (!instance) return std::unexpected(instance.error());
      auto a = instance->request_adapter({.name_contains = adapter});
      if (!a) return std::unexpected(a.error());
      auto device = a->request_device({.label = "weft-python"});
      if (!device) return std::unexpected(device.error());
      return std::make_shared<PyDevice>(std::move(*instance), std::move(*a), std::move(*device));
    }();
  }
  return unwrap(std::move(made));
}

namespace {

py::dict adapter_dict(const gpu::AdapterInfo& a) {
  py::dict d;
  d["name"] = a.name;
  d["driver"] = a.driver;
  d["driver_info"] = a.driver_info;
  d["type"] = std::string(gpu::to_string(a.type));
  d["api_version"] = a.api_version_string();
  d["device_local_bytes"] = a.device_local_bytes;
  d["timestamps"] = a.limits.timestamps;
  d["max_texture_dimension_2d"] = a.limits.max_texture_dimension_2d;
  return d;
}

struct PyPipeline {
  pipeline::Pipeline pipeline;
};
using PipelineRef = std::shared_ptr<PyPipeline>;

PipelineRef parse(const json& document, const std::string& source) {
  auto p = std::make_shared<PyPipeline>();
  p->pipeline = unwrap(pipeline::parse_pipeline(document.dump(), source));
  return p;
}
json document_of(const pipeline::Pipeline& p) { return json::parse(pipeline::to_json(p)); }

struct PyRenderer {
  std::shared_ptr<PyDevice> device;
  std::optional<renderer::Renderer> renderer;  // destroyed before the device it uses
  std::mutex mutex;
  ~PyRenderer() {
    std::scoped_lock lock(mutex);
    renderer.reset();
  }
};
using RendererRef = std::shared_ptr<PyRenderer>;

struct Request {
  renderer::RenderOptions options;
  PipelineRef pipeline;  // kept alive for the call
};

Request request(const py::object& size, const std::string& quality, float exposure, bool aces, const py::object& pipeline) {
  Request r;
  const auto [w, h] = size_argument(size);
  r.options.width = w;
  r.options.height = h;
  r.options.quality = quality_argument(quality);
  // The limits `weft render --exposure` has: NaN, 0 and negative exposures drew black images.
  if (!(exposure > 0.0f && exposure <= 1e6f))
    raise(ErrorKind::InvalidArgument, weft::format("exposure {} must be a number in (0, 1e6]", exposure));
  r.options.exposure = exposure;
  r.options.aces = aces;
  if (!pipeline.is_none()) {
    if (py::isinstance<PyPipeline>(pipeline)) {
      r.pipeline = pipeline.cast<PipelineRef>();
      r.options.pipeline = &r.pipeline->pipeline;
    } else if (py::isinstance<py::str>(pipeline) || py::hasattr(pipeline, "__fspath__")) {
      r.pipeline = std::make_shared<PyPipeline>();
      r.pipeline->pipeline = unwrap(pipeline::load_pipeline(py::str(pipeline).cast<std::string>()));
      r.options.pipeline = &r.pipeline->pipeline;
    } else {
      raise(ErrorKind::InvalidArgument, "pipeline must be a weft.Pipeline, a path to a pipeline file, or None");
    }
  }
  return r;
}

renderer::Frame run(PyRenderer& r, const PyScene& scene, const renderer::RenderOptions& options) {
  Result<renderer::Frame> frame;
  {
    py::gil_scoped_release release;
    std::scoped_lock lock(r.mutex, r.device->mutex);
    std::shared_lock scene_lock(scene.mutex);
    frame = r.renderer->render(scene.scene, options);
  }
  return unwrap(std::move(frame));
}

py::dict stats_dict(const FrameStats& s) {
  py::dict d;
  py::list passes;
  for (const auto& p : s.passes) {
    py::dict pd;
    pd["name"] = p.name;
    pd["kind"] = std::string(to_string(p.kind));
    pd["gpu_ms"] = p.gpu_ms;
    pd["cpu_record_us"] = p.cpu_record_us;
    pd["wall_ms"] = p.wall_ms;
    passes.append(pd);
  }
  d["passes"] = passes;
  d["gpu_total_ms"] = s.gpu_total_ms;
  d["cpu_record_total_us"] = s.cpu_record_total_us;
  d["cpu_frame_ms"] = s.cpu_frame_ms;
  d["transient_bytes"] = s.transient_bytes;
  d["transient_bytes_unaliased"] = s.transient_bytes_unaliased;
  return d;
}

py::array hdr_array(image::Image&& hdr, float exposure) {
  // What `weft render -o x.exr` writes: the linear scene colour times the exposure.
  if (exposure != 1.0f)
    for (float& v : hdr.pixels) v *= exposure;
  return image_to_array(std::move(hdr));
}

const char* const render_options_doc = R"(
  scene      a weft.Scene
  size       (width, height), each 1..8192; None: the scene's output size
  quality    'low' | 'medium' | 'high' | 'reference': the preset each feature's unset knobs follow
  exposure   multiplier before the tone curve, (0, 1e6]; HDR arrays are multiplied by it too
  aces       False: plain clamp instead of the ACES curve
  pipeline   a weft.Pipeline or a pipeline file; None: the scene's "pipeline", else the default)";

}  // namespace

void bind_render(py::module_& m) {
  m.def(
      "adapters",
      [] {
        std::vector<gpu::AdapterInfo> adapters;
        {
          py::gil_scoped_release release;
          auto instance = gpu::Instance::create({.application_name = "weft-python"});
          if (!instance) throw WeftError{instance.error()};
          adapters = instance->enumerate_adapters();
        }
        py::list out;
        for (const auto& a : adapters) out.append(adapter_dict(a));
        return out;
      },
      R"(adapters() -> list[dict]

The Vulkan adapters of this machine: name, driver, driver_info, type ('cpu', 'discrete gpu', ...),
api_version, device_local_bytes, timestamps, max_texture_dimension_2d. Lavapipe (Mesa's CPU
driver) is there on machines without a GPU. RuntimeError when Vulkan has no instance.)");

  py::class_<PyDevice, std::shared_ptr<PyDevice>>(m, "Device", R"(A Vulkan device on one adapter (weft.gpu).

Renderers made with the same Device share it and take turns on its queue; a Renderer made
without one gets its own. WEFT_ADAPTER=cpu|gpu|<name> overrides the choice, as for `weft`.)")
      .def(py::init(&make_device), py::arg("adapter") = "", py::arg("validation") = py::none(),
           R"(Device(adapter='', validation=None) -> Device

adapter: the first adapter whose name contains this (case-insensitive); '' picks a GPU if there
is one, else the CPU adapter. validation: True turns on the Khronos validation layer with
synchronization validation (None: WEFT_VALIDATION=1 in the environment does). ValueError /
RuntimeError with weft's message when no such adapter or device exists.)")
      .def_property_readonly("adapter", [](const PyDevice& d) { return adapter_dict(d.adapter.info()); },
                             "The adapter this device runs on, as weft.adapters() describes it.")
      .def_property_readonly("validation", [](const PyDevice& d) { return d.instance.validation_enabled(); },
                             "Whether the validation layer is on (bool).")
      .def(
          "validation_messages", [](const PyDevice& d) { return d.instance.take_validation_messages(); },
          R"(validation_messages() -> list[str]

Warnings and errors the validation layer reported since the last call (and forgets them); []
when validation is off. weft's own tests fail on any.)");

  py::class_<PyPipeline, PipelineRef>(m, "Pipeline", R"(A frame's pipeline: named passes of registered pass types with options, connections, outputs (weft.pipeline; docs/pipelines.md).

Pipelines are values: Pipeline.load(path), Pipeline.from_dict(d), Pipeline.default(); edit with
with_options(...) or to_dict() -> edit -> Pipeline.from_dict(...), which checks everything the
file reader checks (pass types, option ranges, formats, sizes, cycles) with JSON-path messages.)")
      .def_static(
          "load", [](const std::filesystem::path& path) {
            auto p = std::make_shared<PyPipeline>();
            p->pipeline = unwrap(pipeline::load_pipeline(path));
            return p;
          },
          py::arg("path"), "Pipeline.load(path) -> Pipeline: reads and validates a pipeline file.")
      .def_static(
          "from_dict", [](const py::dict& d, const std::string& source) { return parse(to_json(d), source); }, py::arg("document"),
          py::arg("source") = "pipeline dict",
          R"(Pipeline.from_dict(document, source='pipeline dict') -> Pipeline

A pipeline document as a dict ({'passes': {...}, 'connections': [...], 'outputs': [...]}), read
and checked like a file: ValueError with every problem, each at its JSON path.)")
      .def_static(
          "default", [] {
            auto p = std::make_shared<PyPipeline>();
            p->pipeline = unwrap(pipeline::default_pipeline());
            return p;
          },
          "Pipeline.default() -> Pipeline: the frame every scene without a pipeline renders with.")
      .def(
          "to_dict", [](const PyPipeline& p) { return from_json(document_of(p.pipeline)); },
          "to_dict() -> dict: the pipeline as a document, every option written out (reads back equal).")
      .def(
          "to_json", [](const PyPipeline& p) { return pipeline::to_json(p.pipeline); },
          "to_json() -> str: the pipeline as a file (what `weft graph --export-pipeline` writes).")
      .def(
          "with_options",
          [](const PyPipeline& p, const std::string& pass, const py::kwargs& options) {
            json d = document_of(p.pipeline);
            if (!d["passes"].contains(pass)) {
              std::string names;
              for (const auto& q : p.pipeline.passes) names += (names.empty() ? "" : ", ") + q.name;
              raise(ErrorKind::InvalidArgument, weft::format("the pipeline has no pass '{}' (passes: {})", pass, names));
            }
            for (const auto& [k, v] : to_json(options).items()) d["passes"][pass]["options"][k] = v;
            return parse(d, p.pipeline.source);
          },
          py::arg("pass_name"),
          R"(with_options(pass_name, **options) -> Pipeline

A copy with these options of one pass changed (e.g. with_options('tonemap', exposure=2.0)),
checked against the pass type's options table: ValueError with the JSON path otherwise.)")
      .def_property_readonly("source", [](const PyPipeline& p) { return p.pipeline.source; }, "Where it came from (str).")
      .def_property_readonly("description", [](const PyPipeline& p) { return p.pipeline.description; },
                             "The pipeline's description (str; '' when it has none).")
      .def_property_readonly(
          "passes",
          [](const PyPipeline& p) {
            py::list out;
            for (const auto& q : p.pipeline.passes) {
              py::dict d;
              d["name"] = q.name;
              d["type"] = q.type->name;
              d["options"] = from_json(q.options.json());
              out.append(d);
            }
            return out;
          },
          "The passes in run order, as dicts: name, type, options (every option, defaults filled in).")
      .def_property_readonly(
          "connections",
          [](const PyPipeline& p) {
            std::vector<std::string> out;
            for (const auto& c : p.pipeline.connections) out.push_back(c.from.text() + " -> " + c.to.text());
            return out;
          },
          "The connections as 'pass.slot -> pass.slot' strings.")
      .def_property_readonly(
          "outputs",
          [](const PyPipeline& p) {
            std::vector<std::string> out;
            for (const auto& o : p.pipeline.outputs) out.push_back(o.text());
            return out;
          },
          "The outputs ('pass.slot'); the first is the frame's image.")
      .def_property_readonly("warnings", [](const PyPipeline& p) { return p.pipeline.warnings; },
                             "The reader's warnings (passes that reach no output and are culled).")
      .def("__repr__", [](const PyPipeline& p) {
        std::string names;
        for (const auto& q : p.pipeline.passes) names += (names.empty() ? "" : ", ") + q.name;
        return weft::format("<weft.Pipeline '{}': {}>", p.pipeline.source, names);
      });

  py::class_<PyRenderer, RendererRef>(m, "Renderer", R"(weft's renderer (weft.renderer): turns a scene and a pipeline into a frame.

It keeps GPU meshes, textures, environment maps, pass instances and the last frame's graph plan
across renders, so a loop that changes one knob re-prepares only what that knob touches
(cache_stats() counts the real work). Rendering releases the GIL; a Renderer is used by one
thread at a time (calls from several threads wait their turn), renderers with their own
devices render in parallel.)")
      .def(py::init([](std::shared_ptr<PyDevice> device, const std::string& adapter) {
             if (!device) device = make_device(adapter, std::nullopt);
             auto r = std::make_shared<PyRenderer>();
             r->device = std::move(device);
             r->renderer.emplace(unwrap(renderer::Renderer::create(r->device->device)));
             return r;
           }),
           py::arg("device") = nullptr, py::arg("adapter") = "",
           R"(Renderer(device=None, adapter='') -> Renderer

On `device` (a weft.Device), or on a new device of its own on the adapter whose name contains
`adapter` (see weft.Device).)")
      .def_property_readonly("device", [](const PyRenderer& r) { return r.device; }, "The weft.Device it renders on.")
      .def(
          "render",
          [](PyRenderer& r, const PyScene& scene, const py::object& size, const std::string& quality,
             const std::optional<std::string>& output, float exposure, bool aces, const py::object& pipeline) -> py::array {
            Request q = request(size, quality, exposure, aces, pipeline);
            q.options.timestamps = false;
            const bool hdr = output && *output == "hdr";
            if (hdr) q.options.read_hdr = true;
            else if (output) q.options.outputs.push_back(*output);
            auto frame = run(r, scene, q.options);
            if (hdr) return hdr_array(std::move(frame.hdr), exposure);
            if (output) return image_to_array(std::move(frame.outputs.front().pixels));
            return image_to_array(std::move(frame.image));
          },
          py::arg("scene"), py::arg("size") = py::none(), py::arg("quality") = "medium", py::arg("output") = py::none(),
          py::arg("exposure") = 1.0f, py::arg("aces") = true, py::arg("pipeline") = py::none(),
          (std::string(R"(render(scene, size=None, quality='medium', output=None, exposure=1.0, aces=True, pipeline=None) -> numpy.ndarray

Renders one frame and returns it as an array, without a copy:
  output=None        the frame's image: uint8 (height, width, 4) RGBA, sRGB-encoded -- the pixels
                     `weft render -o x.png` writes
  output='hdr'       the linear scene colour before the tone curve, times the exposure: float32
                     (height, width, 4) -- what `weft render -o x.exr` writes
  output='PASS.SLOT' or a texture's name ('shadow_map.depth', 'scene.depth', 'ssdf_visibility'):
                     that resource of the frame as float32 (height, width, 4) linear RGBA (8-bit
                     formats scaled to 0..1, depth in red), as `weft render --output NAME -o x.exr`
ValueError with weft's message for an unknown resource, a bad material, a pipeline that does
not compile; RuntimeError for device failures.)") + render_options_doc)
              .c_str())
      .def(
          "render_frame",
          [](PyRenderer& r, const PyScene& scene, const py::object& size, const std::string& quality,
             const std::vector<std::string>& outputs, bool hdr, float exposure, bool aces, const py::object& pipeline,
             bool timestamps, bool serial_passes) {
            Request q = request(size, quality, exposure, aces, pipeline);
            q.options.outputs = outputs;
            q.options.read_hdr = hdr;
            q.options.timestamps = timestamps;
            q.options.serial_passes = serial_passes;
            auto frame = run(r, scene, q.options);
            py::dict d;
            d["image"] = image_to_array(std::move(frame.image));
            d["hdr"] = hdr ? py::object(hdr_array(std::move(frame.hdr), exposure)) : py::object(py::none());
            py::dict out;
            py::dict formats;
            for (auto& o : frame.outputs) {
              formats[py::str(o.name)] = std::string(gpu::to_string(o.format));
              out[py::str(o.name)] = image_to_array(std::move(o.pixels));
            }
            d["outputs"] = out;
            d["output_formats"] = formats;
            d["stats"] = stats_dict(frame.stats);
            d["passes"] = frame.passes;
            d["warnings"] = frame.warnings;
            return d;
          },
          py::arg("scene"), py::arg("size") = py::none(), py::arg("quality") = "medium", py::arg("outputs") = std::vector<std::string>{},
          py::arg("hdr") = false, py::arg("exposure") = 1.0f, py::arg("aces") = true, py::arg("pipeline") = py::none(),
          py::arg("timestamps") = true, py::arg("serial_passes") = false,
          (std::string(R"(render_frame(scene, size=None, quality='medium', outputs=[], hdr=False, exposure=1.0, aces=True, pipeline=None, timestamps=True, serial_passes=False) -> dict

Renders one frame and returns everything about it:
  'image'          uint8 (height, width, 4) sRGB, as render()
  'hdr'            float32 linear scene colour times the exposure when hdr=True, else None
  'outputs'        {name: float32 (height, width, 4)} for each resource named in `outputs`
  'output_formats' {name: the resource's own format ('rgba16float', 'depth32float', ...)}
  'stats'          per-pass times and memory: {'passes': [{'name', 'kind', 'gpu_ms',
                   'cpu_record_us', 'wall_ms'}], 'gpu_total_ms', 'cpu_record_total_us',
                   'cpu_frame_ms', 'transient_bytes', 'transient_bytes_unaliased'}
                   (gpu_ms is -1 without timestamps; wall_ms with serial_passes=True)
  'passes'         the graph passes that ran, in order
  'warnings'       what the features said (clamped knobs, weak inputs)
serial_passes=True submits and waits after every pass, timing each alone (the honest per-pass
cost on CPU adapters).)") + render_options_doc)
              .c_str())
      .def(
          "describe",
          [](PyRenderer& r, const PyScene& scene, const py::object& size, const std::string& quality, const py::object& pipeline) {
            Request q = request(size, quality, 1.0f, true, pipeline);
            Result<renderer::GraphReport> report;
            {
              py::gil_scoped_release release;
              std::scoped_lock lock(r.mutex, r.device->mutex);
              std::shared_lock scene_lock(scene.mutex);
              report = r.renderer->describe(scene.scene, q.options);
            }
            auto g = unwrap(std::move(report));
            py::dict d;
            d["passes"] = g.passes;
            d["culled_passes"] = g.culled_passes;
            d["resources"] = g.resources;
            d["slots"] = g.slots;
            d["warnings"] = g.warnings;
            d["pipeline"] = g.pipeline;
            d["dot"] = g.dot;
            d["dump"] = g.dump;
            return d;
          },
          py::arg("scene"), py::arg("size") = py::none(), py::arg("quality") = "medium", py::arg("pipeline") = py::none(),
          R"(describe(scene, size=None, quality='medium', pipeline=None) -> dict

The compiled frame without executing it (`weft graph`): 'passes' (run, in order),
'culled_passes', 'resources' (every texture and buffer by name: what render(output=...) takes),
'slots' (every 'pass.slot'), 'warnings', 'pipeline' (as a file), 'dot' (Graphviz), 'dump'.)")
      .def(
          "cache_stats",
          [](const PyRenderer& r) {
            const auto s = r.renderer->cache_stats();
            py::dict d;
            d["mesh_uploads"] = s.mesh_uploads;
            d["environment_uploads"] = s.environment_uploads;
            d["texture_uploads"] = s.texture_uploads;
            d["pass_creations"] = s.pass_creations;
            d["graph_plans"] = s.graph_plans;
            d["graph_plans_reused"] = s.graph_plans_reused;
            return d;
          },
          R"(cache_stats() -> dict

How many times each of the renderer's caches did real work since it was made: mesh_uploads,
environment_uploads, texture_uploads, pass_creations (pipeline pass and feature pass
instances), graph_plans (frames planned afresh) and graph_plans_reused (frames that reused the
last plan). A second render of an unchanged scene adds only to graph_plans_reused.)")
      .def("__repr__", [](const PyRenderer& r) {
        return weft::format("<weft.Renderer on '{}'>", r.device->adapter.info().name);
      });
}

}  // namespace weft::python
