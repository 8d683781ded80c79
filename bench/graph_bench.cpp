// weft-bench-graph: how the render graph's CPU cost grows with the number of passes, how much
// transient memory aliasing saves on a realistic frame, and (with a Vulkan device) the
// per-frame CPU overhead of executing through the graph against recording by hand.
//
//   build/bin/weft-bench-graph [--runs N] [--sizes 10,100,...] [--shapes chain,dag,dag-long]
//                              [--builds first,default,new,changed,unchanged] [--no-device] [--keep-heap]
//
// Prints markdown tables. Times are medians over --runs frames of std::chrono::steady_clock,
// plus thread-CPU time (steadier on a shared machine) and minor page faults per frame. Each
// shape and size is timed five ways (see Build): a new RenderGraph per frame in fresh memory,
// the same written the plain way (its thread's memory), a new one per frame on a GraphMemory,
// and one graph reset() and rebuilt, changed or unchanged.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <functional>
#include <malloc.h>
#include <sys/resource.h>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <vector>
#include <weft/args.h>
import weft.core;
import weft.gpu;
import weft.graph;

using namespace weft;
using Clock = std::chrono::steady_clock;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

double us_since(Clock::time_point t) { return std::chrono::duration<double, std::micro>(Clock::now() - t).count(); }

// CPU time of this thread: on a shared machine it excludes the time other processes held
// the core, which wall-clock medians cannot.
double thread_cpu_us() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e6 + double(t.tv_nsec) / 1e3;
}

// Pass names are made before timing: the graph copies them, the benchmark should not
// measure std::to_string.
std::vector<std::string> names(const char* prefix, int n) {
  std::vector<std::string> out;
  out.reserve(std::size_t(n));
  for (int i = 0; i < n; ++i) out.push_back(prefix + std::to_string(i));
  return out;
}

struct Timing {
  double setup_us = 0, compile_us = 0, total_us = 0, frame_us = 0, cpu_us = 0, faults = 0;
};

// Minor page faults of this thread so far: memory the kernel maps on first touch (what a
// graph pays when the heap gave its last graph's arrays back).
long minor_faults() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return usage.ru_minflt;
}

// How a run gets its graph. First: a new RenderGraph in a new GraphMemory, so every array, the
// arena and the compiled state are allocated. Default: `RenderGraph graph(name);` every frame,
// as a user writes it, which takes its thread's memory (GraphMemory::for_this_thread). New per frame: a new RenderGraph made with a GraphMemory the
// benchmark keeps across runs (an application's frame loop). Reset + rebuild: one RenderGraph,
// reset() and declared again. New per frame and reset + rebuild start with two untimed runs
// (a graph alternates between two sets of arrays), so the timed runs reuse their memory; "changed" frames differ from the last one in their
// very last declaration (a full compile), "unchanged" frames declare the same (plan reused).
enum class Build { First, Default, NewPerFrame, Changed, Unchanged };

const char* to_string(Build build) {
  switch (build) {
    case Build::First: return "first build";
    case Build::Default: return "new graph per frame (default), changed";
    case Build::NewPerFrame: return "new graph per frame (GraphMemory), changed";
    case Build::Changed: return "reset + rebuild, changed";
    case Build::Unchanged: return "reset + rebuild, unchanged (plan reused)";
  }
  return "?";
}

// Times `runs` frames of one shape: declare(graph, changed) adds the passes, where `changed`
// asks for a frame that differs from the last in its last declaration. Setup = making or
// resetting the graph and declaring; compile = compile(); frame = both plus destroying the
// compiled graph (and the graph, when it is new per frame), which thread-CPU and the faults
// also cover.
template <class Declare>
Timing time_frames(int runs, Build build, const char* name, Declare&& declare, std::size_t* culled = nullptr) {
  std::vector<double> setup, compile, total, frame, cpu;
  long faults = 0;
  GraphMemory memory;
  RenderGraph reused(name);
  for (int run = build == Build::First ? 0 : -2; run < runs; ++run) {
    const bool changed =
        (build == Build::Changed || build == Build::NewPerFrame || build == Build::Default) && (run & 1) != 0;
    const long f0 = minor_faults();
    const double c0 = thread_cpu_us();
    const auto t0 = Clock::now();
    Clock::time_point t1, t2;
    {
      std::optional<GraphMemory> cold;  // destroyed after the graph made in it
      std::optional<RenderGraph> fresh;
      RenderGraph& graph = build == Build::First         ? fresh.emplace(name, cold.emplace())
                           : build == Build::Default     ? fresh.emplace(name)
                           : build == Build::NewPerFrame ? fresh.emplace(name, memory)
                                                         : (reused.reset(), reused);
      declare(graph, changed);
      t1 = Clock::now();
      auto compiled = graph.compile({.output_extent = {1920, 1080, 1}});
      t2 = Clock::now();
      if (!compiled) {
        std::fprintf(stderr, "%s\n", compiled.error().to_string().c_str());
        std::exit(1);
      }
      if (culled) *culled = graph.pass_count() - compiled->order().size();
    }
    const auto t3 = Clock::now();
    const double c1 = thread_cpu_us();
    const long f1 = minor_faults();
    if (run < 0) continue;
    faults += f1 - f0;
    cpu.push_back(c1 - c0);
    setup.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    compile.push_back(std::chrono::duration<double, std::micro>(t2 - t1).count());
    total.push_back(std::chrono::duration<double, std::micro>(t2 - t0).count());
    frame.push_back(std::chrono::duration<double, std::micro>(t3 - t0).count());
  }
  return {median(setup), median(compile), median(total), median(frame), median(cpu), double(faults) / runs};
}

// A chain: each pass samples the previous pass's texture and renders a new one. Not inlined,
// so that `valgrind --tool=callgrind --toggle-collect='*time_chain*'` counts this shape alone.
[[gnu::noinline]] Timing time_chain(int n, int runs, Build build, const std::vector<std::string>& pass_names,
                                    const std::vector<std::string>& tex_names) {
  const gpu::TextureDescriptor output_desc{.label = "output", .size = {1920, 1080, 1}, .format = gpu::Format::RGBA8Unorm,
                                           .usage = gpu::TextureUsage::ColorAttachment};
  return time_frames(runs, build, "chain", [&](RenderGraph& graph, bool changed) {
    TextureHandle previous;
    for (int i = 0; i < n; ++i) {
      graph.add_pass(pass_names[std::size_t(i)], [&](PassBuilder& b) {
        if (previous.valid()) b.read(previous, TextureUse::Sampled);
        previous = b.write(b.create_texture(tex_names[std::size_t(i)], {.size = RelativeSize{1.0f}}),
                           TextureUse::ColorAttachment);
      });
    }
    auto output = graph.import_texture("output", output_desc, gpu::Access::Undefined);
    // A changed frame reads the last texture another way than the last frame: the very last
    // access differs, so compile() finds it only after comparing everything else.
    graph.add_pass("present", [&](PassBuilder& b) {
      b.read(previous, changed ? TextureUse::StorageRead : TextureUse::Sampled);
      output = b.write(output, TextureUse::ColorAttachment);
    });
    graph.mark_output(output);
  });
}

// A random DAG: each pass reads up to three earlier results (fixed seed, chosen before
// timing), writes one new texture; a tenth of the passes are side effects, so some chains
// reach nothing and are culled. `recent`: reads are mostly of the last few passes, as in a
// real frame (few transients alive at once); otherwise of any earlier pass, so that the
// number of live transients and free memory runs grows with the graph (the planner's worst
// case).
struct DagShape {
  std::vector<std::vector<int>> reads;
  std::vector<bool> side_effect;
};

DagShape make_dag(int n, std::uint32_t seed, bool recent = true) {
  std::mt19937 rng(seed);
  DagShape shape;
  shape.reads.resize(std::size_t(n));
  shape.side_effect.resize(std::size_t(n));
  for (int i = 0; i < n; ++i) {
    const int k = i == 0 ? 0 : std::uniform_int_distribution<int>(1, 3)(rng);
    for (int j = 0; j < k; ++j) {
      const int back = recent ? std::min(i, 1 + int(std::exponential_distribution<double>(0.2)(rng)))
                              : std::uniform_int_distribution<int>(1, i)(rng);
      const int source = i - back;
      if (std::find(shape.reads[std::size_t(i)].begin(), shape.reads[std::size_t(i)].end(), source) ==
          shape.reads[std::size_t(i)].end())
        shape.reads[std::size_t(i)].push_back(source);
    }
    shape.side_effect[std::size_t(i)] = std::uniform_int_distribution<int>(0, 9)(rng) == 0;
  }
  shape.side_effect.back() = true;
  return shape;
}

[[gnu::noinline]] Timing time_dag(const DagShape& shape, int runs, Build build, const std::vector<std::string>& pass_names,
                                  const std::vector<std::string>& tex_names, std::size_t* culled = nullptr) {
  const int n = int(shape.reads.size());
  std::vector<TextureHandle> results(static_cast<std::size_t>(n));
  return time_frames(
      runs, build, "dag",
      [&](RenderGraph& graph, bool changed) {
        for (int i = 0; i < n; ++i) {
          graph.add_pass(pass_names[std::size_t(i)], [&](PassBuilder& b) {
            for (int source : shape.reads[std::size_t(i)])
              b.read(results[std::size_t(source)],
                     changed && i == n - 1 ? TextureUse::StorageRead : TextureUse::Sampled);
            results[std::size_t(i)] =
                b.write(b.create_texture(tex_names[std::size_t(i)], {.size = RelativeSize{(i % 3) ? 1.0f : 0.5f},
                                                                     .format = gpu::Format::RGBA16Float}),
                        TextureUse::StorageWrite);
            if (shape.side_effect[std::size_t(i)]) b.side_effect();
          });
        }
      },
      culled);
}

// A deferred frame: depth prepass, shadow map, gbuffer, SSAO, lighting, TAA (with last
// frame's history imported), depth of field, a five-level bloom chain (down and up),
// tonemap into an LDR target and FXAA into the imported output.
const gpu::TextureDescriptor realistic_output_desc{.label = "output", .size = {1920, 1080, 1},
                                                   .format = gpu::Format::RGBA8Unorm,
                                                   .usage = gpu::TextureUsage::ColorAttachment};
const gpu::TextureDescriptor realistic_history_desc{.label = "taa_history", .size = {1920, 1080, 1},
                                                    .format = gpu::Format::RGBA16Float,
                                                    .usage = gpu::TextureUsage::Sampled};

// `output` and `history`: the gpu textures to import (for execute), or null for descriptors
// only. `variant` leaves the output in another state (a frame that differs from the last).
void build_realistic_frame(RenderGraph& graph, const gpu::Texture* output_texture = nullptr,
                           const gpu::Texture* history_texture = nullptr, bool variant = false) {
  using F = gpu::Format;
  auto output = output_texture ? graph.import_texture("output", output_texture, gpu::Access::Undefined)
                               : graph.import_texture("output", realistic_output_desc, gpu::Access::Undefined);
  auto history = history_texture ? graph.import_texture("taa_history", history_texture, gpu::Access::ShaderRead)
                                 : graph.import_texture("taa_history", realistic_history_desc, gpu::Access::ShaderRead);
  TextureHandle depth, shadow, albedo, normal, material, ao, hdr, taa, dof, ldr;
  graph.add_pass("depth_prepass", [&](PassBuilder& b) {
    depth = b.write(b.create_texture("depth", {.size = RelativeSize{1.0f}, .format = F::Depth32Float}),
                    TextureUse::DepthAttachment);
  });
  graph.add_pass("shadow_map", [&](PassBuilder& b) {
    shadow = b.write(b.create_texture("shadow_map", {.size = gpu::Extent3D{2048, 2048, 1}, .format = F::Depth32Float}),
                     TextureUse::DepthAttachment);
  });
  graph.add_pass("gbuffer", [&](PassBuilder& b) {
    depth = b.write(depth, TextureUse::DepthAttachment);
    albedo = b.write(b.create_texture("albedo", {.size = RelativeSize{1.0f}, .format = F::RGBA8Unorm}), TextureUse::ColorAttachment);
    normal = b.write(b.create_texture("normal", {.size = RelativeSize{1.0f}, .format = F::RGBA16Float}), TextureUse::ColorAttachment);
    material = b.write(b.create_texture("material", {.size = RelativeSize{1.0f}, .format = F::RGBA8Unorm}), TextureUse::ColorAttachment);
  });
  graph.add_pass("ssao", [&](PassBuilder& b) {
    b.read(depth, TextureUse::Sampled);
    b.read(normal, TextureUse::Sampled);
    ao = b.write(b.create_texture("ao", {.size = RelativeSize{0.5f}, .format = F::R8Unorm}), TextureUse::StorageWrite);
  });
  graph.add_pass("lighting", [&](PassBuilder& b) {
    for (TextureHandle t : {albedo, normal, material, ao, shadow}) b.read(t, TextureUse::Sampled);
    b.read(depth, TextureUse::Sampled);
    hdr = b.write(b.create_texture("hdr", {.size = RelativeSize{1.0f}, .format = F::RGBA16Float}), TextureUse::ColorAttachment);
  });
  graph.add_pass("taa", [&](PassBuilder& b) {
    b.read(hdr, TextureUse::Sampled);
    b.read(history, TextureUse::Sampled);
    taa = b.write(b.create_texture("taa_color", {.size = RelativeSize{1.0f}, .format = F::RGBA16Float}), TextureUse::StorageWrite);
  });
  graph.add_pass("depth_of_field", [&](PassBuilder& b) {
    b.read(taa, TextureUse::Sampled);
    b.read(depth, TextureUse::Sampled);
    dof = b.write(b.create_texture("dof_color", {.size = RelativeSize{1.0f}, .format = F::RGBA16Float}), TextureUse::StorageWrite);
  });
  std::vector<TextureHandle> down;
  TextureHandle source = dof;
  float scale = 0.5f;
  for (int level = 0; level < 5; ++level, scale *= 0.5f) {
    graph.add_pass("bloom_down" + std::to_string(level), [&](PassBuilder& b) {
      b.read(source, TextureUse::Sampled);
      source = b.write(b.create_texture("bloom_down" + std::to_string(level), {.size = RelativeSize{scale}, .format = F::RGBA16Float}),
                       TextureUse::ColorAttachment);
    });
    down.push_back(source);
  }
  scale = 1.0f / 16.0f;
  for (int level = 3; level >= 0; --level, scale *= 2.0f) {
    graph.add_pass("bloom_up" + std::to_string(level), [&](PassBuilder& b) {
      b.read(source, TextureUse::Sampled);
      b.read(down[std::size_t(level)], TextureUse::Sampled);
      source = b.write(b.create_texture("bloom_up" + std::to_string(level), {.size = RelativeSize{scale}, .format = F::RGBA16Float}),
                       TextureUse::ColorAttachment);
    });
  }
  graph.add_pass("tonemap", [&](PassBuilder& b) {
    b.read(dof, TextureUse::Sampled);
    b.read(source, TextureUse::Sampled);
    ldr = b.write(b.create_texture("ldr", {.size = RelativeSize{1.0f}, .format = F::RGBA8Unorm}), TextureUse::ColorAttachment);
  });
  graph.add_pass("fxaa", [&](PassBuilder& b) {
    b.read(ldr, TextureUse::Sampled);
    output = b.write(output, TextureUse::ColorAttachment);
  });
  graph.mark_output(output, variant ? gpu::Access::ColorAttachment : gpu::Access::Undefined);
}

// A frame loop: every frame reset(), declare the realistic frame, compile, execute. When
// the frames alternate (changed), every compile plans again and execute creates the
// transients again; when they do not, compile() reuses the plan and its transients.
void frame_loop_table(gpu::Device& device, int runs) {
  std::printf("\n### A frame loop rebuilding the realistic frame every frame\n\n");
  std::printf("Per frame: reset(), declare the 18 passes, compile(), execute() (passes record only their "
              "barriers and labels; timestamps off). Median CPU time per frame over %d frames.\n\n",
              runs);
  auto output = device.create_texture(realistic_output_desc);
  auto history = device.create_texture(realistic_history_desc);
  if (!output || !history) std::exit(1);
  std::printf("| frames | setup + compile µs | execute ms | frame ms | plans reused |\n|:--|--:|--:|--:|--:|\n");
  for (bool changing : {true, false}) {
    RenderGraph graph("realistic");
    std::vector<double> declare_compile, execute, frame;
    int reused = 0;
    for (int run = -2; run < runs; ++run) {
      const auto t0 = Clock::now();
      graph.reset();
      build_realistic_frame(graph, &*output, &*history, changing && (run & 1) != 0);
      auto compiled = graph.compile({.output_extent = {1920, 1080, 1}});
      const auto t1 = Clock::now();
      if (!compiled) {
        std::fprintf(stderr, "%s\n", compiled.error().to_string().c_str());
        std::exit(1);
      }
      auto stats = compiled->execute(device, {.timestamps = false});
      const auto t2 = Clock::now();
      if (!stats) {
        std::fprintf(stderr, "%s\n", stats.error().message.c_str());
        std::exit(1);
      }
      if (run < 0) continue;
      reused += compiled->plan_reused() ? 1 : 0;
      declare_compile.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      execute.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
      frame.push_back(std::chrono::duration<double, std::milli>(t2 - t0).count());
    }
    std::printf("| %s | %.1f | %.2f | %.2f | %d of %d |\n", changing ? "alternating (changed every frame)" : "identical",
                median(declare_compile), median(execute), median(frame), reused, runs);
  }
}

std::string mib(std::uint64_t bytes) { return weft::format("{:.1f} MiB", double(bytes) / (1024.0 * 1024.0)); }

// ---- per-frame CPU overhead with a device ------------------------------------------------

struct ComputeKit {
  gpu::BindGroupLayout layout;
  gpu::PipelineLayout pipeline_layout;
  gpu::ComputePipeline pipeline;
};

std::optional<ComputeKit> make_kit(gpu::Device& device) {
  auto module = device.create_shader_module({.label = "bench-copy", .stage = gpu::ShaderStage::Compute, .glsl = R"(#version 460
layout(local_size_x = 64) in;
layout(set = 0, binding = 0) readonly buffer In { uint a[]; };
layout(set = 0, binding = 1) writeonly buffer Out { uint b[]; };
void main() { b[gl_GlobalInvocationID.x] = a[gl_GlobalInvocationID.x] + 1u; })"});
  if (!module) return std::nullopt;
  auto bgl = device.create_bind_group_layout(
      {.label = "bench", .entries = {{0, gpu::BindingType::ReadOnlyStorageBuffer, gpu::ShaderStage::Compute},
                                     {1, gpu::BindingType::StorageBuffer, gpu::ShaderStage::Compute}}});
  if (!bgl) return std::nullopt;
  auto layout = device.create_pipeline_layout({.label = "bench", .bind_group_layouts = {&*bgl}});
  if (!layout) return std::nullopt;
  auto pipeline = device.create_compute_pipeline({.label = "bench", .layout = &*layout, .module = &*module});
  if (!pipeline) return std::nullopt;
  return ComputeKit{std::move(*bgl), std::move(*layout), std::move(*pipeline)};
}

void record_step(gpu::CommandEncoder& encoder, gpu::Device& device, const ComputeKit& kit, const gpu::Buffer& in,
                 const gpu::Buffer& out, std::vector<gpu::BindGroup>& keep) {
  auto group = device.create_bind_group({.label = "step", .layout = &kit.layout, .entries = {gpu::bind(0, in), gpu::bind(1, out)}});
  if (!group) std::exit(1);
  keep.push_back(std::move(*group));
  auto pass = encoder.begin_compute_pass("step");
  pass.set_pipeline(kit.pipeline);
  pass.set_bind_group(0, keep.back());
  pass.dispatch(1);
  pass.end();
}

void overhead_table(gpu::Device& device, int runs) {
  auto kit = make_kit(device);
  if (!kit) {
    std::printf("(no compute pipeline: skipping the execute overhead table)\n");
    return;
  }
  std::printf("\n### Per-frame CPU cost: graph execute vs the same commands recorded by hand\n\n");
  std::printf("Each pass: a debug label, one bind group, one 64-thread dispatch reading the previous pass's 256-byte "
              "storage buffer, its barriers; timestamps off. record = CPU time until the command buffer is finished; "
              "frame = record + submit + wait.\n\n");
  std::printf("| passes | by hand: record µs | graph: record µs | overhead µs/pass | by hand: frame ms | graph: frame ms |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|\n");
  for (int n : {10, 100, 500, 5000}) {
    const std::vector<std::string> step_names = names("step", n);
    // By hand: dedicated buffers, explicit barriers, a debug label per pass as the graph does.
    std::vector<gpu::Buffer> buffers;
    for (int i = 0; i <= n; ++i) {
      auto b = device.create_buffer({.label = "hand", .size = 256, .usage = gpu::BufferUsage::Storage});
      if (!b) std::exit(1);
      buffers.push_back(std::move(*b));
    }
    std::vector<double> hand_record, hand_frame;
    for (int run = 0; run < runs; ++run) {
      std::vector<gpu::BindGroup> keep;
      keep.reserve(std::size_t(n));
      const auto t0 = Clock::now();
      auto encoder = device.create_command_encoder("by-hand");
      for (int i = 0; i < n; ++i) {
        encoder->push_debug_group(step_names[std::size_t(i)]);
        const gpu::BufferBarrier barriers[2] = {{&buffers[std::size_t(i)], gpu::Access::StorageWrite, gpu::Access::StorageRead},
                                                {&buffers[std::size_t(i) + 1], gpu::Access::StorageRead, gpu::Access::StorageWrite}};
        encoder->barrier({}, std::span(barriers, i == 0 ? 1 : 2));
        record_step(*encoder, device, *kit, buffers[std::size_t(i)], buffers[std::size_t(i) + 1], keep);
        encoder->pop_debug_group();
      }
      auto commands = encoder->finish();
      hand_record.push_back(us_since(t0));
      if (!commands || !device.queue().submit(std::move(*commands)) || !device.queue().wait_idle()) std::exit(1);
      hand_frame.push_back(us_since(t0) / 1000.0);
    }

    // Through the graph: the same passes, transient buffers, barriers derived.
    RenderGraph graph("overhead");
    auto first = graph.import_buffer("seed", &buffers[0], gpu::Access::StorageWrite);
    struct Data {
      BufferHandle in, out;
    };
    BufferHandle previous = first;
    const ComputeKit& k = *kit;
    for (int i = 0; i < n; ++i) {
      auto& d = graph.add_pass<Data>(
          step_names[std::size_t(i)],
          [&](PassBuilder& b, Data& data) {
            data.in = b.read(previous, BufferUse::StorageRead);
            data.out = b.write(b.create_buffer("b" + std::to_string(i), {.size = 256}), BufferUse::StorageWrite);
            if (i == n - 1) b.side_effect();
          },
          [&k](const PassResources& res, const Data& data, PassContext& ctx) {
            auto group = ctx.device().create_bind_group(
                {.label = "step", .layout = &k.layout, .entries = {gpu::bind(0, res.buffer(data.in)), gpu::bind(1, res.buffer(data.out))}});
            if (!group) std::exit(1);
            const gpu::BindGroup& kept = ctx.keep(std::move(*group));
            auto pass = ctx.encoder().begin_compute_pass("step");
            pass.set_pipeline(k.pipeline);
            pass.set_bind_group(0, kept);
            pass.dispatch(1);
            pass.end();
          });
      previous = d.out;
    }
    auto compiled = graph.compile({.device = &device});
    if (!compiled) {
      std::fprintf(stderr, "%s\n", compiled.error().to_string().c_str());
      std::exit(1);
    }
    if (!compiled->execute(device, {.timestamps = false})) std::exit(1);  // realize once
    std::vector<double> graph_record, graph_frame;
    for (int run = 0; run < runs; ++run) {
      auto stats = compiled->execute(device, {.timestamps = false});
      if (!stats) {
        std::fprintf(stderr, "%s\n", stats.error().message.c_str());
        std::exit(1);
      }
      graph_record.push_back(stats->cpu_record_total_us);
      graph_frame.push_back(stats->cpu_frame_ms);
    }
    const double hr = median(hand_record), gr = median(graph_record);
    std::printf("| %d | %.0f | %.0f | %.2f | %.2f | %.2f |\n", n, hr, gr, (gr - hr) / n, median(hand_frame),
                median(graph_frame));
  }
}

}  // namespace

constexpr const char* usage_text =
    "usage: weft-bench-graph [--runs N] [--sizes 10,100,...] [--shapes chain,dag,dag-long]\n"
    "                        [--builds first,default,new,changed,unchanged] [--no-device] [--keep-heap]\n"
    "  --runs N     frames per row (default 15, at least 7; rows of 10,000+ passes run half)\n"
    "  --sizes      pass counts (default 10,100,1000,5000,10000)\n"
    "  --shapes     chain; dag (reads of recent passes); dag-long (reads of any earlier pass)\n"
    "  --builds     first: a new RenderGraph per frame in fresh memory; default: `RenderGraph g(name)`\n"
    "               per frame (its thread's memory); new: a new RenderGraph per frame on a GraphMemory;\n"
    "               changed / unchanged: reset() and rebuilt, full compile / plan reused\n"
    "  --no-device  graph tables only (no Vulkan device: no execute overhead or frame loop)\n"
    "  --keep-heap  tell glibc never to give freed memory back to the kernel\n";

// The items of a comma-separated list, each mapped by `parse` (false: unknown).
template <class T, class Parse>
bool parse_list(const char* text, std::vector<T>& out, Parse&& parse) {
  out.clear();
  const std::string list = text;
  for (std::size_t start = 0; start <= list.size();) {
    const std::size_t end = std::min(list.find(',', start), list.size());
    T value{};
    if (!parse(list.substr(start, end - start), value)) return false;
    out.push_back(value);
    start = end + 1;
  }
  return !out.empty();
}

enum class Shape { Chain, Dag, DagLong };

int main(int argc, char** argv) {
  int runs = 15;
  bool use_device = true;
  std::vector<int> sizes{10, 100, 1000, 5000, 10000};
  bool keep_heap = false;
  std::vector<Build> builds{Build::First, Build::Default, Build::NewPerFrame, Build::Changed, Build::Unchanged};
  std::vector<Shape> shapes{Shape::Chain, Shape::Dag, Shape::DagLong};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--help" || arg == "-h") {
      std::printf("%s", usage_text);
      return 0;
    } else if (arg == "--runs" && has_value) {
      // Digits only (issue 33: atoi read "abc" as 0, silently 7 runs).
      const auto n = weft::args::whole(argv[++i], 1, 100000);
      if (!n) {
        std::fprintf(stderr, "weft-bench-graph: --runs expects a whole number 1..100000 (at least 7 are run), got '%s'\n", argv[i]);
        return 2;
      }
      runs = std::max(7, int(*n));
    } else if (arg == "--sizes" && has_value) {
      if (!parse_list(argv[++i], sizes, [](const std::string& item, int& n) {
            const auto v = weft::args::whole(item, 1, 1'000'000);
            n = int(v.value_or(0));
            return v.has_value();
          })) {
        std::fprintf(stderr, "weft-bench-graph: --sizes: a comma-separated list of pass counts 1..1000000, got '%s'\n", argv[i]);
        return 2;
      }
    } else if (arg == "--no-device") {
      use_device = false;
    } else if (arg == "--keep-heap") {
      keep_heap = true;
    } else if (arg == "--builds" && has_value) {
      // e.g. `--builds changed` to count the instructions of one case alone under callgrind
      if (!parse_list(argv[++i], builds, [](const std::string& item, Build& b) {
            if (item == "first") b = Build::First;
            else if (item == "default") b = Build::Default;
            else if (item == "new") b = Build::NewPerFrame;
            else if (item == "changed") b = Build::Changed;
            else if (item == "unchanged") b = Build::Unchanged;
            else return false;
            return true;
          })) {
        std::fprintf(stderr, "weft-bench-graph: --builds: a comma-separated list of first, default, new, changed, unchanged, got '%s'\n", argv[i]);
        return 2;
      }
    } else if (arg == "--shapes" && has_value) {
      if (!parse_list(argv[++i], shapes, [](const std::string& item, Shape& s) {
            if (item == "chain") s = Shape::Chain;
            else if (item == "dag") s = Shape::Dag;
            else if (item == "dag-long") s = Shape::DagLong;
            else return false;
            return true;
          })) {
        std::fprintf(stderr, "weft-bench-graph: --shapes: a comma-separated list of chain, dag, dag-long, got '%s'\n", argv[i]);
        return 2;
      }
    } else {
      std::fprintf(stderr, "weft-bench-graph: unknown or incomplete argument '%s'\n%s", argv[i], usage_text);
      return 2;
    }
  }

  if (keep_heap) {
    // What an engine rebuilding its graph every frame gets from a frame allocator: memory
    // that stays mapped between frames. glibc otherwise returns the freed top of the heap
    // to the kernel after every graph, and the next graph pays a page fault per 4 KiB.
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
    mallopt(M_MMAP_THRESHOLD, 256 << 20);
  }
  std::printf("## weft.graph benchmark\n\nMedians of %d frames (half at 10,000+ passes). setup = making or reset() of "
              "the graph + declaring every pass; compile = validate, cull, order, lifetimes, aliasing, barriers; "
              "frame = setup + compile + destroying the compiled graph (and a graph made per frame); thread-CPU "
              "and minor page faults (getrusage, mean per frame) cover the frame.\n\n",
              runs);
  std::printf("Builds: first = a new RenderGraph per frame in a new GraphMemory (nothing kept); default = "
              "`RenderGraph graph(name)` per frame, as a user writes it (its thread's memory); new graph per frame = "
              "a new RenderGraph per frame made with a GraphMemory kept across frames; reset + rebuild = one RenderGraph, reset() and declared again. "
              "Changed frames differ from the last in their last declaration (a full compile every frame); unchanged "
              "frames declare the same (compile() reuses the last plan).\n\n");
  std::printf("| graph | build | passes | setup µs | compile µs | setup+compile µs | µs/pass | frame µs | frame "
              "thread-CPU µs | minor faults/frame |\n|:--|:--|--:|--:|--:|--:|--:|--:|--:|--:|\n");
  for (Shape shape : shapes) {
    for (Build build : builds) {
      for (int n : sizes) {
        const auto pass_names = names("pass", n), tex_names = names("tex", n);
        const int r = n >= 10000 ? std::max(7, runs / 2) : runs;
        std::size_t culled = 0;
        Timing t;
        std::string label = "chain";
        if (shape == Shape::Chain) {
          t = time_chain(n, r, build, pass_names, tex_names);
        } else {
          t = time_dag(make_dag(n, 42, shape == Shape::Dag), r, build, pass_names, tex_names, &culled);
          label = weft::format("{} ({} culled)", shape == Shape::Dag ? "random DAG" : "random DAG, long reads", culled);
        }
        std::printf("| %s | %s | %d | %.1f | %.1f | %.1f | %.3f | %.1f | %.1f | %.1f |\n", label.c_str(),
                    to_string(build), n, t.setup_us, t.compile_us, t.total_us, t.total_us / n, t.frame_us, t.cpu_us,
                    t.faults);
      }
    }
  }

  std::printf("\n### Transient memory of a realistic 1920x1080 frame\n\n");
  std::printf("Depth prepass, 2048² shadow map, gbuffer (3 targets), SSAO, lighting, TAA, depth of field, 5-level bloom "
              "down/up, tonemap, FXAA into the imported output.\n\n");
  std::printf("| memory sizes from | without aliasing | with aliasing | saved |\n|:--|--:|--:|--:|\n");
  {
    RenderGraph graph("realistic");
    build_realistic_frame(graph);
    auto compiled = graph.compile({.output_extent = {1920, 1080, 1}});
    if (!compiled) {
      std::fprintf(stderr, "%s\n", compiled.error().to_string().c_str());
      return 1;
    }
    const MemoryPlan& m = compiled->memory();
    std::printf("| estimate (texels × bytes, 64 KiB aligned) | %s | %s | %.0f%% |\n", mib(m.unaliased_bytes).c_str(),
                mib(m.aliased_bytes).c_str(), 100.0 * (1.0 - double(m.aliased_bytes) / double(m.unaliased_bytes)));
  }

  if (!use_device) return 0;
  auto instance = gpu::Instance::create({.application_name = "weft-bench-graph"});
  std::optional<gpu::Adapter> adapter;
  if (instance) {
    if (auto a = instance->request_adapter()) adapter.emplace(std::move(*a));
  }
  if (!adapter) {
    std::printf("\n(no Vulkan adapter: skipping device measurements)\n");
    return 0;
  }
  auto device = adapter->request_device({.label = "bench"});
  if (!device) {
    std::printf("\n(no Vulkan device: %s)\n", device.error().message.c_str());
    return 0;
  }
  {
    RenderGraph graph("realistic");
    build_realistic_frame(graph);
    auto compiled = graph.compile({.output_extent = {1920, 1080, 1}, .device = &*device});
    if (compiled) {
      const MemoryPlan& m = compiled->memory();
      std::printf("| %s (Device::memory_requirements) | %s | %s | %.0f%% |\n", adapter->info().name.c_str(),
                  mib(m.unaliased_bytes).c_str(), mib(m.aliased_bytes).c_str(),
                  100.0 * (1.0 - double(m.aliased_bytes) / double(m.unaliased_bytes)));
    }
  }
  std::printf("\nDevice: %s (%s)\n", adapter->info().name.c_str(), adapter->info().driver.c_str());
  overhead_table(*device, runs);
  frame_loop_table(*device, runs);
  return 0;
}
