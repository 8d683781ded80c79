#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// NeuralBTFMaterial's fragment stage with the paper's decoder shape compiled in (btf_decode.glsl).
#define BTF_PAPER_SHAPE
#include "neural_btf_fragment.glsl"
