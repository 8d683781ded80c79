#version 460
// One step of the running mean: history' = mix(history, current, weight), weight = 1 / n for
// the n-th sample (up to the pass's `frames`, then an exponential average of about that many).
// Display-encoded (8-bit sRGB) colour is averaged as light, not as code values, so the result
// is what a box filter of the supersampled image gives.
layout(set = 0, binding = 0) uniform sampler2D current;
layout(set = 0, binding = 1) uniform sampler2D history;
layout(push_constant) uniform Settings { float weight; uint display_encoded; } settings;
layout(location = 0) out vec4 out_color;

vec3 srgb_to_linear(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), c));
}

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 c = texelFetch(current, p, 0);
  if (settings.display_encoded != 0u) c.rgb = srgb_to_linear(c.rgb);
  // The first sample never reads the history: it is undefined then (and may hold NaN).
  if (settings.weight >= 1.0) {
    out_color = c;
    return;
  }
  out_color = mix(texelFetch(history, p, 0), c, settings.weight);
}
