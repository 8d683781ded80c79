#version 460
#extension GL_EXT_control_flow_attributes : require
// weft-bench-btf-decode's "peak" section: pure FMA throughput of this device's compute path,
// the limit the neural BTF decode's GFLOP/s is measured against. Each invocation runs 12
// independent chains a = fma(a, b, c) (b, c unknown at compile time, so nothing folds; 12
// chains cover the FMA latency on 2 pipes without spilling AVX2's 16 registers).
layout(local_size_x = 64) in;
layout(std430, set = 0, binding = 0) writeonly buffer Sums { float sums[]; };
layout(push_constant) uniform Push {
  float b;
  float c;
  uint iterations;
} push;
const int CHAINS = 12;
void main() {
  float a[CHAINS];
  [[unroll]] for (int i = 0; i < CHAINS; ++i) a[i] = float(gl_GlobalInvocationID.x + uint(i)) * 1e-6;
  for (uint n = 0u; n < push.iterations; ++n) {
    [[unroll]] for (int i = 0; i < CHAINS; ++i) a[i] = fma(a[i], push.b, push.c);
  }
  float s = 0.0;
  [[unroll]] for (int i = 0; i < CHAINS; ++i) s += a[i];
  sums[gl_GlobalInvocationID.x] = s;
}
