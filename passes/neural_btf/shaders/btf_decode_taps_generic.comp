#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// The batched path's decode for any decoder shape: btf_decode per row (see btf_decode_taps.glsl).
#include "btf_decode_taps.glsl"
