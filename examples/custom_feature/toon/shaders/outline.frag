#version 460
#extension GL_GOOGLE_include_directive : require
#include "frame.glsl"
#include "toon_common.glsl"
layout(location = 0) out vec4 out_color;
void main() { out_color = vec4(draw.outline_color_width.rgb, 1.0); }
