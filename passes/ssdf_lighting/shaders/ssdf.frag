#version 460
#extension GL_GOOGLE_include_directive : require
// SSDFLightingPass: a Lambert surface under the environment's spherical Gaussians, each
// lobe's visibility from the SSDF at its centre (per vertex, or per pixel from the
// interpolated distances with the pixel's normal), plus the key light's direct term through
// the shadow map as the forward pass does it. light_color is the irradiance at normal
// incidence, so the direct term is albedo/π E cos θ.
#include "frame.glsl"
#include "ssdf_common.glsl"
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec3 vertex_light;
layout(location = 3) in vec4 lobe_distance[12];
layout(location = 0) out vec4 out_color;

// The forward pass's 3x3 PCF.
float shadow_factor(vec3 p, vec3 n) {
  vec4 clip = frame.light_view_projection * vec4(p + n * 0.002, 1.0);
  vec3 ndc = clip.xyz / clip.w;
  vec2 uv = ndc.xy * 0.5 + 0.5;
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) || ndc.z > 1.0) return 1.0;
  vec2 texel = 1.0 / vec2(textureSize(shadow_map, 0));
  float lit = 0.0;
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) lit += texture(shadow_map, vec3(uv + vec2(x, y) * texel, ndc.z));
  return lit / 9.0;
}

void main() {
  vec3 n = normalize(world_normal);
  vec3 albedo = draw.albedo_mode.rgb;
  vec3 environment = vertex_light;
  if (draw.albedo_mode.w > 0.5) {
    environment = vec3(0.0);
    uint count = min(draw.info.y, 48u);
    for (uint j = 0u; j < count; ++j) environment += lobe_light(j, n, lobe_distance[j >> 2u][j & 3u]);
    environment /= PI;
  }
  vec3 l = normalize(frame.light_direction.xyz);
  float ndl = max(dot(n, l), 0.0);
  vec3 direct = albedo / PI * frame.light_color.rgb * ndl;
  if (ndl > 0.0) direct *= shadow_factor(world_position, n);
  out_color = vec4(albedo * environment + direct, 1.0);
}
