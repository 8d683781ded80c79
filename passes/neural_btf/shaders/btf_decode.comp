#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// The decode kernel for any decoder shape (see btf_decode_kernel.glsl).
#include "btf_decode_kernel.glsl"
