// Which decodes a pixel of the batched path needs (docs/neural-btf.md, "The batched decode"),
// shared by the list (btf_list_taps.comp) and the decode (btf_decode_taps.glsl) so both see
// the same taps. A pixel's taps are bits of a mask: bit term * 4 + corner (term 0: the key light,
// 1: the ambient; corner 0..3 when bilinear, 0 when nearest), skipping a term whose weight is 0.
// The decode adds a pixel's taps in increasing bit order, the fragment path's order. Its popcount
// (1, 2, 4 or 8) is the pixel's class: how many decode rows it takes. The includer binds
// g_light, g_weights and g_marker (neural_btf_gbuffer.frag).
#ifndef WEFT_BTF_PIXEL_TAPS_GLSL
#define WEFT_BTF_PIXEL_TAPS_GLSL

const uint BTF_CLASSES = 4u;  // pixels of 1, 2, 4 and 8 taps

// The model pixel px is marked with in the G-buffer, or ~0u where there is none.
uint pixel_model(ivec2 px) {
  uint marker = uint(texelFetch(g_marker, px, 0).r + 0.5);
  return marker == 0u ? ~0u : (marker - 1u) >> 1;
}

bool pixel_bilinear(ivec2 px) { return ((uint(texelFetch(g_marker, px, 0).r + 0.5) - 1u) & 1u) != 0u; }

vec3 term_weight(ivec2 px, uint term) {
  vec4 weights = texelFetch(g_weights, px, 0);
  return term == 0u ? vec3(texelFetch(g_light, px, 0).zw, weights.x) : weights.yzw;
}

uint pixel_tap_mask(ivec2 px) {
  uint corners = pixel_bilinear(px) ? 0xfu : 0x1u, mask = 0u;
  if (term_weight(px, 0u) != vec3(0.0)) mask |= corners;
  if (term_weight(px, 1u) != vec3(0.0)) mask |= corners << 4;
  return mask;
}

// Class c's pixels take 1 << c rows each.
uint tap_class(uint mask) { return findLSB(bitCount(mask)); }

// The bit of the mask's j-th tap (j < bitCount(mask)).
uint nth_tap(uint mask, uint j) {
  for (uint i = 0u; i < j; ++i) mask &= mask - 1u;
  return findLSB(mask);
}

// Where class c's i-th pixel is in the list: two halves of `pixels` entries each; classes 0
// and 1 fill the first from either end, 2 and 3 the second (a pixel is in one class, nearest
// pixels in 0 or 1, bilinear ones in 2 or 3, so neither half overflows).
uint list_index(uint c, uint i, uint pixels) {
  uint half_start = (c >> 1) * pixels;
  return (c & 1u) == 0u ? half_start + i : half_start + pixels - 1u - i;
}

#endif
