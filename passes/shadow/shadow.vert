#version 460
#extension GL_GOOGLE_include_directive : require
// Depth-only: positions in the key light's clip space.
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
layout(push_constant) uniform Draw { mat4 light_mvp; } draw;
void main() { gl_Position = draw.light_mvp * vec4(in_position, 1.0); }
