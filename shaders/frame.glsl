// Shared by weft's passes: the per-frame uniforms (weft::frame::FrameUniforms, std140),
// the vertex layout (weft::frame::Vertex), and small colour and mapping helpers.
#ifndef WEFT_FRAME_GLSL
#define WEFT_FRAME_GLSL

const float PI = 3.14159265358979323846;

// Lights beyond the key light (weft::frame::PunctualLight): no shadows.
const int MAX_PUNCTUAL_LIGHTS = 8;
struct PunctualLight {
  vec4 position_range;  // xyz, w range (0 = infinite)
  vec4 direction_type;  // xyz travel direction, w 0 point / 1 spot / 2 directional
  vec4 color;           // rgb * intensity
  vec4 cone;            // spot: x scale, y offset of cos(angle to the axis)
};

// KHR_lights_punctual's falloff: what multiplies color * intensity at `p` (inverse square
// with the recommended range window, times the spot cone), and the unit vector towards the
// light in `l`.
float punctual_attenuation(PunctualLight light, vec3 p, out vec3 l) {
  int type = int(light.direction_type.w + 0.5);
  if (type == 2) {
    l = -light.direction_type.xyz;
    return 1.0;
  }
  vec3 to_light = light.position_range.xyz - p;
  float d2 = max(dot(to_light, to_light), 1e-8);
  l = to_light * inversesqrt(d2);
  float attenuation = 1.0 / d2;
  float range = light.position_range.w;
  if (range > 0.0) {
    float r = d2 / (range * range);  // (d / range)^2
    float window = clamp(1.0 - r * r, 0.0, 1.0);
    attenuation *= window * window;
  }
  if (type == 1) {
    float cd = dot(light.direction_type.xyz, -l);
    float cone = clamp(cd * light.cone.x + light.cone.y, 0.0, 1.0);
    attenuation *= cone * cone;
  }
  return attenuation;
}

struct FrameData {
  mat4 view;
  mat4 projection;
  mat4 view_projection;
  mat4 inverse_view_projection;
  mat4 light_view_projection;
  vec4 camera_position;
  vec4 light_direction;  // xyz towards the key light
  vec4 light_color;      // rgb * intensity
  vec4 environment;      // x intensity, y rotation (radians), z has map
  vec4 viewport;         // w, h, 1/w, 1/h
  vec4 irradiance_sh[9];
  vec4 light_count;      // x: punctual lights used
  PunctualLight lights[MAX_PUNCTUAL_LIGHTS];
};

#ifdef WEFT_VERTEX_INPUTS
layout(location = 0) in vec3 in_position;
layout(location = 1) in float in_curvature;
layout(location = 2) in vec3 in_normal;
layout(location = 3) in vec4 in_tangent;
layout(location = 4) in vec2 in_uv;
#endif

// Equirectangular mapping shared with weft::frame::irradiance_sh:
// u = atan(z, x) / 2π + 0.5, v = acos(y) / π, after rotating by -rotation about +y.
vec2 equirect_uv(vec3 d, float rotation) {
  float c = cos(rotation), s = sin(rotation);
  vec3 r = vec3(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
  float u = atan(r.z, r.x) / (2.0 * PI) + 0.5;
  float v = acos(clamp(r.y, -1.0, 1.0)) / PI;
  return vec2(u, v);
}

vec3 evaluate_irradiance_sh(vec4 sh[9], vec3 n) {
  vec3 e = sh[0].rgb * 0.282095
         + sh[1].rgb * 0.488603 * n.y + sh[2].rgb * 0.488603 * n.z + sh[3].rgb * 0.488603 * n.x
         + sh[4].rgb * 1.092548 * n.x * n.y + sh[5].rgb * 1.092548 * n.y * n.z
         + sh[6].rgb * 0.315392 * (3.0 * n.z * n.z - 1.0) + sh[7].rgb * 1.092548 * n.x * n.z
         + sh[8].rgb * 0.546274 * (n.x * n.x - n.y * n.y);
  return max(e, vec3(0.0));
}

// The environment seen in direction r by a glossy reflection of this roughness: the map's mip
// level whose texels are about as wide as the lobe (GGX alpha = roughness^2, in radians), so a
// rough surface reflects a blurred sky, not a sharp mirror of its texels (which 8-bit normal
// maps then band). An explicit level: the seam of the equirectangular map has no derivative.
vec3 environment_glossy(sampler2D map, vec3 r, float rotation, float roughness) {
  float alpha = max(roughness * roughness, 1e-4);
  float texels = float(textureSize(map, 0).x) * alpha / (2.0 * PI);
  float lod = clamp(log2(max(texels, 1.0)), 0.0, float(textureQueryLevels(map) - 1));
  return textureLod(map, equirect_uv(r, rotation), lod).rgb;
}

vec3 linear_to_srgb(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

#endif
