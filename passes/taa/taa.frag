#version 460
// One step of TAA: the history reprojected through this pixel's depth into the last frame
// (clip to clip: `reprojection`), clamped to the current 3x3 neighbourhood, blended in.
// Display-encoded colour is blended as light.
layout(set = 0, binding = 0) uniform sampler2D current;
layout(set = 0, binding = 1) uniform sampler2D depth;
layout(set = 0, binding = 2) uniform sampler2D history;
layout(push_constant) uniform Settings {
  mat4 reprojection;   // unjittered NDC of this frame -> clip of the last frame
  vec2 jitter_uv;      // this frame's jitter in uv units (the projection's offset)
  float alpha;         // the current frame's weight; >= 1: no history
  uint flags;          // 1: display-encoded colour, 2: neighbourhood clamp
} settings;
layout(location = 0) out vec4 out_color;

vec3 srgb_to_linear(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), c));
}
vec3 fetch(ivec2 p) {
  vec3 c = texelFetch(current, clamp(p, ivec2(0), textureSize(current, 0) - 1), 0).rgb;
  return (settings.flags & 1u) != 0u ? srgb_to_linear(c) : c;
}

// The history at `uv` through a Catmull-Rom filter (16 texels): bilinear reads, repeated every
// frame at the sub-pixel offsets a moving camera gives, blur the history until it is softer than
// the supersampled image; Catmull-Rom keeps it sharp (it can overshoot: the clamp bounds it).
vec3 history_at(vec2 uv) {
  vec2 size = vec2(textureSize(history, 0));
  vec2 texel = uv * size - 0.5;
  vec2 base = floor(texel), f = texel - base;
  vec2 w0 = f * (-0.5 + f * (1.0 - 0.5 * f));
  vec2 w1 = 1.0 + f * f * (-2.5 + 1.5 * f);
  vec2 w2 = f * (0.5 + f * (2.0 - 1.5 * f));
  vec2 w3 = f * f * (-0.5 + 0.5 * f);
  vec2 w[4] = vec2[4](w0, w1, w2, w3);
  ivec2 hi = textureSize(history, 0) - 1;
  vec3 sum = vec3(0.0);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      ivec2 q = clamp(ivec2(base) + ivec2(x - 1, y - 1), ivec2(0), hi);
      sum += texelFetch(history, q, 0).rgb * (w[x].x * w[y].y);
    }
  return max(sum, vec3(0.0));
}

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec3 c = fetch(p);
  if (settings.alpha >= 1.0) {  // no history yet (undefined: it may hold NaN)
    out_color = vec4(c, 1.0);
    return;
  }
  // The pixel's motion between the unjittered cameras, applied to its centre: a still view
  // reads its own history texel exactly (no resampling blur building up frame after frame).
  vec2 size = vec2(textureSize(current, 0));
  vec2 centre = (vec2(p) + 0.5) / size;
  vec2 uv = centre - settings.jitter_uv;
  // The nearest depth of the 3x3 (Karis 2014): an edge pixel moves with the object in front,
  // so the history follows the edge instead of smearing it where the background shows again.
  float d = 1.0;
  ivec2 depth_size = textureSize(depth, 0) - 1;
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) d = min(d, texelFetch(depth, clamp(p + ivec2(x, y), ivec2(0), depth_size), 0).r);
  vec4 last = settings.reprojection * vec4(uv * 2.0 - 1.0, d, 1.0);
  vec2 last_uv = centre - (uv - (last.xy / last.w * 0.5 + 0.5));
  if (!(last.w > 0.0) || any(lessThan(last_uv, vec2(0.0))) || any(greaterThan(last_uv, vec2(1.0)))) {
    out_color = vec4(c, 1.0);  // it was off screen: nothing to blend with
    return;
  }
  vec3 h = history_at(last_uv);
  if ((settings.flags & 2u) != 0u) {
    // Variance clipping (Salvi 2016): the history clamped to the neighbourhood's mean +- its
    // standard deviation, within its min and max -- tighter than the min/max box alone.
    vec3 lo = c, hi = c, m1 = vec3(0.0), m2 = vec3(0.0);
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x) {
        vec3 n = fetch(p + ivec2(x, y));
        lo = min(lo, n);
        hi = max(hi, n);
        m1 += n;
        m2 += n * n;
      }
    vec3 mean = m1 / 9.0, sigma = sqrt(max(m2 / 9.0 - mean * mean, vec3(0.0)));
    h = clamp(h, max(lo, mean - sigma), min(hi, mean + sigma));
  }
  out_color = vec4(mix(h, c, settings.alpha), 1.0);
}
