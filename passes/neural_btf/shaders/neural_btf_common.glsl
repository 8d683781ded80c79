// Shared by neural_btf.vert and neural_btf.frag: the bindings and the per-draw constants
// (weft::passes NeuralBtfConstants, 112 bytes).
#ifndef WEFT_NEURAL_BTF_COMMON_GLSL
#define WEFT_NEURAL_BTF_COMMON_GLSL
layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
layout(set = 0, binding = 1) uniform sampler2DShadow shadow_map;  // comparison, PCF

layout(push_constant) uniform Draw {
  mat4 model;
  vec4 uv_scale;  // xy tiling of the texel grid over the mesh UVs, z flags, w exposure
  vec4 tint;      // rgb multiplies the decoded colour
  vec4 debug;     // x debug view
} draw;

const int FLAG_AMBIENT = 1;   // one more decode at ω_i = n, times the SH irradiance
const int FLAG_BILINEAR = 2;  // four texels decoded and blended (smooth magnification)
const int FLAG_SHADOW = 4;    // the key light's shadow map

const int DEBUG_NONE = 0;
const int DEBUG_TEXEL = 1;    // the texel grid (a hash colour per texel)
const int DEBUG_UV = 2;       // the wrapped texel coordinate
const int DEBUG_FRAME = 3;    // ω_o in the tangent frame, as colour
#endif
