#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// NeuralBTFMaterial's fragment stage for any decoder shape (see neural_btf_fragment.glsl).
#include "neural_btf_fragment.glsl"
