// weft-bench-btf-decode: how fast the NeuralBTFMaterial's decoder runs on this device.
//   peak    the FMA limit, measured: a compute shader of pure FMA chains on this device
//           (fma_peak.comp) and plain C++ AVX2 / AVX-512 FMA loops on every CPU thread
//           (fma_peak_cpu.cpp); the kernel and frame tables give % of the device's
//   kernel  the decode kernel (btf_decode.comp, the material's GLSL) over 512 x 512 queries:
//           texels per second and GFLOP/s (2 FLOP per multiply-add, 24,383 of them per decode
//           for the paper's 12 -> 106 -> 106 -> 106 -> 3 decoder) against the CPU's peak
//           estimate, plain and clustered models; the scalar CPU decode (weft::btf::decode,
//           one thread) is the baseline measured in the same run
//   frame   a 512 x 512 frame filled by a neural_btf quad through weft::renderer: the passes'
//           GPU time per quality knob (decodes per pixel: key light, + ambient, bilinear), the
//           batched path and the fragment path alternating in one run
//   storage the .wbtf sizes of the paper's models in fp32 and compact storage, and what fp16
//           weights and latents change in the decoded values
//
//   build/bin/weft-bench-btf-decode [peak] [kernel] [frame] [storage] [--runs N] [--size N] [--ghz F]
//
// Times are medians over --runs runs (default 5) of steady_clock around submit + wait.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <set>
#include <span>
#include <string>
#include <thread>
#include <vector>
#include <glm/glm.hpp>
#include <weft/args.h>
#include "fma_peak_cpu.h"
#include "weft-bench-btf-decode_shaders.h"
import weft.core;
import weft.feature;
import weft.gpu;
import weft.scene;
import weft.renderer;
import weft.builtin_features;
import weft.btf.model;
import weft.pass.neural_btf;
import weft.bench.device;

using namespace weft;
using Clock = std::chrono::steady_clock;

namespace {

struct Options {
  int runs = 5;
  std::uint32_t size = 512;
  double ghz = 0.0;  // 0: from /proc/cpuinfo
  std::set<std::string> sections;
  [[nodiscard]] bool wants(const std::string& s) const { return sections.empty() || sections.contains(s); }
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// The clock the kernel reports (cpu MHz of /proc/cpuinfo; on a VM the nominal frequency).
double cpu_ghz() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("cpu MHz", 0) == 0)
      if (auto colon = line.find(':'); colon != std::string::npos) return std::atof(line.c_str() + colon + 1) / 1000.0;
  return 0.0;
}

// FP32 FLOP per cycle per core: AVX2 with two FMA pipes (Zen 2/3, Haswell and later) = 2 x 8 x 2.
constexpr double kFlopPerCycle = 32.0;

using bench::Session;

std::size_t multiply_adds(const btf::NeuralBtf& m) { return m.decoder.parameter_count(); }

std::vector<passes::DecodeQuery> random_queries(const btf::NeuralBtf& m, std::size_t count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  auto hemisphere = [&] {
    const float z = u(rng), phi = 2.0f * pi * u(rng), r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    return vec3(r * std::cos(phi), r * std::sin(phi), z);
  };
  std::vector<passes::DecodeQuery> q(count);
  for (auto& x : q) x = {hemisphere(), float(rng() % m.texels()), hemisphere(), 0.0f};
  return q;
}

// The device's FMA throughput (fma_peak.comp): GFLOP/s, median of o.runs; 0 on failure.
double device_fma_peak(Session& s, const Options& o) {
  auto cs = s.device.create_shader_module(
      {.label = "fma_peak.comp", .stage = gpu::ShaderStage::Compute, .spirv = shaders::fma_peak_comp()});
  auto layout = s.device.create_bind_group_layout(
      {.label = "fma-peak", .entries = {{0, gpu::BindingType::StorageBuffer, gpu::ShaderStage::Compute}}});
  if (!cs || !layout) return 0.0;
  auto pipeline_layout =
      s.device.create_pipeline_layout({.label = "fma-peak", .bind_group_layouts = {&*layout}, .push_constant_size = 12});
  if (!pipeline_layout) return 0.0;
  auto pipeline = s.device.create_compute_pipeline({.label = "fma-peak", .layout = &*pipeline_layout, .module = &*cs});
  const std::uint32_t groups = 1024, invocations = groups * 64, iterations = 4096;
  auto out = s.device.create_buffer({.label = "fma-sums", .size = invocations * 4, .usage = gpu::BufferUsage::Storage});
  if (!pipeline || !out) return 0.0;
  auto group = s.device.create_bind_group({.label = "fma-peak", .layout = &*layout, .entries = {gpu::bind(0, *out)}});
  if (!group) return 0.0;
  struct Push {
    float b, c;
    std::uint32_t iterations;
  };
  std::vector<double> gflops;
  for (int r = 0; r <= o.runs; ++r) {
    auto enc = s.device.create_command_encoder("fma-peak");
    if (!enc) return 0.0;
    {
      auto pass = enc->begin_compute_pass("fma-peak");
      pass.set_pipeline(*pipeline);
      pass.set_bind_group(0, *group);
      pass.push(Push{0.999f, 0.001f, iterations});
      pass.dispatch(groups);
      pass.end();
    }
    auto cmd = enc->finish();
    if (!cmd) return 0.0;
    const auto start = Clock::now();
    if (!s.device.queue().submit(std::move(*cmd)) || !s.device.queue().wait_idle()) return 0.0;
    const double t = std::chrono::duration<double>(Clock::now() - start).count();
    if (r > 0) gflops.push_back(double(invocations) * iterations * 12 * 2.0 / t / 1e9);  // run 0: warm-up
  }
  return median(gflops);
}

double peak_table(Session* s, const Options& o, double estimate) {
  std::printf("\n## FMA peak, measured (%d runs, medians)\n\n| what | GFLOP/s | of the clock estimate (%.0f) |\n|:--|--:|--:|\n",
              o.runs, estimate);
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  const bench::CpuFmaPeak cpu = bench::measure_cpu_fma_peak(threads, o.runs);
  if (cpu.has_avx2)
    std::printf("| CPU, C++ AVX2 FMA loop, %u threads | %.1f | %.0f %% |\n", threads, median(cpu.avx2_gflops),
                100.0 * median(cpu.avx2_gflops) / estimate);
  if (cpu.has_avx512)
    std::printf("| CPU, C++ AVX-512 FMA loop, %u threads | %.1f | %.0f %% |\n", threads, median(cpu.avx512_gflops),
                100.0 * median(cpu.avx512_gflops) / estimate);
  double device = 0.0;
  if (s) {
    device = device_fma_peak(*s, o);
    std::printf("| device compute shader, 12 FMA chains per invocation (fma_peak.comp) | %.1f | %.0f %% |\n", device,
                100.0 * device / estimate);
  }
  return device;
}

void kernel_table(Session& s, const Options& o, double peak_gflops, double device_peak) {
  auto kernel = passes::BtfDecodeKernel::create(s.device);
  if (!kernel) {
    std::printf("kernel: %s\n", kernel.error().what().c_str());
    return;
  }
  const std::size_t count = std::size_t(o.size) * o.size;
  std::printf("\n## Decode kernel, %u x %u queries (random texels and hemisphere directions)\n\n", o.size, o.size);
  std::printf("| model | ms (median of %d) | Mtexels/s | GFLOP/s | %% of measured device FMA peak | %% of CPU clock estimate | CPU scalar decode, 1 thread: Mtexels/s | GPU / CPU-1-thread |\n",
              o.runs);
  std::printf("|:--|--:|--:|--:|--:|--:|--:|--:|\n");
  struct Variant {
    const char* name;
    btf::RandomModelOptions options;
    passes::DecodeVariant variant;
  };
  using passes::DecodeVariant;
  const Variant variants[] = {
      {"plain, 100 x 100 latents, generic shader", {.width = 100, .height = 100}, DecodeVariant::Generic},
      {"plain, 100 x 100 latents, unrolled shader", {.width = 100, .height = 100}, DecodeVariant::Unrolled},
      {"plain, 100 x 100 latents, tiled (batched) shader", {.width = 100, .height = 100}, DecodeVariant::Tiled},
      {"clustered k = 500 + scales, unrolled shader", {.width = 100, .height = 100, .clusters = 500, .scales = true},
       DecodeVariant::Unrolled},
      {"clustered k = 500 + scales, tiled (batched) shader",
       {.width = 100, .height = 100, .clusters = 500, .scales = true},
       DecodeVariant::Tiled},
  };
  for (const auto& v : variants) {
    const btf::NeuralBtf model = btf::random_model(v.options);
    auto buffer = passes::upload_model(s.device, model, "bench-model", true);
    const auto queries = random_queries(model, count, 1);
    auto in = s.device.create_buffer_with_data({.label = "queries", .size = count * sizeof(passes::DecodeQuery),
                                                .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopyDst},
                                               std::as_bytes(std::span(queries)));
    auto out = s.device.create_buffer(
        {.label = "results", .size = count * sizeof(vec4), .usage = gpu::BufferUsage::Storage | gpu::BufferUsage::CopySrc});
    if (!buffer || !in || !out) {
      std::printf("| %s | upload failed | | | | | |\n", v.name);
      continue;
    }
    (void)kernel->run(s.device, *buffer, *in, *out, std::uint32_t(count), v.variant);  // warm-up (pipeline compile)
    std::vector<double> seconds;
    for (int r = 0; r < o.runs; ++r) {
      auto t = kernel->run(s.device, *buffer, *in, *out, std::uint32_t(count), v.variant);
      if (!t) {
        std::printf("| %s | %s | | | | | |\n", v.name, t.error().what().c_str());
        break;
      }
      seconds.push_back(*t);
    }
    const double t = median(seconds);
    const double rate = double(count) / t;
    const double gflops = rate * 2.0 * double(multiply_adds(model)) / 1e9;
    // The CPU baseline: weft::btf::decode on one thread, a 4096-query sample.
    const std::size_t cpu_count = 4096;
    std::vector<double> cpu_seconds;
    volatile float sink = 0.0f;
    for (int r = 0; r < std::max(1, o.runs / 2); ++r) {
      const auto start = Clock::now();
      for (std::size_t i = 0; i < cpu_count; ++i) {
        const auto& q = queries[i];
        sink = sink + btf::decode(model, std::size_t(q.texel), q.light, q.view).x;
      }
      cpu_seconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
    }
    const double cpu_rate = double(cpu_count) / median(cpu_seconds);
    std::printf("| %s | %.1f | %.3f | %.2f | %.1f %% | %.1f %% | %.3f | %.1fx |\n", v.name, t * 1e3, rate / 1e6, gflops,
                device_peak > 0 ? 100.0 * gflops / device_peak : 0.0, peak_gflops > 0 ? 100.0 * gflops / peak_gflops : 0.0,
                cpu_rate / 1e6, rate / cpu_rate);
  }
}

std::string quad_scene(const std::string& model_path, const std::string& knobs, std::uint32_t size) {
  return weft::format(R"({{"version": 1, "output": {{"width": {0}, "height": {0}}},
    "camera": {{"position": [0, 0, 40], "target": [0, 0, 0], "fov": 2.6, "near": 30, "far": 50}},
    "environment": {{"color": [0.2, 0.2, 0.2]}},
    "lights": [{{"type": "directional", "direction": [0.3, -0.2, -1], "intensity": 2}}],
    "meshes": {{"quad": {{"primitive": "plane", "size": 2, "subdivisions": 1}}}},
    "materials": {{"cloth": {{"type": "neural_btf", "model": "{1}", "uv_scale": 4 {2}}}}},
    "objects": [{{"name": "quad", "mesh": "quad", "material": "cloth", "transform": {{"rotation_degrees": [90, 0, 0]}}}}]}})",
                      size, model_path, knobs);
}

void frame_table(Session& s, const Options& o, double peak_gflops, double device_peak) {
  const auto dir = std::filesystem::temp_directory_path() / "weft-bench-btf-decode";
  std::filesystem::create_directories(dir);
  const auto path = dir / "paper.wbtf";
  const btf::NeuralBtf model = btf::random_model({.width = 100, .height = 100, .clusters = 500, .scales = true});
  if (auto ok = btf::save_wbtf(model, path); !ok) {
    std::printf("frame: %s\n", ok.error().what().c_str());
    return;
  }
  auto r = renderer::Renderer::create(s.device);
  if (!r) return;
  std::printf("\n## A %u x %u frame covered by a neural_btf quad (clustered k = 500 model)\n\n", o.size, o.size);
  std::printf("The neural_btf passes' time (batched: neural_btf geometry + neural_btf_list_clear + neural_btf_list + neural_btf_decode + neural_btf_resolve; "
              "fragment: the neural_btf pass), each pass submitted and waited for alone on the wall clock "
              "(serial passes: llvmpipe's timestamps miss work it defers past a pass's end), medians of %d runs, "
              "the two decoders alternating; frame ms is the whole serial frame.\n\n", o.runs);
  std::printf("| knobs | decodes / pixel | decoder | passes ms | Mpixels/s | GFLOP/s | %% of device FMA peak | %% of CPU clock estimate | frame ms | fragment / batched |\n");
  std::printf("|:--|--:|:--|--:|--:|--:|--:|--:|--:|--:|\n");
  struct Knobs {
    const char* name;
    const char* json;
    int decodes;
  };
  const Knobs rows[] = {
      {"key light only (quality low)", R"(, "ambient": false, "filter": "nearest", "shadow": false)", 1},
      {"+ shadow map", R"(, "ambient": false, "filter": "nearest", "shadow": true)", 1},
      {"+ ambient decode (quality medium)", R"(, "ambient": true, "filter": "nearest", "shadow": true)", 2},
      {"+ bilinear texels (quality high)", R"(, "ambient": true, "filter": "bilinear", "shadow": true)", 8},
  };
  const char* decoders[] = {"batched", "fragment"};
  for (const auto& k : rows) {
    std::optional<scene::Scene> scenes[2];
    for (int d = 0; d < 2; ++d) {
      const std::string knobs = weft::format(R"({}, "decoder": "{}")", k.json, decoders[d]);
      auto desc = scene::parse_scene(quad_scene(path.string(), knobs, o.size), dir);
      if (!desc) {
        std::printf("| %s | %s |\n", k.name, desc.error().message.c_str());
        return;
      }
      auto sc = scene::load_scene(*desc);
      if (!sc) return;
      scenes[d] = std::move(*sc);
    }
    std::vector<double> pass_ms[2], frame_ms[2];
    for (int run = 0; run <= o.runs; ++run)
      for (int d = 0; d < 2; ++d) {
        auto frame = r->render(*scenes[d], {.quality = Quality::Medium, .serial_passes = true});
        if (!frame) {
          std::printf("| %s | %s |\n", k.name, frame.error().message.c_str());
          return;
        }
        if (run == 0) continue;  // warm-up: model upload, pipelines
        double ms = 0.0;
        for (const auto& p : frame->stats.passes)
          if (p.name.starts_with("neural_btf")) ms += p.wall_ms;
        pass_ms[d].push_back(ms);
        frame_ms[d].push_back(frame->stats.cpu_frame_ms);
      }
    for (int d = 0; d < 2; ++d) {
      const double ms = median(pass_ms[d]);
      // Pixels the quad covers: all of them (the quad is larger than the view).
      const double pixels = double(o.size) * o.size;
      const double rate = pixels / (ms / 1e3);
      const double gflops = rate * k.decodes * 2.0 * double(multiply_adds(model)) / 1e9;
      std::printf("| %s | %d | %s | %.1f | %.3f | %.2f | %.1f %% | %.1f %% | %.1f | %s |\n", k.name, k.decodes, decoders[d],
                  ms, rate / 1e6, gflops, device_peak > 0 ? 100.0 * gflops / device_peak : 0.0,
                  peak_gflops > 0 ? 100.0 * gflops / peak_gflops : 0.0, median(frame_ms[d]),
                  d == 1 ? weft::format("{:.1f}x", median(pass_ms[1]) / median(pass_ms[0])).c_str() : "");
    }
  }
}

void storage_table() {
  std::printf("\n## Storage: the paper's models (100 x 100 texels, 8-D latents, 24,383-parameter decoder)\n\n");
  std::printf("| model | storage | decoder | latents | ids | scales | total KB | ratio to 751 MB raw | max |Δ| of decoded RGB vs fp32 |\n");
  std::printf("|:--|:--|--:|--:|--:|--:|--:|--:|--:|\n");
  const double raw = 100.0 * 100 * 6561 * 3 * 4;
  struct Row {
    const char* name;
    btf::RandomModelOptions options;
  };
  const Row rows[] = {
      {"plain", {.width = 100, .height = 100}},
      {"k = 500 + scales", {.width = 100, .height = 100, .clusters = 500, .scales = true}},
      {"k = 256 + scales", {.width = 100, .height = 100, .clusters = 256, .scales = true}},
  };
  for (const auto& row : rows) {
    const btf::NeuralBtf m = btf::random_model(row.options);
    for (const auto& [label, opts] : {std::pair{"fp32", btf::WbtfOptions{}}, std::pair{"compact", btf::kCompactWbtf}}) {
      auto bytes = btf::encode_wbtf(m, opts);
      if (!bytes) continue;
      auto back = btf::decode_wbtf(*bytes, "memory");
      if (!back) continue;
      float worst = 0.0f;
      std::mt19937_64 rng(3);
      const auto queries = random_queries(m, 2000, 2);
      for (const auto& q : queries)
        worst = std::max(worst, glm::length(btf::decode(m, std::size_t(q.texel), q.light, q.view) -
                                            btf::decode(*back, std::size_t(q.texel), q.light, q.view)));
      const auto b = btf::model_bytes(m, opts);
      std::printf("| %s | %s | %zu | %zu | %zu | %zu | %.1f | 1:%.0f | %.2g |\n", row.name, label, b.decoder, b.latents,
                  b.ids, b.scales, double(bytes->size()) / 1024.0, raw / double(bytes->size()), double(worst));
    }
  }
  std::printf("\n(file sizes include the 72-byte header and the section framing; the decoded difference is over 2,000 "
              "random texel/direction queries of a random-weight model, whose outputs are O(1))\n");
}

}  // namespace

int main(int argc, char** argv) {
  // This program links one feature and registers it, as any application does.
  // The frame's pass types (the default pipeline's shadow map, scene colour, background, tone map).
  if (auto ok = weft::register_builtin_pass_types(); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().what().c_str());
    return 1;
  }
  if (auto ok = register_feature(passes::neural_btf_feature()); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().what().c_str());
    return 1;
  }
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    // A bad value is named before any work (issue 33: atoi read "abc" as 0, "-1" as the minimum).
    const auto bad = [&](const std::string& why) {
      std::fprintf(stderr, "weft-bench-btf-decode: %s (see --help)\n", why.c_str());
      return 2;
    };
    if (a == "--runs" || a == "--size" || a == "--ghz") {
      if (i + 1 >= argc) return bad(a + " needs a value");
      const std::string v = argv[++i];
      if (a == "--runs") {
        const auto n = weft::args::whole(v, 1, 1000);
        if (!n) return bad("--runs '" + v + "': expected a whole number within 1..1000");
        o.runs = int(*n);
      } else if (a == "--size") {
        const auto n = weft::args::whole(v, 8, 4096);
        if (!n) return bad("--size '" + v + "': expected a whole number within 8..4096");
        o.size = std::uint32_t(*n);
      } else {
        const auto g = weft::args::number(v, 0.01, 100.0);
        if (!g) return bad("--ghz '" + v + "': expected a clock in GHz within 0.01..100");
        o.ghz = *g;
      }
    } else if (a == "-h" || a == "--help") {
      std::printf(
          "weft-bench-btf-decode [peak] [kernel] [frame] [storage] [--runs N] [--size N] [--ghz F]\n"
          "  peak     FMA throughput measured: a compute shader of FMA chains on the device, C++ AVX2/AVX-512 loops\n"
          "  kernel   the decode kernel's shaders (generic, unrolled, tiled) over --size^2 random queries\n"
          "  frame    a --size^2 frame of a neural_btf quad: batched and fragment decoders alternating, per knob\n"
          "  storage  .wbtf sizes and what fp16 storage changes in the decoded values\n"
          "  (no section: all of them; medians of --runs runs; --ghz overrides the clock of the estimate)\n");
      return 0;
    } else if (a.starts_with("-")) {
      return bad("unknown option '" + a + "'");
    } else if (a == "peak" || a == "kernel" || a == "frame" || a == "storage") {
      o.sections.insert(a);
    } else {
      return bad("unknown section '" + a + "' (peak, kernel, frame or storage)");
    }
  }
  const unsigned threads = std::thread::hardware_concurrency();
  const double ghz = o.ghz > 0 ? o.ghz : cpu_ghz();
  const double peak = threads * ghz * kFlopPerCycle;
  std::printf("# weft-bench-btf-decode\n\nCPU: %u hardware threads at %.2f GHz; FP32 peak estimate %u x %.2f GHz x %.0f "
              "FLOP/cycle (AVX2, 2 FMA pipes) = %.0f GFLOP/s.\n",
              threads, ghz, threads, ghz, kFlopPerCycle, peak);
  if (o.wants("storage")) storage_table();
  if (o.wants("kernel") || o.wants("frame") || o.wants("peak")) {
    auto session = bench::open_session("weft-bench-btf-decode");
    if (!session) {
      std::printf("\n(no Vulkan device: kernel and frame sections skipped)\n");
      if (o.wants("peak")) peak_table(nullptr, o, peak);
      return 0;
    }
    std::printf("\nDevice: %s (%s).\n", session->adapter.info().name.c_str(), session->adapter.info().driver.c_str());
    // The kernel and frame tables' "% of device FMA peak" is of this run's measurement.
    const double device_peak = peak_table(&*session, o, peak);
    if (o.wants("kernel")) kernel_table(*session, o, peak, device_peak);
    if (o.wants("frame")) frame_table(*session, o, peak, device_peak);
  }
  return 0;
}
