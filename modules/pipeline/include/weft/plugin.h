// weft/plugin.h — the entry point of a weft plugin: a shared library that registers pass types
// and features when weft loads it (`weft --plugin PATH`, WEFT_PLUGIN_PATH; docs/pipelines.md).
//
//   import weft.pipeline;
//   #include <weft/plugin.h>   // in the global module fragment, or in a plain .cpp after the import
//   void register_my_passes(weft::pipeline::PluginRegistrar& r) {
//     r.add_pass_type(my_pass_type());
//   }
//   WEFT_PLUGIN(register_my_passes)
//
// The plugin links the same installed libweft_*.so the loading program does (find_package(weft)),
// so it shares weft's registries. WEFT_PLUGIN_ABI_VERSION changes whenever the registrar or a
// descriptor changes shape; weft refuses a plugin built for another one.
#pragma once
#include <cstdint>

#define WEFT_PLUGIN_ABI_VERSION 4u

#define WEFT_PLUGIN(register_function)                                                              \
  extern "C" __attribute__((visibility("default"))) std::uint32_t weft_plugin_abi_version() {      \
    return WEFT_PLUGIN_ABI_VERSION;                                                                 \
  }                                                                                                 \
  extern "C" __attribute__((visibility("default"))) void weft_register_plugin(                     \
      weft::pipeline::PluginRegistrar* registrar) {                                                 \
    register_function(*registrar);                                                                  \
  }
