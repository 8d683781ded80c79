#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// The decode kernel with the paper's decoder shape compiled in (see btf_decode.glsl).
#define BTF_PAPER_SHAPE
#include "btf_decode_kernel.glsl"
