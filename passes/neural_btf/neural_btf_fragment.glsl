// NeuralBTFMaterial: the neural BTF decoder per fragment. ω_i (the key light) and ω_o (the
// camera) go into the surface's tangent frame (the mesh's tangents, Gram-Schmidt against the
// interpolated normal), through the stereographic projection, into the MLP with the texel's
// latent. The decoded value is the texel's reflected radiance per unit irradiance at normal
// incidence (an "apparent BRDF": cos θ_i included, as in measured BTFs), so the key light
// adds decode(ω_i, ω_o) * light_color * shadow. The optional ambient term decodes once more
// with ω_i = n and multiplies by the environment's SH irradiance: exact for a Lambertian
// texel (a/π * E), an approximation for anything glossier.
#include "frame.glsl"
#include "neural_btf_common.glsl"
#define BTF_MODEL_SET 1
#define BTF_MODEL_BINDING 0
#ifdef BTF_REFERENCE  // the raw BTF in place of the decoder (neural_btf_reference.frag)
#include "btf_reference.glsl"
#define BTF_GRID btf_reference_grid()
#define BTF_EVALUATE(texel, si, so) btf_reference(texel, si, so)
#else
#include "btf_decode.glsl"
#define BTF_GRID btf_model.shape.zw
#define BTF_EVALUATE(texel, si, so) btf_decode(texel, si, so)
#endif
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec4 world_tangent;
layout(location = 3) in vec2 uv;
layout(location = 0) out vec4 out_color;

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

// Texel (x, y) covers [x, x + 1) x [y, y + 1) of uv * uv_scale * (width, height), wrapped.
uint texel_at(ivec2 xy, uvec2 grid) {
  ivec2 g = ivec2(grid);
  ivec2 w = ((xy % g) + g) % g;
  return uint(w.y) * grid.x + uint(w.x);
}

vec3 hash_colour(uint x) {
  x = (x ^ 61u) ^ (x >> 16);
  x *= 9u;
  x ^= x >> 4;
  x *= 0x27d4eb2du;
  x ^= x >> 15;
  return vec3(x & 255u, (x >> 8) & 255u, (x >> 16) & 255u) / 255.0;
}

// The decodes a fragment needs (up to four texels for each of the key light and the ambient
// term) are gathered first and run in one loop with ONE call of btf_decode: every inlined copy
// of the decoder is thousands of instructions, and ten copies (two terms, four bilinear taps
// each, plus the nearest-texel paths) take LLVM in lavapipe minutes to compile.
const uint MAX_TAPS = 8;
uint tap_texel[MAX_TAPS];
vec2 tap_si[MAX_TAPS];
vec3 tap_weight[MAX_TAPS];
uint tap_count = 0u;

void add_taps(vec2 st, uvec2 grid, bool bilinear, vec2 si, vec3 weight) {
  if (!bilinear) {
    tap_texel[tap_count] = texel_at(ivec2(floor(st)), grid);
    tap_si[tap_count] = si;
    tap_weight[tap_count] = weight;
    ++tap_count;
    return;
  }
  vec2 p = st - 0.5;
  ivec2 i0 = ivec2(floor(p));
  vec2 f = p - vec2(i0);
  for (int k = 0; k < 4; ++k) {
    ivec2 o = ivec2(k & 1, k >> 1);
    vec2 w2 = mix(1.0 - f, f, vec2(o));
    tap_texel[tap_count] = texel_at(i0 + o, grid);
    tap_si[tap_count] = si;
    tap_weight[tap_count] = weight * (w2.x * w2.y);
    ++tap_count;
  }
}

void main() {
  int flags = int(draw.uv_scale.z + 0.5);
  int debug_view = int(draw.debug.x + 0.5);
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
  vec3 wo = vec3(dot(v, t), dot(v, b), dot(v, n));
  wo.z = max(wo.z, 0.0);  // silhouettes of interpolated normals: clamp onto the horizon
  vec3 wi = vec3(dot(l, t), dot(l, b), dot(l, n));
  vec2 so = btf_stereographic(wo);

  uvec2 grid = BTF_GRID;
  vec2 st = uv * draw.uv_scale.xy * vec2(grid);
  bool bilinear = (flags & FLAG_BILINEAR) != 0;

  if (wi.z > 0.0 && frame.light_color.rgb != vec3(0.0)) {
    float shadow = (flags & FLAG_SHADOW) != 0 ? shadow_factor(world_position, n) : 1.0;
    if (shadow > 0.0) add_taps(st, grid, bilinear, btf_stereographic(wi), frame.light_color.rgb * shadow);
  }
  if ((flags & FLAG_AMBIENT) != 0) {
    vec3 irradiance = evaluate_irradiance_sh(frame.irradiance_sh, n) * frame.environment.x;
    if (irradiance != vec3(0.0)) add_taps(st, grid, bilinear, vec2(0.0), irradiance);
  }
  vec3 color = vec3(0.0);
  [[dont_unroll]] for (uint i = 0u; i < tap_count; ++i)
    color += BTF_EVALUATE(tap_texel[i], tap_si[i], so) * tap_weight[i];
  color *= draw.tint.rgb * draw.uv_scale.w;
  if (debug_view == DEBUG_TEXEL) color = hash_colour(texel_at(ivec2(floor(st)), grid));
  else if (debug_view == DEBUG_UV) color = vec3(fract(st / vec2(grid)), 0.0);
  else if (debug_view == DEBUG_FRAME) color = wo * 0.5 + 0.5;
  out_color = vec4(color, 1.0);
}
