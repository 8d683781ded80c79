// weft-bench-objects: what a frame costs as the object count grows, with a directional light
// (shadow map, shadow-caster selection) and without (issue 33: one small mesh repeated at
// 64x48 took 48 s for 30,000 lit objects and 0.75 s unlit). The scene is built in code: N
// copies of one mesh on a square grid, standard materials, the camera framing the grid.
//
//   build/bin/weft-bench-objects [--counts 1000,3000,10000,30000] [--runs N] [--size WxH]
//                                [--mesh cube|quad|sphere] [--quality low|medium|high|reference]
//                                [--reference-max N] [--no-render]
//
// Prints a markdown table per mesh: for each count the first frame and the median of --runs
// further frames, lit and unlit (wall clock, and the process's CPU time over all threads), and
// their ratios; then the shadow-caster selection alone,
// the renderer's select_shadow_casters against asking shadows_nothing_visible object by
// object (the reference, skipped above --reference-max objects), and whether they agree.
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <sys/resource.h>
#include <utility>
#include <variant>
#include <vector>
#include <glm/glm.hpp>
#include "weft/try.h"
import weft.core;
import weft.gpu;
import weft.scene;
import weft.renderer;
import weft.builtin_features;
import weft.bench.device;

using namespace weft;
using Clock = std::chrono::steady_clock;

namespace {

struct Options {
  std::vector<std::uint32_t> counts{1000, 3000, 10000, 30000};
  int runs = 3;
  std::uint32_t width = 64, height = 48;
  std::string mesh = "cube";
  std::string quality = "medium";  // the preset: it sets the shadow map's size (1024 .. 8192 texels a side)
  std::uint32_t reference_max = 30000;
  bool render = true;
};

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// CPU seconds of the whole process (every thread: lavapipe's rasteriser threads too). On a
// shared machine it leaves out the time other processes held the cores, which wall-clock
// medians cannot.
double process_cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) + double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec) / 1e6;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// A whole decimal number within [lo, hi], or nothing (no sign tricks, no truncation of "1e9").
std::optional<std::uint32_t> whole(std::string_view text, std::uint32_t lo, std::uint32_t hi) {
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || v < lo || v > hi) return std::nullopt;
  return std::uint32_t(v);
}

Result<scene::Mesh> make_mesh(const std::string& name) {
  if (name == "cube") return scene::make_cube(0.5f);
  if (name == "quad") return scene::make_plane(0.5f, 1);
  if (name == "sphere") return scene::make_sphere(0.25f, 8);
  return fail(ErrorKind::InvalidArgument, "--mesh '{}': expected cube, quad or sphere", name);
}

// N copies of `mesh` on a square grid one unit apart, lit by a sun or by the sky only.
scene::Scene grid(const scene::Mesh& mesh, std::uint32_t n, bool lit, std::uint32_t w, std::uint32_t h) {
  scene::Scene s;
  s.output = {w, h};
  s.environment.constant_color = {0.35f, 0.45f, 0.6f};
  if (lit) s.lights.push_back(scene::DirectionalLight{.name = "sun", .direction = {-0.4f, -1.0f, -0.5f}, .intensity = 3.0f});
  s.meshes.push_back(mesh);
  s.materials.push_back(scene::Material{.name = "grey"});
  const auto side = std::uint32_t(std::ceil(std::sqrt(double(n))));
  s.objects.reserve(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const scene::Transform t{.translation = {float(i % side) - 0.5f * float(side), 0.0f, float(i / side) - 0.5f * float(side)}};
    s.objects.push_back({.name = "o" + std::to_string(i), .mesh = 0, .material = 0, .transform = t.matrix()});
  }
  s.camera = scene::camera_framing(s.bounds(), 45.0f);
  return s;
}

struct FrameTimes {
  double first = 0, median = 0, cpu = 0;  // cpu: the median frame's process CPU seconds
};

Result<FrameTimes> time_frames(renderer::Renderer& r, const scene::Scene& s, int runs, const renderer::RenderOptions& options) {
  FrameTimes t;
  auto start = Clock::now();
  if (auto f = r.render(s, options); !f) return std::unexpected(f.error());
  t.first = seconds_since(start);
  std::vector<double> each, cpu;
  for (int k = 0; k < runs; ++k) {
    start = Clock::now();
    const double cpu_start = process_cpu_seconds();
    if (auto f = r.render(s, options); !f) return std::unexpected(f.error());
    each.push_back(seconds_since(start));
    cpu.push_back(process_cpu_seconds() - cpu_start);
  }
  t.median = median(each);
  t.cpu = median(cpu);
  return t;
}

Result<void> run(const Options& o) {
  WEFT_TRY(auto mesh, make_mesh(o.mesh));
  WEFT_TRY(const Quality quality, renderer::quality_from_string(o.quality));
  const renderer::RenderOptions options{.quality = quality};
  std::optional<bench::Session> session;
  std::optional<renderer::Renderer> r;
  if (o.render) {
    // The frame's pass types (the default pipeline: shadow map, scene colour, background,
    // tone map) are plugins: registered here, as any application does.
    WEFT_TRY_VOID(weft::register_builtin_pass_types());
    session = bench::open_session("weft-bench-objects");
    if (!session) return fail(ErrorKind::Unsupported, "no Vulkan device (run with --no-render for the selection alone)");
    WEFT_TRY(auto made, renderer::Renderer::create(session->device));
    r.emplace(std::move(made));
    std::printf("adapter: %s\n\n", session->adapter.info().name.c_str());
    std::printf("### %s, %ux%u, quality %s: frame time (first frame; median of %d more)\n\n", o.mesh.c_str(), o.width, o.height,
                o.quality.c_str(), o.runs);
    std::printf("| objects | lit, first | lit, median | lit, CPU | unlit, first | unlit, median | unlit, CPU | lit / unlit (medians) | lit / unlit (CPU) |\n");
    std::printf("|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n");
    for (std::uint32_t n : o.counts) {
      const scene::Scene lit = grid(mesh, n, true, o.width, o.height);
      const scene::Scene unlit = grid(mesh, n, false, o.width, o.height);
      WEFT_TRY(auto a, time_frames(*r, lit, o.runs, options));
      WEFT_TRY(auto b, time_frames(*r, unlit, o.runs, options));
      std::printf("| %u | %.3f s | %.3f s | %.3f s | %.3f s | %.3f s | %.3f s | %.2fx | %.2fx |\n", n, a.first, a.median, a.cpu,
                  b.first, b.median, b.cpu, a.median / b.median, a.cpu / b.cpu);
      std::fflush(stdout);
    }
    std::printf("\n");
  }
  std::printf("### %s: shadow-caster selection alone (median of %d)\n\n", o.mesh.c_str(), std::max(o.runs, 1));
  std::printf("| objects | select_shadow_casters | boxes tested | object by object (reference) | same answer |\n");
  std::printf("|--:|--:|--:|--:|:--|\n");
  for (std::uint32_t n : o.counts) {
    const scene::Scene s = grid(mesh, n, true, o.width, o.height);
    const vec3 towards = -std::get<scene::DirectionalLight>(s.lights[0]).direction;
    std::vector<double> fast;
    std::vector<bool> casts;
    renderer::ShadowCasterStats stats;
    for (int k = 0; k < std::max(o.runs, 1); ++k) {
      const auto start = Clock::now();
      casts = renderer::select_shadow_casters(s, towards, &stats);
      fast.push_back(seconds_since(start));
    }
    std::string reference = "skipped", same = "-";
    if (n <= o.reference_max) {
      const auto start = Clock::now();
      bool agree = true;
      for (std::uint32_t i = 0; i < n; ++i) agree &= casts[i] == !renderer::shadows_nothing_visible(s, i, towards);
      reference = weft::format("{:.3f} s", seconds_since(start));
      same = agree ? "yes" : "NO";
    }
    std::printf("| %u | %.4f s | %llu | %s | %s |\n", n, median(fast), static_cast<unsigned long long>(stats.boxes_tested),
                reference.c_str(), same.c_str());
    std::fflush(stdout);
  }
  return {};
}

const char* usage =
    "usage: weft-bench-objects [--counts N,N,...] [--runs N] [--size WxH] [--mesh cube|quad|sphere]\n"
    "                          [--quality low|medium|high|reference] [--reference-max N] [--no-render]\n"
    "  N copies of one mesh on a grid, rendered with a directional light and without; the\n"
    "  shadow-caster selection timed alone against the object-by-object reference.\n"
    "  --counts         object counts, each 1..10000000 (default 1000,3000,10000,30000)\n"
    "  --runs           frames timed after the first, 1..1000 (default 3)\n"
    "  --size           frame size WxH, each 1..16384 (default 64x48)\n"
    "  --mesh           the repeated mesh (default cube; quad is flat, so every copy is tested)\n"
    "  --quality        the preset (default medium); it sets the shadow map's size\n"
    "  --reference-max  largest count given the quadratic reference (default 30000; 0: none)\n"
    "  --no-render      the selection table only (no Vulkan device needed)\n";

}  // namespace

int main(int argc, char** argv) {
  Options o;
  auto bad = [](const std::string& why) {
    std::fprintf(stderr, "weft-bench-objects: %s\n%s", why.c_str(), usage);
    return 2;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "-h" || a == "--help") {
      std::printf("%s", usage);
      return 0;
    } else if (a == "--no-render") {
      o.render = false;
    } else if (a == "--counts" || a == "--runs" || a == "--size" || a == "--mesh" || a == "--quality" || a == "--reference-max") {
      if (!has_value) return bad(std::string(a) + " needs a value");
      const std::string_view v = argv[++i];
      if (a == "--counts") {
        o.counts.clear();
        for (std::size_t pos = 0; pos <= v.size();) {
          const std::size_t comma = std::min(v.find(',', pos), v.size());
          const auto n = whole(v.substr(pos, comma - pos), 1, 10'000'000);
          if (!n) return bad("--counts '" + std::string(v) + "': expected whole numbers within 1..10000000, comma-separated");
          o.counts.push_back(*n);
          pos = comma + 1;
        }
      } else if (a == "--runs") {
        const auto n = whole(v, 1, 1000);
        if (!n) return bad("--runs '" + std::string(v) + "': expected a whole number within 1..1000");
        o.runs = int(*n);
      } else if (a == "--reference-max") {
        const auto n = whole(v, 0, 10'000'000);
        if (!n) return bad("--reference-max '" + std::string(v) + "': expected a whole number within 0..10000000");
        o.reference_max = *n;
      } else if (a == "--size") {
        const std::size_t x = v.find('x');
        const auto w = x == std::string_view::npos ? std::nullopt : whole(v.substr(0, x), 1, 16384);
        const auto h = x == std::string_view::npos ? std::nullopt : whole(v.substr(x + 1), 1, 16384);
        if (!w || !h) return bad("--size '" + std::string(v) + "': expected WxH, each within 1..16384");
        o.width = *w, o.height = *h;
      } else if (a == "--quality") {
        o.quality = std::string(v);
        if (!renderer::quality_from_string(o.quality)) return bad("--quality '" + o.quality + "': expected low, medium, high or reference");
      } else {
        o.mesh = std::string(v);
        if (o.mesh != "cube" && o.mesh != "quad" && o.mesh != "sphere")
          return bad("--mesh '" + o.mesh + "': expected cube, quad or sphere");
      }
    } else {
      return bad("unknown argument '" + std::string(a) + "'");
    }
  }
  if (auto ok = run(o); !ok) {
    std::fprintf(stderr, "weft-bench-objects: %s\n", ok.error().what().c_str());
    return 1;
  }
  return 0;
}
