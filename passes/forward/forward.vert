#version 460
#extension GL_GOOGLE_include_directive : require
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
layout(location = 5) in vec2 in_uv1;
layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
layout(push_constant) uniform Draw {
  mat4 model;
  vec4 base_color_metallic;
  vec4 roughness_emissive;
  vec4 maps;
} draw;
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec2 uv;
layout(location = 3) out vec2 uv1;
layout(location = 4) out vec4 world_tangent;
void main() {
  uv = in_uv;
  uv1 = in_uv1;
  vec4 world = draw.model * vec4(in_position, 1.0);
  world_position = world.xyz;
  mat3 linear = mat3(draw.model);
  world_normal = transpose(inverse(linear)) * in_normal;
  // A mirroring transform turns the bitangent w * cross(n, t) around: keep it on the image's top.
  world_tangent = vec4(linear * in_tangent.xyz, in_tangent.w * (determinant(linear) < 0.0 ? -1.0 : 1.0));
  gl_Position = frame.view_projection * world;
}
