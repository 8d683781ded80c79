#version 460
#extension GL_GOOGLE_include_directive : require
// SSDFLightingPass vertex stage: reconstructs the vertex's SSDF at every lobe centre from its
// cluster's basis and its coefficients; per-vertex shading sums the lobes here, per-pixel
// shading hands the distances to the fragment stage (interpolated across the triangle: the
// three vertices may belong to different clusters, so coefficients cannot be interpolated).
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
#include "ssdf_common.glsl"
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec3 vertex_light;        // (1/π) Σ E_j V_j, per-vertex shading
layout(location = 3) out vec4 lobe_distance[12];   // SSDF at lobe centres, per-pixel shading
void main() {
  vec4 world = draw.model * vec4(in_position, 1.0);
  world_position = world.xyz;
  world_normal = transpose(inverse(mat3(draw.model))) * in_normal;
  gl_Position = frame.view_projection * world;

  uvec2 row = vertex_slot[draw.info.x + uint(gl_VertexIndex)];
  uvec4 cluster = cluster_info[row.x];
  uint count = min(draw.info.y, 48u);
  bool per_pixel = draw.albedo_mode.w > 0.5;
  vec3 n = normalize(world_normal);
  vec3 light = vec3(0.0);
  vec4 distances[12];
  for (int i = 0; i < 12; ++i) distances[i] = vec4(0.0);
  for (uint j = 0u; j < count; ++j) {
    float d = ssdf_at_lobe(cluster, row.y, j);
    if (per_pixel)
      distances[j >> 2u][j & 3u] = d;
    else
      light += lobe_light(j, n, d);
  }
  vertex_light = light / PI;
  for (int i = 0; i < 12; ++i) lobe_distance[i] = distances[i];
}
