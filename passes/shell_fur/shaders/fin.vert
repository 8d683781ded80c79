#version 460
#extension GL_GOOGLE_include_directive : require
// Silhouette fins: six vertices (two triangles) per mesh edge, extruded from the edge along
// its vertex normals by h_b. Edges away from the silhouette collapse outside the view volume,
// so they cost a vertex shader run and nothing else. One plain draw of 6 x edges vertices
// reading the edges from a storage buffer (vertex pulling), not one instance per edge: a CPU
// rasteriser (llvmpipe) runs its whole vertex pipeline once per instance (docs/fur.md, Speed).
#include "frame.glsl"
#include "fur_common.glsl"
// FurFinEdge (88 bytes, 22 floats): position a, position b, normal a, normal b (vec3 each),
// uv of a and b (vec4), the two faces' normals (vec3 each); packed, so read as floats.
layout(set = 0, binding = 5, std430) readonly buffer Fins { float fin_edges[]; };
vec3 edge_vec3(uint at) { return vec3(fin_edges[at], fin_edges[at + 1u], fin_edges[at + 2u]); }
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec4 world_tangent;
layout(location = 3) out vec2 uv;
layout(location = 4) flat out int layer;
layout(location = 5) out float fin_height;
const vec2 corners[6] = vec2[](vec2(0, 0), vec2(1, 0), vec2(0, 1), vec2(0, 1), vec2(1, 0), vec2(1, 1));
void main() {
  const uint base = uint(gl_VertexIndex / 6) * 22u;
  vec3 position_a = edge_vec3(base), position_b = edge_vec3(base + 3u);
  vec3 normal_a = edge_vec3(base + 6u), normal_b = edge_vec3(base + 9u);
  vec4 uv_ab = vec4(fin_edges[base + 12u], fin_edges[base + 13u], fin_edges[base + 14u], fin_edges[base + 15u]);
  vec3 face_normal_0 = edge_vec3(base + 16u), face_normal_1 = edge_vec3(base + 19u);
  vec2 c = corners[gl_VertexIndex % 6];
  mat3 to_world = normal_matrix(draw.model);
  vec3 middle = (draw.model * vec4(0.5 * (position_a + position_b), 1.0)).xyz;
  vec3 v = normalize(frame.camera_position.xyz - middle);
  vec3 n0 = to_world * face_normal_0, n1 = to_world * face_normal_1;
  n0 = dot(n0, n0) > 0.0 ? normalize(n0) : vec3(0.0);
  n1 = dot(n1, n1) > 0.0 ? normalize(n1) : vec3(0.0);
  vec3 edge_normal = n0 + n1;
  edge_normal = dot(edge_normal, edge_normal) > 1e-8 ? normalize(edge_normal) : n0;
  float d0 = dot(n0, v), d1 = dot(n1, v);
  bool near_silhouette = d0 * d1 <= 0.0 || abs(dot(edge_normal, v)) < draw.specular.z;
  layer = 0;
  fin_height = c.y;
  uv = mix(uv_ab.xy, uv_ab.zw, c.x);
  vec3 n = mix(normal_a, normal_b, c.x);
  world_normal = to_world * n;
  world_tangent = vec4(mat3(draw.model) * (position_b - position_a), 1.0);
  vec4 world = draw.model * vec4(mix(position_a, position_b, c.x) + n * (draw.tint_thickness.w * c.y), 1.0);
  world_position = world.xyz;
  if (!near_silhouette || !(draw.tint_thickness.w > 0.0)) {
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the view volume: clipped
    return;
  }
  gl_Position = frame.view_projection * world;
}
