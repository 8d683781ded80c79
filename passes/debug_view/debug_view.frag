#version 460
#extension GL_GOOGLE_include_directive : require
// A picture of the camera's depth: view 0 shows distance (white at `near`, black at `far`,
// linear in metres between), view 1 world-space normals reconstructed from the depth's screen
// derivatives (n * 0.5 + 0.5; geometric normals, not the materials' normal maps). Texels at
// the far plane (nothing drawn) are black.
#include "frame.glsl"
layout(set = 0, binding = 0) uniform sampler2D depth;
layout(set = 0, binding = 1) uniform Frame { FrameData frame; };
layout(push_constant) uniform View { uint view; float near_distance; float far_distance; } settings;
layout(location = 0) out vec4 out_color;

void main() {
  ivec2 texel = ivec2(gl_FragCoord.xy);
  float d = texelFetch(depth, texel, 0).r;
  vec2 ndc = (vec2(texel) + 0.5) * frame.viewport.zw * 2.0 - 1.0;
  vec4 p = frame.inverse_view_projection * vec4(ndc, d, 1.0);
  vec3 world = p.xyz / p.w;
  vec3 n = normalize(cross(dFdx(world), dFdy(world)));
  if (d >= 1.0) {
    out_color = vec4(0.0, 0.0, 0.0, 1.0);
    return;
  }
  if (settings.view == 0u) {
    float distance_m = length(world - frame.camera_position.xyz);
    float t = clamp((distance_m - settings.near_distance) / max(settings.far_distance - settings.near_distance, 1e-6), 0.0, 1.0);
    out_color = vec4(vec3(1.0 - t), 1.0);
  } else {
    // dFdx/dFdy point along +x right, +y down the screen: flip so normals face the camera.
    if (dot(n, frame.camera_position.xyz - world) < 0.0) n = -n;
    out_color = vec4(n * 0.5 + 0.5, 1.0);
  }
}
