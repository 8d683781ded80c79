#version 460
#extension GL_GOOGLE_include_directive : require
// Outlines where the distance to the camera jumps: a texel is on an edge when a neighbour
// `thickness` texels away (left, right, up, down) is further or nearer by more than
// `threshold` times the nearer of the two (relative, so it holds at every scale). Nothing
// drawn counts as infinitely far, so silhouettes against the sky are edges. Off the edges the
// colour passes through untouched: a flat depth writes the input exactly.
#include "frame.glsl"
layout(set = 0, binding = 0) uniform sampler2D color;
layout(set = 0, binding = 1) uniform sampler2D depth;
layout(set = 0, binding = 2) uniform Frame { FrameData frame; };
layout(push_constant) uniform Settings { float threshold; int thickness; float brightness; } settings;
layout(location = 0) out vec4 out_color;

float distance_at(ivec2 t) {
  ivec2 size = textureSize(depth, 0);
  t = clamp(t, ivec2(0), size - 1);
  float d = texelFetch(depth, t, 0).r;
  if (d >= 1.0) return 1e30;
  vec2 ndc = (vec2(t) + 0.5) * frame.viewport.zw * 2.0 - 1.0;
  vec4 p = frame.inverse_view_projection * vec4(ndc, d, 1.0);
  return length(p.xyz / p.w - frame.camera_position.xyz);
}

void main() {
  ivec2 t = ivec2(gl_FragCoord.xy);
  vec4 c = texelFetch(color, t, 0);
  float here = distance_at(t);
  bool edge = false;
  int k = settings.thickness;
  for (int i = 0; i < 4; ++i) {
    ivec2 o = i == 0 ? ivec2(k, 0) : i == 1 ? ivec2(-k, 0) : i == 2 ? ivec2(0, k) : ivec2(0, -k);
    float there = distance_at(t + o);
    float nearer = min(here, there);
    if (nearer < 1e29 && abs(there - here) > settings.threshold * nearer) edge = true;
  }
  out_color = edge ? vec4(vec3(settings.brightness), c.a) : c;
}
