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
import weft.pass.skin_sss;
import weft.pass.shell_fur;
import weft.pass.ssdf_lighting;
import weft.pass.neural_btf;

namespace weft::renderer::detail {

FeatureFactory feature_factory(scene::MaterialType type) {
  switch (type) {
    case scene::MaterialType::Fur: return &passes::create_shell_fur_feature;
    case scene::MaterialType::Skin: return &passes::create_skin_feature;
    case scene::MaterialType::NeuralBtf: return &passes::create_neural_btf_feature;
    case scene::MaterialType::Ssdf: return &passes::create_ssdf_feature;
    default: return nullptr;
  }
}

}  // namespace weft::renderer::detail
