#version 460
#extension GL_GOOGLE_include_directive : require
// The toon surface: the mesh as it is (the outline pass grows it along its normals).
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
#include "toon_common.glsl"
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
void main() {
  vec4 world = draw.model * vec4(in_position, 1.0);
  world_position = world.xyz;
  world_normal = transpose(inverse(mat3(draw.model))) * in_normal;
  gl_Position = frame.view_projection * world;
}
