// The `weft` Python module: the engine from Python (docs/python.md). A thin binding over the
// engine's own APIs -- weft.scene reads scenes (and the scene dicts and fragments built in
// code, so every message carries weft's JSON paths), weft.feature's registry gives the knobs
// and their ranges, weft.renderer renders, weft.image saves and measures, weft.tradeoff plans
// and scores studies -- nothing here re-implements what those modules do.
//
// This unit: the module itself (registration of the built-in passes and features, plugins
// from WEFT_PLUGIN_PATH), errors, JSON and NumPy conversions, image files and metrics, the
// registries' listings.
#include <pybind11/pybind11.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <pybind11/eval.h>
#include <nlohmann/json.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <expected>
#include <filesystem>
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
import weft.pipeline;
import weft.builtin_features;
#include "common.h"

namespace weft::python {

json to_json(py::handle value) {
  if (value.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>();
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<py::int_>(value)) return value.cast<std::int64_t>();
  if (py::isinstance<py::float_>(value)) return value.cast<double>();
  if (py::isinstance<py::dict>(value)) {
    json out = json::object();
    for (auto [k, v] : value.cast<py::dict>()) {
      if (!py::isinstance<py::str>(k)) raise(ErrorKind::InvalidArgument, "dict keys must be strings, got " + std::string(py::str(py::type::of(k)))) ;
      out[k.cast<std::string>()] = to_json(v);
    }
    return out;
  }
  // NumPy arrays and scalars: their Python equivalents (numpy.int64 -> int, float32 -> float).
  if (py::hasattr(value, "tolist") && !py::isinstance<py::list>(value)) return to_json(value.attr("tolist")());
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
    json out = json::array();
    for (auto v : value) out.push_back(to_json(v));
    return out;
  }
  if (py::hasattr(value, "__fspath__"))
    return py::str(value.attr("__fspath__")()).cast<std::string>();
  raise(ErrorKind::InvalidArgument,
        "cannot write a " + std::string(py::str(py::type::of(value).attr("__name__"))) +
            " as a JSON value (use dict, list, str, bool, int, float or None)");
}

py::object from_json(const json& value) {
  switch (value.type()) {
    case json::value_t::null: return py::none();
    case json::value_t::boolean: return py::bool_(value.get<bool>());
    case json::value_t::number_integer: return py::int_(value.get<std::int64_t>());
    case json::value_t::number_unsigned: return py::int_(value.get<std::uint64_t>());
    case json::value_t::number_float: return py::float_(value.get<double>());
    case json::value_t::string: return py::str(value.get<std::string>());
    case json::value_t::array: {
      py::list out;
      for (const auto& v : value) out.append(from_json(v));
      return std::move(out);
    }
    case json::value_t::object: {
      py::dict out;
      for (const auto& [k, v] : value.items()) out[py::str(k)] = from_json(v);
      return std::move(out);
    }
    default: return py::none();
  }
}

py::array image_to_array(image::Image8&& image) {
  const py::ssize_t h = image.height, w = image.width, c = image.channels;
  return adopt(std::move(image.pixels), {h, w, c});
}
py::array image_to_array(image::Image&& image) {
  const py::ssize_t h = image.height, w = image.width, c = image.channels;
  return adopt(std::move(image.pixels), {h, w, c});
}

namespace {
template <class T>
std::tuple<std::uint32_t, std::uint32_t, std::uint32_t, std::vector<T>> read_array(const py::handle& object, const char* what) {
  auto array = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(object);
  if (!array) raise(ErrorKind::InvalidArgument, std::string(what) + ": expected an array of shape (height, width[, channels])");
  if (array.ndim() != 2 && array.ndim() != 3)
    raise(ErrorKind::InvalidArgument, weft::format("{}: expected an array of shape (height, width[, channels]), got {} dimension(s)",
                                                   what, array.ndim()));
  const auto h = array.shape(0), w = array.shape(1), c = array.ndim() == 3 ? array.shape(2) : 1;
  if (h < 1 || w < 1 || c < 1 || c > 4)
    raise(ErrorKind::InvalidArgument, weft::format("{}: shape ({}, {}, {}) is not an image (1 to 4 channels)", what, h, w, c));
  std::vector<T> pixels(array.data(), array.data() + array.size());
  return {std::uint32_t(w), std::uint32_t(h), std::uint32_t(c), std::move(pixels)};
}
}  // namespace

image::Image8 array_to_image8(const py::handle& array, const char* what) {
  if (auto a = py::array::ensure(array); a && a.dtype().kind() != 'u' && a.dtype().kind() != 'i')
    raise(ErrorKind::InvalidArgument, weft::format("{}: expected uint8 pixels (sRGB), got dtype {}", what,
                                                   std::string(py::str(a.dtype()))));
  auto [w, h, c, pixels] = read_array<std::uint8_t>(array, what);
  return image::Image8{w, h, c, std::move(pixels)};
}
image::Image array_to_image(const py::handle& array, const char* what) {
  auto [w, h, c, pixels] = read_array<float>(array, what);
  return image::Image{w, h, c, std::move(pixels)};
}

Quality quality_argument(const std::string& name) { return unwrap(quality_from_string(name)); }

std::pair<std::uint32_t, std::uint32_t> size_argument(const py::object& size) {
  if (size.is_none()) return {0, 0};
  const auto bad = [&] {
    raise(ErrorKind::InvalidArgument,
          weft::format("size expects (width, height) with each side 1 to {}, got {}", scene::max_output_side,
                       std::string(py::repr(size))));
  };
  if (!py::isinstance<py::sequence>(size) || py::len(size) != 2) bad();
  std::uint32_t out[2]{};
  for (int i = 0; i < 2; ++i) {
    py::object v = size.cast<py::sequence>()[i];
    if (py::isinstance<py::bool_>(v) || !py::hasattr(v, "__index__")) bad();
    const long long n = v.attr("__index__")().cast<long long>();
    if (n < 1 || n > scene::max_output_side) bad();
    out[i] = std::uint32_t(n);
  }
  return {out[0], out[1]};
}

namespace {

// ---- images and metrics ----------------------------------------------------------------------

py::object load_image(const std::filesystem::path& path) {
  const std::string ext = [&] {
    std::string e = path.extension().string();
    for (char& ch : e) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    return e;
  }();
  if (ext == ".exr" || ext == ".hdr") return image_to_array(unwrap(image::load_float_image(path)));
  return image_to_array(unwrap(image::load_ldr(path)));
}

void save_image(const std::filesystem::path& path, const py::array& pixels) {
  const char kind = pixels.dtype().kind();
  if (kind == 'f') {
    unwrap(image::save_image(path, array_to_image(pixels, "save_image")));
    return;
  }
  const image::Image8 image = array_to_image8(pixels, "save_image");
  std::string ext = path.extension().string();
  for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  if (ext == ".jpg" || ext == ".jpeg") unwrap(image::save_jpeg(path, image));
  else unwrap(image::save_image(path, image));
}

py::dict knob_dict(const Knob& k) {
  py::dict d;
  d["name"] = k.name;
  d["kind"] = k.kind == KnobKind::Integer  ? "integer"
              : k.kind == KnobKind::Number ? "number"
              : k.kind == KnobKind::Boolean ? "boolean"
                                            : "choice";
  if (k.kind == KnobKind::Integer || k.kind == KnobKind::Number) {
    d["min"] = k.min;
    d["max"] = k.max;
  }
  if (k.kind == KnobKind::Choice) d["choices"] = k.choices;
  py::list sweep;
  for (const auto& v : k.sweep) sweep.append(from_json(v));
  d["sweep"] = sweep;
  d["meaning"] = k.meaning;
  return d;
}

py::dict feature_dict(const FeatureDescriptor& f) {
  py::dict d;
  d["name"] = f.name;
  d["aliases"] = f.aliases;
  d["summary"] = f.summary;
  d["doc"] = f.doc;
  d["passes"] = f.passes;
  py::list knobs;
  for (const auto& k : f.knobs) knobs.append(knob_dict(k));
  d["knobs"] = knobs;
  py::dict presets;
  if (f.preset_values)
    for (Quality q : {Quality::Low, Quality::Medium, Quality::High, Quality::Reference})
      presets[py::str(std::string(to_string(q)))] = from_json(f.preset_values(q));
  d["presets"] = presets;
  d["reference"] = from_json(f.reference);
  d["reference_why"] = f.reference_why;
  d["cost"] = std::string(to_string(f.cost));
  py::list bakes;
  for (const auto& b : f.bakes) bakes.append(b.name);
  d["bakes"] = bakes;
  return d;
}

py::dict slot_dict(const pipeline::Slot& s) {
  py::dict d;
  d["name"] = s.name;
  py::list formats;
  for (auto f : s.formats) formats.append(std::string(gpu::to_string(f)));
  d["formats"] = formats;
  d["frame_size"] = s.size == pipeline::SlotSize::Frame;
  d["optional"] = s.optional;
  d["same_as"] = s.same_as;
  d["meaning"] = s.meaning;
  return d;
}

py::dict pass_type_dict(const pipeline::PassTypeDescriptor& t) {
  py::dict d;
  d["name"] = t.name;
  d["summary"] = t.summary;
  d["doc"] = t.doc;
  py::list inputs, outputs, options;
  for (const auto& s : t.inputs) inputs.append(slot_dict(s));
  for (const auto& s : t.outputs) outputs.append(slot_dict(s));
  for (const auto& o : t.options) {
    py::dict od;
    od["name"] = o.name;
    od["kind"] = o.kind == KnobKind::Integer  ? "integer"
                 : o.kind == KnobKind::Number ? "number"
                 : o.kind == KnobKind::Boolean ? "boolean"
                                               : "choice";
    if (o.kind == KnobKind::Integer || o.kind == KnobKind::Number) {
      od["min"] = o.min;
      od["max"] = o.max;
    }
    if (o.kind == KnobKind::Choice) od["choices"] = o.choices;
    od["default"] = from_json(o.default_value);
    od["meaning"] = o.meaning;
    options.append(od);
  }
  d["inputs"] = inputs;
  d["outputs"] = outputs;
  d["options"] = options;
  return d;
}

const FeatureDescriptor& feature_named(const std::string& name) { return *unwrap(feature_registry().get(name)); }

}  // namespace

void bind_images(py::module_& m) {
  m.def("load_image", &load_image, py::arg("path"),
        R"(load_image(path) -> numpy.ndarray

Reads an image file with weft.image: .png/.jpg/.bmp as uint8 (height, width, channels),
sRGB-encoded as stored; .exr/.hdr as float32 (height, width, channels), linear.
Raises FileNotFoundError for a missing file, ValueError for a corrupt one.)");
  m.def("save_image", &save_image, py::arg("path"), py::arg("pixels"),
        R"(save_image(path, pixels) -> None

Writes an array with weft.image. uint8 (height, width[, channels]) pixels go to .png or .jpg
as they are (weft.save_image of a render writes the same bytes as `weft render -o x.png`);
float32 pixels go to .exr/.hdr as they are, or to .png sRGB-encoded. The file is written to
path + '.tmp' and renamed, so a failed save leaves nothing half-written.)");
  m.def(
      "srgb_to_linear",
      [](const py::array& pixels) { return image_to_array(image::from_srgb8(array_to_image8(pixels, "srgb_to_linear"))); },
      py::arg("pixels"),
      R"(srgb_to_linear(pixels) -> numpy.ndarray

uint8 sRGB pixels (height, width[, channels]) to float32 linear values in [0, 1] (alpha c/255),
weft.image's exact sRGB curve.)");
  m.def(
      "linear_to_srgb",
      [](const py::array& pixels, float exposure) {
        return image_to_array(image::to_srgb8(array_to_image(pixels, "linear_to_srgb"), exposure));
      },
      py::arg("pixels"), py::arg("exposure") = 1.0f,
      R"(linear_to_srgb(pixels, exposure=1.0) -> numpy.ndarray

float linear pixels times `exposure`, clamped to [0, 1] and sRGB-encoded to uint8 (alpha is
clamped and rounded, never encoded).)");

  const auto float_pair = [](const py::array& a, const py::array& b, const char* what) {
    return std::pair{array_to_image(a, what), array_to_image(b, what)};
  };
  m.def(
      "rmse",
      [float_pair](const py::array& a, const py::array& b) {
        auto [x, y] = float_pair(a, b, "rmse");
        return unwrap(image::rmse(x, y));
      },
      py::arg("a"), py::arg("b"),
      R"(rmse(a, b) -> float

Root mean square difference over every sample of two images of the same shape
(height, width[, channels]), taken as float values (pass linear float32 for radiometric error).
ValueError for different shapes or NaN/infinite pixels.)");
  m.def(
      "psnr",
      [float_pair](const py::array& a, const py::array& b, double peak) {
        auto [x, y] = float_pair(a, b, "psnr");
        return unwrap(image::psnr(x, y, peak));
      },
      py::arg("a"), py::arg("b"), py::arg("peak") = 1.0,
      R"(psnr(a, b, peak=1.0) -> float

10 log10(peak^2 / MSE) in dB over float images of the same shape; inf when identical.)");
  m.def(
      "ssim",
      [float_pair](const py::array& a, const py::array& b, double dynamic_range) {
        auto [x, y] = float_pair(a, b, "ssim");
        return unwrap(image::ssim(x, y, dynamic_range));
      },
      py::arg("a"), py::arg("b"), py::arg("dynamic_range") = 1.0,
      R"(ssim(a, b, dynamic_range=1.0) -> float

Mean SSIM (Wang et al. 2004) of the luminance of two float images of the same shape: 11x11
Gaussian window, sigma 1.5, valid windows only.)");
  m.def(
      "max_abs_diff",
      [float_pair](const py::array& a, const py::array& b) {
        auto [x, y] = float_pair(a, b, "max_abs_diff");
        return unwrap(image::max_abs_diff(x, y));
      },
      py::arg("a"), py::arg("b"), R"(max_abs_diff(a, b) -> float

Largest |a - b| over every sample of two float images of the same shape.)");
}

void bind_registry(py::module_& m) {
  m.def(
      "features",
      [] {
        py::list out;
        for (const FeatureDescriptor* f : feature_registry().all()) out.append(feature_dict(*f));
        return out;
      },
      R"(features() -> list[dict]

Every registered feature (weft's four and any plugin's), in registration order, from the
feature registry: name, aliases, summary, doc, passes (its graph passes), knobs (see knobs()),
presets ({'low': {knob: value}, ...}: what each quality gives), reference (the knob values of
its most accurate setting), reference_why, cost ('frame' or 'cold frame'), bakes.)");
  m.def(
      "feature", [](const std::string& name) { return feature_dict(feature_named(name)); }, py::arg("name"),
      R"(feature(name) -> dict

One feature by name or alias ('shell_fur' or 'fur'), as features() lists it. ValueError naming
the registered features when there is none of that name.)");
  m.def(
      "knobs",
      [](const std::string& name) {
        py::list out;
        for (const auto& k : feature_named(name).knobs) out.append(knob_dict(k));
        return out;
      },
      py::arg("feature"),
      R"(knobs(feature) -> list[dict]

A feature's quality knobs from the registry's knob table: name (the material field; '.'
descends into objects, e.g. 'lut.size'), kind ('integer', 'number', 'boolean', 'choice'),
min/max (inclusive, numbers) or choices, sweep (the values `weft tradeoff` tries), meaning.)");
  m.def(
      "presets",
      [](const std::string& name) {
        const FeatureDescriptor& f = feature_named(name);
        py::dict presets;
        if (f.preset_values)
          for (Quality q : {Quality::Low, Quality::Medium, Quality::High, Quality::Reference})
            presets[py::str(std::string(to_string(q)))] = from_json(f.preset_values(q));
        return presets;
      },
      py::arg("feature"),
      R"(presets(feature) -> dict

The knob values each quality ('low', 'medium', 'high', 'reference') gives a feature's materials
that leave those knobs unset; {} for a feature whose knobs do not follow the quality.)");
  m.def(
      "reference", [](const std::string& name) { return from_json(feature_named(name).reference); }, py::arg("feature"),
      R"(reference(feature) -> dict

The knob values of a feature's reference setting: slow, as exact as weft can make it; what
`weft tradeoff` measures error against.)");
  m.def(
      "pass_types",
      [] {
        py::list out;
        for (const auto* t : pipeline::pass_type_registry().all()) out.append(pass_type_dict(*t));
        return out;
      },
      R"(pass_types() -> list[dict]

Every registered pass type a pipeline can name: name, summary, doc, inputs and outputs (slots:
name, formats, frame_size, optional, same_as, meaning) and options (name, kind, min/max or
choices, default, meaning).)");
  m.def(
      "load_plugin",
      [](const std::filesystem::path& path) {
        const auto loaded = unwrap(pipeline::load_plugin(path));
        py::dict d;
        d["path"] = loaded.path;
        d["pass_types"] = loaded.pass_types;
        d["features"] = loaded.features;
        return d;
      },
      py::arg("path"),
      R"(load_plugin(path) -> dict

Loads a weft plugin (a shared library with a WEFT_PLUGIN entry point) and registers its pass
types and features with this process's registries, as `weft --plugin` does. Returns what it
registered: {'path', 'pass_types', 'features'}. Loading the same file again is a no-op.
ValueError/RuntimeError with weft's message when it cannot be loaded.)");
}

}  // namespace weft::python

using namespace weft::python;

namespace {
py::object& not_found_error() {
  static py::object* type = new py::object();  // leaked: lives as long as the interpreter
  return *type;
}
}  // namespace

PYBIND11_MODULE(weft, m) {
  m.doc() = R"(weft: a real-time render-graph engine (Vulkan; lavapipe on machines without a GPU), from Python.

  weft.adapters()                          the Vulkan adapters
  r = weft.Renderer()                      a renderer on its own device (WEFT_ADAPTER picks it)
  s = weft.load_scene("examples/scenes/default.json")   or weft.Scene.from_dict({...}), weft.Scene()
  s.materials["fur"]["layers"] = 32        a knob, checked against the feature registry's range
  img = r.render(s, size=(320, 240), quality="medium")  uint8 (h, w, 4) sRGB, as `weft render -o x.png`
  hdr = r.render(s, output="hdr")          float32 linear scene colour, as `weft render -o x.exr`
  d = r.render(s, output="shadow_map.depth")  any pass slot or texture of the frame, float32
  f = r.render_frame(s, outputs=[...])     image, hdr, outputs, per-pass stats, passes, warnings
  rows = weft.tradeoff(s, "shell_fur")     the speed/accuracy study, the rows `weft tradeoff` writes

Errors carry weft's one-line messages: ValueError (bad arguments, scene and pipeline problems
with their JSON paths, graph errors), FileNotFoundError, OSError, RuntimeError (device).
Rendering releases the GIL: renderers in different threads render at the same time (each
renderer is used by one thread at a time; renderers sharing a Device take turns on it).
See docs/python.md.)";

  // weft's NotFound is a missing file or a missing named thing (an adapter, a resource of the
  // frame, a feature): both FileNotFoundError and LookupError catch it.
  {
    py::dict scope;
    py::exec(R"(
class NotFoundError(FileNotFoundError, LookupError):
    """weft could not find a file or a named thing (adapter, resource, feature): weft's NotFound."""
    __module__ = "weft"
)",
             py::globals(), scope);
    m.attr("NotFoundError") = scope["NotFoundError"];
    not_found_error() = scope["NotFoundError"];
  }
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const WeftError& e) {
      const std::string message = e.error.what();
      switch (e.error.kind) {
        case weft::ErrorKind::InvalidArgument:
        case weft::ErrorKind::Parse:
        case weft::ErrorKind::Graph:
        case weft::ErrorKind::Unsupported: PyErr_SetString(PyExc_ValueError, message.c_str()); return;
        case weft::ErrorKind::NotFound: PyErr_SetString(not_found_error().ptr(), message.c_str()); return;
        case weft::ErrorKind::Io: PyErr_SetString(PyExc_OSError, message.c_str()); return;
        default: PyErr_SetString(PyExc_RuntimeError, message.c_str()); return;
      }
    }
  });

  unwrap(weft::register_builtins());
  for (const auto& w : weft::pipeline::load_plugins_from_environment()) weft::log::warn(w);

  bind_images(m);
  bind_registry(m);
  bind_scene(m);
  bind_render(m);
  bind_study(m);
}
