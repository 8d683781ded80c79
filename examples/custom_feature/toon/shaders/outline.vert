#version 460
#extension GL_GOOGLE_include_directive : require
// The outline: the mesh grown along its normals by the outline width, drawn with its front
// faces culled, so only the rim around the object shows (the "inverted hull").
#define WEFT_VERTEX_INPUTS
#include "frame.glsl"
#include "toon_common.glsl"
void main() {
  vec3 grown = in_position + normalize(in_normal) * draw.outline_color_width.w;
  gl_Position = frame.view_projection * (draw.model * vec4(grown, 1.0));
}
