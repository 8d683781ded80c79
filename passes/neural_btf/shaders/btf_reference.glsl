// The raw BTF on the GPU, sampled as weft::btf::sample_reference samples it on the CPU: the
// reference mode of NeuralBTFMaterial (neural_btf_reference.frag), so a rendered neural cushion
// can be compared pixel for pixel with its data. The includer defines BTF_MODEL_SET and
// BTF_MODEL_BINDING.
//
// One read-only storage buffer (weft::passes::pack_reference), 32-bit words:
//   shape    x lights, y views, z texel width, w texel height (the crop that fit)
//   values   the light directions then the view directions (unit tangent-frame vectors,
//            4 floats each, w unused), then the samples in weft::btf::Btf's layout:
//            ((texel * lights + l) * views + v) * 3 + c
#ifndef WEFT_BTF_REFERENCE_GLSL
#define WEFT_BTF_REFERENCE_GLSL

layout(std430, set = BTF_MODEL_SET, binding = BTF_MODEL_BINDING) readonly buffer NeuralBtfReference {
  uvec4 shape;
  float values[];
} btf_raw;

// The same projection as btf_decode.glsl's (the fragment stage hands its taps ω as stereographic
// points); the reference mode includes only this file, so it has its own copy.
vec2 btf_stereographic(vec3 d) {
  float len = length(d);
  if (!(len > 0.0)) return vec2(0.0);
  d /= len;
  return d.xy / (1.0 + d.z);
}

// The unit direction whose stereographic point is s: z = (1 − |s|²) / (1 + |s|²), xy = 2s / (1 + |s|²).
vec3 btf_from_stereographic(vec2 s) {
  float r2 = dot(s, s);
  return vec3(2.0 * s, 1.0 - r2) / (1.0 + r2);
}

vec3 btf_reference_direction(uint i) { return vec3(btf_raw.values[4u * i], btf_raw.values[4u * i + 1u], btf_raw.values[4u * i + 2u]); }

// weft::btf::interpolation_weights over directions [first, first + count): the 3 nearest by
// squared chord distance (ties: the lower index), weights 1/d² − 1/d₄², exact at a measured
// direction. Returns the count of directions used (at most 3).
uint btf_reference_weights(uint first, uint count, vec3 direction, out uint index[3], out float weight[3]) {
  float len = length(direction);
  vec3 q = len > 0.0 ? direction / len : vec3(0.0, 0.0, 1.0);
  const float inf = 1.0 / 0.0;
  float d2[4] = float[4](inf, inf, inf, inf);
  uint idx[4] = uint[4](0u, 0u, 0u, 0u);
  for (uint i = 0u; i < count; ++i) {
    vec3 diff = btf_reference_direction(first + i) - q;
    float d = dot(diff, diff);
    if (d >= d2[3]) continue;
    int k = 3;
    while (k > 0 && d < d2[k - 1]) {
      d2[k] = d2[k - 1];
      idx[k] = idx[k - 1];
      --k;
    }
    d2[k] = d;
    idx[k] = i;
  }
  uint used = min(3u, count);
  for (uint k = 0u; k < 3u; ++k) {
    index[k] = idx[k];
    weight[k] = 0.0;
  }
  if (d2[0] <= 1e-12) {
    weight[0] = 1.0;
    return used;
  }
  float cutoff = count > 3u ? 1.0 / d2[3] : 0.0;
  float sum = 0.0;
  for (uint k = 0u; k < used; ++k) {
    weight[k] = max(0.0, 1.0 / d2[k] - cutoff);
    sum += weight[k];
  }
  if (sum <= 0.0) {  // all four equally far: equal weights
    for (uint k = 0u; k < used; ++k) weight[k] = 1.0;
    sum = float(used);
  }
  for (uint k = 0u; k < used; ++k) weight[k] /= sum;
  return used;
}

uvec2 btf_reference_grid() { return btf_raw.shape.zw; }

// The raw BTF of `texel` at ω_i and ω_o given as stereographic points (as the fragment's taps
// hold them): the 3 x 3 samples of the nearest measured lights and views, blended.
vec3 btf_reference(uint texel, vec2 si, vec2 so) {
  uint lights = btf_raw.shape.x, views = btf_raw.shape.y;
  uint li[3], vi[3];
  float lw[3], vw[3];
  uint nl = btf_reference_weights(0u, lights, btf_from_stereographic(si), li, lw);
  uint nv = btf_reference_weights(lights, views, btf_from_stereographic(so), vi, vw);
  uint samples = 4u * (lights + views);
  vec3 sum = vec3(0.0);
  for (uint a = 0u; a < nl; ++a) {
    if (lw[a] == 0.0) continue;
    for (uint b = 0u; b < nv; ++b) {
      if (vw[b] == 0.0) continue;
      uint at = samples + ((texel * lights + li[a]) * views + vi[b]) * 3u;
      sum += lw[a] * vw[b] * vec3(btf_raw.values[at], btf_raw.values[at + 1u], btf_raw.values[at + 2u]);
    }
  }
  return sum;
}
#endif
