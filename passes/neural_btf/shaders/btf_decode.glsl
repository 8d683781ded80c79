// The neural BTF decoder on the GPU, shared by the material's fragment shader and the
// decode kernel (tests, benchmark): the arithmetic of weft::btf::decode on the CPU. The
// includer defines BTF_MODEL_SET and BTF_MODEL_BINDING.
//
// One read-only storage buffer holds the whole model (weft::passes::pack_model), in vec4s so
// that the inner loop is 4x4 blocks (four dot products per four loaded weight vectors):
//   shape    x layer count, y latent size, z texel width, w texel height
//   offsets  in vec4s into values: x latents (each padded to whole vec4s), y cluster ids (as
//            floats, 4 per vec4; ~0u: none), z scales (4 per vec4; ~0u: none)
//   scales   x output scale (the training targets' global max)
//   layers   per layer: inputs / 4, outputs / 4 (both padded up with zero weights), weight
//            offset (row-major, one row of inputs / 4 vec4s per output), bias offset
//   values   everything else, fp32
#ifndef WEFT_BTF_DECODE_GLSL
#define WEFT_BTF_DECODE_GLSL

const uint BTF_MAX_LAYERS = 8;
const uint BTF_MAX_WIDTH4 = 32;  // widest layer (and latent + 4) the shader evaluates: 128
const uint BTF_NONE = 0xffffffffu;

layout(std430, set = BTF_MODEL_SET, binding = BTF_MODEL_BINDING) readonly buffer NeuralBtfModel {
  uvec4 shape;
  uvec4 offsets;
  vec4 scales;
  uvec4 layers[BTF_MAX_LAYERS];
  vec4 values[];
} btf_model;

// Stereographic projection of a tangent-frame direction (z = normal): (x, y) / (1 + z) of the
// unit vector, tan(θ/2) from the origin; (0, 0) at θ = 0, the unit circle at θ = 90°. Below
// the horizon (z < 0) the caller clamps first.
vec2 btf_stereographic(vec3 d) {
  float len = length(d);
  if (!(len > 0.0)) return vec2(0.0);
  d /= len;
  return d.xy / (1.0 + d.z);
}

float btf_scalar(uint offset4, uint i) { return btf_model.values[offset4 + (i >> 2)][i & 3u]; }

// The texel's latent index (its cluster's when the model is clustered).
uint btf_latent_index(uint texel) {
  uint ids = btf_model.offsets.y;
  return ids == BTF_NONE ? texel : uint(btf_scalar(ids, texel));
}

#ifdef BTF_PAPER_SHAPE
// The paper's decoder, 8 + 4 -> 106 -> 106 -> 106 -> 3, with its shape compiled in: the loop
// over a layer's inputs is unrolled ([[unroll]] with a constant bound), so the activations it
// reads are at constant indices, and only each output's store is indexed at run time. (Unrolling
// the output loops too makes one ~25k-FMA block that LLVM in lavapipe needs over 20 GB to compile.)
const uint BTF_IN4 = 3, BTF_H4 = 27;
#define BTF_DENSE(LAYER, IN4, OUT4, X, Y, RELU)                                      \
  {                                                                                \
    uvec4 d = btf_model.layers[LAYER];                                             \
    [[dont_unroll]] for (uint o = 0; o < OUT4; ++o) {                              \
      vec4 s = btf_model.values[d.w + o];                                          \
      uint row = d.z + 4u * o * IN4;                                               \
      [[unroll]] for (uint i = 0; i < IN4; ++i) {                                  \
        s.x += dot(btf_model.values[row + i], X[i]);                               \
        s.y += dot(btf_model.values[row + IN4 + i], X[i]);                         \
        s.z += dot(btf_model.values[row + 2u * IN4 + i], X[i]);                    \
        s.w += dot(btf_model.values[row + 3u * IN4 + i], X[i]);                    \
      }                                                                            \
      Y[o] = RELU ? max(s, vec4(0.0)) : s;                                         \
    }                                                                              \
  }

vec3 btf_decode(uint texel, vec2 si, vec2 so) {
  uint base = btf_model.offsets.x + btf_latent_index(texel) * 2u;
  vec4 x[BTF_IN4];
  x[0] = btf_model.values[base];
  x[1] = btf_model.values[base + 1u];
  x[2] = vec4(si, so);
  vec4 h1[BTF_H4], h2[BTF_H4];
  vec4 y[1];
  BTF_DENSE(0, BTF_IN4, BTF_H4, x, h1, true)
  BTF_DENSE(1, BTF_H4, BTF_H4, h1, h2, true)
  BTF_DENSE(2, BTF_H4, BTF_H4, h2, h1, true)
  BTF_DENSE(3, BTF_H4, 1, h1, y, false)
  float scale = btf_model.scales.x;
  if (btf_model.offsets.z != BTF_NONE) scale *= btf_scalar(btf_model.offsets.z, texel);
  return max(y[0].xyz, vec3(0.0)) * scale;
}
#else
// max(0, MLP(latent, stereo(ω_i), stereo(ω_o))) * output scale * texel scale: linear RGB.
vec3 btf_decode(uint texel, vec2 si, vec2 so) {
  vec4 a[BTF_MAX_WIDTH4];
  vec4 b[BTF_MAX_WIDTH4];
  uint latent_size = btf_model.shape.y;
  uint latent4 = (latent_size + 3u) >> 2;
  uint input4 = (latent_size + 7u) >> 2;
  uint base = btf_model.offsets.x + btf_latent_index(texel) * latent4;
  for (uint i = 0; i < latent4; ++i) a[i] = btf_model.values[base + i];
  for (uint i = latent4; i < input4; ++i) a[i] = vec4(0.0);
  a[(latent_size + 0u) >> 2][(latent_size + 0u) & 3u] = si.x;
  a[(latent_size + 1u) >> 2][(latent_size + 1u) & 3u] = si.y;
  a[(latent_size + 2u) >> 2][(latent_size + 2u) & 3u] = so.x;
  a[(latent_size + 3u) >> 2][(latent_size + 3u) & 3u] = so.y;
  uint layer_count = btf_model.shape.x;
  for (uint l = 0; l < layer_count; ++l) {
    uvec4 layer = btf_model.layers[l];
    bool hidden = l + 1 < layer_count;
    for (uint o = 0; o < layer.y; ++o) {
      vec4 sum = btf_model.values[layer.w + o];
      uint row = layer.z + 4u * o * layer.x;  // four output rows of layer.x vec4s each
      for (uint i = 0; i < layer.x; ++i) {
        vec4 x = a[i];
        sum.x += dot(btf_model.values[row + i], x);
        sum.y += dot(btf_model.values[row + layer.x + i], x);
        sum.z += dot(btf_model.values[row + 2u * layer.x + i], x);
        sum.w += dot(btf_model.values[row + 3u * layer.x + i], x);
      }
      b[o] = hidden ? max(sum, vec4(0.0)) : sum;
    }
    for (uint o = 0; o < layer.y; ++o) a[o] = b[o];
  }
  float scale = btf_model.scales.x;
  if (btf_model.offsets.z != BTF_NONE) scale *= btf_scalar(btf_model.offsets.z, texel);
  return max(a[0].xyz, vec3(0.0)) * scale;
}

#endif  // BTF_PAPER_SHAPE

#endif
