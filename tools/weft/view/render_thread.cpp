// Scene frames on a thread of their own: a showcase frame takes hundreds of milliseconds on
// lavapipe (seconds with a bake), and the window must keep answering meanwhile. On the
// window's device (shared) a frame is rendered into a texture the window then shows; the
// textures go round a small pool (give_back). On a device of its own the image crosses over
// as pixels, which the UI thread uploads: the CPU round trip, kept for CPU adapters, whose one
// queue would otherwise make each UI frame wait for the scene frame submitted before it.
module;
#include <chrono>
#include <condition_variable>
#include <expected>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <weft/try.h>
#include <utility>
#include <vector>
#include <nlohmann/json.hpp>
module weft.viewer;
import weft.core;
import weft.gpu;
import weft.scene;
import weft.renderer;
import weft.governor;

namespace weft::viewer::detail {
namespace {

// The pipeline a job renders with: the edited one, its file, the scene's, or the default.
// The job's pipeline as the renderer chooses it (its file read again only when it changed).
Result<pipeline::Pipeline> job_pipeline(renderer::Renderer& renderer, const RenderJob& job, const scene::Scene& scene) {
  renderer::RenderOptions options;
  options.pipeline = job.pipeline.get();
  options.pipeline_file = job.pipeline_file;
  WEFT_TRY(const pipeline::Pipeline* chosen, renderer.pipeline_for(scene, options));
  return *chosen;
}

// `base` with an accumulate pass ("refine") after the frame's image, averaging `samples`
// samples -- or with its own accumulate pass's frames set, when it has one.
Result<pipeline::Pipeline> refining_pipeline(const pipeline::Pipeline& base, std::uint32_t samples) {
  for (const auto& pass : base.passes)
    if (pass.type && pass.type->name == "accumulate") return pipeline::with_options(base, pass.name, {{"frames", samples}});
  auto file = nlohmann::json::parse(pipeline::to_json(base));
  std::string name = "refine";
  while (file["passes"].contains(name)) name += "_";
  const std::string image = file["outputs"][0].get<std::string>();
  file["passes"][name] = {{"type", "accumulate"}, {"options", {{"frames", samples}}}};
  file["connections"].push_back(image + " -> " + name + ".color");
  file["outputs"][0] = name + ".color";
  return pipeline::parse_pipeline(file.dump(), base.source + " (refined by accumulation in weft view)");
}

}  // namespace

struct SceneRenderer::Shared {
  std::mutex mutex;
  std::condition_variable wake;
  std::optional<RenderJob> pending;
  std::optional<RenderResult> result;
  bool stop = false;
  bool busy = false;
  Clock::time_point busy_since{};
  std::string progress;
  bool renew = false;
  std::vector<std::shared_ptr<gpu::Texture>> free_frames;  // shared device: textures to render into
};

Result<SceneRenderer> SceneRenderer::start(const gpu::Adapter& adapter, gpu::Device* shared_device) {
  std::shared_ptr<gpu::Device> owned;
  if (!shared_device) {
    auto device = adapter.request_device({.label = "weft view scene"});
    if (!device) return std::unexpected(device.error());
    owned = std::make_shared<gpu::Device>(std::move(*device));
  }
  gpu::Device* const device = shared_device ? shared_device : owned.get();
  SceneRenderer r;
  r.shared_ = std::make_shared<Shared>();
  auto renderer = renderer::Renderer::create(*device);
  if (!renderer) return std::unexpected(renderer.error());
  r.thread_ = std::thread([shared = r.shared_, owned, device, on_window_device = shared_device != nullptr,
                           made = std::make_shared<renderer::Renderer>(std::move(*renderer))]() mutable {
    // A texture of the window's device to render a frame of this size into: a free one, or new.
    auto frame_texture = [&](std::uint32_t w, std::uint32_t h) -> Result<std::shared_ptr<gpu::Texture>> {
      {
        std::lock_guard lock(shared->mutex);
        auto& free = shared->free_frames;
        std::erase_if(free, [&](const auto& t) { return t->size().width != w || t->size().height != h; });
        if (!free.empty()) {
          auto t = std::move(free.back());
          free.pop_back();
          return t;
        }
      }
      auto t = device->create_texture({.label = "viewer frame", .size = {w, h, 1}, .format = gpu::Format::RGBA8Unorm,
                                       .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
      if (!t) return std::unexpected(t.error());
      return std::make_shared<gpu::Texture>(std::move(*t));
    };
    std::shared_ptr<const scene::Scene> source;
    scene::Scene scene;  // the thread's copy; only the camera changes between versions
    // The refining pipeline (an accumulate pass after the image) and what it was made from.
    std::shared_ptr<const pipeline::Pipeline> refining;
    std::uint64_t refining_from = 0;
    std::string refining_source;
    std::uint32_t refining_samples = 0;
    std::shared_ptr<const pipeline::Pipeline> refining_edited;
    bool renew = false;
    auto post = [&shared](RenderResult result) {
      std::lock_guard lock(shared->mutex);
      shared->result = std::move(result);
      shared->busy = false;
      shared->progress.clear();
    };
    while (true) {
      RenderJob job;
      {
        std::unique_lock lock(shared->mutex);
        shared->wake.wait(lock, [&] { return shared->stop || shared->pending; });
        if (shared->stop) break;
        job = std::move(*shared->pending);
        shared->pending.reset();
        renew = std::exchange(shared->renew, false);
        shared->busy = true;
        shared->busy_since = Clock::now();
      }
      if (renew) {  // shaders were replaced: the old renderer's pipelines go, with their passes
        (void)device->queue().wait_idle();
        made.reset();
        auto fresh = renderer::Renderer::create(*device);
        if (!fresh) {
          post({.id = job.id, .moving = job.moving, .reference = job.reference, .error = fresh.error().what()});
          continue;
        }
        made = std::make_shared<renderer::Renderer>(std::move(*fresh));
      }
      if (job.scene != source) {
        source = job.scene;
        scene = *source;
      }
      scene.camera = job.camera;
      RenderResult result{.id = job.id, .moving = job.moving, .reference = job.reference};
      const auto t0 = Clock::now();
      renderer::RenderOptions options{.width = job.width, .height = job.height, .quality = job.quality};
      options.pipeline_file = job.pipeline_file;
      options.pipeline = job.pipeline.get();  // the job holds it while the frame renders
      // A still view refining: through a pipeline that averages the jittered samples, made
      // again only when what it is made from changed (an edit, a reload of the file).
      if (job.refine_samples > 1 && !job.reference && job.budget_ms <= 0.0) {
        auto base = job_pipeline(*made, job, scene);
        if (!base) {
          post({.id = job.id, .moving = job.moving, .reference = job.reference, .error = base.error().what()});
          continue;
        }
        if (!refining || refining_from != base->content_hash || refining_source != base->source ||
            refining_samples != job.refine_samples || refining_edited != job.pipeline) {
          auto made_pipeline = refining_pipeline(*base, job.refine_samples);
          if (!made_pipeline) {
            post({.id = job.id, .moving = job.moving, .reference = job.reference, .error = made_pipeline.error().what()});
            continue;
          }
          refining = std::make_shared<const pipeline::Pipeline>(std::move(*made_pipeline));
          refining_from = base->content_hash;
          refining_source = base->source;
          refining_samples = job.refine_samples;
          refining_edited = job.pipeline;  // kept: its address is not reused meanwhile
        }
        options.pipeline = refining.get();
        options.sample_index = job.sample_index;
      }
      if (!job.show.empty() && !job.reference) options.outputs = {job.show};
      if (job.budget_ms > 0.0) {
        governor::BudgetOptions budget{.budget_ms = job.budget_ms};
        budget.progress = [&](std::string_view line) {
          log::info(std::string(line));
          std::lock_guard lock(shared->mutex);
          shared->progress = line;
        };
        auto fitted = governor::fit_budget(*made, scene, options, budget);
        result.ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        if (fitted) {
          BudgetOutcome outcome{.summary = fitted->summary(job.budget_ms), .measured_ms = fitted->measured_ms,
                                .met = fitted->met};
          for (std::size_t f = 0; f < fitted->table.features.size(); ++f) {
            const auto& feature = fitted->table.features[f];
            outcome.values.emplace_back(feature.study->material, feature.levels.at(fitted->choice.level.at(f)).setting.values);
          }
          result.budget = std::move(outcome);
        } else {
          result.error = fitted.error().what();
        }
      } else {
        // On the window's device the frame's image goes into a texture the window shows as it is.
        std::shared_ptr<gpu::Texture> target;
        if (on_window_device && options.outputs.empty() && !job.reference) {
          auto t = frame_texture(job.width, job.height);
          if (!t) {
            post({.id = job.id, .moving = job.moving, .reference = job.reference, .error = t.error().what()});
            continue;
          }
          target = std::move(*t);
          options.target = target.get();
          options.target_final_state = gpu::Access::CopySrc;  // the window blits it
        }
        auto frame = made->render(scene, options);
        if (!frame) {
          if (target) {
            std::lock_guard lock(shared->mutex);
            shared->free_frames.push_back(std::move(target));
          }
          result.ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
          result.error = frame.error().what();
          post(std::move(result));
          continue;
        }
        result.ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        result.texture = std::move(target);
        // A resource shown instead of the image: its picture takes the image's place.
        if (!options.outputs.empty() && !frame->outputs.empty()) frame->image = renderer::picture(frame->outputs.front());
        result.frame = std::move(*frame);
        if (job.describe)
          if (auto report = made->describe(scene, options)) result.graph = std::move(*report);
      }
      post(std::move(result));
    }
    made.reset();  // the renderer's GPU objects go before their device
    (void)device->queue().wait_idle();
    {
      std::lock_guard lock(shared->mutex);
      shared->free_frames.clear();
    }
    owned.reset();
  });
  return r;
}

SceneRenderer::SceneRenderer(SceneRenderer&&) noexcept = default;
SceneRenderer& SceneRenderer::operator=(SceneRenderer&&) noexcept = default;
SceneRenderer::~SceneRenderer() {
  if (!shared_) return;
  {
    std::lock_guard lock(shared_->mutex);
    shared_->stop = true;
  }
  shared_->wake.notify_all();
  if (thread_.joinable()) thread_.join();
}

void SceneRenderer::submit(RenderJob job) {
  {
    std::lock_guard lock(shared_->mutex);
    shared_->pending = std::move(job);  // a newer job replaces one not started yet
  }
  shared_->wake.notify_one();
}

std::optional<RenderResult> SceneRenderer::take() {
  std::lock_guard lock(shared_->mutex);
  return std::exchange(shared_->result, std::nullopt);
}

double SceneRenderer::busy_seconds() const {
  std::lock_guard lock(shared_->mutex);
  if (!shared_->busy) return 0.0;
  return std::chrono::duration<double>(Clock::now() - shared_->busy_since).count();
}

void SceneRenderer::give_back(std::shared_ptr<gpu::Texture> texture) {
  if (!texture) return;
  std::lock_guard lock(shared_->mutex);
  shared_->free_frames.push_back(std::move(texture));
}

void SceneRenderer::renew_renderer() {
  std::lock_guard lock(shared_->mutex);
  shared_->renew = true;
}

std::string SceneRenderer::progress() const {
  std::lock_guard lock(shared_->mutex);
  return shared_->progress;
}

bool SceneRenderer::idle() const {
  std::lock_guard lock(shared_->mutex);
  return !shared_->busy && !shared_->pending;
}

}  // namespace weft::viewer::detail
