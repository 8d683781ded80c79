#version 460
// Transforms a lit mesh; per-draw matrices come as push constants.
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(push_constant) uniform Draw {
  mat4 view_projection;
  mat4 model;
  vec4 albedo;
  vec4 light_direction;  // xyz: direction towards the light, world space
  vec4 camera_position;
} draw;
layout(location = 0) out vec3 world_position;
layout(location = 1) out vec3 world_normal;
void main() {
  vec4 world = draw.model * vec4(position, 1.0);
  world_position = world.xyz;
  world_normal = mat3(draw.model) * normal;
  gl_Position = draw.view_projection * world;
}
