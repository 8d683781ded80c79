// Graph execution on lavapipe (or a GPU) under validation + synchronization validation:
// results read back and checked against the CPU, aliased memory, execute-twice reuse,
// history imports, undeclared accesses, culled passes never run.
#include <doctest/doctest.h>
#include <cstdint>
#include <cstring>
#include <algorithm>
#include <random>
#include <span>
#include <string>
#include <vector>
#include "graph_test_util.hpp"
import weft.core;
import weft.gpu;
import weft.graph;
import weft.test.gpu;

using namespace weft;
using graph_test::contains;
using weft::test::expect_no_validation_messages;

namespace {

gpu::Device& device() { return weft::test::gpu().device; }

using graph_test::fullscreen_vs;

// A compute pipeline over one storage image (binding 0) and, optionally, a second one it
// reads (binding 1), both r32float: dst = src + add (or just add without a source).
struct StoragePipeline {
  gpu::BindGroupLayout layout;
  gpu::PipelineLayout pipeline_layout;
  gpu::ComputePipeline pipeline;
};

StoragePipeline make_add_pipeline(bool with_source) {
  const std::string source = std::string(R"(#version 460
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, r32f) uniform image2D dst;
)") + (with_source ? "layout(set = 0, binding = 1, r32f) uniform readonly image2D src;\n" : "") +
                             R"(layout(push_constant) uniform P { float add; };
void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(p, imageSize(dst)))) return;
)" + (with_source ? "  imageStore(dst, p, imageLoad(src, p) + vec4(add));\n"
                  : "  imageStore(dst, p, vec4(add + float(p.x + 100 * p.y)));\n") +
                             "}\n";
  auto module = device().create_shader_module(
      {.label = with_source ? "add-from-source" : "fill", .stage = gpu::ShaderStage::Compute, .glsl = source});
  REQUIRE_MESSAGE(module, (module ? "" : module.error().message));
  std::vector<gpu::BindGroupLayoutEntry> entries{
      {0, gpu::BindingType::StorageTexture, gpu::ShaderStage::Compute, gpu::Format::R32Float}};
  if (with_source) entries.push_back({1, gpu::BindingType::StorageTexture, gpu::ShaderStage::Compute, gpu::Format::R32Float});
  auto bgl = device().create_bind_group_layout({.label = "add-bgl", .entries = entries});
  REQUIRE(bgl);
  auto layout = device().create_pipeline_layout({.label = "add-layout", .bind_group_layouts = {&*bgl}, .push_constant_size = 4});
  REQUIRE(layout);
  auto pipeline = device().create_compute_pipeline({.label = "add", .layout = &*layout, .module = &*module});
  REQUIRE_MESSAGE(pipeline, (pipeline ? "" : pipeline.error().message));
  return {std::move(*bgl), std::move(*layout), std::move(*pipeline)};
}

void dispatch_add(PassContext& ctx, const StoragePipeline& p, const gpu::TextureView& dst, const gpu::TextureView* src,
                  float add, std::uint32_t w, std::uint32_t h) {
  std::vector<gpu::BindGroupEntry> entries{gpu::bind(0, dst)};
  if (src) entries.push_back(gpu::bind(1, *src));
  auto group = ctx.device().create_bind_group({.label = "add-group", .layout = &p.layout, .entries = entries});
  REQUIRE_MESSAGE(group, (group ? "" : group.error().message));
  const gpu::BindGroup& kept = ctx.keep(std::move(*group));
  auto pass = ctx.encoder().begin_compute_pass(ctx.pass_name());
  pass.set_pipeline(p.pipeline);
  pass.set_bind_group(0, kept);
  pass.push(add);
  pass.dispatch((w + 7) / 8, (h + 7) / 8);
  pass.end();
}

std::vector<float> read_floats(const gpu::Buffer& buffer) {
  auto bytes = buffer.mapped();
  REQUIRE(bytes);
  std::vector<float> out(bytes->size() / 4);
  std::memcpy(out.data(), bytes->data(), out.size() * 4);
  return out;
}

}  // namespace

TEST_CASE("compute fills a storage texture, a render pass samples it, a copy pass reads it back") {
  constexpr std::uint32_t w = 16, h = 16;
  auto fill_module = device().create_shader_module({.label = "pattern", .stage = gpu::ShaderStage::Compute, .glsl = R"(#version 460
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba8) uniform writeonly image2D dst;
void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  imageStore(dst, p, vec4(float(p.x * 17) / 255.0, float(p.y * 17) / 255.0, 0.0, 1.0));
})"});
  REQUIRE_MESSAGE(fill_module, (fill_module ? "" : fill_module.error().message));
  auto fill_bgl = device().create_bind_group_layout(
      {.label = "pattern-bgl", .entries = {{0, gpu::BindingType::StorageTexture, gpu::ShaderStage::Compute, gpu::Format::RGBA8Unorm}}});
  REQUIRE(fill_bgl);
  auto fill_layout = device().create_pipeline_layout({.label = "pattern-layout", .bind_group_layouts = {&*fill_bgl}});
  REQUIRE(fill_layout);
  auto fill_pipeline = device().create_compute_pipeline({.label = "pattern", .layout = &*fill_layout, .module = &*fill_module});
  REQUIRE(fill_pipeline);

  auto vs = device().create_shader_module({.label = "fullscreen", .stage = gpu::ShaderStage::Vertex, .glsl = fullscreen_vs});
  auto fs = device().create_shader_module({.label = "swizzle", .stage = gpu::ShaderStage::Fragment, .glsl = R"(#version 460
layout(location = 0) out vec4 color;
layout(set = 0, binding = 0) uniform sampler2D pattern;
void main() {
  vec4 t = texelFetch(pattern, ivec2(gl_FragCoord.xy), 0);
  color = vec4(t.g, t.r, 1.0 - t.r, 1.0);
})"});
  REQUIRE(vs);
  REQUIRE_MESSAGE(fs, (fs ? "" : fs.error().message));
  auto shade_bgl = device().create_bind_group_layout(
      {.label = "swizzle-bgl", .entries = {{0, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment}}});
  REQUIRE(shade_bgl);
  auto shade_layout = device().create_pipeline_layout({.label = "swizzle-layout", .bind_group_layouts = {&*shade_bgl}});
  REQUIRE(shade_layout);
  auto shade_pipeline = device().create_render_pipeline({.label = "swizzle", .layout = &*shade_layout, .vertex = &*vs,
                                                         .fragment = &*fs, .color_targets = {{gpu::Format::RGBA8Unorm}}});
  REQUIRE(shade_pipeline);
  auto sampler = device().create_sampler({.label = "nearest", .mag_filter = gpu::FilterMode::Nearest,
                                          .min_filter = gpu::FilterMode::Nearest});
  REQUIRE(sampler);
  auto readback = device().create_buffer(
      {.label = "readback", .size = w * h * 4, .usage = gpu::BufferUsage::MapRead | gpu::BufferUsage::CopyDst});
  REQUIRE(readback);

  RenderGraph graph("three-kinds");
  int culled_runs = 0;
  struct FillData {
    TextureHandle pattern;
  };
  auto& fill = graph.add_pass<FillData>(
      "fill",
      [&](PassBuilder& b, FillData& d) {
        d.pattern = b.create_texture("pattern", {.size = RelativeSize{1.0f}, .format = gpu::Format::RGBA8Unorm});
        d.pattern = b.write(d.pattern, TextureUse::StorageWrite);
      },
      [&](const PassResources& res, const FillData& d, PassContext& ctx) {
        auto group = ctx.device().create_bind_group(
            {.label = "pattern-group", .layout = &*fill_bgl, .entries = {gpu::bind(0, res.view(d.pattern))}});
        REQUIRE(group);
        auto pass = ctx.encoder().begin_compute_pass("pattern");
        pass.set_pipeline(*fill_pipeline);
        pass.set_bind_group(0, ctx.keep(std::move(*group)));
        pass.dispatch(w / 8, h / 8);
        pass.end();
      });
  struct ShadeData {
    TextureHandle pattern, shaded;
  };
  auto& shade = graph.add_pass<ShadeData>(
      "shade",
      [&](PassBuilder& b, ShadeData& d) {
        d.pattern = b.read(fill.pattern, TextureUse::Sampled);
        d.shaded = b.write(b.create_texture("shaded", {.size = RelativeSize{1.0f}}), TextureUse::ColorAttachment);
      },
      [&](const PassResources& res, const ShadeData& d, PassContext& ctx) {
        auto group = ctx.device().create_bind_group({.label = "swizzle-group", .layout = &*shade_bgl,
                                                     .entries = {gpu::bind(0, res.view(d.pattern), &*sampler)}});
        REQUIRE(group);
        auto pass = ctx.encoder().begin_render_pass({.label = "shade", .color_attachments = {{.view = &res.view(d.shaded)}}});
        pass.set_pipeline(*shade_pipeline);
        pass.set_bind_group(0, ctx.keep(std::move(*group)));
        pass.draw(3);
        pass.end();
      });
  struct CopyData {
    TextureHandle shaded;
    BufferHandle readback;
  };
  auto readback_handle = graph.import_buffer("readback", &*readback, gpu::Access::Undefined);
  auto& copy = graph.add_pass<CopyData>(
      "copy",
      [&](PassBuilder& b, CopyData& d) {
        d.shaded = b.read(shade.shaded, TextureUse::CopySrc);
        d.readback = b.write(readback_handle, BufferUse::CopyDst);
      },
      [](const PassResources& res, const CopyData& d, PassContext& ctx) {
        ctx.encoder().copy_texture_to_buffer(res.texture(d.shaded), res.buffer(d.readback), 0);
      });
  graph.add_pass<FillData>(
      "unused_debug_view",
      [&](PassBuilder& b, FillData& d) {
        d.pattern = b.write(b.create_texture("debug", {.size = RelativeSize{1.0f}}), TextureUse::StorageWrite);
      },
      [&](const PassResources&, const FillData&, PassContext&) { ++culled_runs; });
  graph.mark_output(copy.readback, gpu::Access::HostRead);

  auto compiled = graph.compile({.output_extent = {w, h, 1}});
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  CHECK(compiled->culled("unused_debug_view"));
  auto stats = compiled->execute(device());
  REQUIRE_MESSAGE(stats, stats.error().message);
  CHECK(culled_runs == 0);
  CHECK(compiled->memory().from_device);

  auto bytes = readback->mapped();
  REQUIRE(bytes);
  int wrong = 0;
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      const auto* px = reinterpret_cast<const std::uint8_t*>(bytes->data()) + (y * w + x) * 4;
      const std::uint8_t expected[4] = {std::uint8_t(y * 17), std::uint8_t(x * 17), std::uint8_t(255 - x * 17), 255};
      if (std::memcmp(px, expected, 4) != 0) ++wrong;
    }
  CHECK(wrong == 0);

  REQUIRE(stats->passes.size() == 3);
  CHECK(stats->passes[0].name == "fill");
  CHECK(stats->passes[1].kind == PassKind::Render);
  CHECK(stats->passes[2].kind == PassKind::Transfer);
  if (device().adapter_info().limits.timestamps) {
    for (const PassStats& p : stats->passes) CHECK(p.gpu_ms >= 0.0);
    CHECK(stats->gpu_total_ms >= 0.0);
  }
  const std::string table = stats->format_table();
  CHECK(contains(table, "| fill | compute |"));
  CHECK(contains(table, "| shade | render |"));
  CHECK(contains(table, "**total** (3 passes)"));
  expect_no_validation_messages();
}

TEST_CASE("aliased transients: a texture taking over another's memory waits for it (sync validation)") {
  constexpr std::uint32_t w = 32, h = 32;
  const StoragePipeline fill = make_add_pipeline(false);
  const StoragePipeline add = make_add_pipeline(true);
  auto readback = device().create_buffer(
      {.label = "alias-readback", .size = w * h * 4, .usage = gpu::BufferUsage::MapRead | gpu::BufferUsage::CopyDst});
  REQUIRE(readback);

  RenderGraph graph("aliasing");
  struct StepData {
    TextureHandle src, dst;
  };
  const TextureDesc desc{.size = gpu::Extent3D{w, h, 1}, .format = gpu::Format::R32Float};
  auto& first = graph.add_pass<StepData>(
      "first", [&](PassBuilder& b, StepData& d) { d.dst = b.write(b.create_texture("t0", desc), TextureUse::StorageWrite); },
      [&](const PassResources& res, const StepData& d, PassContext& ctx) {
        dispatch_add(ctx, fill, res.view(d.dst), nullptr, 1.0f, w, h);
      });
  const StepData* previous = &first;
  for (int i = 1; i <= 3; ++i) {
    auto& step = graph.add_pass<StepData>(
        "step" + std::to_string(i),
        [&, i](PassBuilder& b, StepData& d) {
          d.src = b.read(previous->dst, TextureUse::StorageRead);
          d.dst = b.write(b.create_texture("t" + std::to_string(i), desc), TextureUse::StorageWrite);
        },
        [&](const PassResources& res, const StepData& d, PassContext& ctx) {
          dispatch_add(ctx, add, res.view(d.dst), &res.view(d.src), 10.0f, w, h);
        });
    previous = &step;
  }
  struct CopyData {
    TextureHandle src;
    BufferHandle dst;
  };
  auto readback_handle = graph.import_buffer("alias-readback", &*readback, gpu::Access::Undefined);
  auto& copy = graph.add_pass<CopyData>(
      "copy",
      [&](PassBuilder& b, CopyData& d) {
        d.src = b.read(previous->dst, TextureUse::CopySrc);
        d.dst = b.write(readback_handle, BufferUse::CopyDst);
      },
      [](const PassResources& res, const CopyData& d, PassContext& ctx) {
        ctx.encoder().copy_texture_to_buffer(res.texture(d.src), res.buffer(d.dst), 0);
      });
  graph.mark_output(copy.dst, gpu::Access::HostRead);

  auto compiled = graph.compile({.output_extent = {w, h, 1}, .device = &device()});
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  // t2 reuses t0's memory and t3 reuses t1's: the chain needs two textures' worth.
  const auto resources = compiled->resources();
  const auto t0 = *compiled->find_resource("t0"), t1 = *compiled->find_resource("t1");
  const auto t2 = *compiled->find_resource("t2"), t3 = *compiled->find_resource("t3");
  CHECK(resources[t2].offset == resources[t0].offset);
  CHECK(resources[t3].offset == resources[t1].offset);
  CHECK(resources[t0].alias_group == resources[t2].alias_group);
  CHECK(compiled->memory().aliased_bytes * 2 == compiled->memory().unaliased_bytes);

  const std::uint64_t allocated_before = device().allocated_bytes();
  for (int frame = 0; frame < 2; ++frame) {
    auto stats = compiled->execute(device());
    REQUIRE_MESSAGE(stats, stats.error().message);
    CHECK(stats->transient_bytes < stats->transient_bytes_unaliased);
    const std::vector<float> values = read_floats(*readback);
    int wrong = 0;
    for (std::uint32_t y = 0; y < h; ++y)
      for (std::uint32_t x = 0; x < w; ++x)
        if (values[y * w + x] != 1.0f + float(x + 100 * y) + 30.0f) ++wrong;
    CHECK_MESSAGE(wrong == 0, "frame " << frame);
    if (frame == 0) {
      // Transient memory is created on the first execute and kept: the second adds nothing.
      CHECK(device().allocated_bytes() > allocated_before);
    }
  }
  const std::uint64_t after_two_frames = device().allocated_bytes();
  REQUIRE(compiled->execute(device()));
  CHECK(device().allocated_bytes() == after_two_frames);
  CHECK(compiled->texture(TextureHandle{t0, 0}) != nullptr);
  expect_no_validation_messages();
}

TEST_CASE("a frame loop rebuilding the same graph reuses its plan and gpu objects, running this frame's callbacks") {
  constexpr std::uint32_t w = 16, h = 16;
  const StoragePipeline fill = make_add_pipeline(false);
  const StoragePipeline add = make_add_pipeline(true);
  auto readback = device().create_buffer(
      {.label = "loop-readback", .size = w * h * 4, .usage = gpu::BufferUsage::MapRead | gpu::BufferUsage::CopyDst});
  REQUIRE(readback);
  struct StepData {
    TextureHandle src, dst;
  };
  struct CopyData {
    TextureHandle src;
    BufferHandle dst;
  };
  // A chain fill -> add x steps -> copy; each frame adds its own amount, so a stale callback
  // would show in the result. Frame 3 has one step more (a new plan), frame 4 is like 3.
  auto build = [&](RenderGraph& graph, int steps, float amount) {
    const TextureDesc desc{.size = gpu::Extent3D{w, h, 1}, .format = gpu::Format::R32Float};
    const StepData* previous = &graph.add_pass<StepData>(
        "fill", [&](PassBuilder& b, StepData& d) { d.dst = b.write(b.create_texture("t0", desc), TextureUse::StorageWrite); },
        [&fill](const PassResources& res, const StepData& d, PassContext& ctx) {
          dispatch_add(ctx, fill, res.view(d.dst), nullptr, 1.0f, w, h);
        });
    for (int i = 1; i <= steps; ++i) {
      previous = &graph.add_pass<StepData>(
          "step" + std::to_string(i),
          [&, previous](PassBuilder& b, StepData& d) {
            d.src = b.read(previous->dst, TextureUse::StorageRead);
            d.dst = b.write(b.create_texture("t" + std::to_string(i), desc), TextureUse::StorageWrite);
          },
          [&add, amount](const PassResources& res, const StepData& d, PassContext& ctx) {
            dispatch_add(ctx, add, res.view(d.dst), &res.view(d.src), amount, w, h);
          });
    }
    auto target = graph.import_buffer("loop-readback", &*readback, gpu::Access::Undefined);
    auto& copy = graph.add_pass<CopyData>(
        "copy",
        [&, previous](PassBuilder& b, CopyData& d) {
          d.src = b.read(previous->dst, TextureUse::CopySrc);
          d.dst = b.write(target, BufferUse::CopyDst);
        },
        [](const PassResources& res, const CopyData& d, PassContext& ctx) {
          ctx.encoder().copy_texture_to_buffer(res.texture(d.src), res.buffer(d.dst), 0);
        });
    graph.mark_output(copy.dst, gpu::Access::HostRead);
  };
  RenderGraph graph("loop");
  std::uint64_t allocated_after_first = 0;
  const gpu::Texture* t1_before = nullptr;
  for (int frame = 0; frame < 5; ++frame) {
    INFO("frame " << frame);
    const int steps = frame >= 3 ? 4 : 3;
    const float amount = 10.0f * float(frame + 1);
    graph.reset();
    build(graph, steps, amount);
    auto compiled = graph.compile({.output_extent = {w, h, 1}});
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK(compiled->plan_reused() == (frame != 0 && frame != 3));
    auto stats = compiled->execute(device());
    REQUIRE_MESSAGE(stats, stats.error().message);
    const std::vector<float> values = read_floats(*readback);
    int wrong = 0;
    for (std::uint32_t y = 0; y < h; ++y)
      for (std::uint32_t x = 0; x < w; ++x)
        if (values[y * w + x] != 1.0f + float(x + 100 * y) + float(steps) * amount) ++wrong;
    CHECK(wrong == 0);
    const gpu::Texture* t1 = compiled->texture(TextureHandle{*compiled->find_resource("t1"), 1});
    REQUIRE(t1 != nullptr);
    if (frame == 0) allocated_after_first = device().allocated_bytes();
    if (frame == 1 || frame == 2) {
      // The reused plan keeps last frame's transients: no new memory, the same textures.
      CHECK(device().allocated_bytes() == allocated_after_first);
      CHECK(t1 == t1_before);
    }
    t1_before = t1;
  }
  expect_no_validation_messages();
}

TEST_CASE("a graph compiled without a device is re-planned with the device's memory requirements") {
  constexpr std::uint32_t w = 16, h = 16;
  const StoragePipeline fill = make_add_pipeline(false);
  auto readback = device().create_buffer(
      {.label = "plain-readback", .size = w * h * 4, .usage = gpu::BufferUsage::MapRead | gpu::BufferUsage::CopyDst});
  REQUIRE(readback);
  RenderGraph graph("replan");
  struct Data {
    TextureHandle t;
    BufferHandle out;
  };
  auto& make = graph.add_pass<Data>(
      "make",
      [&](PassBuilder& b, Data& d) {
        d.t = b.write(b.create_texture("t", {.size = RelativeSize{1.0f}, .format = gpu::Format::R32Float}),
                      TextureUse::StorageWrite);
      },
      [&](const PassResources& res, const Data& d, PassContext& ctx) {
        dispatch_add(ctx, fill, res.view(d.t), nullptr, 0.5f, w, h);
      });
  auto out = graph.import_buffer("plain-readback", &*readback, gpu::Access::Undefined);
  auto& copy = graph.add_pass<Data>(
      "copy",
      [&](PassBuilder& b, Data& d) {
        d.t = b.read(make.t, TextureUse::CopySrc);
        d.out = b.write(out, BufferUse::CopyDst);
      },
      [](const PassResources& res, const Data& d, PassContext& ctx) {
        ctx.encoder().copy_texture_to_buffer(res.texture(d.t), res.buffer(d.out), 0);
      });
  graph.mark_output(copy.out, gpu::Access::HostRead);
  auto compiled = graph.compile({.output_extent = {w, h, 1}});
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  CHECK_FALSE(compiled->memory().from_device);
  REQUIRE(compiled->execute(device()));
  CHECK(compiled->memory().from_device);
  const auto values = read_floats(*readback);
  CHECK(values[0] == 0.5f);
  CHECK(values[w * h - 1] == 0.5f + float((w - 1) + 100 * (h - 1)));
  expect_no_validation_messages();
}

TEST_CASE("history: an imported texture written every frame comes back to its declared state") {
  constexpr std::uint32_t w = 8, h = 8;
  const StoragePipeline add = make_add_pipeline(true);
  auto history = device().create_texture({.label = "history", .size = {w, h, 1}, .format = gpu::Format::R32Float,
                                          .usage = gpu::TextureUsage::Storage | gpu::TextureUsage::Sampled |
                                                   gpu::TextureUsage::CopySrc | gpu::TextureUsage::CopyDst});
  REQUIRE(history);
  std::vector<float> zeros(w * h, 0.0f);
  REQUIRE(device().queue().write_texture(*history, std::as_bytes(std::span(zeros)), 0, gpu::Access::ShaderRead));

  RenderGraph graph("history");
  auto imported = graph.import_texture("history", &*history, gpu::Access::ShaderRead);
  struct Data {
    TextureHandle last, next;
  };
  graph.add_pass<Data>(
      "accumulate",
      [&](PassBuilder& b, Data& d) {
        d.last = b.read(imported, TextureUse::StorageRead);
        d.next = b.write(imported, TextureUse::StorageWrite);
      },
      [&](const PassResources& res, const Data& d, PassContext& ctx) {
        dispatch_add(ctx, add, res.view(d.next), &res.view(d.last), 1.0f, w, h);
      });
  auto compiled = graph.compile();
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  for (int frame = 0; frame < 3; ++frame) REQUIRE(compiled->execute(device()));
  CHECK(history->state() == gpu::Access::StorageWrite);
  auto back = device().queue().read_texture(*history);
  REQUIRE(back);
  std::vector<float> values(w * h);
  std::memcpy(values.data(), back->data(), values.size() * 4);
  CHECK(values[0] == 3.0f);
  CHECK(values[w * h - 1] == 3.0f);
  expect_no_validation_messages();
}

TEST_CASE("transient buffers: compute writes, compute reads, barriers between them") {
  constexpr std::uint32_t n = 256;
  auto module_write = device().create_shader_module({.label = "write-buffer", .stage = gpu::ShaderStage::Compute, .glsl = R"(#version 460
layout(local_size_x = 64) in;
layout(set = 0, binding = 0) writeonly buffer Out { uint v[]; };
void main() { v[gl_GlobalInvocationID.x] = gl_GlobalInvocationID.x * 3u; })"});
  auto module_double = device().create_shader_module({.label = "double-buffer", .stage = gpu::ShaderStage::Compute, .glsl = R"(#version 460
layout(local_size_x = 64) in;
layout(set = 0, binding = 0) readonly buffer In { uint a[]; };
layout(set = 0, binding = 1) writeonly buffer Out { uint b[]; };
void main() { b[gl_GlobalInvocationID.x] = a[gl_GlobalInvocationID.x] * 2u + 1u; })"});
  REQUIRE(module_write);
  REQUIRE(module_double);
  auto bgl1 = device().create_bind_group_layout({.label = "w-bgl", .entries = {{0, gpu::BindingType::StorageBuffer, gpu::ShaderStage::Compute}}});
  auto bgl2 = device().create_bind_group_layout(
      {.label = "d-bgl", .entries = {{0, gpu::BindingType::ReadOnlyStorageBuffer, gpu::ShaderStage::Compute},
                                     {1, gpu::BindingType::StorageBuffer, gpu::ShaderStage::Compute}}});
  REQUIRE(bgl1);
  REQUIRE(bgl2);
  auto layout1 = device().create_pipeline_layout({.label = "w-layout", .bind_group_layouts = {&*bgl1}});
  auto layout2 = device().create_pipeline_layout({.label = "d-layout", .bind_group_layouts = {&*bgl2}});
  REQUIRE(layout1);
  REQUIRE(layout2);
  auto write_pipeline = device().create_compute_pipeline({.label = "w", .layout = &*layout1, .module = &*module_write});
  auto double_pipeline = device().create_compute_pipeline({.label = "d", .layout = &*layout2, .module = &*module_double});
  REQUIRE(write_pipeline);
  REQUIRE(double_pipeline);
  auto readback = device().create_buffer({.label = "buffer-readback", .size = n * 4,
                                          .usage = gpu::BufferUsage::MapRead | gpu::BufferUsage::CopyDst});
  REQUIRE(readback);

  RenderGraph graph("buffers");
  struct Data {
    BufferHandle in, out;
  };
  auto& produce = graph.add_pass<Data>(
      "produce", [&](PassBuilder& b, Data& d) { d.out = b.write(b.create_buffer("values", {.size = n * 4}), BufferUse::StorageWrite); },
      [&](const PassResources& res, const Data& d, PassContext& ctx) {
        auto group = ctx.device().create_bind_group({.label = "w", .layout = &*bgl1, .entries = {gpu::bind(0, res.buffer(d.out))}});
        REQUIRE(group);
        auto pass = ctx.encoder().begin_compute_pass("produce");
        pass.set_pipeline(*write_pipeline);
        pass.set_bind_group(0, ctx.keep(std::move(*group)));
        pass.dispatch(n / 64);
        pass.end();
      });
  auto& transform = graph.add_pass<Data>(
      "transform",
      [&](PassBuilder& b, Data& d) {
        d.in = b.read(produce.out, BufferUse::StorageRead);
        d.out = b.write(b.create_buffer("doubled", {.size = n * 4}), BufferUse::StorageWrite);
      },
      [&](const PassResources& res, const Data& d, PassContext& ctx) {
        auto group = ctx.device().create_bind_group(
            {.label = "d", .layout = &*bgl2, .entries = {gpu::bind(0, res.buffer(d.in)), gpu::bind(1, res.buffer(d.out))}});
        REQUIRE(group);
        auto pass = ctx.encoder().begin_compute_pass("transform");
        pass.set_pipeline(*double_pipeline);
        pass.set_bind_group(0, ctx.keep(std::move(*group)));
        pass.dispatch(n / 64);
        pass.end();
      });
  auto out = graph.import_buffer("buffer-readback", &*readback, gpu::Access::Undefined);
  auto& copy = graph.add_pass<Data>(
      "copy",
      [&](PassBuilder& b, Data& d) {
        d.in = b.read(transform.out, BufferUse::CopySrc);
        d.out = b.write(out, BufferUse::CopyDst);
      },
      [](const PassResources& res, const Data& d, PassContext& ctx) {
        ctx.encoder().copy_buffer_to_buffer(res.buffer(d.in), 0, res.buffer(d.out), 0, n * 4);
      });
  graph.mark_output(copy.out, gpu::Access::HostRead);
  auto compiled = graph.compile();
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  REQUIRE(compiled->execute(device()));
  auto bytes = readback->mapped();
  REQUIRE(bytes);
  std::vector<std::uint32_t> values(n);
  std::memcpy(values.data(), bytes->data(), n * 4);
  int wrong = 0;
  for (std::uint32_t i = 0; i < n; ++i) wrong += values[i] != i * 3u * 2u + 1u ? 1 : 0;
  CHECK(wrong == 0);
  expect_no_validation_messages();
}

TEST_CASE("a copy between two ranges of one buffer in one pass: declared as read and write, synchronized") {
  // Buffers have no layouts, so a pass may copy within one (vkCmdCopyBuffer with the same
  // buffer and disjoint ranges); the graph puts it in one transfer state whose barrier
  // covers the read and the write (synchronization validation is on).
  constexpr std::uint32_t n = 64;
  auto readback = device().create_buffer({.label = "within-readback", .size = 2 * n * 4,
                                          .usage = gpu::BufferUsage::MapRead | gpu::BufferUsage::CopyDst});
  REQUIRE(readback);
  RenderGraph graph("copy within");
  struct Data {
    BufferHandle buffer;
  };
  auto& fill = graph.add_pass<Data>(
      "fill",
      [&](PassBuilder& b, Data& d) { d.buffer = b.write(b.create_buffer("halves", {.size = 2 * n * 4}), BufferUse::CopyDst); },
      [](const PassResources& res, const Data& d, PassContext& ctx) {
        ctx.encoder().fill_buffer(res.buffer(d.buffer), 0x11111111u, 0, n * 4);
        ctx.encoder().fill_buffer(res.buffer(d.buffer), 0x22222222u, n * 4, n * 4);
      });
  auto& within = graph.add_pass<Data>(
      "copy_within",
      [&](PassBuilder& b, Data& d) {
        d.buffer = b.read(fill.buffer, BufferUse::CopySrc);
        d.buffer = b.write(d.buffer, BufferUse::CopyDst);
      },
      [](const PassResources& res, const Data& d, PassContext& ctx) {
        // the first half over the second
        ctx.encoder().copy_buffer_to_buffer(res.buffer(d.buffer), 0, res.buffer(d.buffer), n * 4, n * 4);
      });
  auto out = graph.import_buffer("within-readback", &*readback, gpu::Access::Undefined);
  auto& copy = graph.add_pass<Data>(
      "read_back",
      [&](PassBuilder& b, Data& d) {
        (void)b.read(within.buffer, BufferUse::CopySrc);
        d.buffer = b.write(out, BufferUse::CopyDst);
      },
      [&](const PassResources& res, const Data& d, PassContext& ctx) {
        ctx.encoder().copy_buffer_to_buffer(res.buffer(within.buffer), 0, res.buffer(d.buffer), 0, 2 * n * 4);
      });
  graph.mark_output(copy.buffer, gpu::Access::HostRead);
  auto compiled = graph.compile();
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  REQUIRE(compiled->execute(device()));
  auto bytes = readback->mapped();
  REQUIRE(bytes);
  std::vector<std::uint32_t> values(2 * n);
  std::memcpy(values.data(), bytes->data(), 2 * n * 4);
  int wrong = 0;
  for (std::uint32_t v : values) wrong += v != 0x11111111u ? 1 : 0;
  CHECK(wrong == 0);
  expect_no_validation_messages();
}

TEST_CASE("a pass touching a resource it did not declare fails execute, naming pass and resource") {
  const StoragePipeline fill = make_add_pipeline(false);
  RenderGraph graph("undeclared");
  TextureHandle secret;
  graph.add_pass<TextureHandle>(
      "owner", [&](PassBuilder& b, TextureHandle& t) {
        secret = t = b.write(b.create_texture("secret", {.size = gpu::Extent3D{8, 8, 1}, .format = gpu::Format::R32Float}),
                             TextureUse::StorageWrite);
        b.side_effect();
      },
      [&](const PassResources& res, const TextureHandle& t, PassContext& ctx) { dispatch_add(ctx, fill, res.view(t), nullptr, 0.0f, 8, 8); });
  graph.add_pass<TextureHandle>(
      "sneaky",
      [&](PassBuilder& b, TextureHandle& t) {
        t = b.write(b.create_texture("mine", {.size = gpu::Extent3D{8, 8, 1}, .format = gpu::Format::R32Float}),
                    TextureUse::StorageWrite);
        b.side_effect();
      },
      [&](const PassResources& res, const TextureHandle& t, PassContext& ctx) {
        CHECK(res.extent(secret).width == 8);  // still answers, but the access is recorded as an error
        dispatch_add(ctx, fill, res.view(t), nullptr, 0.0f, 8, 8);
      });
  auto compiled = graph.compile();
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  auto result = compiled->execute(device());
  REQUIRE_FALSE(result);
  CHECK(result.error().kind == ErrorKind::Graph);
  CHECK(contains(result.error().message,
                 "pass 'sneaky': execute uses texture 'secret', which its setup did not declare"));
  expect_no_validation_messages();
}

namespace {

// Random graphs whose passes really touch every declared resource (clears, copies, storage
// writes, sampling), so that synchronization validation checks every planned barrier,
// including the memory takeovers of aliased textures and buffers.
struct RandomKit {
  gpu::BindGroupLayout store_layout, sample_layout;
  gpu::PipelineLayout store_pipeline_layout, sample_pipeline_layout;
  gpu::ComputePipeline store, sample;
  gpu::Sampler sampler;
  gpu::Buffer source;
};

RandomKit make_random_kit() {
  auto store_module = device().create_shader_module({.label = "store", .stage = gpu::ShaderStage::Compute, .glsl = R"(#version 460
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba8) uniform writeonly image2D img;
void main() { imageStore(img, ivec2(gl_GlobalInvocationID.xy), vec4(0.25)); })"});
  auto sample_module = device().create_shader_module({.label = "sample", .stage = gpu::ShaderStage::Compute, .glsl = R"(#version 460
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0) uniform sampler2D tex;
layout(set = 0, binding = 1) writeonly buffer Out { uint v[]; };
void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  v[p.y * 16 + p.x] = packUnorm4x8(texelFetch(tex, p, 0));
})"});
  REQUIRE(store_module);
  REQUIRE(sample_module);
  auto store_layout = device().create_bind_group_layout(
      {.label = "store", .entries = {{0, gpu::BindingType::StorageTexture, gpu::ShaderStage::Compute, gpu::Format::RGBA8Unorm}}});
  auto sample_layout = device().create_bind_group_layout(
      {.label = "sample", .entries = {{0, gpu::BindingType::TextureSampler, gpu::ShaderStage::Compute},
                                      {1, gpu::BindingType::StorageBuffer, gpu::ShaderStage::Compute}}});
  REQUIRE(store_layout);
  REQUIRE(sample_layout);
  auto store_pl = device().create_pipeline_layout({.label = "store", .bind_group_layouts = {&*store_layout}});
  auto sample_pl = device().create_pipeline_layout({.label = "sample", .bind_group_layouts = {&*sample_layout}});
  REQUIRE(store_pl);
  REQUIRE(sample_pl);
  auto store = device().create_compute_pipeline({.label = "store", .layout = &*store_pl, .module = &*store_module});
  auto sample = device().create_compute_pipeline({.label = "sample", .layout = &*sample_pl, .module = &*sample_module});
  REQUIRE(store);
  REQUIRE(sample);
  auto sampler = device().create_sampler({.label = "random-nearest", .mag_filter = gpu::FilterMode::Nearest,
                                          .min_filter = gpu::FilterMode::Nearest});
  REQUIRE(sampler);
  std::vector<std::uint8_t> texels(16 * 16 * 4, 200);
  auto source = device().create_buffer_with_data({.label = "source", .size = texels.size(), .usage = gpu::BufferUsage::CopySrc},
                                                 std::as_bytes(std::span(texels)));
  REQUIRE(source);
  return {std::move(*store_layout), std::move(*sample_layout), std::move(*store_pl), std::move(*sample_pl),
          std::move(*store), std::move(*sample), std::move(*sampler), std::move(*source)};
}

struct Op {
  TextureUse use;
  TextureHandle texture;
  BufferHandle buffer;  // the sink of a read, or the source of a copy
};

struct OpsData {
  std::vector<Op> ops;
};

void run_op(const RandomKit& kit, const PassResources& res, const Op& op, PassContext& ctx) {
  gpu::CommandEncoder& enc = ctx.encoder();
  switch (op.use) {
    case TextureUse::ColorAttachment: {
      auto pass = enc.begin_render_pass({.label = "clear", .color_attachments = {{.view = &res.view(op.texture)}}});
      pass.end();
      break;
    }
    case TextureUse::CopyDst: enc.copy_buffer_to_texture(res.buffer(op.buffer), 0, res.texture(op.texture)); break;
    case TextureUse::CopySrc: enc.copy_texture_to_buffer(res.texture(op.texture), res.buffer(op.buffer), 0); break;
    case TextureUse::StorageWrite: {
      auto group = ctx.device().create_bind_group({.label = "store", .layout = &kit.store_layout,
                                                   .entries = {gpu::bind(0, res.view(op.texture))}});
      REQUIRE(group);
      auto pass = enc.begin_compute_pass("store");
      pass.set_pipeline(kit.store);
      pass.set_bind_group(0, ctx.keep(std::move(*group)));
      pass.dispatch(2, 2);
      pass.end();
      break;
    }
    case TextureUse::Sampled: {
      auto group = ctx.device().create_bind_group(
          {.label = "sample", .layout = &kit.sample_layout,
           .entries = {gpu::bind(0, res.view(op.texture), &kit.sampler), gpu::bind(1, res.buffer(op.buffer))}});
      REQUIRE(group);
      auto pass = enc.begin_compute_pass("sample");
      pass.set_pipeline(kit.sample);
      pass.set_bind_group(0, ctx.keep(std::move(*group)));
      pass.dispatch(2, 2);
      pass.end();
      break;
    }
    default: FAIL("unexpected use"); break;
  }
}

}  // namespace

TEST_CASE("random graphs executed under synchronization validation report nothing") {
  const RandomKit kit = make_random_kit();
  int takeovers = 0, executed_passes = 0;
  for (std::uint32_t seed = 1; seed <= 40; ++seed) {
    std::mt19937 rng(seed);
    auto roll = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
    RenderGraph graph("random-gpu");
    const BufferHandle source = graph.import_buffer("source", &kit.source, gpu::Access::CopySrc);
    struct Entry {
      TextureHandle handle;
      bool readable;
    };
    std::vector<Entry> pool;
    const int passes = roll(4, 14);
    int ran = 0;
    for (int p = 0; p < passes; ++p) {
      graph.add_pass<OpsData>(
          "p" + std::to_string(p),
          [&](PassBuilder& b, OpsData& d) {
            std::vector<std::uint32_t> used;
            auto fresh = [&](std::uint32_t index) {
              return std::find(used.begin(), used.end(), index) == used.end();
            };
            for (int r = roll(0, 2); r > 0 && !pool.empty(); --r) {
              Entry& e = pool[std::size_t(roll(0, int(pool.size()) - 1))];
              if (!e.readable || !fresh(e.handle.index)) continue;
              used.push_back(e.handle.index);
              const TextureUse use = roll(0, 1) ? TextureUse::CopySrc : TextureUse::Sampled;
              b.read(e.handle, use);
              const BufferHandle sink = b.write(b.create_buffer("sink" + std::to_string(p) + "_" + std::to_string(r), {.size = 1024}),
                                                use == TextureUse::CopySrc ? BufferUse::CopyDst : BufferUse::StorageWrite);
              d.ops.push_back({use, e.handle, sink});
            }
            auto write = [&](Entry& e) {
              used.push_back(e.handle.index);
              const int kind = roll(0, 2);
              const TextureUse use = kind == 0 ? TextureUse::ColorAttachment
                                               : kind == 1 ? TextureUse::CopyDst : TextureUse::StorageWrite;
              e.handle = b.write(e.handle, use);
              e.readable = true;
              if (use == TextureUse::CopyDst) b.read(source, BufferUse::CopySrc);
              d.ops.push_back({use, e.handle, source});
            };
            if (!pool.empty() && roll(0, 2) == 0) {
              Entry& e = pool[std::size_t(roll(0, int(pool.size()) - 1))];
              if (fresh(e.handle.index)) write(e);
            }
            if (roll(0, 3) > 0) {
              pool.push_back({b.create_texture("t" + std::to_string(p), {.size = gpu::Extent3D{16, 16, 1}}), false});
              write(pool.back());
            }
            if (roll(0, 3) == 0) b.side_effect();
          },
          [&](const PassResources& res, const OpsData& d, PassContext& ctx) {
            ++ran;
            for (const Op& op : d.ops) run_op(kit, res, op, ctx);
          });
    }
    for (const Entry& e : pool)
      if (e.readable && roll(0, 2) == 0) graph.mark_output(e.handle, gpu::Access::CopySrc);
    auto compiled = graph.compile({.device = &device()});
    REQUIRE_MESSAGE(compiled, "seed " << seed << ": " << compiled.error().to_string());
    for (std::uint32_t p : compiled->order())
      for (const PlannedBarrier& b : compiled->barriers_before(p)) takeovers += b.previous_occupant != invalid_index;
    for (int frame = 0; frame < 2; ++frame) {
      auto stats = compiled->execute(device());
      REQUIRE_MESSAGE(stats, "seed " << seed << ": " << stats.error().message);
    }
    CHECK(ran == int(compiled->order().size()) * 2);
    executed_passes += ran;
    INFO("seed " << seed << "\n" << compiled->dump());
    expect_no_validation_messages();
  }
  CHECK(takeovers > 20);
  MESSAGE("executed " << executed_passes << " passes with " << takeovers << " memory takeovers");
}
