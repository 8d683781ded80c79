// The fragment shader of shells (FUR_SHELL), fins (FUR_FIN) and the naive method's shells
// (FUR_NAIVE): keep the texel if the layer's band says so, then shade it.
layout(location = 0) in vec3 world_position;
layout(location = 1) in vec3 world_normal;
layout(location = 2) in vec4 world_tangent;
layout(location = 3) in vec2 uv;
layout(location = 4) flat in int shell_layer;
#ifdef FUR_FIN
layout(location = 5) in float fin_height;
#endif
layout(location = 0) out vec4 out_color;

void main() {
  int layers = int(draw.uv_layers.z + 0.5);
#ifdef FUR_FIN
  int layer = clamp(int(floor((1.0 - fin_height) * float(layers) + 0.5)), 0, layers);
#else
  int layer = clamp(shell_layer, 0, layers);
#endif
  vec2 st = uv * draw.uv_layers.xy;
  vec4 texel = texture(photo, st);
#ifdef FUR_NAIVE
  if (texel.a < 0.5) discard;
  vec3 albedo = texel.rgb;
#else
  FurLayer band = bands[layer];
  if (texel.a < band.keep_min || texel.a >= band.keep_max) discard;
  vec3 albedo = texel.a > band.top ? texel.rgb * (code_to_luminance(max(band.top, 0.0)) / code_to_luminance(texel.a))
                                    : texel.rgb;
#endif
  albedo *= draw.tint_thickness.rgb;
  vec3 n = normalize(world_normal);
  vec3 hair = draw.uv_layers.w < 0.5 ? n : hair_tangent(n, world_tangent, st);
  out_color = vec4(fur_shade(albedo, world_position, n, hair), 1.0);
}
