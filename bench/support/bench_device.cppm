// weft.bench.device — the benchmarks' device: an instance, an adapter (a real GPU first,
// lavapipe otherwise; WEFT_ADAPTER picks) and its device, opened in one call, without the
// validation layer (benchmarks time the driver, not the layer).
module;
#include <optional>
#include <string>
#include <utility>
export module weft.bench.device;
import weft.gpu;

export namespace weft::bench {

struct Session {
  gpu::Instance instance;
  gpu::Adapter adapter;
  gpu::Device device;
};

// Empty when there is no Vulkan device; the benchmark prints that and skips its GPU tables.
std::optional<Session> open_session(const std::string& application_name) {
  auto instance = gpu::Instance::create({.application_name = application_name});
  if (!instance) return std::nullopt;
  auto adapter = instance->request_adapter();
  if (!adapter) return std::nullopt;
  auto device = adapter->request_device();
  if (!device) return std::nullopt;
  return Session{std::move(*instance), std::move(*adapter), std::move(*device)};
}

}  // namespace weft::bench
