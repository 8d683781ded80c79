// The CPU's FP32 FMA throughput, measured (fma_peak_cpu.cpp): GFLOP/s per run (2 FLOP per FMA),
// all threads busy.
#pragma once
#include <vector>
namespace weft::bench {
struct CpuFmaPeak {
  bool has_avx2 = false, has_avx512 = false;
  std::vector<double> avx2_gflops, avx512_gflops;
};
CpuFmaPeak measure_cpu_fma_peak(unsigned threads, int runs);
}  // namespace weft::bench
