module;
#include <algorithm>
#include <chrono>
#include <ctime>
#include <expected>
#include <optional>
#include <string>
#include <utility>
#include <vector>
module weft.study;
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.tradeoff;

namespace weft::study {
namespace {
// CPU time of the whole process (every thread, llvmpipe's rasteriser included): on lavapipe
// the work a frame does, which other processes' load does not inflate as it does wall time.
double process_cpu_ms() {
  timespec t{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) / 1e6;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// The costs of a setting's steady frames, one sample per frame.
struct Samples {
  std::vector<double> gpu, cpu, feature, process;
};

// One steady frame of the setting, its costs added to `samples`.
Result<renderer::Frame> measured_frame(renderer::Renderer& r, const scene::Scene& scene, const renderer::RenderOptions& options,
                                       const tradeoff::Study& study, const tradeoff::Setting& setting, Samples& samples) {
  const double c0 = process_cpu_ms();
  auto f = r.render(scene, options);
  if (!f) return with_context(weft::format("setting '{}'", setting.label), f.error());
  samples.process.push_back(process_cpu_ms() - c0);
  samples.gpu.push_back(f->stats.gpu_total_ms);
  samples.cpu.push_back(f->stats.cpu_frame_ms);
  double ms = 0.0;
  for (const auto& p : f->stats.passes)
    if (std::find(study.passes.begin(), study.passes.end(), p.name) != study.passes.end()) ms += p.gpu_ms;
  samples.feature.push_back(ms);
  return f;
}

// The medians into the row; the frame's cost is process CPU time on a CPU adapter.
void fill_costs(tradeoff::Row& row, const Samples& samples, bool cpu_adapter) {
  row.gpu_ms = median(samples.gpu);
  row.wall_ms = median(samples.cpu);
  row.feature_gpu_ms = median(samples.feature);
  row.process_cpu_ms = median(samples.process);
  row.frame_ms = cpu_adapter ? row.process_cpu_ms : row.gpu_ms;
}
}  // namespace

Result<RenderedSetting> render_setting(gpu::Device& device, const scene::Scene& base, const tradeoff::Study& study,
                                       const tradeoff::Setting& setting, const renderer::RenderOptions& defaults,
                                       unsigned frames, bool cpu_adapter) {
  scene::Scene scene = base;
  if (auto ok = tradeoff::apply_setting(scene, study, setting); !ok) return std::unexpected(ok.error());
  renderer::RenderOptions options = defaults;
  options.quality = setting.quality;
  if (study.clear_caches) study.clear_caches();
  auto r = renderer::Renderer::create(device);
  if (!r) return std::unexpected(r.error());
  const auto t0 = std::chrono::steady_clock::now();
  auto first = r->render(scene, options);
  if (!first) return with_context(weft::format("setting '{}'", setting.label), first.error());
  RenderedSetting out;
  out.row.setting = setting;
  out.row.cold_frame_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  Samples samples;
  for (unsigned i = 0; i < frames; ++i) {
    auto f = measured_frame(*r, scene, options, study, setting, samples);
    if (!f) return std::unexpected(f.error());
    if (i + 1 == frames) out.image = std::move(f->image);
  }
  if (frames == 0) out.image = std::move(first->image);
  fill_costs(out.row, samples, cpu_adapter);
  out.warnings = std::move(first->warnings);
  return out;
}

Result<AlternatedSetting> render_alternating(gpu::Device& device, const scene::Scene& base, const tradeoff::Study& study,
                                             const tradeoff::Setting& setting, const tradeoff::Setting& baseline,
                                             const renderer::RenderOptions& defaults, unsigned frames, bool cpu_adapter) {
  Baseline fresh{baseline, std::nullopt};
  return render_alternating(device, base, study, setting, fresh, defaults, frames, cpu_adapter);
}

Result<AlternatedSetting> render_alternating(gpu::Device& device, const scene::Scene& base, const tradeoff::Study& study,
                                             const tradeoff::Setting& setting, Baseline& kept,
                                             const renderer::RenderOptions& defaults, unsigned frames, bool cpu_adapter) {
  const tradeoff::Setting& baseline = kept.setting;
  scene::Scene scene = base, baseline_scene = base;
  if (auto ok = tradeoff::apply_setting(scene, study, setting); !ok) return std::unexpected(ok.error());
  if (auto ok = tradeoff::apply_setting(baseline_scene, study, baseline); !ok) return std::unexpected(ok.error());
  renderer::RenderOptions options = defaults, baseline_options = defaults;
  options.quality = setting.quality;
  baseline_options.quality = baseline.quality;
  if (study.clear_caches) study.clear_caches();
  auto r = renderer::Renderer::create(device);
  if (!r) return std::unexpected(r.error());
  const auto t0 = std::chrono::steady_clock::now();
  auto first = r->render(scene, options);
  if (!first) return with_context(weft::format("setting '{}'", setting.label), first.error());
  AlternatedSetting out;
  out.setting.row.setting = setting;
  out.setting.row.cold_frame_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (!kept.renderer) {
    auto made = renderer::Renderer::create(device);
    if (!made) return std::unexpected(made.error());
    kept.renderer.emplace(std::move(*made));
  }
  renderer::Renderer* rb = &*kept.renderer;
  if (auto f = rb->render(baseline_scene, baseline_options); !f)
    return with_context(weft::format("baseline '{}'", baseline.label), f.error());
  Samples samples;
  std::vector<double> baseline_cost, ratio;
  for (unsigned i = 0; i < frames; ++i) {
    auto f = measured_frame(*r, scene, options, study, setting, samples);
    if (!f) return std::unexpected(f.error());
    if (i + 1 == frames) out.setting.image = std::move(f->image);
    const double c0 = process_cpu_ms();
    auto b = rb->render(baseline_scene, baseline_options);
    if (!b) return with_context(weft::format("baseline '{}'", baseline.label), b.error());
    const double b_ms = cpu_adapter ? process_cpu_ms() - c0 : b->stats.gpu_total_ms;
    const double a_ms = cpu_adapter ? samples.process.back() : samples.gpu.back();
    baseline_cost.push_back(b_ms);
    if (b_ms > 0.0) ratio.push_back(a_ms / b_ms);
  }
  if (frames == 0) out.setting.image = std::move(first->image);
  auto& row = out.setting.row;
  fill_costs(row, samples, cpu_adapter);
  out.baseline_frame_ms = median(baseline_cost);
  out.cost_ratio = median(ratio);
  row.cost_ratio = out.cost_ratio;
  out.setting.warnings = std::move(first->warnings);
  return out;
}

Result<image::Image8> coverage_render(gpu::Device& device, const scene::Scene& base, const tradeoff::Study& study,
                                      const renderer::RenderOptions& options, bool white) {
  scene::Scene scene = base;
  for (auto& m : scene.materials) {
    if (m.type != study.material) continue;
    m.type = scene::standard_material;
    m.standard = {};
    m.standard.base_color = vec3(0.0f);
    m.standard.emissive = vec3(white ? 1e4f : 0.0f);
  }
  auto r = renderer::Renderer::create(device);
  if (!r) return std::unexpected(r.error());
  auto f = r->render(scene, options);
  if (!f) return with_context("the coverage frame", f.error());
  return std::move(f->image);
}

}  // namespace weft::study
