// The fragment shader of shells (FUR_SHELL), fins (FUR_FIN) and the naive method's shells
// (FUR_NAIVE): keep the texel if the layer's band says so, then shade it. Under MSAA
// (draw.specular.w = 1, alpha-to-coverage on) the band's edges become a coverage ramp one
// screen-space texel wide instead of a hard test, so a hair's edge covers some of a pixel's
// samples rather than all or none.
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec4 world_tangent;
#ifdef FUR_PER_SAMPLE
// Each sample of an MSAA pixel looks its own texel up and keeps or drops itself: the hair
// test supersampled, as accumulating jittered frames would (the shader runs per sample).
layout(location = 3) sample in vec2 uv;
#else
layout(location = 3) in vec2 uv;
#endif
layout(location = 4) flat in int shell_layer;
#ifdef FUR_FIN
layout(location = 5) in float fin_height;
#endif
layout(location = 0) out vec4 out_color;

// 1 inside [lo, hi), 0 outside, ramping over one pixel's change of `a` at each end.
float band_coverage(float a, float lo, float hi) {
  float w = max(fwidth(a), 1e-4);
  return clamp((a - lo) / w + 0.5, 0.0, 1.0) * clamp((hi - a) / w + 0.5, 0.0, 1.0);
}

void main() {
#ifdef FUR_PER_SAMPLE
  bool coverage = false;  // each sample tests its own texel: a hard test per sample
#else
  bool coverage = draw.specular.w > 0.5;
#endif
  float alpha = 1.0;
  int layers = int(draw.uv_layers.z + 0.5);
#ifdef FUR_FIN
  int layer = clamp(int(floor((1.0 - fin_height) * float(layers) + 0.5)), 0, layers);
#else
  int layer = clamp(shell_layer, 0, layers);
#endif
  vec2 st = uv * draw.uv_layers.xy;
  vec4 texel = texture(photo, st);
#ifdef FUR_NAIVE
  if (coverage) alpha = band_coverage(texel.a, 0.5, 2.0);
  else if (texel.a < 0.5) discard;
  vec3 albedo = texel.rgb;
#else
  FurLayer band = bands[layer];
  if (coverage) alpha = band_coverage(texel.a, band.keep_min, band.keep_max);
  else if (texel.a < band.keep_min || texel.a >= band.keep_max) discard;
  vec3 albedo = texel.a > band.top ? texel.rgb * (code_to_luminance(max(band.top, 0.0)) / code_to_luminance(texel.a))
                                    : texel.rgb;
#endif
  albedo *= draw.tint_thickness.rgb;
  vec3 n = normalize(world_normal);
  vec3 hair = draw.uv_layers.w < 0.5 ? n : hair_tangent(n, world_tangent, st);
  if (alpha <= 0.0) discard;
  out_color = vec4(fur_shade(albedo, world_position, n, hair), alpha);
}
