#version 460
// FXAA 3.11's quality algorithm (T. Lottes, NVIDIA 2011), written from its description. On the
// tone-mapped (display-encoded) colour, so the luma is perceptual:
//  1. skip pixels whose 4-neighbour luma range is below max(threshold_min, threshold * max);
//  2. blend sub-pixel features by how far the centre is from its 3x3 average (`subpixel`);
//  3. pick the edge's orientation from second differences, step half a texel onto the edge,
//     and search both ways along it (up to `steps` steps of growing size) for where the
//     luma leaves the edge's average;
//  4. move the sample across the edge by the distance to the nearer end (a pixel at an end
//     of a stair-step takes most of its neighbour; one in the middle keeps its own).
// Bilinear taps do the blending, so the sampler must filter linearly and clamp.
layout(set = 0, binding = 0) uniform sampler2D color;
layout(push_constant) uniform Settings {
  float threshold;
  float threshold_min;
  float subpixel;
  int steps;
} settings;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 out_color;

float luma(vec3 c) { return dot(c, vec3(0.299, 0.587, 0.114)); }
float luma_at(vec2 p) { return luma(textureLod(color, p, 0.0).rgb); }
float luma_off(vec2 p, ivec2 o) {
  ivec2 size = textureSize(color, 0);
  return luma(texelFetch(color, clamp(ivec2(p * vec2(size)) + o, ivec2(0), size - 1), 0).rgb);
}

// The search's step sizes in texels (FXAA's quality preset 39 spacing, 12 steps).
float step_size(int i) {
  const float sizes[12] = float[12](1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 2.0, 2.0, 2.0, 4.0, 8.0);
  return sizes[clamp(i, 0, 11)];
}

void main() {
  vec2 texel = 1.0 / vec2(textureSize(color, 0));
  vec2 p = (floor(gl_FragCoord.xy) + 0.5) * texel;
  vec4 centre = textureLod(color, p, 0.0);
  float m = luma(centre.rgb);
  float n = luma_off(p, ivec2(0, -1)), s = luma_off(p, ivec2(0, 1));
  float w = luma_off(p, ivec2(-1, 0)), e = luma_off(p, ivec2(1, 0));
  float hi = max(m, max(max(n, s), max(w, e)));
  float lo = min(m, min(min(n, s), min(w, e)));
  float range = hi - lo;
  if (range < max(settings.threshold_min, hi * settings.threshold)) {
    out_color = centre;
    return;
  }
  float nw = luma_off(p, ivec2(-1, -1)), ne = luma_off(p, ivec2(1, -1));
  float sw = luma_off(p, ivec2(-1, 1)), se = luma_off(p, ivec2(1, 1));

  // Sub-pixel aliasing: a centre unlike its neighbourhood (a thin line, a dot).
  float average = (2.0 * (n + s + w + e) + nw + ne + sw + se) / 12.0;
  float subpix = clamp(abs(average - m) / range, 0.0, 1.0);
  subpix = smoothstep(0.0, 1.0, subpix);
  subpix = subpix * subpix * settings.subpixel;

  // A horizontal edge changes luma vertically (north to south).
  float vertical_change = abs(0.25 * nw - 0.5 * n + 0.25 * ne) + abs(0.5 * w - m + 0.5 * e) +
                          abs(0.25 * sw - 0.5 * s + 0.25 * se);
  float horizontal_change = abs(0.25 * nw - 0.5 * w + 0.25 * sw) + abs(0.5 * n - m + 0.5 * s) +
                            abs(0.25 * ne - 0.5 * e + 0.25 * se);
  bool horizontal = horizontal_change >= vertical_change;

  // The side of the edge the centre is not on: the neighbour with the steeper gradient.
  float luma1 = horizontal ? n : w, luma2 = horizontal ? s : e;
  float gradient1 = luma1 - m, gradient2 = luma2 - m;
  bool towards1 = abs(gradient1) >= abs(gradient2);
  float gradient = 0.25 * max(abs(gradient1), abs(gradient2));
  float across = horizontal ? texel.y : texel.x;
  float edge_luma;
  if (towards1) {
    across = -across;
    edge_luma = 0.5 * (luma1 + m);
  } else {
    edge_luma = 0.5 * (luma2 + m);
  }

  // Onto the edge, then along it both ways until the luma leaves the edge's average.
  vec2 on_edge = p;
  if (horizontal) on_edge.y += 0.5 * across;
  else on_edge.x += 0.5 * across;
  vec2 along = horizontal ? vec2(texel.x, 0.0) : vec2(0.0, texel.y);
  vec2 p1 = on_edge - along, p2 = on_edge + along;
  float end1 = luma_at(p1) - edge_luma, end2 = luma_at(p2) - edge_luma;
  bool done1 = abs(end1) >= gradient, done2 = abs(end2) >= gradient;
  for (int i = 1; i < settings.steps && !(done1 && done2); ++i) {
    if (!done1) {
      p1 -= along * step_size(i);
      end1 = luma_at(p1) - edge_luma;
      done1 = abs(end1) >= gradient;
    }
    if (!done2) {
      p2 += along * step_size(i);
      end2 = luma_at(p2) - edge_luma;
      done2 = abs(end2) >= gradient;
    }
  }
  float distance1 = horizontal ? p.x - p1.x : p.y - p1.y;
  float distance2 = horizontal ? p2.x - p.x : p2.y - p.y;
  bool nearer1 = distance1 < distance2;
  float nearest = min(distance1, distance2);
  float span = distance1 + distance2;
  float offset = -nearest / span + 0.5;
  // Only where the luma at the nearer end moves away from the centre's side of the edge.
  bool centre_darker = m < edge_luma;
  bool moves = ((nearer1 ? end1 : end2) < 0.0) != centre_darker;
  float final_offset = max(moves ? offset : 0.0, subpix);

  vec2 q = p;
  if (horizontal) q.y += final_offset * across;
  else q.x += final_offset * across;
  out_color = vec4(textureLod(color, q, 0.0).rgb, centre.a);
}
