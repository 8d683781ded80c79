#version 460
#extension GL_GOOGLE_include_directive : require
// TAA's (linear) history back in the input's encoding.
#include "frame.glsl"
layout(set = 0, binding = 0) uniform sampler2D history;
layout(push_constant) uniform Settings {
  mat4 reprojection;
  vec2 jitter_uv;
  float alpha;
  uint flags;
} settings;
layout(location = 0) out vec4 out_color;

void main() {
  vec4 c = texelFetch(history, ivec2(gl_FragCoord.xy), 0);
  out_color = (settings.flags & 1u) != 0u ? vec4(linear_to_srgb(c.rgb), 1.0) : c;
}
