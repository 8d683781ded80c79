// The batched material path's decode (NeuralBTFMaterial, docs/neural-btf.md "The batched
// decode"): one workgroup of 32 invocations per 16 x 16 tile of the screen. The geometry pass
// left, per visible neural BTF pixel, its decode inputs in the G-buffer
// (neural_btf_gbuffer.frag); this kernel lists the tile's (pixel, tap) pairs of one model that
// need a decode (taps: the key light and the ambient term; four texels each when bilinear, in
// two groups of four), decodes them in batches of 256 rows (btf_decode_tiled.glsl), and writes
// each pixel's weighted sum, in the fragment path's order, to the radiance buffer, which
// neural_btf_resolve.frag composites into the scene colour. Only pixels that survived the depth
// test are decoded (no overdraw), each tap once. The includer defines BTF_TILED_PAPER (the
// paper's shape, batched) or not (any shape: btf_decode per row, same structure).
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
layout(set = 0, binding = 2) uniform sampler2D g_light;    // si.xy, marker (0: none; 2 * model + bilinear + 1)
layout(set = 0, binding = 3) uniform sampler2D g_light_weight;    // rgb: key light * shadow * tint * exposure
layout(set = 0, binding = 4) uniform sampler2D g_ambient_weight;  // rgb: irradiance * tint * exposure
layout(std430, set = 0, binding = 5) writeonly buffer Radiance { vec4 radiance[]; };
layout(push_constant) uniform Push {
  uvec2 size;   // the frame
  uint model;   // which model's pixels this dispatch decodes
} push;

const uint TILE = 16u, TILE_PIXELS = TILE * TILE, LANES = 32u, PER_LANE = TILE_PIXELS / LANES;
const uint BATCH = LANES * BTF_T_ROWS;  // 256 rows
shared uint tile_flags;                 // 1: some pixel of this model; 2: some bilinear one
shared uint tile_count;
shared uint tile_list[4u * TILE_PIXELS];  // (pixel | tap << 8) pairs of the current group
shared vec3 tile_tap[4u * TILE_PIXELS];   // each pair's weighted decode, by tap and pixel
shared vec3 tile_rgb[TILE_PIXELS];

#include "btf_taps.glsl"

// What term 0 (the key light) or 1 (the ambient) of a pixel's decodes is weighted by.
vec3 term_weight(uint term, ivec2 px) {
  return term == 0u ? texelFetch(g_light_weight, px, 0).rgb : texelFetch(g_ambient_weight, px, 0).rgb;
}

ivec2 tile_pixel(uint p) { return ivec2(gl_WorkGroupID.xy * TILE + uvec2(p % TILE, p / TILE)); }

void main() {
  uint lane = gl_LocalInvocationIndex;
  if (lane == 0u) tile_flags = 0u;
  barrier();
  uint mine = 0u;      // bit j: pixel lane + 32 j is one of this model's
  uint bilinear = 0u;  // bit j: ... and bilinear
  for (uint j = 0u; j < PER_LANE; ++j) {
    uint p = lane + LANES * j;
    tile_rgb[p] = vec3(0.0);
    ivec2 px = tile_pixel(p);
    if (any(greaterThanEqual(px, ivec2(push.size)))) continue;
    uint marker = uint(texelFetch(g_light, px, 0).z + 0.5);
    if (marker == 0u || (marker - 1u) >> 1 != push.model) continue;
    mine |= 1u << j;
    if (((marker - 1u) & 1u) != 0u) bilinear |= 1u << j;
  }
  if (mine != 0u) atomicOr(tile_flags, bilinear != 0u ? 3u : 1u);
  barrier();
  uint flags = tile_flags;
  if (flags == 0u) return;  // the same for the whole workgroup
  uvec2 grid = btf_model.shape.zw;
  // Groups of taps: nearest = {light, ambient}; bilinear = {the light's 4 texels}, {the ambient's}.
  bool bilinear_tile = (flags & 2u) != 0u;
  uint groups = bilinear_tile ? 2u : 1u, group_taps = bilinear_tile ? 4u : 2u;
  for (uint g = 0u; g < groups; ++g) {
    barrier();
    if (lane == 0u) tile_count = 0u;
    barrier();
    for (uint j = 0u; j < PER_LANE; ++j) {
      if ((mine & (1u << j)) == 0u) continue;
      uint p = lane + LANES * j;
      ivec2 px = tile_pixel(p);
      for (uint t = 0u; t < group_taps; ++t) {
        tile_tap[t * TILE_PIXELS + p] = vec3(0.0);
        uint term = bilinear_tile ? g : t, corner = bilinear_tile ? t : 0u;
        if (corner != 0u && (bilinear & (1u << j)) == 0u) continue;
        if (term_weight(term, px) == vec3(0.0)) continue;
        tile_list[atomicAdd(tile_count, 1u)] = p | (t << 8);
      }
    }
    barrier();
    uint n = tile_count;
    for (uint first = 0u; first < n; first += BATCH) {
      uint texel[BTF_T_ROWS];
      vec4 dirs[BTF_T_ROWS];
      vec3 w[BTF_T_ROWS];
      uint entry[BTF_T_ROWS];
      [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) {
        entry[r] = tile_list[min(first + lane + LANES * r, n - 1u)];
        uint p = entry[r] & 255u, t = entry[r] >> 8;
        ivec2 px = tile_pixel(p);
        vec4 coords = texelFetch(g_coords, px, 0);
        vec4 light = texelFetch(g_light, px, 0);
        bool pixel_bilinear = ((uint(light.z + 0.5) - 1u) & 1u) != 0u;
        uint term = bilinear_tile ? g : t, corner = bilinear_tile ? t : 0u;
        float tap_weight;
        texel[r] = btf_tap(coords.xy, grid, pixel_bilinear, corner, tap_weight);
        w[r] = term_weight(term, px) * tap_weight;
        dirs[r] = vec4(term == 0u ? light.xy : vec2(0.0), coords.zw);
      }
      vec3 rgb[BTF_T_ROWS];
#ifdef BTF_TILED_PAPER
      btf_decode_tiled(texel, dirs, rgb);
#else
      // One inlined copy of the decoder (each copy is thousands of instructions for LLVM).
      [[dont_unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) rgb[r] = btf_decode(texel[r], dirs[r].xy, dirs[r].zw);
#endif
      [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r)
        if (first + lane + LANES * r < n) tile_tap[(entry[r] >> 8) * TILE_PIXELS + (entry[r] & 255u)] = rgb[r] * w[r];
    }
    barrier();
    // The fragment path's order: colour += each tap's weighted decode, light first.
    for (uint j = 0u; j < PER_LANE; ++j) {
      if ((mine & (1u << j)) == 0u) continue;
      uint p = lane + LANES * j;
      for (uint t = 0u; t < group_taps; ++t) tile_rgb[p] += tile_tap[t * TILE_PIXELS + p];
    }
  }
  for (uint j = 0u; j < PER_LANE; ++j) {
    if ((mine & (1u << j)) == 0u) continue;
    ivec2 px = tile_pixel(lane + LANES * j);
    radiance[uint(px.y) * push.size.x + uint(px.x)] = vec4(tile_rgb[lane + LANES * j], 1.0);
  }
}
