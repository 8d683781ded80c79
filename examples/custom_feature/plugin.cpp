// The toon feature as a weft plugin: the material type "toon" (its knob table, presets and
// FeaturePass), registered when weft loads the library:
//   weft --plugin libweft_toon_plugin.so render examples/custom_feature/scenes/toon.json -o toon.png
// Built out of tree against the installed weft (plugin/CMakeLists.txt) from the same toon/
// folder the example program links; nothing of weft is rebuilt to add a material.
module;
#include <weft/plugin.h>  // WEFT_PLUGIN: macros only, so the global fragment is its place
module custom.toon;
import weft.feature;
import weft.pipeline;

namespace custom {
namespace {
void register_toon(weft::pipeline::PluginRegistrar& registrar) { registrar.add_feature(toon_feature()); }
}  // namespace
}  // namespace custom

WEFT_PLUGIN(custom::register_toon)
