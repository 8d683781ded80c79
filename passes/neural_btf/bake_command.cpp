// `weft bake btf IN|--synthetic WxH -o OUT.wbtf --clusters K ...`: trains a neural BTF
// (docs/neural-btf.md) from a BTF on disk (a .btfraw, or a UBO2003 / UTIA folder) or from the
// synthetic fabric, writes the .wbtf and prints sizes, the ratio to the raw float data and the
// RMSE. The feature's descriptor offers it to `weft bake` (FeatureDescriptor::bakes).
module;
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <expected>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>
#include <CLI/CLI.hpp>
#include <charconv>
#include <optional>
#include <string_view>
module weft.pass.neural_btf;
import weft.core;
import weft.btf;
import weft.btf.model;
import weft.btf.training;

namespace weft::passes::detail {
namespace {

int failed(const Error& e) { return bake_failed("btf", e); }
int invalid(std::string message) { return failed(Error{ErrorKind::InvalidArgument, std::move(message)}); }

struct Texels {
  std::uint32_t width = 0, height = 0;
};
// "64x64" -> {64, 64}; nothing unless both sides are plain numbers in 1..4096.
std::optional<Texels> parse_texels(std::string_view text) {
  const auto x = text.find('x');
  if (x == std::string_view::npos) return std::nullopt;
  Texels t;
  const auto side = [](std::string_view s, std::uint32_t& out) {
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
    return ec == std::errc{} && end == s.data() + s.size() && out >= 1 && out <= 4096;
  };
  if (!side(text.substr(0, x), t.width) || !side(text.substr(x + 1), t.height)) return std::nullopt;
  return t;
}

}  // namespace

std::function<int()> add_btf_bake(CLI::App& command) {
  struct Args {
    std::string input, output, synthetic, weave = "twill", checkpoint, optimizer, schedule, recipe = "best";
    std::uint32_t clusters = 0, epochs = 0, directions = 0, batch = 0, holdout = 0, patience = 3;
    double minutes = 0.0, learning_rate = 0.0, finetune = 0.25;
    std::uint64_t seed = 1;
    std::size_t threads = 0;
    bool compact = false, no_scales = false, resume = false;
  };
  auto a = std::make_shared<Args>();
  auto* sub = &command;
  sub->add_option("input", a->input, "BTF: a .btfraw file or a UBO2003 / UTIA image folder (or use --synthetic)");
  sub->add_option("-o,--output", a->output, "Output .wbtf file")->required();
  sub->add_option("--clusters", a->clusters, "k clusters of ABRDFs (0: the plain model, a latent per texel)")
      ->capture_default_str();
  sub->add_option("--synthetic", a->synthetic, "Instead of IN: the synthetic fabric, WxH texels at 81 x 81 directions");
  sub->add_option("--weave", a->weave, "Synthetic weave: plain, twill or knit")->capture_default_str();
  sub->add_option("--epochs", a->epochs, "Epochs, at least 1 (each visits every texel once; default 20, or unlimited with --minutes)")
      ->check(CLI::Range(1u, 1000000u));
  sub->add_option("--minutes", a->minutes, "Training time budget in minutes (0: none)");
  // The recipe sets the five options below; any of them given on the command line wins.
  sub->add_option("--recipe", a->recipe,
                  "best (default: Adam at 0.003, cosine, batch 32, 256 directions; 0.365 of a "
                  "constant's RMSE in 3 minutes on a 100x100 twill) or paper (the paper's SGD, constant rate, batch 5, all directions, no "
                  "holdout: reproduces its rows; docs/neural-btf.md)")
      ->capture_default_str();
  auto* directions = sub->add_option("--directions", a->directions, "Light/view pairs per texel per step (0: all, the paper's)");
  auto* batch = sub->add_option("--batch", a->batch, "Texels per step (best 32, the paper's 5)");
  auto* optimizer = sub->add_option("--optimizer", a->optimizer, "sgd (the paper's) or adam (best)");
  auto* learning_rate =
      sub->add_option("--learning-rate", a->learning_rate, "Learning rate (best 0.003; 0: SGD 0.05 plain, 0.08 clustered; Adam 0.001)");
  auto* schedule = sub->add_option("--schedule", a->schedule, "Learning rate: constant (the paper's) or cosine (best; down to 5 %)");
  auto* holdout = sub->add_option("--holdout", a->holdout,
                                  "Early stopping: hold out every Nth light/view pair, measure it each epoch, keep the best "
                                  "model (0: off, both recipes)");
  sub->add_option("--patience", a->patience, "Early stopping: epochs without a better held-out RMSE before a stage ends")
      ->capture_default_str();
  sub->add_option("--finetune", a->finetune, "Fraction of the training spent on decoder + latents alone, [0, 1]")
      ->capture_default_str();
  sub->add_option("--seed", a->seed, "Seed of the synthetic data, the clustering and the training")->capture_default_str();
  // At most 1024 (issue 33: --threads 100000 started 100,000 threads and never finished).
  sub->add_option("--threads", a->threads, "Threads (0: all; the result does not depend on it)")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t(0), std::size_t(1024)));
  sub->add_option("--checkpoint", a->checkpoint, "Checkpoint file, written every epoch");
  sub->add_flag("--resume", a->resume, "Continue from --checkpoint when it exists");
  sub->add_flag("--compact", a->compact, "Store fp16 weights and latents, 8/16-bit ids, 8-bit scales");
  sub->add_flag("--no-scales", a->no_scales, "Clustered without the per-texel luminance scale");
  return [a, directions, batch, optimizer, learning_rate, schedule, holdout] {
            if (a->recipe != "best" && a->recipe != "paper")
              return invalid(weft::format("--recipe '{}' is not best or paper", a->recipe));
            // The recipe's values where the command line gave none (measured in docs/neural-btf.md).
            const bool best = a->recipe == "best";
            if (!directions->count()) a->directions = best ? 256 : 0;
            const bool batch_given = batch->count() > 0;
            if (!batch_given) a->batch = best ? 32 : 5;
            if (!optimizer->count()) a->optimizer = best ? "adam" : "sgd";
            if (!learning_rate->count()) a->learning_rate = best ? 0.003 : 0.0;
            if (!schedule->count()) a->schedule = best ? "cosine" : "constant";
            // No holdout in either: early stopping (patience 3) ended a 3-minute budget at 42 %
            // and fitted worse (0.49 of a constant's RMSE against 0.365 without; docs/neural-btf.md).
            if (!holdout->count()) a->holdout = 0;
            if (a->input.empty() == a->synthetic.empty())
              return invalid("give either a BTF path (IN) or --synthetic WxH, not both or neither");
            if (a->batch == 0) return invalid("--batch 0 (must be at least 1)");
            if (!(a->minutes >= 0.0)) return invalid(weft::format("--minutes {} is negative", a->minutes));
            if (!(a->finetune >= 0.0 && a->finetune <= 1.0))
              return invalid(weft::format("--finetune {} is outside [0, 1]", a->finetune));
            if (!(a->learning_rate >= 0.0)) return invalid(weft::format("--learning-rate {} is negative", a->learning_rate));
            if (a->resume && a->checkpoint.empty()) return invalid("--resume needs --checkpoint FILE");
            if (a->optimizer != "sgd" && a->optimizer != "adam")
              return invalid(weft::format("--optimizer '{}' is not sgd or adam", a->optimizer));
            if (a->schedule != "constant" && a->schedule != "cosine")
              return invalid(weft::format("--schedule '{}' is not constant or cosine", a->schedule));
            if (a->holdout == 1) return invalid("--holdout 1 holds out every pair (0: off, or 2 and more)");
            btf::Btf data;
            std::string source;
            if (!a->synthetic.empty()) {
              btf::SyntheticOptions so;
              const auto size = parse_texels(a->synthetic);
              if (!size)
                return invalid(weft::format("--synthetic '{}' is not WxH (e.g. 64x64, each side 1..4096, and the samples "
                                            "must fit in memory: 78.7 KB per texel)",
                                            a->synthetic));
              so.width = size->width, so.height = size->height;
              auto weave = btf::parse_weave(a->weave);
              if (!weave) return failed(weave.error());
              so.weave = *weave;
              so.seed = a->seed;
              so.threads = a->threads;
              std::printf("making the synthetic %s, %u x %u texels x 81 x 81 directions...\n", a->weave.c_str(), so.width,
                          so.height);
              std::fflush(stdout);
              auto made = btf::synthetic_btf(so);
              if (!made) return failed(made.error());
              data = std::move(*made);
              source = weft::format("synthetic {} {}", a->weave, a->synthetic);
            } else {
              auto loaded = btf::load_btf(std::filesystem::path(a->input));
              if (!loaded) return failed(loaded.error());
              data = std::move(*loaded);
              source = a->input;
            }
            // A recipe's batch on a fabric with fewer texels: every texel each step.
            if (!batch_given && a->batch > data.texels()) a->batch = std::uint32_t(std::max<std::size_t>(data.texels(), 1));
            std::printf("recipe: %s (%s, learning rate %g, %s, batch %u, %s directions per texel, holdout %u)\n",
                        a->recipe.c_str(), a->optimizer.c_str(), a->learning_rate, a->schedule.c_str(), a->batch,
                        a->directions ? std::to_string(a->directions).c_str() : "all", a->holdout);
            btf::TrainOptions o;
            o.clusters = a->clusters;
            o.texel_scales = !a->no_scales;
            o.learning_rate = float(a->learning_rate);
            o.batch = a->batch;
            o.optimizer = a->optimizer == "adam" ? btf::Optimizer::Adam : btf::Optimizer::Sgd;
            o.schedule = a->schedule == "cosine" ? btf::LearningRateSchedule::Cosine : btf::LearningRateSchedule::Constant;
            o.holdout_every = a->holdout;
            o.patience = a->patience;
            o.directions_per_texel = a->directions;
            o.epochs = a->epochs ? a->epochs : (a->minutes > 0.0 ? 1000000u : 20u);
            o.max_seconds = a->minutes * 60.0;
            o.finetune_fraction = float(a->finetune);
            o.seed = a->seed;
            o.threads = a->threads;
            o.checkpoint = a->checkpoint;
            o.resume = a->resume;
            o.progress = [](const btf::TrainProgress& p) {
              std::printf("epoch %zu/%zu step %zu/%zu%s: loss %.4g, lr %.3g%s, %.0f %%, %s elapsed, ETA %s\n", p.epoch + 1,
                          p.epochs, p.step, p.steps_per_epoch, p.finetuning ? " (latents + decoder)" : "", p.loss,
                          p.learning_rate,
                          p.validation_rmse >= 0.0 ? weft::format(", held-out RMSE {:.5f}", p.validation_rmse).c_str() : "",
                          100.0 * p.fraction, btf::describe_seconds(p.elapsed_s).c_str(),
                          btf::describe_seconds(p.eta_s).c_str());
              std::fflush(stdout);
            };
            if (a->clusters > data.texels())
              return invalid(weft::format("--clusters {} is more than the {} texels of {}", a->clusters, data.texels(), source));
            std::printf("training on %s: %u x %u texels, %zu x %zu directions, %s, training SIMD %s\n", source.c_str(),
                        data.width, data.height, data.lights.size(), data.views.size(),
                        a->clusters ? weft::format("k = {} clusters", a->clusters).c_str() : "plain (a latent per texel)",
                        std::string(btf::training_simd_width()).c_str());
            std::fflush(stdout);
            auto trained = btf::train_neural_btf(data, o);
            if (!trained) return failed(trained.error());
            const btf::WbtfOptions storage = a->compact ? btf::kCompactWbtf : btf::WbtfOptions{};
            if (auto ok = btf::save_wbtf(trained->model, a->output, storage); !ok) return failed(ok.error());
            auto error = btf::model_rmse(trained->model, data, {}, a->threads);
            if (!error) return failed(error.error());
            const btf::ModelBytes bytes = btf::model_bytes(trained->model, storage);
            const double raw = double(data.rgb.size() * sizeof(float));
            std::error_code ec;
            const auto file_size = std::filesystem::file_size(a->output, ec);
            double mean = 0.0;
            for (float v : data.rgb) mean += v;
            mean /= double(data.rgb.size());
            std::printf("wrote %s: %u x %u texels, %zu latents%s, %zu epochs (%zu steps) in %s (clustering %s)\n",
                        a->output.c_str(), trained->model.width, trained->model.height, trained->model.latent_count(),
                        trained->model.clustered() ? weft::format(" (k = {})", trained->clusters).c_str() : "",
                        trained->epochs_done, trained->steps_done, btf::describe_seconds(trained->seconds).c_str(),
                        btf::describe_seconds(trained->cluster_seconds).c_str());
            std::printf("size: raw %.1f MiB -> %.1f KiB (decoder %.1f, latents %.1f, ids %.1f, scales %.1f; file %.1f KiB), "
                        "ratio 1:%.0f\n",
                        raw / 1048576.0, double(bytes.total()) / 1024.0, double(bytes.decoder) / 1024.0,
                        double(bytes.latents) / 1024.0, double(bytes.ids) / 1024.0, double(bytes.scales) / 1024.0,
                        ec ? 0.0 : double(file_size) / 1024.0, raw / double(bytes.total()));
            if (trained->validation_rmse >= 0.0)
              std::printf("early stopping: kept epoch %zu's model, held-out RMSE %.5f%s\n", trained->best_epoch,
                          trained->validation_rmse, trained->stopped_early ? " (patience ran out)" : "");
            std::printf("RMSE %.5f over every sample (mean sample %.4f; the best constant scores %.4f), final training "
                        "loss %.4g\n",
                        *error, mean, btf::constant_rmse(data), trained->final_loss);
            return 0;
          };
}

}  // namespace weft::passes::detail
