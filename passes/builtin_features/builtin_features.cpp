module;
#include <expected>
#include <weft/try.h>
module weft.builtin_features;
import weft.feature;
import weft.pipeline;
import weft.base_pass.shadow;
import weft.base_pass.forward;
import weft.base_pass.background;
import weft.base_pass.tonemap;
import weft.base_pass.bloom;
import weft.base_pass.outline;
import weft.base_pass.fxaa;
import weft.base_pass.accumulate;
import weft.base_pass.taa;
import weft.base_pass.debug_view;
import weft.pass.shell_fur;
import weft.pass.skin_sss;
import weft.pass.neural_btf;
import weft.pass.ssdf_lighting;

namespace weft {

Result<void> register_builtin_features() {
  for (const FeatureDescriptor* d : {&passes::shell_fur_feature(), &passes::skin_sss_feature(),
                                     &passes::neural_btf_feature(), &passes::ssdf_lighting_feature()})
    WEFT_TRY_VOID(register_feature(*d));
  return {};
}

Result<void> register_builtin_pass_types() {
  for (const pipeline::PassTypeDescriptor* d : {&passes::shadow_map_pass_type(), &passes::scene_color_pass_type(),
                                                &passes::background_pass_type(), &passes::tonemap_pass_type(),
                                                &passes::bloom_pass_type(), &passes::outline_pass_type(), &passes::fxaa_pass_type(), &passes::accumulate_pass_type(), &passes::taa_pass_type(),
                                                &passes::debug_view_pass_type()})
    WEFT_TRY_VOID(pipeline::register_pass_type(*d));
  return {};
}

Result<void> register_builtins() {
  WEFT_TRY_VOID(register_builtin_pass_types());
  return register_builtin_features();
}

}  // namespace weft
