// weft.study — a trade-off study's frames: each setting of tradeoff::plan_sweep rendered in a
// fresh renderer (the feature's process-wide caches dropped first, so the first frame is cold)
// and timed, and the coverage frames that give the feature's mask. weft.tradeoff plans, masks
// and scores without a GPU; this is the part that renders, shared by `weft tradeoff` and the
// Python module so both measure the same way.
module;
#include <expected>
#include <optional>
#include <string>
#include <vector>
export module weft.study;
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.tradeoff;

export namespace weft::study {

struct RenderedSetting {
  tradeoff::Row row;          // the setting, its cold frame and the medians of the steady frames
  image::Image8 image;        // the last frame
  std::vector<std::string> warnings;  // the first frame's (clamped knobs, weak inputs)
};

// One setting: `frames` steady frames after the timed cold one. `cpu_adapter`: the cost axis
// is the process's CPU time per frame (lavapipe's rasteriser included) instead of GPU time.
Result<RenderedSetting> render_setting(gpu::Device& device, const scene::Scene& base, const tradeoff::Study& study,
                                       const tradeoff::Setting& setting, const renderer::RenderOptions& defaults,
                                       unsigned frames, bool cpu_adapter);

// A farm task's setting (weft.farm): the same as render_setting, and `baseline` rendered in a
// second fresh renderer in the same process, one steady frame of each in turn, so the cost of
// the setting is also a ratio to the baseline's measured on the same node under the same
// load (frames taken on different nodes are not comparable; ratios are). The image is the
// setting's last frame, as render_setting's.
struct AlternatedSetting {
  RenderedSetting setting;
  double baseline_frame_ms = 0.0;  // median of the baseline's steady frames (the same clock as row.frame_ms)
  double cost_ratio = 0.0;         // median over the frame pairs of setting / baseline
};
Result<AlternatedSetting> render_alternating(gpu::Device& device, const scene::Scene& base, const tradeoff::Study& study,
                                             const tradeoff::Setting& setting, const tradeoff::Setting& baseline,
                                             const renderer::RenderOptions& defaults, unsigned frames, bool cpu_adapter);
// The baseline's renderer, kept from one setting to the next of a task with several (its
// cold frame paid once per task, not per setting); made on first use.
struct Baseline {
  tradeoff::Setting setting;
  std::optional<renderer::Renderer> renderer;
};
Result<AlternatedSetting> render_alternating(gpu::Device& device, const scene::Scene& base, const tradeoff::Study& study,
                                             const tradeoff::Setting& setting, Baseline& baseline,
                                             const renderer::RenderOptions& defaults, unsigned frames, bool cpu_adapter);

// The feature's objects drawn flat black (white: emissive white) in place of its material.
Result<image::Image8> coverage_render(gpu::Device& device, const scene::Scene& base, const tradeoff::Study& study,
                                      const renderer::RenderOptions& options, bool white);

}  // namespace weft::study
