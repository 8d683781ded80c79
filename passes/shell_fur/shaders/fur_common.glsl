// Shared by the shell fur shaders: bindings, the per-draw push constants and the shading.
#ifndef WEFT_FUR_COMMON_GLSL
#define WEFT_FUR_COMMON_GLSL

layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
// RGBA8 sRGB: the photo's colour, and in A the texel's luminance code (linear channel). The
// naive method binds its layer's own texture here (A: 1 kept, 0 not).
layout(set = 0, binding = 1) uniform sampler2D photo;
// RG8: the hair direction's double angle times the coherence, in [0, 1].
layout(set = 0, binding = 2) uniform sampler2D orientation;
struct FurLayer {
  float keep_min;       // draw texels whose A lies in [keep_min, keep_max)
  float keep_max;
  float top;            // texels above the band's top (drawn below their band) are darkened to it
  float height;         // above the skin, in units of h_b
};
layout(set = 0, binding = 3, std430) readonly buffer Bands { FurLayer bands[]; };
layout(set = 0, binding = 4) uniform sampler2DShadow shadow_map;

layout(push_constant) uniform FurDraw {
  mat4 model;
  vec4 tint_thickness;  // rgb tint, w h_b (object units)
  vec4 uv_layers;       // xy uv scale, z N, w lighting (0 Lambert, 1 Kajiya-Kay)
  vec4 hair;            // xy comb direction in UV space (0: from the photo), z sin(lift), w cos(lift)
  vec4 specular;        // x strength, y shininess, z fin threshold |N.V|
} draw;

// The cofactor matrix: the inverse transpose times the determinant, so normals transform
// correctly (up to length) for any invertible model matrix, with three cross products.
mat3 normal_matrix(mat4 m) {
  vec3 a = m[0].xyz, b = m[1].xyz, c = m[2].xyz;
  return mat3(cross(b, c), cross(c, a), cross(a, b));
}

float code_to_luminance(float a) {
  return a <= 0.04045 ? a / 12.92 : pow((a + 0.055) / 1.055, 2.4);
}

float fur_shadow(vec3 p, vec3 n) {
  vec4 clip = frame.light_view_projection * vec4(p + n * 0.002, 1.0);
  vec3 ndc = clip.xyz / clip.w;
  vec2 uv = ndc.xy * 0.5 + 0.5;
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) || ndc.z > 1.0) return 1.0;
  return texture(shadow_map, vec3(uv, ndc.z));  // one bilinear comparison (2x2 PCF)
}

// The hair direction: the comb (or the photo's streak direction) in the surface's tangent
// plane, lifted towards the normal by the lift angle.
vec3 hair_tangent(vec3 n, vec4 tangent, vec2 st) {
  vec3 t = tangent.xyz - n * dot(n, tangent.xyz);
  t = dot(t, t) > 1e-12 ? normalize(t) : (abs(n.x) < 0.9 ? normalize(cross(n, vec3(1, 0, 0))) : normalize(cross(n, vec3(0, 1, 0))));
  // Along +v (down the photo, as its orientation is measured): the mesh's bitangent
  // w * cross(n, t) points to -v, the image's top (glTF's rule).
  vec3 b = -cross(n, t) * (tangent.w < 0.0 ? -1.0 : 1.0);
  vec2 d;
  if (dot(draw.hair.xy, draw.hair.xy) > 0.0) {
    d = normalize(draw.hair.xy);
  } else {
    vec2 v = texture(orientation, st).rg * 2.0 - 1.0;
    float phi = 0.5 * atan(v.y, v.x + 1e-9);
    d = vec2(cos(phi), sin(phi));
  }
  return normalize((d.x * t + d.y * b) * draw.hair.w + n * draw.hair.z);
}

// Lambert (the paper) or Kajiya-Kay (diffuse sin(T,L), specular on the reflection cone),
// under the key light with its shadow map, plus the environment's SH irradiance.
vec3 fur_shade(vec3 albedo, vec3 p, vec3 n, vec3 hair) {
  n = normalize(n);
  vec3 v = normalize(frame.camera_position.xyz - p);
  if (dot(n, v) < 0.0) n = -n;  // two-sided: open surfaces show their underside
  vec3 l = normalize(frame.light_direction.xyz);
  vec3 radiance = frame.light_color.rgb;
  float ndl = dot(n, l);
  vec3 ambient = albedo * evaluate_irradiance_sh(frame.irradiance_sh, n) * frame.environment.x / PI;
  if (draw.uv_layers.w < 0.5) {
    float lit = max(ndl, 0.0);
    if (lit > 0.0) lit *= fur_shadow(p, n);
    return albedo / PI * radiance * lit + ambient;
  }
  float tl = dot(hair, l), tv = dot(hair, v);
  float sin_tl = sqrt(max(1.0 - tl * tl, 0.0)), sin_tv = sqrt(max(1.0 - tv * tv, 0.0));
  float body = clamp((ndl + 0.25) / 1.25, 0.0, 1.0);  // the skin hides light from below its horizon
  if (body > 0.0) body *= fur_shadow(p, n);
  float cone = max(sin_tl * sin_tv - tl * tv, 0.0);
  vec3 diffuse = albedo / PI * sin_tl;
  vec3 specular = vec3(draw.specular.x * pow(cone, draw.specular.y));
  return (diffuse + specular) * radiance * body + ambient;
}

#endif
