// Fuzz harness: the pipeline file reader (weft::pipeline::parse_pipeline), on text in memory.
// It registers pass types of the built-in shapes under their names (fixed formats, outputs
// the same as an input, optional inputs, every option kind) without linking the passes, so
// the harness builds from the engine's modules alone. Every input must be a pipeline or a
// clean error, and a pipeline written back must read back to itself.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <memory>
#include <string>
#include <string_view>
#include "fuzz_support.h"
import weft.core;
import weft.gpu;
import weft.pipeline;

namespace {
using namespace weft;
using pipeline::Slot;
using pipeline::SlotSize;
constexpr auto hdr = gpu::Format::RGBA16Float, depth = gpu::Format::Depth32Float, ldr = gpu::Format::RGBA8Unorm;

Result<std::unique_ptr<pipeline::FramePass>> no_pass(const pipeline::PassOptions&) {
  return fail(ErrorKind::Unsupported, "fuzzing: nothing is created");
}

void register_types() {
  const auto add = [](pipeline::PassTypeDescriptor d) {
    d.create = &no_pass;
    if (!pipeline::register_pass_type(std::move(d))) std::abort();
  };
  add({.name = "shadow_map", .outputs = {{.name = "depth", .formats = {depth}, .size = SlotSize::Any}},
       .options = {pipeline::integer_option("resolution", 0, 16384, 0, "")}});
  add({.name = "scene_color",
       .inputs = {{.name = "shadow_map", .formats = {depth}, .size = SlotSize::Any, .optional = true}},
       .outputs = {{.name = "color", .formats = {hdr}}, {.name = "depth", .formats = {depth}}},
       .options = {pipeline::number_option("clear", 0, 1e6, 0, "")}});
  add({.name = "background", .inputs = {{.name = "color", .formats = {hdr}}, {.name = "depth", .formats = {depth}}},
       .outputs = {{.name = "color", .same_as = "color"}}});
  add({.name = "bloom", .inputs = {{.name = "color", .formats = {hdr}}}, .outputs = {{.name = "color", .same_as = "color"}},
       .options = {pipeline::number_option("intensity", 0, 1, 0.04, ""), pipeline::integer_option("levels", 1, 10, 6, "")}});
  add({.name = "tonemap", .inputs = {{.name = "color", .formats = {hdr, gpu::Format::RGBA32Float}, .linear_source = true}},
       .outputs = {{.name = "color", .formats = {ldr}}},
       .options = {pipeline::number_option("exposure", 1e-6, 1e6, 1, ""),
                   pipeline::choice_option("operator", {"aces", "clamp"}, "aces", "")}});
  add({.name = "outline", .inputs = {{.name = "color", .formats = {ldr, hdr}}, {.name = "depth", .formats = {depth}}},
       .outputs = {{.name = "color", .same_as = "color"}},
       .options = {pipeline::boolean_option("enabled", true, "")}});
  add({.name = "debug_view", .inputs = {{.name = "depth", .formats = {depth}}}, .outputs = {{.name = "color", .formats = {ldr}}},
       .options = {pipeline::choice_option("view", {"depth", "normals"}, "depth", "")}});
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool ready = [] {
    weft::log::set_level("off");
    register_types();
    return true;
  }();
  (void)ready;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  auto parsed = weft::pipeline::parse_pipeline(text, "fuzz pipeline");
  if (parsed) {
    const std::string written = weft::pipeline::to_json(*parsed);
    auto again = weft::pipeline::parse_pipeline(written, "fuzz pipeline (written back)");
    if (!again || weft::pipeline::to_json(*again) != written) {
      std::fprintf(stderr, "a pipeline written back does not read back to itself:\n%s\n", written.c_str());
      std::abort();
    }
  }
  weft_fuzz::expect_clean(parsed);
  return 0;
}
