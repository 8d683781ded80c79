#version 460
#extension GL_GOOGLE_include_directive : require
// SkinSSSPass vertex stage: world-space position, normal, tangent and UV, and the mesh's
// per-vertex curvature (|Δn|/|Δp| in 1/mesh units; the fragment stage scales it).
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
#include "skin_common.glsl"
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec4 world_tangent;
layout(location = 3) out vec2 uv;
layout(location = 4) out float vertex_curvature;
layout(location = 5) out vec3 vertex_reference;
void main() {
  vec4 world = draw.model * vec4(in_position, 1.0);
  mat3 normal_matrix = transpose(inverse(mat3(draw.model)));
  world_position = world.xyz;
  world_normal = normal_matrix * in_normal;
  world_tangent = vec4(mat3(draw.model) * in_tangent.xyz, in_tangent.w);
  uv = in_uv;
  vertex_curvature = in_curvature;
  int flags = int(draw.transmit.z + 0.5) & 15;
  vertex_reference = (flags & FLAG_REFERENCE) != 0 ? reference_diffuse[gl_VertexIndex].rgb : vec3(0.0);
  gl_Position = frame.view_projection * world;
}
