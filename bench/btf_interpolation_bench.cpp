// weft-bench-btf-interpolation: how far a neural BTF and the raw-data reference each are from
// the truth *between* the measured directions. The synthetic twill can be made at any
// directions, so the truth there is known: the model's decode() and sample_reference (the
// reference mode's blend of the nearest measured samples) are both compared with it, on the
// model's texels, at random light and view directions inside the measured cone (θ ≤ 75°).
// It separates the model's error from the reference's own interpolation error in the
// rendered comparison (docs/neural-btf.md, "The rendered cloth against its raw data").
//
//   weft-bench-btf-interpolation MODEL.wbtf [--directions N] [--seed S] [--weave twill]
//                                           [--btf-seed S]
// MODEL must be a model of the synthetic fabric (`weft bake btf --synthetic WxH`, seed 1 unless
// --btf-seed says otherwise); its size is read from the file.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <random>
#include <string>
#include <string_view>
#include <vector>
#include <glm/glm.hpp>
#include <weft/args.h>
import weft.core;
import weft.btf;
import weft.btf.model;

using namespace weft;
using namespace weft::btf;

namespace {

struct Errors {
  double sum_sq = 0.0, sum_truth_sq = 0.0;
  std::size_t count = 0;
  void add(const vec3& got, const vec3& truth) {
    for (int c = 0; c < 3; ++c) {
      const double e = double(got[c]) - double(truth[c]);
      sum_sq += e * e;
      sum_truth_sq += double(truth[c]) * double(truth[c]);
      ++count;
    }
  }
  [[nodiscard]] double rmse() const { return count ? std::sqrt(sum_sq / double(count)) : 0.0; }
  [[nodiscard]] double relative() const { return sum_truth_sq > 0.0 ? std::sqrt(sum_sq / sum_truth_sq) : 0.0; }
};

}  // namespace

int main(int argc, char** argv) {
  std::string model_path, weave = "twill";
  unsigned long directions = 24;
  std::uint64_t seed = 7, btf_seed = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    const auto bad = [&](const std::string& why) {
      std::fprintf(stderr, "weft-bench-btf-interpolation: %s (see --help)\n", why.c_str());
      return 2;
    };
    if (a == "--help" || a == "-h") {
      std::printf(
          "usage: weft-bench-btf-interpolation MODEL.wbtf [--directions N] [--seed S] [--weave twill] [--btf-seed S]\n"
          "Compares a neural BTF of the synthetic fabric and the raw-data reference (sample_reference) with the\n"
          "fabric made at N random light and N random view directions (theta <= 75 deg, N x N pairs per texel),\n"
          "and both with the data at the 81 x 81 measured directions. N 1 to 256, default 24; seed 7.\n");
      return 0;
    }
    if (a == "--directions" || a == "--seed" || a == "--btf-seed" || a == "--weave") {
      if (i + 1 >= argc) return bad(std::string(a) + " needs a value");
      const std::string v = argv[++i];
      if (a == "--weave") {
        weave = v;
        continue;
      }
      // Digits only (issue 33: std::stoull read "-1" as 18446744073709551615).
      const auto n = weft::args::whole(v, 0, UINT64_MAX);
      if (!n) return bad(std::string(a) + " '" + v + "': expected a whole number");
      if (a == "--directions") directions = *n;
      else if (a == "--seed") seed = *n;
      else btf_seed = *n;
    } else if (!a.starts_with("-") && model_path.empty()) {
      model_path = std::string(a);
    } else {
      return bad("unknown option " + std::string(a));
    }
  }
  if (model_path.empty()) {
    std::fprintf(stderr, "weft-bench-btf-interpolation: a model (MODEL.wbtf) is required\n"
                         "usage: weft-bench-btf-interpolation MODEL.wbtf [--directions N] (see --help)\n");
    return 2;
  }
  // The truth holds N x N samples per texel: 256 (65,536 pairs, 10x the measured 6,561) keeps a
  // 100 x 100 model's truth under 8 GiB.
  if (directions == 0 || directions > 256) {
    std::fprintf(stderr, "--directions %lu: must be 1 to 256 (N x N light/view pairs per texel)\n", directions);
    return 2;
  }
  auto model = load_wbtf(model_path);
  if (!model) return std::fprintf(stderr, "%s\n", model.error().what().c_str()), 1;
  auto weave_kind = parse_weave(weave);
  if (!weave_kind) return std::fprintf(stderr, "%s\n", weave_kind.error().what().c_str()), 1;

  SyntheticOptions measured;
  measured.width = model->width, measured.height = model->height;
  measured.weave = *weave_kind, measured.seed = btf_seed;
  auto raw = synthetic_btf(measured);
  if (!raw) return std::fprintf(stderr, "%s\n", raw.error().what().c_str()), 1;

  // Random directions, uniform in solid angle over the measured cone.
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const float cos_max = std::cos(75.0f * std::numbers::pi_v<float> / 180.0f);
  auto draw = [&] {
    std::vector<Direction> out(directions);
    for (auto& d : out) d = {std::acos(1.0f - unit(rng) * (1.0f - cos_max)), 2.0f * std::numbers::pi_v<float> * unit(rng)};
    return out;
  };
  SyntheticOptions between = measured;
  between.lights = draw();
  between.views = draw();
  auto truth = synthetic_btf(between);
  if (!truth) return std::fprintf(stderr, "%s\n", truth.error().what().c_str()), 1;

  std::printf("model %s: %u x %u texels; %s fabric, seed %llu; %lu x %lu random directions (seed %llu)\n",
              model_path.c_str(), model->width, model->height, weave.c_str(), (unsigned long long)btf_seed, directions,
              directions, (unsigned long long)seed);
  Errors neural_between, reference_between, neural_vs_reference, neural_measured;
  const std::size_t texels = raw->texels();
  for (std::size_t t = 0; t < texels; ++t) {
    for (std::size_t l = 0; l < between.lights.size(); ++l)
      for (std::size_t v = 0; v < between.views.size(); ++v) {
        const vec3 li = to_vector(between.lights[l]), vo = to_vector(between.views[v]);
        const vec3 want = sample(*truth, t, l, v);
        const vec3 neural = decode(*model, t, li, vo), reference = sample_reference(*raw, t, li, vo);
        neural_between.add(neural, want);
        reference_between.add(reference, want);
        neural_vs_reference.add(neural, reference);
      }
    for (std::size_t l = 0; l < raw->lights.size(); ++l)
      for (std::size_t v = 0; v < raw->views.size(); ++v)
        neural_measured.add(decode(*model, t, to_vector(raw->lights[l]), to_vector(raw->views[v])), sample(*raw, t, l, v));
  }
  std::printf("| compared | against | RMSE | relative RMSE |\n|---|---|--:|--:|\n");
  auto row = [](const char* what, const char* against, const Errors& e) {
    std::printf("| %s | %s | %.5f | %.1f %% |\n", what, against, e.rmse(), 100.0 * e.relative());
  };
  row("neural decode()", "the data, at the measured directions", neural_measured);
  row("neural decode()", "the truth, between them", neural_between);
  row("reference (sample_reference)", "the truth, between them", reference_between);
  row("neural decode()", "the reference, between them", neural_vs_reference);
  return 0;
}
