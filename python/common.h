// What the units of the `weft` Python module share. Included after each unit's includes and
// `import`s (it uses pybind11, nlohmann::json and weft's module types, and includes nothing).
#pragma once

namespace weft::python {

namespace py = pybind11;
using json = nlohmann::json;

// A weft Error crossing into Python: translated by the module's exception translator into
// ValueError (bad arguments, parse and graph errors, unsupported requests), FileNotFoundError
// (NotFound), OSError (Io) or RuntimeError (device, shader, internal), with weft's one-line
// message (error.what()).
struct WeftError {
  Error error;
};

template <class T>
T unwrap(Result<T>&& r) {
  if (!r) throw WeftError{std::move(r.error())};
  return std::move(*r);
}
inline void unwrap(Result<void>&& r) {
  if (!r) throw WeftError{std::move(r.error())};
}
[[noreturn]] inline void raise(ErrorKind kind, std::string message) { throw WeftError{Error{kind, std::move(message)}}; }

// Python values <-> JSON (dict, list, tuple, numpy arrays and scalars, str, bool, int, float, None).
json to_json(py::handle value);
py::object from_json(const json& value);

// A vector's storage handed to NumPy without a copy: the array owns it through a capsule.
template <class T>
py::array_t<T> adopt(std::vector<T>&& data, std::vector<py::ssize_t> shape) {
  auto* owned = new std::vector<T>(std::move(data));
  py::capsule owner(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, owned->data(), owner);
}
py::array image_to_array(image::Image8&& image);
py::array image_to_array(image::Image&& image);
image::Image8 array_to_image8(const py::handle& array, const char* what);
image::Image array_to_image(const py::handle& array, const char* what);

// A scene as Python holds it: the loaded scene::Scene and a lock, so a render in another
// thread (which reads it with the GIL released) never sees a half-made edit.
struct PyScene {
  scene::Scene scene;
  mutable std::shared_mutex mutex;
};

// A Vulkan instance, adapter and device. Renderers that share one take turns on it (`mutex`):
// a device's queue is not to be used from two threads at once.
struct PyDevice {
  gpu::Instance instance;
  gpu::Adapter adapter;
  gpu::Device device;
  std::mutex mutex;
};
std::shared_ptr<PyDevice> make_device(const std::string& adapter, std::optional<bool> validation);

Quality quality_argument(const std::string& name);
// (width, height) or None -> {0, 0} (the scene's size); ValueError naming the limit otherwise.
std::pair<std::uint32_t, std::uint32_t> size_argument(const py::object& size);

void bind_images(py::module_& m);
void bind_registry(py::module_& m);
void bind_scene(py::module_& m);
void bind_render(py::module_& m);
void bind_study(py::module_& m);

}  // namespace weft::python
