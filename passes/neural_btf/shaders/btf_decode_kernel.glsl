// The decode kernel's body (btf_decode.comp, btf_decode_paper.comp): one invocation per
// query (texel, ω_i, ω_o in the tangent frame), writing the decoded RGB. Tests compare it with weft::btf::decode; the benchmark times it.
layout(local_size_x = 64) in;
#define BTF_MODEL_SET 0
#define BTF_MODEL_BINDING 0
#include "btf_decode.glsl"
struct Query {
  vec4 light;  // xyz ω_i, w the texel (as a float: exact below 2^24)
  vec4 view;   // xyz ω_o
};
layout(std430, set = 0, binding = 1) readonly buffer Queries { Query queries[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Results { vec4 results[]; };
layout(push_constant) uniform Push { uint count; } push;
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= push.count) return;
  Query q = queries[i];
  results[i] = vec4(btf_decode(uint(q.light.w), btf_stereographic(q.light.xyz), btf_stereographic(q.view.xyz)), 1.0);
}
