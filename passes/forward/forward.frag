#version 460
#extension GL_GOOGLE_include_directive : require
// Forward PBR: Lambert + GGX (height-correlated Smith, Schlick Fresnel) for the key light
// with a 3x3 PCF shadow, and image-based ambient: SH irradiance for diffuse, the
// environment in the reflected direction for specular. In a white furnace (constant
// environment of radiance 1, white, non-metal, no key light) it returns exactly 1.
#include "frame.glsl"
layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
layout(set = 0, binding = 1) uniform sampler2DShadow shadow_map;
layout(set = 0, binding = 2) uniform sampler2D environment_map;
layout(set = 1, binding = 0) uniform sampler2D base_color_map;  // white when the material has none
layout(push_constant) uniform Draw {
  mat4 model;
  vec4 base_color_metallic;
  vec4 roughness_emissive;
} draw;
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec2 uv;
layout(location = 0) out vec4 out_color;

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
  vec3 base = draw.base_color_metallic.rgb * texture(base_color_map, uv).rgb;
  float metallic = clamp(draw.base_color_metallic.a, 0.0, 1.0);
  float roughness = clamp(draw.roughness_emissive.x, 0.045, 1.0);
  vec3 emissive = draw.roughness_emissive.yzw;

  vec3 n = normalize(world_normal);
  vec3 v = normalize(frame.camera_position.xyz - world_position);
  if (dot(n, v) < 0.0) n = -n;  // two-sided: open meshes show their inside lit correctly
  vec3 l = normalize(frame.light_direction.xyz);
  vec3 h = normalize(v + l);
  float NdotL = max(dot(n, l), 0.0), NdotV = max(dot(n, v), 1e-4), NdotH = max(dot(n, h), 0.0);
  float VdotH = max(dot(v, h), 0.0);

  vec3 f0 = mix(vec3(0.04), base, metallic);
  float a = roughness * roughness, a2 = a * a;
  float dd = NdotH * NdotH * (a2 - 1.0) + 1.0;
  float D = a2 / (PI * dd * dd);
  float vis = 0.5 / max(NdotL * sqrt(NdotV * NdotV * (1.0 - a2) + a2) + NdotV * sqrt(NdotL * NdotL * (1.0 - a2) + a2), 1e-6);
  vec3 F = f0 + (1.0 - f0) * pow(1.0 - VdotH, 5.0);
  vec3 kd = (1.0 - F) * (1.0 - metallic);
  vec3 direct = (kd * base / PI + D * vis * F) * frame.light_color.rgb * NdotL;
  if (NdotL > 0.0) direct *= shadow_factor(world_position, n);

  float intensity = frame.environment.x, rotation = frame.environment.y;
  vec3 F_ambient = f0 + (max(vec3(1.0 - roughness), f0) - f0) * pow(1.0 - NdotV, 5.0);
  vec3 irradiance = evaluate_irradiance_sh(frame.irradiance_sh, n) * intensity;
  vec3 r = reflect(-v, n);
  vec3 mirror = texture(environment_map, equirect_uv(r, rotation)).rgb * intensity;
  vec3 glossy = mix(mirror, evaluate_irradiance_sh(frame.irradiance_sh, r) * intensity / PI, roughness);
  vec3 ambient = (1.0 - F_ambient) * (1.0 - metallic) * base * irradiance / PI + F_ambient * glossy;

  out_color = vec4(direct + ambient + emissive, 1.0);
}
