module;
#include <expected>
#include <weft/try.h>
module weft.builtin_features;
import weft.feature;
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

}  // namespace weft
