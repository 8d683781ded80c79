// The neural BTF decoder on the GPU, shared by the material's fragment shader and the
// decode kernel (tests, benchmark): the same arithmetic as weft::btf::decode on the CPU.
// The includer defines BTF_MODEL_SET and BTF_MODEL_BINDING.
//
// One read-only storage buffer holds the whole model (weft::passes::pack_model):
//   shape    x layer count, y latent size, z texel width, w texel height
//   offsets  into values: x latents, y cluster ids (as floats; ~0u: none), z scales (~0u: none)
//   scales   x output scale (the training targets' global max)
//   layers   per layer: inputs, outputs, weight offset (row-major outputs x inputs), bias offset
//   values   everything else, fp32
#ifndef WEFT_BTF_DECODE_GLSL
#define WEFT_BTF_DECODE_GLSL

const uint BTF_MAX_LAYERS = 8;
const uint BTF_MAX_WIDTH = 128;  // widest layer (and latent + 4) the shader evaluates
const uint BTF_NONE = 0xffffffffu;

layout(std430, set = BTF_MODEL_SET, binding = BTF_MODEL_BINDING) readonly buffer NeuralBtfModel {
  uvec4 shape;
  uvec4 offsets;
  vec4 scales;
  uvec4 layers[BTF_MAX_LAYERS];
  float values[];
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

// The texel's latent index (its cluster's when the model is clustered).
uint btf_latent_index(uint texel) {
  uint ids = btf_model.offsets.y;
  return ids == BTF_NONE ? texel : uint(btf_model.values[ids + texel]);
}

// max(0, MLP(latent, stereo(ω_i), stereo(ω_o))) * output scale * texel scale: linear RGB.
vec3 btf_decode(uint texel, vec2 si, vec2 so) {
  float a[BTF_MAX_WIDTH];
  float b[BTF_MAX_WIDTH];
  uint latent_size = btf_model.shape.y;
  uint base = btf_model.offsets.x + btf_latent_index(texel) * latent_size;
  for (uint i = 0; i < latent_size; ++i) a[i] = btf_model.values[base + i];
  a[latent_size + 0] = si.x;
  a[latent_size + 1] = si.y;
  a[latent_size + 2] = so.x;
  a[latent_size + 3] = so.y;
  uint layer_count = btf_model.shape.x;
  uint width = latent_size + 4;
  for (uint l = 0; l < layer_count; ++l) {
    uvec4 layer = btf_model.layers[l];
    bool hidden = l + 1 < layer_count;
    for (uint o = 0; o < layer.y; ++o) {
      float sum = btf_model.values[layer.w + o];
      uint row = layer.z + o * layer.x;
      for (uint i = 0; i < layer.x; ++i) sum += btf_model.values[row + i] * a[i];
      b[o] = hidden ? max(sum, 0.0) : sum;
    }
    width = layer.y;
    for (uint o = 0; o < width; ++o) a[o] = b[o];
  }
  float scale = btf_model.scales.x;
  if (btf_model.offsets.z != BTF_NONE) scale *= btf_model.values[btf_model.offsets.z + texel];
  return max(vec3(a[0], a[1], a[2]), vec3(0.0)) * scale;
}

#endif
