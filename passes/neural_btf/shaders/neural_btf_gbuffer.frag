#version 460
#extension GL_GOOGLE_include_directive : require
// The batched material path's geometry pass: instead of decoding, each visible neural BTF
// pixel writes its decode inputs (neural_btf_surface.glsl, the numbers the fragment-shader
// decoder would use) into the G-buffer; btf_decode_tiles.comp decodes them. Later fragments
// that win the depth test overwrite earlier ones, so only what is visible is decoded.
#include "frame.glsl"
#include "neural_btf_common.glsl"
#define BTF_MODEL_SET 1
#define BTF_MODEL_BINDING 0
#include "btf_decode.glsl"
#include "neural_btf_surface.glsl"
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec4 world_tangent;
layout(location = 3) in vec2 uv;
// Twelve fp32 numbers without gaps, and the marker (pass.cpp's gbuffer_formats):
layout(location = 0) out vec4 g_coords;   // st.xy, so.xy
layout(location = 1) out vec4 g_light;    // si.xy, light weight .rg (key light * shadow * tint * exposure)
layout(location = 2) out vec4 g_weights;  // light weight .b, ambient weight .rgb (SH irradiance * tint * exposure)
layout(location = 3) out vec4 g_marker;   // r: draw.debug.y, 2 * model + bilinear + 1 (0: no BTF pixel)
void main() {
  int flags = int(draw.uv_scale.z + 0.5);
  BtfSurface s = btf_surface(world_position, world_normal, world_tangent, uv, flags);
  vec3 tint = draw.tint.rgb * draw.uv_scale.w;
  vec3 light_weight = s.light_weight * tint, ambient_weight = s.ambient_weight * tint;
  g_coords = vec4(s.st, s.so);
  g_light = vec4(s.si, light_weight.rg);
  g_weights = vec4(light_weight.b, ambient_weight);
  g_marker = vec4(draw.debug.y, 0.0, 0.0, 0.0);
}
