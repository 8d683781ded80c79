#version 460
#extension GL_GOOGLE_include_directive : require
// Depth-only: positions in the key light's clip space. Casters sharing a mesh are one
// instanced draw; each instance's light-space matrix is in the casters buffer.
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
layout(set = 0, binding = 0, std430) readonly buffer Casters { mat4 light_mvp[]; } casters;
void main() { gl_Position = casters.light_mvp[gl_InstanceIndex] * vec4(in_position, 1.0); }
