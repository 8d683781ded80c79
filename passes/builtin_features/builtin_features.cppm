// weft.builtin_features — the calls that register weft's own pass types (shadow_map,
// scene_color, background, tonemap, and the standard post-processing and debug passes) and
// features (shell_fur, skin_sss, neural_btf, ssdf_lighting) with the registries. The `weft`
// tool, the tests and the examples call register_builtins(); an application that links fewer
// registers their descriptors itself. Feature order is the order they draw into the frame.
module;
#include <expected>
export module weft.builtin_features;
import weft.core;

export namespace weft {

// Each is idempotent: a second call changes nothing.
[[nodiscard]] Result<void> register_builtin_features();
[[nodiscard]] Result<void> register_builtin_pass_types();
// Both of the above: everything the default pipeline and the shipped scenes name.
[[nodiscard]] Result<void> register_builtins();

}  // namespace weft
