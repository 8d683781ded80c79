// parallel_for / parallel_each over std::thread: the cheap parallelism the bakes need.
module;
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <thread>
#include <vector>
module weft.cluster;

namespace weft::cluster {
namespace {
std::size_t resolve_threads(std::size_t threads, std::size_t count) {
  if (threads == 0) threads = std::max<std::size_t>(1, std::thread::hardware_concurrency());
  return std::max<std::size_t>(1, std::min(threads, count));
}
}  // namespace

void parallel_for(std::size_t count, std::size_t threads, const std::function<void(std::size_t, std::size_t)>& body) {
  if (count == 0) return;
  const std::size_t n = resolve_threads(threads, count);
  if (n == 1) {
    body(0, count);
    return;
  }
  std::vector<std::thread> workers;
  workers.reserve(n);
  for (std::size_t t = 0; t < n; ++t) {
    const std::size_t begin = count * t / n, end = count * (t + 1) / n;
    workers.emplace_back([&body, begin, end] { body(begin, end); });
  }
  for (auto& w : workers) w.join();
}

void parallel_each(std::size_t count, std::size_t threads, const std::function<void(std::size_t)>& body) {
  if (count == 0) return;
  const std::size_t n = resolve_threads(threads, count);
  if (n == 1) {
    for (std::size_t i = 0; i < count; ++i) body(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::vector<std::thread> workers;
  workers.reserve(n);
  for (std::size_t t = 0; t < n; ++t)
    workers.emplace_back([&] {
      for (std::size_t i = next++; i < count; i = next++) body(i);
    });
  for (auto& w : workers) w.join();
}

}  // namespace weft::cluster
