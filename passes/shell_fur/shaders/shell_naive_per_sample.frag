#version 460
#extension GL_GOOGLE_include_directive : require
// shell_naive.frag run once per sample (MSAA on an adapter with sample-rate shading).
#define FUR_NAIVE
#define FUR_PER_SAMPLE
#include "frame.glsl"
#include "fur_common.glsl"
#include "fur_fragment.glsl"
