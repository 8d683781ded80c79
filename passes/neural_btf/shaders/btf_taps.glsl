// Which BTF texels a texel coordinate reads, and with what weights: nearest (one tap) or
// bilinear (four). Shared by the fragment decode (neural_btf_surface.glsl) and the tiled
// compute decode (btf_decode_taps.glsl), so both read exactly the same texels.
#ifndef WEFT_BTF_TAPS_GLSL
#define WEFT_BTF_TAPS_GLSL

// Texel (x, y) covers [x, x + 1) x [y, y + 1) of st, wrapped.
uint texel_at(ivec2 xy, uvec2 grid) {
  ivec2 g = ivec2(grid);
  ivec2 w = ((xy % g) + g) % g;
  return uint(w.y) * grid.x + uint(w.x);
}

// Tap `corner` (0..3; nearest has only 0) of texel coordinate st: the texel and its weight.
uint btf_tap(vec2 st, uvec2 grid, bool bilinear, uint corner, out float weight) {
  if (!bilinear) {
    weight = 1.0;
    return texel_at(ivec2(floor(st)), grid);
  }
  vec2 p = st - 0.5;
  ivec2 i0 = ivec2(floor(p));
  vec2 f = p - vec2(i0);
  ivec2 o = ivec2(int(corner & 1u), int(corner >> 1));
  vec2 w2 = mix(1.0 - f, f, vec2(o));
  weight = w2.x * w2.y;
  return texel_at(i0 + o, grid);
}

#endif
