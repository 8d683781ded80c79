#version 460
#extension GL_GOOGLE_include_directive : require
// The environment where nothing was drawn: depth-tested (LessEqual) at the far plane.
#include "frame.glsl"
layout(set = 0, binding = 0) uniform Frame { FrameData frame; };
layout(set = 0, binding = 1) uniform sampler2D environment_map;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 out_color;
void main() {
  vec4 far_point = frame.inverse_view_projection * vec4(uv * 2.0 - 1.0, 1.0, 1.0);
  vec3 direction = normalize(far_point.xyz / far_point.w - frame.camera_position.xyz);
  vec3 radiance = textureLod(environment_map, equirect_uv(direction, frame.environment.y), 0.0).rgb;
  out_color = vec4(radiance * frame.environment.x, 1.0);
}
