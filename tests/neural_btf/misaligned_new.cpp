// Linked into test_btf_training_misaligned only: a global operator new that places each block
// 16, 32 or 48 bytes past a 64-byte boundary, in turn. malloc's 16-byte alignment leaves where a
// buffer falls against a SIMD vector to chance; this makes it vary on purpose, so the training's
// determinism tests check that no result depends on it. With AVX (WEFT_TRAINING_SIMD auto on an
// AVX machine, avx2 or avx512), Eigen computes a misaligned vector's head and tail on another
// path than its middle, so the training keeps what it hands to Eigen in 64-byte-aligned storage.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

namespace {
std::atomic<unsigned> next_shift{0};
}

void* operator new(std::size_t size) {
  const std::size_t shift = 16 * (1 + next_shift.fetch_add(1, std::memory_order_relaxed) % 3);
  auto* raw = static_cast<unsigned char*>(std::malloc(size + 128));
  if (!raw) throw std::bad_alloc();
  const auto at = (reinterpret_cast<std::uintptr_t>(raw) + 16 + 63) / 64 * 64 + shift;  // >= raw + 32
  auto* p = reinterpret_cast<unsigned char*>(at);
  reinterpret_cast<void**>(p)[-1] = raw;
  return p;
}
void* operator new[](std::size_t size) { return ::operator new(size); }
void operator delete(void* p) noexcept {
  if (p) std::free(static_cast<void**>(p)[-1]);
}
void operator delete[](void* p) noexcept { ::operator delete(p); }
void operator delete(void* p, std::size_t) noexcept { ::operator delete(p); }
void operator delete[](void* p, std::size_t) noexcept { ::operator delete(p); }
