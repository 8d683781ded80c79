#version 460
#extension GL_GOOGLE_include_directive : require
// Forward PBR, glTF's metallic-roughness material: Lambert + GGX (height-correlated Smith,
// Schlick Fresnel) for the key light with a 3x3 PCF shadow and for the punctual lights
// (KHR_lights_punctual falloff, no shadows), and image-based ambient: SH irradiance for
// diffuse, the environment in the reflected direction for specular, dimmed by the occlusion
// map. Base colour, metallic-roughness, normal, occlusion and emissive maps, each on UV set
// 0 or 1. In a white furnace (constant environment of radiance 1, white, non-metal, no
// lights) it returns exactly 1.
#include "frame.glsl"
layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
layout(set = 0, binding = 1) uniform sampler2DShadow shadow_map;
layout(set = 0, binding = 2) uniform sampler2D environment_map;
// Neutral when the material has no map: white, white, flat (0.5, 0.5, 1), white, white.
layout(set = 1, binding = 0) uniform sampler2D base_color_map;
layout(set = 1, binding = 1) uniform sampler2D metallic_roughness_map;
layout(set = 1, binding = 2) uniform sampler2D normal_map;
layout(set = 1, binding = 3) uniform sampler2D occlusion_map;
layout(set = 1, binding = 4) uniform sampler2D emissive_map;
// The instance's material factors (forward.vert reads them from its draw record).
layout(location = 5) flat in vec4 in_base_color_metallic;
layout(location = 6) flat in vec4 in_roughness_emissive;
layout(location = 7) flat in vec4 in_maps;  // x normal scale, y occlusion strength, z: bit i set = map i reads uv1, w: 1 = has a normal map
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec2 uv0;
layout(location = 3) in vec2 uv1;
layout(location = 4) in vec4 world_tangent;
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

vec2 map_uv(int map) { return ((int(in_maps.z + 0.5) >> map) & 1) != 0 ? uv1 : uv0; }

// Lambert + GGX for one light of radiance `light` (already times the falloff) from `l`.
vec3 direct_light(vec3 n, vec3 v, vec3 l, vec3 light, vec3 base, float metallic, float roughness, vec3 f0) {
  float NdotL = max(dot(n, l), 0.0);
  if (NdotL <= 0.0) return vec3(0.0);
  vec3 h = normalize(v + l);
  float NdotV = max(dot(n, v), 1e-4), NdotH = max(dot(n, h), 0.0), VdotH = max(dot(v, h), 0.0);
  float a = roughness * roughness, a2 = a * a;
  float dd = NdotH * NdotH * (a2 - 1.0) + 1.0;
  float D = a2 / (PI * dd * dd);
  float vis = 0.5 / max(NdotL * sqrt(NdotV * NdotV * (1.0 - a2) + a2) + NdotV * sqrt(NdotL * NdotL * (1.0 - a2) + a2), 1e-6);
  vec3 F = f0 + (1.0 - f0) * pow(1.0 - VdotH, 5.0);
  vec3 kd = (1.0 - F) * (1.0 - metallic);
  return (kd * base / PI + D * vis * F) * light * NdotL;
}

void main() {
  vec3 base = in_base_color_metallic.rgb * texture(base_color_map, map_uv(0)).rgb;
  vec4 mr = texture(metallic_roughness_map, map_uv(1));
  float metallic = clamp(in_base_color_metallic.a * mr.b, 0.0, 1.0);
  float roughness = clamp(in_roughness_emissive.x * mr.g, 0.045, 1.0);
  vec3 emissive = in_roughness_emissive.yzw * texture(emissive_map, map_uv(4)).rgb;
  float occlusion = mix(1.0, texture(occlusion_map, map_uv(3)).r, clamp(in_maps.y, 0.0, 1.0));

  vec3 ng = normalize(world_normal);
  vec3 v = normalize(frame.camera_position.xyz - world_position);
  if (dot(ng, v) < 0.0) ng = -ng;  // two-sided: open meshes show their inside lit correctly
  // The normal map in the tangent frame: t along +u, b = w * cross(n, t) towards the image's
  // top (glTF's rule), the map's +Y.
  vec3 n = ng;
  vec3 t = world_tangent.xyz - ng * dot(ng, world_tangent.xyz);
  if (in_maps.w > 0.5 && dot(t, t) > 1e-12) {
    t = normalize(t);
    vec3 b = cross(ng, t) * (world_tangent.w < 0.0 ? -1.0 : 1.0);
    vec3 tn = texture(normal_map, map_uv(2)).xyz * 2.0 - 1.0;
    tn.xy *= in_maps.x;
    n = normalize(t * tn.x + b * tn.y + ng * max(tn.z, 1e-3));
  }

  vec3 f0 = mix(vec3(0.04), base, metallic);
  vec3 l = normalize(frame.light_direction.xyz);
  vec3 direct = direct_light(n, v, l, frame.light_color.rgb, base, metallic, roughness, f0);
  if (dot(n, l) > 0.0) direct *= shadow_factor(world_position, ng);
  int count = min(int(frame.light_count.x + 0.5), MAX_PUNCTUAL_LIGHTS);
  for (int i = 0; i < count; ++i) {
    vec3 li;
    float attenuation = punctual_attenuation(frame.lights[i], world_position, li);
    direct += direct_light(n, v, li, frame.lights[i].color.rgb * attenuation, base, metallic, roughness, f0);
  }

  float NdotV = max(dot(n, v), 1e-4);
  float intensity = frame.environment.x, rotation = frame.environment.y;
  vec3 F_ambient = f0 + (max(vec3(1.0 - roughness), f0) - f0) * pow(1.0 - NdotV, 5.0);
  vec3 irradiance = evaluate_irradiance_sh(frame.irradiance_sh, n) * intensity;
  vec3 r = reflect(-v, n);
  vec3 mirror = environment_glossy(environment_map, r, rotation, roughness) * intensity;
  vec3 glossy = mix(mirror, evaluate_irradiance_sh(frame.irradiance_sh, r) * intensity / PI, roughness);
  vec3 ambient = ((1.0 - F_ambient) * (1.0 - metallic) * base * irradiance / PI + F_ambient * glossy) * occlusion;

  out_color = vec4(direct + ambient + emissive, 1.0);
}
