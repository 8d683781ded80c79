#version 460
#extension GL_GOOGLE_include_directive : require
// A temporal pass's (linear) history back in its input's encoding (weft.frame's
// TemporalPipelines, for accumulate and taa): 8-bit colour targets are display-encoded.
#include "frame.glsl"
layout(set = 0, binding = 0) uniform sampler2D history;
layout(push_constant) uniform Settings { uint display_encoded; } settings;
layout(location = 0) out vec4 out_color;

void main() {
  vec4 c = texelFetch(history, ivec2(gl_FragCoord.xy), 0);
  out_color = settings.display_encoded != 0u ? vec4(linear_to_srgb(c.rgb), c.a) : c;
}
