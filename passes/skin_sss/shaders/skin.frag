#version 460
#extension GL_GOOGLE_include_directive : require
// SkinSSSPass: pre-integrated subsurface scattering for the key light (one LUT fetch per
// channel, each with its own blurred normal), Kelemen/Szirmay-Kalos specular with the
// Beckmann term from the LUT's alpha, transmittance through thin parts from the shadow
// map's depth (Jimenez et al. 2010), and image-based ambient. Conventions as the forward
// pass: light_color is the irradiance at normal incidence, so a Lambert surface of albedo a
// returns a/π E cos θ; the LUT replaces cos θ by D(θ, 1/r). docs/skin.md has the details.
#include "frame.glsl"
#include "skin_common.glsl"
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec4 world_tangent;
layout(location = 3) in vec2 uv;
layout(location = 4) in float vertex_curvature;
layout(location = 5) in vec3 vertex_reference;
layout(location = 0) out vec4 out_color;

const float F0_SKIN = 0.028;

// x in [0, 1] to the coordinate of the texel-centre mapping: the end points hit texel centres.
vec2 lut_uv(vec2 x) {
  vec2 size = vec2(textureSize(skin_lut, 0));
  return (clamp(x, 0.0, 1.0) * (size - 1.0) + 0.5) / size;
}

// The light-space depth per world unit along the light (the light matrix is orthographic).
float depth_per_unit() {
  mat4 m = frame.light_view_projection;
  return length(vec3(m[0][2], m[1][2], m[2][2]));
}

// 3x3 PCF of the shadow map; `reach` (world units) counts a point as lit when the first surface
// the light meets is less than `reach` in front of it.
float shadow_texel_world() {
  mat4 m = frame.light_view_projection;
  return 2.0 / (float(textureSize(shadow_map, 0).x) * max(length(vec3(m[0][0], m[1][0], m[2][0])), 1e-20));
}

float shadow_factor(vec3 p, vec3 n, float reach) {
  // Normal offset of two shadow texels (world size from the matrix's x row), so grazing
  // surfaces do not shadow themselves texel by texel.
  mat4 m = frame.light_view_projection;
  vec4 clip = m * vec4(p + n * (2.0 * shadow_texel_world()), 1.0);
  vec3 ndc = clip.xyz / clip.w;
  ndc.z -= reach * depth_per_unit();
  vec2 suv = ndc.xy * 0.5 + 0.5;
  if (any(lessThan(suv, vec2(0.0))) || any(greaterThan(suv, vec2(1.0))) || ndc.z > 1.0) return 1.0;
  vec2 texel = 1.0 / vec2(textureSize(shadow_map, 0));
  float lit = 0.0;
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) lit += texture(shadow_map, vec3(suv + vec2(x, y) * texel, ndc.z));
  return lit / 9.0;
}

// One bilinear comparison (2x2 PCF): enough for the specular and the transmittance mask.
float shadow_factor_1tap(vec3 p, vec3 n) {
  vec4 clip = frame.light_view_projection * vec4(p + n * (2.0 * shadow_texel_world()), 1.0);
  vec3 ndc = clip.xyz / clip.w;
  vec2 suv = ndc.xy * 0.5 + 0.5;
  if (any(lessThan(suv, vec2(0.0))) || any(greaterThan(suv, vec2(1.0))) || ndc.z > 1.0) return 1.0;
  return texture(shadow_map, vec3(suv, ndc.z));
}

// World-space distance the light travels inside the object before reaching p: p's light
// depth minus the shadow map's (the first surface the light meets). The light matrix is
// orthographic, so depth is linear: its z row's length converts depth to distance.
float thickness_world(vec3 p, vec3 n) {
  vec3 q = p - n * draw.transmit.y;
  vec4 clip = frame.light_view_projection * vec4(q, 1.0);
  vec3 ndc = clip.xyz / clip.w;
  vec2 suv = ndc.xy * 0.5 + 0.5;
  if (any(lessThan(suv, vec2(0.0))) || any(greaterThan(suv, vec2(1.0)))) return 1e9;
  float occluder = texture(shadow_depth, suv).r;
  return max(ndc.z - occluder, 0.0) / max(depth_per_unit(), 1e-20);
}

// Jimenez et al.'s transmittance profile of d'Eon's Gaussians, s in mm.
vec3 transmittance_profile(float s) {
  float s2 = s * s;
  return vec3(0.233, 0.455, 0.649) * exp(-s2 / 0.0064) + vec3(0.1, 0.336, 0.344) * exp(-s2 / 0.0484) +
         vec3(0.118, 0.198, 0.0) * exp(-s2 / 0.187) + vec3(0.113, 0.007, 0.007) * exp(-s2 / 0.567) +
         vec3(0.358, 0.004, 0.0) * exp(-s2 / 1.99) + vec3(0.078, 0.0, 0.0) * exp(-s2 / 7.41);
}

float fresnel(float v_dot_h, float f0) {
  float base = 1.0 - clamp(v_dot_h, 0.0, 1.0);
  float e = base * base * base * base * base;
  return e + f0 * (1.0 - e);
}

void main() {
  int packed = int(draw.transmit.z + 0.5);
  int flags = packed & 31;
  int debug_view = packed >> 5;

  vec3 ng = normalize(world_normal);
  vec3 v = normalize(frame.camera_position.xyz - world_position);
  // Two-sided (open scans show their inside), decided by the triangle's winding, not by the
  // interpolated normal: at a closed mesh's silhouette that normal may face slightly away
  // from the camera, and flipping it there would light the rim as if from inside.
  if (!gl_FrontFacing) ng = -ng;

  // Detail normal from the normal map, then one normal per channel: red scatters furthest,
  // so it sees the most blurred (geometric) surface.
  vec3 nd = ng;
  if ((flags & FLAG_NORMAL_MAP) != 0) {
    vec3 t = world_tangent.xyz - ng * dot(ng, world_tangent.xyz);
    float tl = length(t);
    if (tl > 1e-8) {
      t /= tl;
      vec3 b = cross(ng, t) * (world_tangent.w < 0.0 ? -1.0 : 1.0);
      vec3 tn = texture(normal_map, uv).xyz * 2.0 - 1.0;
      tn.xy *= draw.normal_blur.a;
      nd = normalize(t * tn.x + b * tn.y + ng * max(tn.z, 1e-3));
    }
  }
  // Silhouettes (issue 32): where the surface turns edge-on, the map's normals face away from
  // the camera, and a normal that faces away reflects the environment from below the surface:
  // a white rim along chin and neck and banded, glassy reflections (8-bit normals quantise a
  // mirror). The map's detail fades to the geometric normal as the surface turns edge-on
  // (detail there covers a sliver of a pixel anyway), and the shading normal is bent back
  // until it faces the camera; reflections below the geometric surface are occluded further
  // down (horizon occlusion).
  float ng_dot_v = dot(ng, v);
  nd = normalize(mix(ng, nd, smoothstep(0.0, 0.3, ng_dot_v)));
  const float min_n_dot_v = 0.05;
  float nd_dot_v = dot(nd, v);
  if (nd_dot_v < min_n_dot_v) nd = normalize(nd + v * (min_n_dot_v - nd_dot_v));
  vec3 blur = clamp(draw.normal_blur.rgb, 0.0, 1.0);
  vec3 n_r = normalize(mix(nd, ng, blur.r));
  vec3 n_g = normalize(mix(nd, ng, blur.g));
  vec3 n_b = normalize(mix(nd, ng, blur.b));

  // Curvature as the LUT's v in [0, 1]: per vertex, or from screen-space derivatives of the
  // geometric normal and position (the thesis's per-pixel alternative).
  float world_curvature;  // 1/r in 1/world units
  if ((flags & FLAG_SCREEN_CURVATURE) != 0) {
    float dp = length(fwidth(world_position));
    world_curvature = dp > 0.0 ? length(fwidth(ng)) / dp : 0.0;
  } else {
    world_curvature = vertex_curvature * draw.params.y;
  }
  if (!(world_curvature >= 0.0) || isinf(world_curvature)) world_curvature = 0.0;  // NaN, negatives, inf
  float curvature = min(world_curvature * draw.params.z, 1.0);

  vec3 l = normalize(frame.light_direction.xyz);
  vec3 light = frame.light_color.rgb;
  vec3 albedo = draw.albedo_specular.rgb;
  if ((flags & FLAG_ALBEDO_MAP) != 0) albedo *= texture(albedo_map, uv).rgb;

  vec3 lut;
  lut.r = texture(skin_lut, lut_uv(vec2(dot(n_r, l) * 0.5 + 0.5, curvature))).r;
  lut.g = texture(skin_lut, lut_uv(vec2(dot(n_g, l) * 0.5 + 0.5, curvature))).g;
  lut.b = texture(skin_lut, lut_uv(vec2(dot(n_b, l) * 0.5 + 0.5, curvature))).b;
  if ((flags & FLAG_REFERENCE) != 0) lut = vertex_reference;

  // The LUT already accounts for the local sphere of radius r shadowing itself past the
  // terminator (the light it wraps there comes through that sphere), but the shadow map finds
  // the same points shadowed and would kill that light. So the diffuse term ignores occluders
  // nearer than the local sphere's chord along the light, 2r·max(-N·L, 0), plus a margin for
  // faceted meshes (transmit.w): a nose still shadows the cheek, a ball no longer shadows its
  // own wrap. The specular term takes the plain shadow.
  float ngl = dot(ng, l);
  float shadow = shadow_factor_1tap(world_position, ng);
  float self_chord = world_curvature > 0.0 ? min(2.0 * max(-ngl, 0.0) / world_curvature, 1e6) : (ngl < 0.0 ? 1e6 : 0.0);
  // At grazing light a faceted silhouette in the shadow map stands several texels in front of
  // the smooth surface (the shadow terminator problem): a slope-scaled margin hides it.
  float grazing = 2.0 * shadow_texel_world() * min(sqrt(max(1.0 - ngl * ngl, 0.0)) / max(abs(ngl), 0.05), 20.0);
  float diffuse_shadow = shadow_factor(world_position, ng, self_chord + draw.transmit.w + grazing);
  vec3 diffuse = albedo / PI * lut * light * diffuse_shadow;

  // Kelemen/Szirmay-Kalos: N·L ρ_s P(N·H, m) F / |L + V|², divided by π like the diffuse.
  float specular = 0.0;
  float ndl = dot(nd, l);
  if (ndl > 0.0) {
    vec3 h = l + v;
    float hh = dot(h, h);
    if (hh > 1e-12) {
      vec3 hn = h * inversesqrt(hh);
      float p = pow(2.0 * texture(skin_lut, lut_uv(vec2(dot(nd, hn), draw.params.x))).a, 10.0);
      float rho_s = draw.albedo_specular.a;
      if ((flags & FLAG_SPECULAR_MAP) != 0) rho_s *= texture(specular_map, uv).r;
      specular = ndl * rho_s * max(p * fresnel(dot(v, hn), F0_SKIN) / hh, 0.0) / PI * shadow;
    }
  }

  // Transmittance through thin parts (Jimenez et al. 2010) for surfaces turned from the light
  // that the light does not reach directly. Jimenez weights it by saturate(0.3 - N·L); here by
  // saturate(-N·L) (1 - shadow): near the terminator the LUT's wrap already carries the light
  // through the thin sliver of a convex surface, and where the shadow map says a point is the
  // first surface the light meets (faceted silhouettes at grazing light) nothing is transmitted.
  vec3 transmitted = vec3(0.0);
  vec3 profile = vec3(0.0);
  float thickness_mm = 0.0;
  float back = clamp(-ngl, 0.0, 1.0);
  if (draw.transmit.x > 0.0) {
    thickness_mm = thickness_world(world_position, ng) * draw.params.w;
    profile = transmittance_profile(thickness_mm * draw.transmit.x) * back * (1.0 - shadow);
    transmitted = albedo / PI * profile * light;
  }

  // Image-based ambient as the forward pass, with the per-channel normals for the diffuse.
  float intensity = frame.environment.x, rotation = frame.environment.y;
  float m = clamp(draw.params.x, 0.045, 1.0);
  float n_dot_v = max(dot(nd, v), 1e-4);
  float f_ambient = F0_SKIN + (max(1.0 - m, F0_SKIN) - F0_SKIN) * pow(1.0 - n_dot_v, 5.0);
  vec3 irradiance = vec3(evaluate_irradiance_sh(frame.irradiance_sh, n_r).r,
                         evaluate_irradiance_sh(frame.irradiance_sh, n_g).g,
                         evaluate_irradiance_sh(frame.irradiance_sh, n_b).b) * intensity;
  vec3 r = reflect(-v, nd);
  vec3 mirror = environment_glossy(environment_map, r, rotation, m) * intensity;
  vec3 glossy = mix(mirror, evaluate_irradiance_sh(frame.irradiance_sh, r) * intensity / PI, m);
  float horizon = clamp(1.0 + 1.3 * dot(r, ng), 0.0, 1.0);  // Jimenez et al. 2016's fade below the surface
  glossy *= horizon * horizon;
  vec3 ambient = (1.0 - f_ambient) * albedo * irradiance / PI + f_ambient * glossy;

  vec3 color = diffuse + specular * light + transmitted + ambient;
  if (debug_view == DEBUG_CURVATURE) color = vec3(curvature);
  else if (debug_view == DEBUG_DIFFUSE) color = lut;
  else if (debug_view == DEBUG_TRANSMITTANCE) color = profile;
  else if (debug_view == DEBUG_THICKNESS) color = vec3(thickness_mm / 10.0);
  out_color = vec4(color, 1.0);
}
