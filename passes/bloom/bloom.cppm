// weft.base_pass.bloom — physically based bloom on the linear HDR colour (Jimenez 2014, as in
// Call of Duty and Unreal): no threshold; a chain of half-size levels made with a 13-tap
// filter, summed back up with 3x3 tents, and mixed with the colour by `intensity`. Every step
// is normalised, so the frame's energy is kept (tests/passes/test_post_passes.cpp measures it).
module;
export module weft.base_pass.bloom;
import weft.pipeline;

export namespace weft::passes {

// The pass type (registered by weft::register_builtins()).
const pipeline::PassTypeDescriptor& bloom_pass_type();

}  // namespace weft::passes
