// weft.builtin_features — the one call that registers weft's own features (shell_fur,
// skin_sss, neural_btf, ssdf_lighting) with weft::feature_registry(). The `weft` tool, the
// tests and the examples call it; an application that links fewer features registers
// their descriptors itself. The order is the order their passes draw into the frame.
module;
#include <expected>
export module weft.builtin_features;
import weft.core;

export namespace weft {

// Idempotent: a second call changes nothing.
[[nodiscard]] Result<void> register_builtin_features();

}  // namespace weft
