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
#include "neural_btf_surface.glsl"
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec4 world_tangent;
layout(location = 3) in vec2 uv;
layout(location = 0) out vec4 out_color;

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
  for (uint k = 0u; k < (bilinear ? 4u : 1u); ++k) {
    float w;
    tap_texel[tap_count] = btf_tap(st, grid, bilinear, k, w);
    tap_si[tap_count] = si;
    tap_weight[tap_count] = weight * w;
    ++tap_count;
  }
}

void main() {
  int flags = int(draw.uv_scale.z + 0.5);
  int debug_view = int(draw.debug.x + 0.5);
  BtfSurface surface = btf_surface(world_position, world_normal, world_tangent, uv, flags);
  uvec2 grid = BTF_GRID;
  vec2 st = surface.st;
  bool bilinear = (flags & FLAG_BILINEAR) != 0;
  if (surface.light_weight != vec3(0.0)) add_taps(st, grid, bilinear, surface.si, surface.light_weight);
  if (surface.ambient_weight != vec3(0.0)) add_taps(st, grid, bilinear, vec2(0.0), surface.ambient_weight);
  vec3 color = vec3(0.0);
  [[dont_unroll]] for (uint i = 0u; i < tap_count; ++i)
    color += BTF_EVALUATE(tap_texel[i], tap_si[i], surface.so) * tap_weight[i];
  color *= draw.tint.rgb * draw.uv_scale.w;
  if (debug_view == DEBUG_TEXEL) color = hash_colour(texel_at(ivec2(floor(st)), grid));
  else if (debug_view == DEBUG_UV) color = vec3(fract(st / vec2(grid)), 0.0);
  else if (debug_view == DEBUG_FRAME) color = surface.wo * 0.5 + 0.5;
  out_color = vec4(color, 1.0);
}
