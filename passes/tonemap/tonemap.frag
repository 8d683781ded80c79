#version 460
#extension GL_GOOGLE_include_directive : require
// HDR scene colour -> display: exposure, then ACES (Narkowicz's fit) or none, then sRGB.
#include "frame.glsl"
layout(set = 0, binding = 0) uniform sampler2D scene_color;
layout(push_constant) uniform Settings { float exposure; uint operator_kind; } settings;
layout(location = 0) out vec4 out_color;

vec3 aces_fitted(vec3 x) {
  const float a = 2.51, b = 0.03, c = 2.43, d = 0.59, e = 0.14;
  return clamp((x * (a * x + b)) / (x * (c * x + d) + e), 0.0, 1.0);
}

void main() {
  vec3 hdr = texelFetch(scene_color, ivec2(gl_FragCoord.xy), 0).rgb * settings.exposure;
  hdr = max(hdr, vec3(0.0));
  if (any(isnan(hdr)) || any(isinf(hdr))) hdr = vec3(1.0, 0.0, 1.0);  // make bad pixels loud
  vec3 mapped = settings.operator_kind == 1u ? aces_fitted(hdr) : clamp(hdr, 0.0, 1.0);
  out_color = vec4(linear_to_srgb(mapped), 1.0);
}
