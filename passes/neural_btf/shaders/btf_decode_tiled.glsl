// The neural BTF decoder as batched matrix products: each invocation decodes BTF_T_ROWS rows
// (texel, ω_i, ω_o) at once, a workgroup of 32 a batch of 256. Shared by the decode kernel's
// tiled variant (btf_decode_tiled.comp: tests, benchmark) and the batched material path
// (btf_decode_taps.glsl). The includer includes btf_decode.glsl first.
//
// Why this shape (docs/neural-btf.md, "The batched decode"): on lavapipe an invocation is one
// lane of an 8-wide SIMD vector, and a load from a buffer, even at an address every lane
// shares, costs far more than an FMA (measured: the same loops with the weights as constants
// ran 9x faster). So the product is blocked for weight reuse in registers:
//  - a layer is an outer-product loop: for each 4 inputs, a block of BTF_T_BLOCK outputs' 4
//    weights is loaded once (at a workgroup-uniform address: on a GPU the scalar / constant
//    path) and used for all BTF_T_ROWS rows of the invocation: BTF_T_ROWS x BTF_T_BLOCK x 4
//    FMAs per weight vec4, into BTF_T_ROWS x BTF_T_BLOCK = 32 independent accumulators (with
//    AVX-512, as on this project's VMs, LLVM has 32 vector registers; on an AVX2-only CPU, 16,
//    some of them spill: measure there before trusting the shape);
//  - activations stay in the invocation's own arrays (ping-pong), indexed by the loop counters
//    only, so the loops stay loops with short bodies that LLVM compiles in seconds.
// Measured on lavapipe (2 cores, idle, medians of 3 alternated rounds; weft-bench-btf-decode
// kernel): 8 rows x 4 outputs 26 GFLOP/s (29 % of the device's FMA peak, ~89), 8 x 3 and 8 x 6
// 24, 8 x 2 20, 4 x 4 19; earlier, loaded: 1 row x 12 outputs 6 % of peak, the per-query
// generic decoder 10 %.
// The shape is the paper's (8-D latent, 12 -> 106 -> 106 -> 106 -> 3; widths padded to 108
// with zero weights by pack_model); other shapes use btf_decode (btf_decode.glsl) per row.
#ifndef WEFT_BTF_DECODE_TILED_GLSL
#define WEFT_BTF_DECODE_TILED_GLSL

#define BTF_T_ROWS 8u   // rows per invocation
#define BTF_T_BLOCK 4u  // outputs per block
const uint BTF_T_WIDTH = 108u;  // the hidden width, padded

// One hidden layer (ReLU): SRC[row][input] -> DST[row][output].
#define BTF_T_LAYER(LAYER, SRC, DST)                                                                \
  {                                                                                                 \
    uvec4 d_ = btf_model.layers[LAYER];                                                             \
    for (uint o = 0u; o < d_.y * 4u; o += BTF_T_BLOCK) {                                            \
      float acc[BTF_T_BLOCK * BTF_T_ROWS];                                                          \
      [[unroll]] for (uint j = 0u; j < BTF_T_BLOCK; ++j) {                                          \
        float b_ = btf_scalar(d_.w, o + j);                                                         \
        [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) acc[j * BTF_T_ROWS + r] = b_;             \
      }                                                                                             \
      for (uint k4 = 0u; k4 < d_.x; ++k4) {                                                         \
        vec4 x_[BTF_T_ROWS];                                                                        \
        [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r)                                           \
          x_[r] = vec4(SRC[r][4u * k4], SRC[r][4u * k4 + 1u], SRC[r][4u * k4 + 2u], SRC[r][4u * k4 + 3u]); \
        [[unroll]] for (uint j = 0u; j < BTF_T_BLOCK; ++j) {                                        \
          vec4 w_ = btf_model.values[d_.z + (o + j) * d_.x + k4];                                   \
          [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r)                                         \
            acc[j * BTF_T_ROWS + r] =                                                               \
                fma(w_.w, x_[r].w, fma(w_.z, x_[r].z, fma(w_.y, x_[r].y, fma(w_.x, x_[r].x, acc[j * BTF_T_ROWS + r])))); \
        }                                                                                           \
      }                                                                                             \
      [[unroll]] for (uint j = 0u; j < BTF_T_BLOCK; ++j)                                            \
        [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) DST[r][o + j] = max(acc[j * BTF_T_ROWS + r], 0.0); \
    }                                                                                               \
  }

// What btf_decode returns, for BTF_T_ROWS rows: texel[r], dirs[r] = (stereo ω_i, stereo ω_o).
void btf_decode_tiled(uint texel[BTF_T_ROWS], vec4 dirs[BTF_T_ROWS], out vec3 rgb[BTF_T_ROWS]) {
  float act_a[BTF_T_ROWS][BTF_T_WIDTH], act_b[BTF_T_ROWS][BTF_T_WIDTH];
  [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) {
    uint base = btf_model.offsets.x + btf_latent_index(texel[r]) * 2u;
    vec4 l0 = btf_model.values[base], l1 = btf_model.values[base + 1u];
    act_a[r][0] = l0.x;
    act_a[r][1] = l0.y;
    act_a[r][2] = l0.z;
    act_a[r][3] = l0.w;
    act_a[r][4] = l1.x;
    act_a[r][5] = l1.y;
    act_a[r][6] = l1.z;
    act_a[r][7] = l1.w;
    act_a[r][8] = dirs[r].x;
    act_a[r][9] = dirs[r].y;
    act_a[r][10] = dirs[r].z;
    act_a[r][11] = dirs[r].w;
  }
  BTF_T_LAYER(0, act_a, act_b)
  BTF_T_LAYER(1, act_b, act_a)
  BTF_T_LAYER(2, act_a, act_b)
  // The output layer: 3 outputs, no ReLU before the final clamp.
  uvec4 d = btf_model.layers[3];
  vec4 y[BTF_T_ROWS];
  [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) y[r] = btf_model.values[d.w];
  for (uint k4 = 0u; k4 < d.x; ++k4) {
    vec4 w0 = btf_model.values[d.z + k4], w1 = btf_model.values[d.z + d.x + k4];
    vec4 w2 = btf_model.values[d.z + 2u * d.x + k4];
    [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) {
      vec4 x4 = vec4(act_b[r][4u * k4], act_b[r][4u * k4 + 1u], act_b[r][4u * k4 + 2u], act_b[r][4u * k4 + 3u]);
      y[r].x += dot(w0, x4);
      y[r].y += dot(w1, x4);
      y[r].z += dot(w2, x4);
    }
  }
  [[unroll]] for (uint r = 0u; r < BTF_T_ROWS; ++r) {
    float scale = btf_model.scales.x;
    if (btf_model.offsets.z != BTF_NONE) scale *= btf_scalar(btf_model.offsets.z, texel[r]);
    rgb[r] = max(y[r].xyz, vec3(0.0)) * scale;
  }
}

#endif
