// The CPU's FP32 FMA peak, measured: every hardware thread runs independent chains of vector
// FMAs (AVX2 8-wide, and AVX-512 16-wide where the CPU has it), so "% of peak" in
// weft-bench-btf-decode compares with what this machine does, not with a clock estimate.
// Plain C++ with intrinsics in functions compiled for their ISA (target attributes), called
// only when the CPU reports it.
#include <immintrin.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>
#include <vector>
#include "fma_peak_cpu.h"

namespace weft::bench {
namespace {

// 10 accumulators: FMA latency 4 x 2 pipes needs >= 8 independent chains; b and c stay in
// registers (12 of AVX2's 16).
constexpr int kChains = 10;

__attribute__((target("avx2,fma"))) float avx2_chains(std::uint64_t iterations, float seed) {
  __m256 acc[kChains];
  for (int i = 0; i < kChains; ++i) acc[i] = _mm256_set1_ps(seed + float(i) * 1e-3f);
  const __m256 b = _mm256_set1_ps(0.999f), c = _mm256_set1_ps(seed * 1e-3f);
  for (std::uint64_t n = 0; n < iterations; ++n)
    for (int i = 0; i < kChains; ++i) acc[i] = _mm256_fmadd_ps(acc[i], b, c);
  __m256 s = acc[0];
  for (int i = 1; i < kChains; ++i) s = _mm256_add_ps(s, acc[i]);
  alignas(32) float out[8];
  _mm256_store_ps(out, s);
  return out[0] + out[7];
}

__attribute__((target("avx512f"))) float avx512_chains(std::uint64_t iterations, float seed) {
  __m512 acc[kChains];
  for (int i = 0; i < kChains; ++i) acc[i] = _mm512_set1_ps(seed + float(i) * 1e-3f);
  const __m512 b = _mm512_set1_ps(0.999f), c = _mm512_set1_ps(seed * 1e-3f);
  for (std::uint64_t n = 0; n < iterations; ++n)
    for (int i = 0; i < kChains; ++i) acc[i] = _mm512_fmadd_ps(acc[i], b, c);
  return _mm512_reduce_add_ps(acc[0]) + _mm512_reduce_add_ps(acc[kChains - 1]);
}

double run_threads(unsigned threads, std::uint64_t iterations, int width, float (*chains)(std::uint64_t, float)) {
  std::vector<std::thread> pool;
  std::atomic<int> sink{0};
  const auto start = std::chrono::steady_clock::now();
  for (unsigned t = 0; t < threads; ++t)
    pool.emplace_back([&, t] {
      const float v = chains(iterations, 0.5f + float(t));
      if (v == 12345.0f) sink.fetch_add(1);  // keeps the result alive
    });
  for (auto& th : pool) th.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return double(threads) * double(iterations) * kChains * width * 2.0 / seconds / 1e9;
}

}  // namespace

CpuFmaPeak measure_cpu_fma_peak(unsigned threads, int runs) {
  CpuFmaPeak p;
  threads = std::max(1u, threads);
  const std::uint64_t iterations = 20'000'000;  // ~0.1 - 0.3 s a run
  __builtin_cpu_init();
  p.has_avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  p.has_avx512 = __builtin_cpu_supports("avx512f");
  for (int r = 0; r < runs; ++r) {
    if (p.has_avx2) p.avx2_gflops.push_back(run_threads(threads, iterations, 8, &avx2_chains));
    if (p.has_avx512) p.avx512_gflops.push_back(run_threads(threads, iterations, 16, &avx512_chains));
  }
  return p;
}

}  // namespace weft::bench
