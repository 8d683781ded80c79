// Shared by skin.vert and skin.frag: the bindings and the per-draw constants
// (weft::passes SkinConstants, 128 bytes).
#ifndef WEFT_SKIN_COMMON_GLSL
#define WEFT_SKIN_COMMON_GLSL
layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
layout(set = 0, binding = 1) uniform sampler2DShadow shadow_map;   // comparison, PCF
layout(set = 0, binding = 2) uniform sampler2D shadow_depth;       // raw depth, for thickness
layout(set = 0, binding = 3) uniform sampler2D environment_map;
layout(set = 1, binding = 0) uniform sampler2D skin_lut;           // rgb D(N·L, 1/r), a Beckmann
layout(set = 1, binding = 1) uniform sampler2D albedo_map;         // sRGB texture (linear reads)
layout(set = 1, binding = 2) uniform sampler2D normal_map;         // tangent space
layout(set = 1, binding = 3) uniform sampler2D specular_map;       // grey, linear: R multiplies rho_s
layout(set = 2, binding = 0) readonly buffer Reference { vec4 reference_diffuse[]; };  // per vertex

layout(push_constant) uniform Draw {
  mat4 model;
  vec4 albedo_specular;  // rgb albedo, a rho_s
  vec4 params;           // x Beckmann m, y 1 / object scale (mesh curvature -> world), z world curvature -> LUT v,
                         // w mm per world unit
  vec4 normal_blur;      // rgb: weight of the geometric normal per channel, a detail strength
  vec4 transmit;         // x thickness scale (0: off), y shrink (world units), z flags + 32 * debug view,
                         // w shadow scatter distance (world units)
} draw;

const int FLAG_ALBEDO_MAP = 1;
const int FLAG_NORMAL_MAP = 2;
const int FLAG_SCREEN_CURVATURE = 4;
const int FLAG_REFERENCE = 8;  // brute-force diffuse per vertex instead of the LUT
const int FLAG_SPECULAR_MAP = 16;

const int DEBUG_NONE = 0;
const int DEBUG_CURVATURE = 1;
const int DEBUG_DIFFUSE = 2;
const int DEBUG_TRANSMITTANCE = 3;
const int DEBUG_THICKNESS = 4;
#endif
