#version 460
#extension GL_GOOGLE_include_directive : require
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
layout(push_constant) uniform Draw {
  mat4 model;
  vec4 base_color_metallic;
  vec4 roughness_emissive;
} draw;
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec2 uv;
void main() {
  uv = in_uv;
  vec4 world = draw.model * vec4(in_position, 1.0);
  world_position = world.xyz;
  world_normal = transpose(inverse(mat3(draw.model))) * in_normal;
  gl_Position = frame.view_projection * world;
}
