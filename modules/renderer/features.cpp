// Which feature shades which material type. A feature is created only when a scene uses
// its material type, so a scene without fur never compiles fur shaders or bakes fur data.
// Each feature adds one line here (and its pass module to this folder's CMakeLists.txt).
module;
#include <expected>
#include <memory>
module weft.renderer;
import weft.core;
import weft.gpu;
import weft.feature;
import weft.scene;

namespace weft::renderer::detail {

FeatureFactory feature_factory(scene::MaterialType type) {
  switch (type) {
    default: return nullptr;
  }
}

}  // namespace weft::renderer::detail
