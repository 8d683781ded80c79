// The X11 handles behind a GLFW window. glfw3native.h would pull in Xlib and Xrandr's
// headers (and Xlib's macros, None and Bool among them); the two functions it declares are
// declared here instead, with Xlib's types spelled as Xlib defines them.
module;
#include <cstdint>
#include <GLFW/glfw3.h>
extern "C" {
struct _XDisplay;
_XDisplay* glfwGetX11Display(void);
unsigned long glfwGetX11Window(GLFWwindow* window);
}
module weft.viewer;
import weft.gpu;

namespace weft::viewer::detail {

gpu::NativeWindow native_window(GLFWwindow* window) {
  return {.x11_display = glfwGetX11Display(), .x11_window = std::uint64_t(glfwGetX11Window(window))};
}

}  // namespace weft::viewer::detail
