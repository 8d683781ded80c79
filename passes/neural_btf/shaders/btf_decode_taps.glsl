// The batched path's decode (docs/neural-btf.md, "The batched decode"): the pixels of one class
// that the list pass (btf_list_taps.comp) collected from the whole screen, decoded 256 rows per
// workgroup of 32 invocations (an indirect dispatch per class: only the GPU knows the lists'
// lengths). A class-c pixel takes 1 << c consecutive rows of one invocation, so every batch is
// full but a list's last, wherever the pixels are, and the invocation adds the pixel's taps in
// order (btf_pixel_taps.glsl) and writes its radiance. Each row reads its decode inputs from the
// G-buffer. The includer defines BTF_TILED_PAPER (the paper's shape: batched matrix products,
// btf_decode_tiled.glsl) or not (any shape: btf_decode per row).
layout(local_size_x = 32) in;
#define BTF_MODEL_SET 0
#define BTF_MODEL_BINDING 0
#include "btf_decode.glsl"
#ifdef BTF_TILED_PAPER
#include "btf_decode_tiled.glsl"
#else
#define BTF_T_ROWS 8u
#endif
layout(set = 0, binding = 1) uniform sampler2D g_coords;   // st.xy, so.xy
layout(set = 0, binding = 2) uniform sampler2D g_light;    // si.xy, light weight .rg
layout(set = 0, binding = 3) uniform sampler2D g_weights;  // light weight .b, ambient weight .rgb
layout(set = 0, binding = 4) uniform sampler2D g_marker;   // r: marker
layout(std430, set = 0, binding = 5) readonly buffer Counts { uint count[]; };
layout(std430, set = 0, binding = 6) readonly buffer List { uint list[]; };
layout(std430, set = 0, binding = 7) writeonly buffer Radiance { float radiance[]; };
layout(push_constant) uniform Push {
  uvec2 size;
  uint model;
  uint tap_class;  // c: this dispatch's pixels take 1 << c rows each
} push;
#include "btf_taps.glsl"
#include "btf_pixel_taps.glsl"

const uint LANES = 32u;

// Row j of pixel `pixel`'s taps: its BTF texel, directions (stereographic ω_i, ω_o) and weight.
uint tap_inputs(uint pixel, uint j, uvec2 grid, out vec4 dirs, out vec3 weight) {
  ivec2 px = ivec2(pixel % push.size.x, pixel / push.size.x);
  vec4 coords = texelFetch(g_coords, px, 0);
  vec4 light = texelFetch(g_light, px, 0);
  uint tap = nth_tap(pixel_tap_mask(px), j), term = tap >> 2;
  float tap_weight;
  uint texel = btf_tap(coords.xy, grid, pixel_bilinear(px), tap & 3u, tap_weight);
  weight = term_weight(px, term) * tap_weight;
  dirs = vec4(term == 0u ? light.xy : vec2(0.0), coords.zw);
  return texel;
}

void main() {
  uint c = push.tap_class, taps = 1u << c, per_lane = BTF_T_ROWS >> c;
  uint pixels = push.size.x * push.size.y;
  uint n = count[push.model * BTF_CLASSES + c];
  // The invocation's k-th pixel is entry first + LANES k of the class's list; row r is tap r % taps of pixel r / taps.
  uint first = gl_WorkGroupID.x * LANES * per_lane + gl_LocalInvocationIndex;
  uvec2 grid = btf_model.shape.zw;
  uint texel[BTF_T_ROWS];
  vec4 dirs[BTF_T_ROWS];
  [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) {
    // Pixels past the list's end decode a copy of its last (control flow stays uniform) and store nothing.
    uint pixel = list[list_index(c, min(first + LANES * (r >> c), n - 1u), pixels)];
    vec3 unused;
    texel[r] = tap_inputs(pixel, r & (taps - 1u), grid, dirs[r], unused);
  }
  vec3 rgb[BTF_T_ROWS];
#ifdef BTF_TILED_PAPER
  btf_decode_tiled(texel, dirs, rgb);
#else
  // One inlined copy of the decoder (each copy is thousands of instructions for LLVM).
  [[dont_unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) rgb[r] = btf_decode(texel[r], dirs[r].xy, dirs[r].zw);
#endif
  // The weights are fetched again rather than kept live across the decode, which wants every register.
  for (uint k = 0u; k < per_lane; ++k) {
    if (first + LANES * k >= n) break;
    uint pixel = list[list_index(c, first + LANES * k, pixels)];
    vec3 sum = vec3(0.0);
    for (uint j = 0u; j < taps; ++j) {
      vec4 unused;
      vec3 weight;
      tap_inputs(pixel, j, grid, unused, weight);
      sum += rgb[k * taps + j] * weight;
    }
    radiance[3u * pixel] = sum.r;
    radiance[3u * pixel + 1u] = sum.g;
    radiance[3u * pixel + 2u] = sum.b;
  }
}
