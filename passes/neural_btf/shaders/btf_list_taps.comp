#version 460
#extension GL_GOOGLE_include_directive : require
// The batched path's list (docs/neural-btf.md, "The batched decode"): one workgroup of 32
// invocations per 16 x 16 screen tile finds the tile's pixels of one model in the G-buffer
// (neural_btf_gbuffer.frag) and appends each to the screen-wide list of its class (how many
// decodes it needs: btf_pixel_taps.glsl), one atomic add per tile and class. The decode then
// runs over whole lists in full batches, wherever the model's pixels fall on the screen. A
// pixel that needs no decode (both weights 0) gets 0 radiance here. The tile's lane 0 also
// raises each class's indirect group count to cover the list's end.
layout(local_size_x = 32) in;
layout(set = 0, binding = 0) uniform sampler2D g_light;    // si.xy, light weight .rg
layout(set = 0, binding = 1) uniform sampler2D g_weights;  // light weight .b, ambient weight .rgb
layout(set = 0, binding = 2) uniform sampler2D g_marker;   // r: marker (0: none; 2 * model + bilinear + 1)
layout(std430, set = 0, binding = 3) buffer Counts { uint count[]; };         // by model and class
layout(std430, set = 0, binding = 4) buffer Groups { uvec4 groups[]; };       // by model and class: pad, x, y, z
layout(std430, set = 0, binding = 5) writeonly buffer List { uint list[]; };  // pixel indices
layout(std430, set = 0, binding = 6) writeonly buffer Radiance { float radiance[]; };  // rgb per pixel
layout(push_constant) uniform Push {
  uvec2 size;  // the frame
  uint model;  // whose pixels this dispatch lists
} push;
#include "btf_pixel_taps.glsl"

const uint TILE = 16u, LANES = 32u, PER_LANE = TILE * TILE / LANES;
const uint ROWS = 256u;  // the decode's rows per workgroup: 1 << (8 - c) pixels of class c
shared uint tile_count[BTF_CLASSES], tile_base[BTF_CLASSES];

void main() {
  uint lane = gl_LocalInvocationIndex;
  if (lane < BTF_CLASSES) tile_count[lane] = 0u;
  barrier();
  uint classes = 0u;  // 3 bits per pixel: its class + 1, or 0 when it is not listed
  for (uint j = 0u; j < PER_LANE; ++j) {
    uint p = lane + LANES * j;
    ivec2 px = ivec2(gl_WorkGroupID.xy * TILE + uvec2(p % TILE, p / TILE));
    if (any(greaterThanEqual(px, ivec2(push.size))) || pixel_model(px) != push.model) continue;
    uint mask = pixel_tap_mask(px);
    if (mask == 0u) {
      uint pixel = uint(px.y) * push.size.x + uint(px.x);
      radiance[3u * pixel] = 0.0;
      radiance[3u * pixel + 1u] = 0.0;
      radiance[3u * pixel + 2u] = 0.0;
      continue;
    }
    uint c = tap_class(mask);
    classes |= (c + 1u) << (3u * j);
    atomicAdd(tile_count[c], 1u);
  }
  barrier();
  uint pixels = push.size.x * push.size.y;
  if (lane < BTF_CLASSES && tile_count[lane] != 0u) {
    uint c = lane, slot = push.model * BTF_CLASSES + c;
    tile_base[c] = atomicAdd(count[slot], tile_count[c]);
    uint per_group = ROWS >> c;
    atomicMax(groups[slot].y, (tile_base[c] + tile_count[c] + per_group - 1u) / per_group);
    groups[slot].z = 1u;
    groups[slot].w = 1u;
  }
  barrier();
  if (lane < BTF_CLASSES) tile_count[lane] = 0u;  // reused as each class's next free entry
  barrier();
  for (uint j = 0u; j < PER_LANE; ++j) {
    uint c1 = (classes >> (3u * j)) & 7u;
    if (c1 == 0u) continue;
    uint p = lane + LANES * j;
    uvec2 px = gl_WorkGroupID.xy * TILE + uvec2(p % TILE, p / TILE);
    uint i = tile_base[c1 - 1u] + atomicAdd(tile_count[c1 - 1u], 1u);
    list[list_index(c1 - 1u, i, pixels)] = px.y * push.size.x + px.x;
  }
}
