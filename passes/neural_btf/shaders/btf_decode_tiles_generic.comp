#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// The batched material path for any decoder shape: btf_decode per row (see btf_decode_tiles.glsl).
#include "btf_decode_tiles.glsl"
