#version 460
#extension GL_GOOGLE_include_directive : require
// Silhouette fins: one instance per mesh edge, six vertices (two triangles) extruded from the
// edge along its vertex normals by h_b. Edges away from the silhouette collapse outside the
// view volume, so they cost a vertex shader run and nothing else.
#include "frame.glsl"
#include "fur_common.glsl"
layout(location = 0) in vec3 position_a;
layout(location = 1) in vec3 position_b;
layout(location = 2) in vec3 normal_a;
layout(location = 3) in vec3 normal_b;
layout(location = 4) in vec4 uv_ab;
layout(location = 5) in vec3 face_normal_0;
layout(location = 6) in vec3 face_normal_1;
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec4 world_tangent;
layout(location = 3) out vec2 uv;
layout(location = 4) flat out int layer;
layout(location = 5) out float fin_height;
const vec2 corners[6] = vec2[](vec2(0, 0), vec2(1, 0), vec2(0, 1), vec2(0, 1), vec2(1, 0), vec2(1, 1));
void main() {
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
