// weft-bench-btf-train: the neural BTF paper's Table 1/2 rows on the synthetic fabric
// (docs/neural-btf.md, "Training numbers"): the plain neural BTF and clustered models, their
// sizes as the issue counts them (fp32 weights and latents, int32 ids, fp32 scales) and
// compact (fp16 weights/latents, 8/16-bit ids, 8-bit scales), ratios to the raw float BTF,
// RMSE against the ground truth on the directions trained on and on held-out ones, and
// training times.
//   weft-bench-btf-train [--texels N] [--clusters k,k,...] [--minutes M] [--epochs E]
//                        [--directions S] [--threads T] [--cache FILE] [--holdout EVERY] [--learning-rate R]
//                        [--optimizer sgd|adam] [--batch B] [--schedule constant|cosine] [--finetune F]
//                        [--early-stop EVERY] [--patience P] [--throughput STEPS] [--runs R]
// --texels: an N x N synthetic twill at the paper's 81 x 81 directions (default 100, the
// paper's 100 x 100). --clusters: 0 is the plain model (default 0,500,1000,2000; values above
// the texel count are skipped). Each model trains for --minutes (and at most --epochs) on
// the light and view directions whose index is not a multiple of --holdout (default 4:
// 61 x 61 of 81 x 81); RMSE is reported on those pairs, on the held-out pairs (a light or a
// view never trained on) and on all 6,561. The optimiser options are TrainOptions' (the defaults
// are the paper's recipe: SGD, batch 5, constant rate); --early-stop holds out every EVERY-th
// trained pair for early stopping (TrainOptions::holdout_every).
// --throughput STEPS: no table; the plain model's training speed instead: STEPS steps with the
// first schedule (TrainOptions::batched = false) and the batched one, alternating, --runs times
// (default 3), each line samples/s, steps/s and epochs/min at the data's size, then medians.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <system_error>
#include <span>
#include <string>
#include <vector>
#include <weft/args.h>
import weft.core;
import weft.btf;
import weft.btf.model;
import weft.btf.training;

using namespace weft;
using namespace weft::btf;

namespace {

double kib(std::size_t bytes) { return double(bytes) / 1024.0; }

}  // namespace

int main(int argc, char** argv) {
  std::uint32_t texels = 100, epochs = 1000000, directions = 0, holdout = 4, batch = 5, early_stop = 0, patience = 3;
  std::uint32_t throughput = 0, runs = 3;
  double minutes = 5.0, finetune = 0.25;
  std::string optimizer = "sgd", schedule = "constant";
  float learning_rate = 0.0f;  // 0: the paper's (0.05 plain, 0.08 clustered)
  std::size_t threads = 0;
  std::vector<std::uint32_t> clusters{0, 500, 1000, 2000};
  std::filesystem::path cache;
  for (int i = 1; i < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::printf("usage: weft-bench-btf-train [--texels N] [--clusters k,k,...] [--minutes M] [--epochs E] [--directions S]\n"
                  "                            [--threads T] [--cache FILE] [--holdout EVERY] [--learning-rate R]\n"
                  "                            [--optimizer sgd|adam] [--batch B] [--schedule constant|cosine] [--finetune F]\n"
                  "                            [--early-stop EVERY] [--patience P] [--throughput STEPS] [--runs R]\n"
                  "Trains the plain and clustered neural BTFs on an N x N synthetic twill (default 100, 5 minutes each)\n"
                  "and prints sizes, ratios, RMSE and times (docs/neural-btf.md). Defaults: the paper's recipe (SGD,\n"
                  "batch 5, constant rate). --throughput STEPS times STEPS steps of the first and the batched schedule\n"
                  "instead, alternating --runs times: samples/s, steps/s, epochs/min.\n");
      return 0;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "weft-bench-btf-train: option %s needs a value (--help lists them)\n", a.c_str());
      return 2;
    }
    const std::string v = argv[i + 1];
    // Digits only, within a range, before any work (issue 33: std::stoul read "-1" as 4294967295
    // texels, std::stod took "nan" minutes).
    const auto bad = [&](const char* expected) {
      std::fprintf(stderr, "weft-bench-btf-train: %s '%s': expected %s (--help lists the options)\n", a.c_str(), v.c_str(),
                   expected);
      return 2;
    };
    const auto whole = [&](std::uint64_t lo, std::uint64_t hi) { return weft::args::whole(v, lo, hi); };
    if (v.empty()) return bad("a value (it was empty)");
    if (a == "--cache") cache = v;
    else if (a == "--optimizer") optimizer = v;
    else if (a == "--schedule") schedule = v;
    else if (a == "--clusters") {
      const auto list = weft::args::whole_list(v, 0, 1'000'000);
      if (!list) return bad("whole numbers 0..1000000, comma-separated");
      clusters.assign(list->begin(), list->end());
    } else if (a == "--minutes" || a == "--learning-rate" || a == "--finetune") {
      const double hi = a == "--finetune" ? 1.0 : a == "--minutes" ? 1e6 : 100.0;
      const auto x = weft::args::number(v, 0.0, hi);
      if (!x) return bad(a == "--finetune" ? "a number in [0, 1]" : a == "--minutes" ? "a number in [0, 1e6]" : "a number in [0, 100]");
      if (a == "--minutes") minutes = *x;
      else if (a == "--finetune") finetune = *x;
      else learning_rate = float(*x);
    } else if (a == "--threads") {
      const auto n = whole(0, 1024);
      if (!n) return bad("a whole number 0..1024 (0: all)");
      threads = *n;
    } else if (a == "--texels" || a == "--epochs" || a == "--directions" || a == "--holdout" || a == "--batch" ||
               a == "--early-stop" || a == "--patience" || a == "--throughput" || a == "--runs") {
      const bool positive = a == "--texels" || a == "--epochs" || a == "--batch" || a == "--runs";
      const std::uint64_t hi = a == "--texels" ? 65536 : a == "--directions" ? 6561 : a == "--runs" ? 1000 : 1'000'000'000;
      const auto n = whole(positive ? 1 : 0, hi);
      if (!n) {
        const std::string range = "a whole number " + std::to_string(positive ? 1 : 0) + ".." + std::to_string(hi);
        return bad(range.c_str());
      }
      const auto u = std::uint32_t(*n);
      if (a == "--texels") texels = u;
      else if (a == "--epochs") epochs = u;
      else if (a == "--directions") directions = u;
      else if (a == "--holdout") holdout = u;
      else if (a == "--batch") batch = u;
      else if (a == "--early-stop") early_stop = u;
      else if (a == "--patience") patience = u;
      else if (a == "--throughput") throughput = u;
      else runs = u;
    } else {
      std::fprintf(stderr, "weft-bench-btf-train: unknown option %s (--help lists them)\n", a.c_str());
      return 2;
    }
  }
  if ((optimizer != "sgd" && optimizer != "adam") || (schedule != "constant" && schedule != "cosine") || batch == 0 ||
      early_stop == 1 || runs == 0) {
    std::fprintf(stderr, "weft-bench-btf-train: --optimizer sgd|adam, --schedule constant|cosine, --batch >= 1, --early-stop 0 or "
                         ">= 2, --runs >= 1\n");
    return 2;
  }
  // The data: the synthetic twill at the paper's sampling, cached as .btfraw.
  Btf btf;
  const auto t_data = std::chrono::steady_clock::now();
  std::error_code cache_error;  // exists() without it threw on a symlink loop (terminate; issue 33)
  if (!cache.empty() && std::filesystem::exists(cache, cache_error)) {
    auto loaded = load_btf(cache);
    if (!loaded) return std::fprintf(stderr, "%s\n", loaded.error().what().c_str()), 1;
    btf = std::move(*loaded);
  } else {
    SyntheticOptions so;
    so.width = so.height = texels;
    so.threads = threads;
    auto made = synthetic_btf(so);
    if (!made) return std::fprintf(stderr, "%s\n", made.error().what().c_str()), 1;
    btf = std::move(*made);
    if (!cache.empty())
      if (auto ok = save_btf(btf, cache); !ok) std::fprintf(stderr, "cache: %s\n", ok.error().what().c_str());
  }
  const double data_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_data).count();
  const std::size_t M = btf.texels();
  const std::size_t raw = btf.rgb.size() * sizeof(float);
  std::printf("data: synthetic twill %u x %u texels x %zu x %zu directions, raw %.1f MiB (%.1f s to make or load)\n",
              btf.width, btf.height, btf.lights.size(), btf.views.size(), double(raw) / 1048576.0, data_s);

  if (throughput > 0) {
    // Both schedules on the same data and options, alternating, so load changes hit both.
    std::printf("throughput: plain model, %u steps per run, batch %u, %s directions per texel, %zu threads, training SIMD %s, load %s\n",
                throughput, batch, directions ? std::to_string(directions).c_str() : "all", threads,
                std::string(training_simd_width()).c_str(), [] {
                  static char buffer[64] = "?";
                  if (std::FILE* f = std::fopen("/proc/loadavg", "r")) {
                    if (!std::fgets(buffer, sizeof buffer, f)) buffer[0] = 0;
                    std::fclose(f);
                  }
                  return buffer;
                }());
    std::printf("| run | schedule | samples/s | steps/s | epochs/min (%zu texels) |\n|---|---|--:|--:|--:|\n", M);
    std::vector<double> rates[2];
    for (std::uint32_t run = 0; run < runs; ++run)
      for (int batched = 0; batched < 2; ++batched) {
        TrainOptions o;
        o.epochs = 1000000;
        o.batch = batch;
        o.directions_per_texel = directions;
        o.learning_rate = learning_rate;
        o.optimizer = optimizer == "adam" ? Optimizer::Adam : Optimizer::Sgd;
        o.threads = threads;
        o.finetune_fraction = 0.0f;
        o.stop_after_steps = throughput;
        o.batched = batched == 1;
        auto r = train_neural_btf(btf, o);
        if (!r) return std::fprintf(stderr, "%s\n", r.error().what().c_str()), 1;
        const double samples_per_s = double(r->samples_done) / r->step_seconds;
        const double steps_per_s = double(r->steps_done) / r->step_seconds;
        const double steps_per_epoch = std::ceil(double(M) / double(batch));
        rates[batched].push_back(steps_per_s);
        std::printf("| %u | %s | %.0f | %.1f | %.2f |\n", run + 1, batched ? "batched" : "first", samples_per_s, steps_per_s,
                    60.0 * steps_per_s / steps_per_epoch);
        std::fflush(stdout);
      }
    for (auto& v : rates) std::sort(v.begin(), v.end());
    const double a = rates[0][rates[0].size() / 2], b = rates[1][rates[1].size() / 2];
    const double steps_per_epoch = std::ceil(double(M) / double(batch));
    std::printf("\nmedian: first %.1f steps/s (%.2f epochs/min), batched %.1f steps/s (%.2f epochs/min), %.2fx\n", a,
                60.0 * a / steps_per_epoch, b, 60.0 * b / steps_per_epoch, b / a);
    return 0;
  }

  std::vector<std::size_t> train_l, train_v;
  for (std::size_t i = 0; i < btf.lights.size(); ++i)
    if (holdout == 0 || i % holdout != 0) train_l.push_back(i);
  for (std::size_t i = 0; i < btf.views.size(); ++i)
    if (holdout == 0 || i % holdout != 0) train_v.push_back(i);
  auto train_set = select_directions(btf, train_l, train_v);
  if (!train_set) return std::fprintf(stderr, "%s\n", train_set.error().what().c_str()), 1;
  std::vector<bool> trained_pair(btf.samples_per_texel(), false);
  for (auto l : train_l)
    for (auto v : train_v) trained_pair[l * btf.views.size() + v] = true;
  std::vector<bool> held_pair(trained_pair.size());
  for (std::size_t i = 0; i < held_pair.size(); ++i) held_pair[i] = !trained_pair[i];
  // std::vector<bool> is not contiguous; model_rmse takes a span of bool.
  std::unique_ptr<bool[]> trained_mask(new bool[trained_pair.size()]), held_mask(new bool[trained_pair.size()]);
  for (std::size_t i = 0; i < trained_pair.size(); ++i) trained_mask[i] = trained_pair[i], held_mask[i] = held_pair[i];
  std::printf("training on %zu x %zu directions, %zu of %zu pairs held out; %.1f min per model, %s directions per texel "
              "per step, batch %u texels, %s, %s rate, fine-tune %.2f%s\n",
              train_l.size(), train_v.size(), btf.samples_per_texel() - train_l.size() * train_v.size(),
              btf.samples_per_texel(), minutes, directions ? std::to_string(directions).c_str() : "all", batch,
              optimizer.c_str(), schedule.c_str(), finetune,
              early_stop ? weft::format(", early stopping on every {}th trained pair (patience {})", early_stop, patience).c_str()
                         : "");

  const double flat = constant_rmse(btf);
  std::printf("the best constant (per-channel mean) scores RMSE %.4f; learning rate %s\n", flat,
              learning_rate > 0.0f ? std::to_string(learning_rate).c_str()
                                   : (optimizer == "adam" ? "Adam's 0.001" : "the paper's (0.05 plain, 0.08 clustered)"));
  std::printf("\n| model | k | fp32 KiB (issue's count) | ratio | compact KiB | ratio | RMSE trained | RMSE held-out | RMSE all | / constant | epochs | train s | cluster s |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (std::uint32_t k : clusters) {
    if (k > M) {
      std::printf("| clustered | %u | skipped: more clusters than the %zu texels |\n", k, M);
      continue;
    }
    TrainOptions o;
    o.clusters = k;
    o.optimizer = optimizer == "adam" ? Optimizer::Adam : Optimizer::Sgd;
    o.schedule = schedule == "cosine" ? LearningRateSchedule::Cosine : LearningRateSchedule::Constant;
    o.batch = batch;
    o.finetune_fraction = float(finetune);
    o.holdout_every = early_stop;
    o.patience = patience;
    o.epochs = epochs;
    o.max_seconds = minutes * 60.0;
    o.directions_per_texel = directions;
    o.learning_rate = learning_rate;
    o.threads = threads;
    o.progress_interval_s = 30.0;
    o.progress = [k](const TrainProgress& p) {
      std::fprintf(stderr, "  k=%u epoch %zu step %zu/%zu%s loss %.3g, lr %.3g, held-out %.4f, %.0f %%, ETA %s\n", k,
                   p.epoch + 1, p.step, p.steps_per_epoch, p.finetuning ? " (latents)" : "", p.loss, p.learning_rate,
                   p.validation_rmse, 100.0 * p.fraction, describe_seconds(p.eta_s).c_str());
    };
    auto r = train_neural_btf(*train_set, o);
    if (!r) return std::fprintf(stderr, "%s\n", r.error().what().c_str()), 1;
    const WbtfOptions issue{FloatStorage::Fp32, FloatStorage::Fp32, IdStorage::U32, ScaleStorage::Fp32};
    const ModelBytes full = model_bytes(r->model, issue), compact = model_bytes(r->model, kCompactWbtf);
    auto e_train = model_rmse(r->model, btf, std::span<const bool>(trained_mask.get(), trained_pair.size()), threads);
    auto e_held = model_rmse(r->model, btf, std::span<const bool>(held_mask.get(), held_pair.size()), threads);
    if (!e_train || !e_held) return std::fprintf(stderr, "RMSE failed\n"), 1;
    // Every pair is trained or held out: the whole RMSE follows from the two.
    const double n_train = double(train_l.size() * train_v.size()), n_all = double(btf.samples_per_texel());
    const double e_all = std::sqrt((n_train * *e_train * *e_train + (n_all - n_train) * *e_held * *e_held) / n_all);
    std::printf("| %s | %u | %.1f (dec %.1f + lat %.1f + ids %.1f + scales %.1f) | 1:%.0f | %.1f | 1:%.0f | %.4f | %.4f | %.4f | %.3f | %zu%s | %.0f | %.1f |\n",
                k ? "clustered + scales" : "plain", r->clusters, kib(full.total()), kib(full.decoder), kib(full.latents),
                kib(full.ids), kib(full.scales), double(raw) / double(full.total()), kib(compact.total()),
                double(raw) / double(compact.total()), *e_train, *e_held, e_all, e_all / flat, r->epochs_done,
                early_stop ? weft::format(" (kept {})", r->best_epoch).c_str() : "", r->seconds, r->cluster_seconds);
    std::fflush(stdout);
  }
  return 0;
}
