// What a neural BTF surface point needs from the rasteriser before any decode, shared by the
// fragment-shader decoder (neural_btf_fragment.glsl) and the batched path's geometry pass
// (neural_btf_gbuffer.frag) so that both feed the decoder the same numbers: the tangent frame,
// ω_i and ω_o in it (stereographic), the texel coordinate, and what each term's decodes are
// weighted by. Also the texel taps (nearest, or bilinear's four) that both paths decode.
// The includer includes frame.glsl, neural_btf_common.glsl and btf_decode.glsl (or
// btf_reference.glsl with BTF_GRID defined) first.
#ifndef WEFT_NEURAL_BTF_SURFACE_GLSL
#define WEFT_NEURAL_BTF_SURFACE_GLSL
#ifndef BTF_GRID
#define BTF_GRID btf_model.shape.zw
#endif

float shadow_factor(vec3 p, vec3 n) {
  vec4 clip = frame.light_view_projection * vec4(p + n * 0.002, 1.0);
  vec3 ndc = clip.xyz / clip.w;
  vec2 suv = ndc.xy * 0.5 + 0.5;
  if (any(lessThan(suv, vec2(0.0))) || any(greaterThan(suv, vec2(1.0))) || ndc.z > 1.0) return 1.0;
  vec2 texel = 1.0 / vec2(textureSize(shadow_map, 0));
  float lit = 0.0;
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) lit += texture(shadow_map, vec3(suv + vec2(x, y) * texel, ndc.z));
  return lit / 9.0;
}

struct BtfSurface {
  vec3 wo;              // ω_o in the tangent frame (z clamped onto the horizon)
  vec2 so;              // stereographic ω_o
  vec2 si;              // stereographic ω_i of the key light
  vec2 st;              // texel coordinate: uv * uv_scale * (width, height), not wrapped
  vec3 light_weight;    // key light * shadow; 0: no key-light decode
  vec3 ambient_weight;  // SH irradiance at n; 0: no ambient decode
};

// world_position, world_normal, world_tangent: the interpolated vertex outputs.
BtfSurface btf_surface(vec3 world_position, vec3 world_normal, vec4 world_tangent, vec2 uv, int flags) {
  // Two-sided by winding, as the skin pass: the back of a cloth shows its own texels.
  vec3 n = normalize(world_normal);
  if (!gl_FrontFacing) n = -n;
  vec3 t = world_tangent.xyz - n * dot(n, world_tangent.xyz);
  float tl = length(t);
  if (tl > 1e-8) {
    t /= tl;
  } else {  // no usable tangent: any perpendicular keeps the frame orthonormal
    t = normalize(abs(n.x) < 0.9 ? cross(n, vec3(1, 0, 0)) : cross(n, vec3(0, 1, 0)));
  }
  // Along +v, the BTF's texel rows (the mesh's bitangent w * cross(n, t) points to -v, glTF's rule).
  vec3 b = -cross(n, t) * (world_tangent.w < 0.0 ? -1.0 : 1.0);

  vec3 v = normalize(frame.camera_position.xyz - world_position);
  vec3 l = normalize(frame.light_direction.xyz);
  BtfSurface s;
  s.wo = vec3(dot(v, t), dot(v, b), dot(v, n));
  s.wo.z = max(s.wo.z, 0.0);  // silhouettes of interpolated normals: clamp onto the horizon
  vec3 wi = vec3(dot(l, t), dot(l, b), dot(l, n));
  s.so = btf_stereographic(s.wo);
  s.si = btf_stereographic(wi);
  s.st = uv * draw.uv_scale.xy * vec2(BTF_GRID);
  s.light_weight = vec3(0.0);
  if (wi.z > 0.0 && frame.light_color.rgb != vec3(0.0)) {
    float shadow = (flags & FLAG_SHADOW) != 0 ? shadow_factor(world_position, n) : 1.0;
    if (shadow > 0.0) s.light_weight = frame.light_color.rgb * shadow;
  }
  s.ambient_weight = vec3(0.0);
  if ((flags & FLAG_AMBIENT) != 0) s.ambient_weight = evaluate_irradiance_sh(frame.irradiance_sh, n) * frame.environment.x;
  return s;
}

#include "btf_taps.glsl"

#endif
