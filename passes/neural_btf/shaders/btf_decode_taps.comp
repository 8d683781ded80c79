#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// The batched path's decode for the paper's decoder shape (see btf_decode_taps.glsl).
#define BTF_TILED_PAPER
#include "btf_decode_taps.glsl"
