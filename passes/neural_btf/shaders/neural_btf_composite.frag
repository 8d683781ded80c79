#version 460
#extension GL_GOOGLE_include_directive : require
// The batched path's last step: the cloth drawn a second time, into the scene colour and depth
// -- depth-tested there (per sample in an MSAA frame) -- and every pixel it covers takes the
// radiance its one decode gave (shaded once per pixel, as MSAA shades). The G-buffer covers
// only the objects' rectangle, whose corner in the frame is draw.debug.zw. An edge pixel whose
// centre the cloth missed has no decode of its own (the G-buffer is one sample per pixel): it
// takes a marked neighbour's, the nearest one in its 3x3.
#include "frame.glsl"
#include "neural_btf_common.glsl"
layout(set = 1, binding = 0) uniform sampler2D g_marker;  // r: marker, 0 where no neural BTF pixel
layout(std430, set = 1, binding = 1) readonly buffer Radiance { float radiance[]; };  // rgb per G-buffer pixel
layout(location = 0) out vec4 out_color;
void main() {
  ivec2 size = textureSize(g_marker, 0);
  ivec2 px = ivec2(gl_FragCoord.xy) - ivec2(draw.debug.zw);
  ivec2 found = ivec2(-1);
  if (all(greaterThanEqual(px, ivec2(0))) && all(lessThan(px, size)) && texelFetch(g_marker, px, 0).r != 0.0) {
    found = px;
  } else {
    // The four edge neighbours first (nearer), then the corners.
    const ivec2 around[8] = ivec2[8](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1),
                                     ivec2(1, 1), ivec2(-1, 1), ivec2(1, -1), ivec2(-1, -1));
    for (int k = 0; k < 8; ++k) {
      ivec2 q = clamp(px + around[k], ivec2(0), size - 1);
      if (texelFetch(g_marker, q, 0).r != 0.0) {
        found = q;
        break;
      }
    }
  }
  if (found.x < 0) discard;  // a sliver no decode reached: the samples keep what was there
  uint i = 3u * (uint(found.y) * uint(size.x) + uint(found.x));
  out_color = vec4(radiance[i], radiance[i + 1u], radiance[i + 2u], 1.0);
}
