// weft.test.gpu — one validated device per test process: the Khronos validation layer with
// synchronization validation on, and a check that fails the test on any message it reported.
module;
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <doctest/doctest.h>
export module weft.test.gpu;
import weft.core;
import weft.gpu;

export namespace weft::test {

struct GpuContext {
  gpu::Instance instance;
  gpu::Adapter adapter;
  gpu::Device device;
};

// The shared context; aborts the process with a clear message if no Vulkan device exists,
// because every GPU suite is meaningless without one (lavapipe is always installable).
GpuContext& gpu() {
  static std::unique_ptr<GpuContext> context = [] {
    auto instance = gpu::Instance::create({.application_name = "weft-tests", .validation = true,
                                           .synchronization_validation = true});
    if (!instance) {
      std::fprintf(stderr, "weft tests: %s\n", instance.error().what().c_str());
      std::exit(2);
    }
    auto adapter = instance->request_adapter();
    if (!adapter) {
      std::fprintf(stderr, "weft tests: %s\n", adapter.error().what().c_str());
      std::exit(2);
    }
    std::fprintf(stderr, "weft tests: adapter '%s' (%s), Vulkan %s, validation + sync validation on\n",
                 adapter->info().name.c_str(), adapter->info().driver.c_str(),
                 adapter->info().api_version_string().c_str());
    auto device = adapter->request_device({.label = "test-device"});
    if (!device) {
      std::fprintf(stderr, "weft tests: %s\n", device.error().what().c_str());
      std::exit(2);
    }
    return std::make_unique<GpuContext>(std::move(*instance), std::move(*adapter), std::move(*device));
  }();
  return *context;
}

// Fails the current test if the validation layer said anything since the last call.
void expect_no_validation_messages() {
  for (const auto& message : gpu().instance.take_validation_messages()) FAIL_CHECK("validation layer: " << message);
}

}  // namespace weft::test
