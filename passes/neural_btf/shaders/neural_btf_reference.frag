#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// NeuralBTFMaterial's reference mode: the same fragment stage (frame, taps, shadow, ambient)
// with the raw BTF sampled (btf_reference.glsl) where the neural mode decodes.
#define BTF_REFERENCE 1
#include "neural_btf_fragment.glsl"
