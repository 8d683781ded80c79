#version 460
#extension GL_GOOGLE_include_directive : require
// Cel shading: the key light's N.L (times its shadow) rounded up to one of `bands` levels,
// plus a constant ambient (the environment's irradiance from straight up), so a toon object
// shows at most bands + 1 flat tones.
#include "frame.glsl"
#include "toon_common.glsl"
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 0) out vec4 out_color;

float shadow_factor(vec3 p, vec3 n) {
  vec4 clip = frame.light_view_projection * vec4(p + n * 0.002, 1.0);
  vec3 ndc = clip.xyz / clip.w;
  vec2 uv = ndc.xy * 0.5 + 0.5;
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) || ndc.z > 1.0) return 1.0;
  return texture(shadow_map, vec3(uv, ndc.z));
}

void main() {
  vec3 n = normalize(world_normal);
  vec3 v = normalize(frame.camera_position.xyz - world_position);
  if (dot(n, v) < 0.0) n = -n;
  float lit = max(dot(n, normalize(frame.light_direction.xyz)), 0.0);
  if (draw.options.x > 0.5 && lit > 0.0) lit *= step(0.5, shadow_factor(world_position, n));
  float bands = max(draw.base_color_bands.w, 1.0);
  float level = ceil(lit * bands - 1e-4) / bands;
  vec3 base = draw.base_color_bands.rgb;
  vec3 ambient = evaluate_irradiance_sh(frame.irradiance_sh, vec3(0.0, 1.0, 0.0)) * frame.environment.x / PI;
  out_color = vec4(base * (ambient + frame.light_color.rgb * level / PI), 1.0);
}
