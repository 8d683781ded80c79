#version 460
#extension GL_GOOGLE_include_directive : require
#define FUR_NAIVE
#include "frame.glsl"
#include "fur_common.glsl"
#include "fur_fragment.glsl"
