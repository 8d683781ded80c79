#version 460
#extension GL_GOOGLE_include_directive : require
// NeuralBTFMaterial vertex stage: world position, normal, tangent (w: handedness) and UV.
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
#include "neural_btf_common.glsl"
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec4 world_tangent;
layout(location = 3) out vec2 uv;
void main() {
  vec4 world = draw.model * vec4(in_position, 1.0);
  world_position = world.xyz;
  world_normal = transpose(inverse(mat3(draw.model))) * in_normal;
  world_tangent = vec4(mat3(draw.model) * in_tangent.xyz, in_tangent.w);
  uv = in_uv;
  gl_Position = frame.view_projection * world;
}
