#version 460
// Lambert + Blinn-Phong with a hemispherical ambient, output encoded to sRGB.
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(push_constant) uniform Draw {
  mat4 view_projection;
  mat4 model;
  vec4 albedo;
  vec4 light_direction;
  vec4 camera_position;
} draw;
layout(location = 0) out vec4 color;

vec3 linear_to_srgb(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

void main() {
  vec3 n = normalize(world_normal);
  vec3 l = normalize(draw.light_direction.xyz);
  vec3 v = normalize(draw.camera_position.xyz - world_position);
  vec3 h = normalize(l + v);
  float diffuse = max(dot(n, l), 0.0);
  float specular = diffuse > 0.0 ? pow(max(dot(n, h), 0.0), 64.0) : 0.0;
  vec3 ambient = mix(vec3(0.05, 0.04, 0.03), vec3(0.12, 0.14, 0.18), n.y * 0.5 + 0.5);
  vec3 lit = draw.albedo.rgb * (ambient + 2.5 * diffuse) + 0.4 * specular;
  color = vec4(linear_to_srgb(lit), 1.0);
}
