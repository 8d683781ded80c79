#version 460
#extension GL_GOOGLE_include_directive : require
// One instance per layer: gl_InstanceIndex = n, 0 the tips (h_b above the skin) .. N the skin.
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
#include "fur_common.glsl"
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec4 world_tangent;
layout(location = 3) out vec2 uv;
layout(location = 4) flat out int layer;
// The skin's depth pre-pass and the shells draw the skin with this shader in two pipelines;
// their depths must agree.
invariant gl_Position;
void main() {
  layer = gl_InstanceIndex;
  float layers = draw.uv_layers.z;
  float height = (layers - float(layer)) / layers;
  vec3 p = in_position + in_normal * (draw.tint_thickness.w * height);
  vec4 world = draw.model * vec4(p, 1.0);
  world_position = world.xyz;
  world_normal = normal_matrix(draw.model) * in_normal;
  world_tangent = vec4(mat3(draw.model) * in_tangent.xyz, in_tangent.w);
  uv = in_uv;
  gl_Position = frame.view_projection * world;
}
