#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// The decode kernel's tiled variant: the batched decoder (btf_decode_tiled.glsl) over a list of
// queries, 256 per workgroup (8 per invocation: rows lane + 32 r). Rows past the end decode a
// copy of the last query (control flow stays uniform) and store nothing.
layout(local_size_x = 32) in;
#define BTF_MODEL_SET 0
#define BTF_MODEL_BINDING 0
#include "btf_decode.glsl"
#include "btf_decode_tiled.glsl"
struct Query {
  vec4 light;  // xyz ω_i, w the texel (as a float: exact below 2^24)
  vec4 view;   // xyz ω_o
};
layout(std430, set = 0, binding = 1) readonly buffer Queries { Query queries[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Results { vec4 results[]; };
layout(push_constant) uniform Push { uint count; } push;
void main() {
  uint first = gl_WorkGroupID.x * 32u * BTF_T_ROWS + gl_LocalInvocationID.x;
  uint texel[BTF_T_ROWS];
  vec4 dirs[BTF_T_ROWS];
  [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) {
    Query q = queries[min(first + 32u * r, push.count - 1u)];
    texel[r] = uint(q.light.w);
    dirs[r] = vec4(btf_stereographic(q.light.xyz), btf_stereographic(q.view.xyz));
  }
  vec3 rgb[BTF_T_ROWS];
  btf_decode_tiled(texel, dirs, rgb);
  [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r)
    if (first + 32u * r < push.count) results[first + 32u * r] = vec4(rgb[r], 1.0);
}
