#version 460
#extension GL_GOOGLE_include_directive : require
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
layout(location = 5) in vec2 in_uv1;
layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
// One record per instance: objects sharing a mesh and a material's maps are one instanced
// draw, each instance's model matrix and material factors read here by gl_InstanceIndex.
struct DrawData {
  mat4 model;
  vec4 base_color_metallic;
  vec4 roughness_emissive;
  vec4 maps;
};
layout(set = 0, binding = 3, std430) readonly buffer Draws { DrawData draws[]; };
layout(location = 5) flat out vec4 out_base_color_metallic;
layout(location = 6) flat out vec4 out_roughness_emissive;
layout(location = 7) flat out vec4 out_maps;
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
layout(location = 2) out vec2 uv;
layout(location = 3) out vec2 uv1;
layout(location = 4) out vec4 world_tangent;
void main() {
  DrawData draw = draws[gl_InstanceIndex];
  out_base_color_metallic = draw.base_color_metallic;
  out_roughness_emissive = draw.roughness_emissive;
  out_maps = draw.maps;
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
