// `weft info`: every adapter, the one weft picks, its driver and limits.
#include <cstdio>
#include <string>
#include "commands.h"
import weft.core;
import weft.gpu;

namespace weft::cli {

Command add_info(CLI::App& app) {
  app.add_subcommand("info", "Show the Vulkan adapters, the chosen one and its limits");
  return [] {
    auto instance = gpu::Instance::create({.application_name = "weft-info"});
    if (!instance) {
      std::fprintf(stderr, "weft info: %s\n", instance.error().what().c_str());
      return 1;
    }
    std::printf("adapters:\n");
    for (const auto& a : instance->enumerate_adapters())
      std::printf("  - %s (%s, %s, Vulkan %s)\n", a.name.c_str(), std::string(to_string(a.type)).c_str(),
                  a.driver.c_str(), a.api_version_string().c_str());
    auto adapter = instance->request_adapter();
    if (!adapter) {
      std::fprintf(stderr, "weft info: %s\n", adapter.error().what().c_str());
      return 1;
    }
    const auto& i = adapter->info();
    const auto& l = i.limits;
    std::printf("chosen: %s\n  driver: %s %s\n  type: %s\n  Vulkan: %s\n  device-local memory: %.1f MiB\n",
                i.name.c_str(), i.driver.c_str(), i.driver_info.c_str(), std::string(to_string(i.type)).c_str(),
                i.api_version_string().c_str(), double(i.device_local_bytes) / (1 << 20));
    std::printf("  max 2D texture: %u\n  max push constants: %u bytes\n  max bound bind groups: %u\n"
                "  max compute workgroup: %u x %u x %u (%u invocations)\n  max storage buffer range: %llu\n"
                "  timestamps: %s (period %.3f ns)\n",
                l.max_texture_dimension_2d, l.max_push_constant_size, l.max_bound_descriptor_sets,
                l.max_compute_workgroup_size[0], l.max_compute_workgroup_size[1], l.max_compute_workgroup_size[2],
                l.max_compute_invocations, static_cast<unsigned long long>(l.max_storage_buffer_range),
                l.timestamps ? "yes" : "no", l.timestamp_period_ns);
    std::printf("  override with WEFT_ADAPTER=cpu|gpu|<name>\n");
    return 0;
  };
}

}  // namespace weft::cli
