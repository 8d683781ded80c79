// The training loop: SGD (the paper's) or Adam over batches of texels, each texel
// contributing its (light, view) samples; the samples of a step are cut into fixed blocks
// that threads run in any order, each writing its own gradient buffer, summed in block order —
// so the weights do not depend on the thread count. Stage 1 trains encoder + decoder end to
// end; stage 2 (the last finetune_fraction) encodes the latents once and trains them with the
// decoder directly. Optional early stopping measures held-out pairs at epoch ends.
module;
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <numeric>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <weft/try.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
module weft.btf.training;
import weft.cluster;

namespace weft::btf {
namespace {

using training_detail::TrainState;

constexpr std::size_t kChunk = 512;  // samples per decoder work item, unbatched (one texel's)
// Samples per decoder work item, batched (across texels), at most; a step's samples are cut into
// equal blocks (1,280 into two of 640, not 1,024 + 256, which left one thread idle). The cut
// depends on the step's size only, never on the thread count. 256 and 2048 were slower.
constexpr std::size_t kBlock = 1024;

// Threads kept for the whole training: a step runs several parallel phases (encoder stages,
// decoder blocks, backward), and starting threads for each cost more than some phases.
class WorkerPool {
 public:
  explicit WorkerPool(std::size_t threads) {
    const std::size_t n = threads ? threads : std::max<std::size_t>(1, std::thread::hardware_concurrency());
    for (std::size_t i = 1; i < n; ++i) workers_.emplace_back([this] { loop(); });
  }
  ~WorkerPool() {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    for (auto& w : workers_) w.join();
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  void run(std::size_t count, const std::function<void(std::size_t)>& body) {
    if (workers_.empty() || count <= 1) {
      for (std::size_t i = 0; i < count; ++i) body(i);
      return;
    }
    {
      std::lock_guard lock(mutex_);
      body_ = &body;
      count_ = count;
      next_ = 0;
      busy_ = workers_.size();
      ++generation_;
    }
    wake_.notify_all();
    work();
    std::unique_lock lock(mutex_);
    done_.wait(lock, [&] { return busy_ == 0; });
  }

 private:
  void work() {
    for (std::size_t i = next_++; i < count_; i = next_++) (*body_)(i);
  }
  void loop() {
    std::uint64_t seen = 0;
    for (;;) {
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [&] { return stopping_ || generation_ != seen; });
        if (stopping_) return;
        seen = generation_;
      }
      work();
      {
        std::lock_guard lock(mutex_);
        --busy_;
      }
      done_.notify_one();
    }
  }
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(std::size_t)>* body_ = nullptr;
  std::size_t count_ = 0, busy_ = 0;
  std::atomic<std::size_t> next_{0};
  std::uint64_t generation_ = 0;
  bool stopping_ = false;
};

std::uint64_t mix(std::uint64_t a, std::uint64_t b) {  // splitmix64 of a combined key
  std::uint64_t z = a * 0x9E3779B97F4A7C15ull + b + 0x632BE59BD9B4E019ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// What the loop trains on, independent of plain / clustered.
struct Data {
  std::size_t texels = 0, floats = 0, pairs = 0, views = 0;
  std::vector<float> encoder_inputs;       // per latent: preprocessed ABRDF
  std::vector<std::uint32_t> latent_of;    // per texel: which encoder input / latent
  std::size_t latent_count = 0;
  std::vector<float> targets;              // per texel: rgb / target_max
  std::vector<float> scales;               // per texel (empty: 1)
  std::vector<vec2> light_stereo, view_stereo;
};

struct Chunk {
  std::size_t begin, end;  // a range of the step's samples (item-major: item = sample / per_texel)
};

}  // namespace

std::string_view to_string(Optimizer optimizer) { return optimizer == Optimizer::Adam ? "adam" : "sgd"; }
std::string_view to_string(LearningRateSchedule schedule) {
  return schedule == LearningRateSchedule::Cosine ? "cosine" : "constant";
}

std::string_view training_simd_width() { return WEFT_TRAINING_SIMD; }

std::string describe_seconds(double s) {
  if (!(s >= 0.0) || !std::isfinite(s)) return "?";
  if (s < 60.0) return weft::format("{:.1f} s", s);
  const auto total = static_cast<std::uint64_t>(s + 0.5);
  if (total < 3600) return weft::format("{} min {} s", total / 60, total % 60);
  return weft::format("{} h {} min", total / 3600, total / 60 % 60);
}

namespace {
// A training step allocates and frees buffers of a few hundred KiB (convolution planes, per-stage
// activations, per-chunk gradients). glibc serves such sizes with mmap, or trims them off the
// heap's top when freed, so every step page-faulted and zeroed them afresh: about half of the
// step's time (perf, weft-bench-btf-train --throughput). Fixed thresholds keep them mapped for
// the process's life; a training process peaks near its steady state anyway.
void keep_freed_memory_mapped() {
#if defined(__GLIBC__)
  static const bool once = [] {
    mallopt(M_MMAP_THRESHOLD, 64 << 20);
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
    return true;
  }();
  (void)once;
#endif
}
}  // namespace

Result<TrainResult> train_neural_btf(const Btf& btf, const TrainOptions& o) {
  keep_freed_memory_mapped();
  WEFT_TRY_VOID(validate(btf, "training data"));
  if (o.batch == 0) return fail(ErrorKind::InvalidArgument, "training batch 0 (must be at least 1 texel)");
  if (o.epochs == 0) return fail(ErrorKind::InvalidArgument, "training epochs 0 (must be at least 1)");
  if (!(o.learning_rate >= 0.0f) || !std::isfinite(o.learning_rate))
    return fail(ErrorKind::InvalidArgument, "learning rate {} (must be finite and >= 0; 0 picks the paper's)",
                o.learning_rate);
  if (!(o.finetune_fraction >= 0.0f && o.finetune_fraction <= 1.0f))
    return fail(ErrorKind::InvalidArgument, "fine-tune fraction {} is outside [0, 1]", o.finetune_fraction);
  if (!(o.max_gradient_norm >= 0.0f) || !std::isfinite(o.max_gradient_norm))
    return fail(ErrorKind::InvalidArgument, "gradient clip {} (must be finite and >= 0; 0 turns it off)",
                o.max_gradient_norm);
  if (!(o.max_seconds >= 0.0)) return fail(ErrorKind::InvalidArgument, "time budget {} s is negative", o.max_seconds);
  if (o.clusters > btf.texels())
    return fail(ErrorKind::InvalidArgument, "{} clusters for {} texels (at most one cluster per texel)", o.clusters,
                btf.texels());
  if (o.resume && o.checkpoint.empty())
    return fail(ErrorKind::InvalidArgument, "resume asked for without a checkpoint file");
  if (!(o.adam_beta1 >= 0.0f && o.adam_beta1 < 1.0f) || !(o.adam_beta2 >= 0.0f && o.adam_beta2 < 1.0f) ||
      !(o.adam_epsilon > 0.0f) || !std::isfinite(o.adam_epsilon))
    return fail(ErrorKind::InvalidArgument, "Adam's beta1 {}, beta2 {} (each in [0, 1)) or epsilon {} (> 0)", o.adam_beta1,
                o.adam_beta2, o.adam_epsilon);
  if (!(o.schedule_floor >= 0.0f && o.schedule_floor <= 1.0f))
    return fail(ErrorKind::InvalidArgument, "learning-rate schedule floor {} is outside [0, 1]", o.schedule_floor);
  if (o.holdout_every == 1)
    return fail(ErrorKind::InvalidArgument, "holdout every 1 pair leaves nothing to train on (use 0 for none, or >= 2)");
  if (o.holdout_every > 0 && o.validation_texels == 0)
    return fail(ErrorKind::InvalidArgument, "early stopping with 0 validation texels");

  TrainResult result;
  Data d;
  d.texels = btf.texels();
  d.floats = btf.abrdf_floats();
  d.pairs = btf.samples_per_texel();
  d.views = btf.views.size();
  for (const auto& l : btf.lights) d.light_stereo.push_back(stereographic(to_vector(l)));
  for (const auto& v : btf.views) d.view_stereo.push_back(stereographic(to_vector(v)));
  {
    Preprocessed pre = preprocess(btf);
    result.preprocessing = pre.constants;
    d.targets = std::move(pre.targets);
    if (o.clusters == 0) {
      d.encoder_inputs = std::move(pre.inputs);
      d.latent_of.resize(d.texels);
      std::iota(d.latent_of.begin(), d.latent_of.end(), 0u);
      d.latent_count = d.texels;
    } else {
      const auto c0 = std::chrono::steady_clock::now();
      ClusterOptions co;
      co.clusters = o.clusters;
      co.pca_components = o.pca_components;
      co.seed = o.seed;
      co.threads = o.threads;
      WEFT_TRY(auto clustering, cluster_abrdfs(btf, co));
      result.cluster_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count();
      const std::size_t k = clustering.count();
      result.clusters = std::uint32_t(k);
      d.latent_count = k;
      d.latent_of = clustering.ids;
      d.encoder_inputs.resize(k * d.floats);
      for (std::size_t c = 0; c < k; ++c)
        preprocess_input(pre.constants, std::span<const float>(clustering.medians).subspan(c * d.floats, d.floats),
                         std::span<float>(d.encoder_inputs).subspan(c * d.floats, d.floats));
      if (o.texel_scales) {
        // The paper's fix for blotchy clusters: texel luminance / its cluster median's. A dark
        // median (no luminance to divide by) keeps scale 1.
        Floats median_lum(k);
        for (std::size_t c = 0; c < k; ++c)
          median_lum[c] = abrdf_luminance(std::span<const float>(clustering.medians).subspan(c * d.floats, d.floats));
        d.scales.resize(d.texels);
        for (std::size_t t = 0; t < d.texels; ++t) {
          const float m = median_lum[d.latent_of[t]];
          d.scales[t] = m > 1e-12f ? abrdf_luminance(btf.abrdf(t)) / m : 1.0f;
        }
      }
    }
  }
  if (o.clusters == 0) result.clusters = 0;

  NetworkShape shape = o.network;
  shape.lights = std::uint32_t(btf.lights.size());
  shape.views = std::uint32_t(btf.views.size());
  WEFT_TRY(auto made, make_network(shape, o.seed));
  Network net = std::move(made);
  const std::size_t L = shape.latent;
  const bool adam = o.optimizer == Optimizer::Adam;
  const float lr = o.learning_rate > 0.0f ? o.learning_rate : adam ? 0.001f : (o.clusters ? 0.08f : 0.05f);
  // The pairs a step may draw: all, or all but the held-out ones (early stopping's).
  std::vector<std::uint32_t> train_pairs, held_pairs;
  for (std::uint32_t pr = 0; pr < d.pairs; ++pr)
    (o.holdout_every && pr % o.holdout_every == o.holdout_every / 2 ? held_pairs : train_pairs).push_back(pr);
  const std::size_t trainable = train_pairs.size();
  const std::size_t per_texel = (o.directions_per_texel == 0 || o.directions_per_texel >= trainable)
                                    ? trainable
                                    : std::size_t(o.directions_per_texel);
  const std::size_t steps_per_epoch = (d.texels + o.batch - 1) / o.batch;
  const std::size_t finetune_epochs =
      std::size_t(std::lround(double(o.epochs) * double(o.finetune_fraction)));
  const std::size_t autoencoder_epochs = o.epochs - std::min<std::size_t>(finetune_epochs, o.epochs);

  // What a checkpoint must match: the data, the network and every option that changes steps.
  Hasher fp;
  fp.value(btf.width).value(btf.height).value(std::uint64_t(d.pairs));
  fp.bytes(btf.rgb.data(), btf.rgb.size() * sizeof(float));
  fp.value(o.clusters).value(o.pca_components).value(o.texel_scales).value(lr).value(o.batch);
  fp.value(o.max_gradient_norm);
  fp.value(std::uint64_t(per_texel)).value(o.seed).value(std::uint64_t(net.parameters.size()));
  for (auto h : shape.hidden) fp.value(h);
  for (auto c : shape.channels) fp.value(c);
  fp.value(std::uint8_t(o.optimizer)).value(o.adam_beta1).value(o.adam_beta2).value(o.adam_epsilon);
  fp.value(std::uint8_t(o.schedule)).value(o.schedule_floor).value(o.holdout_every).value(o.patience);
  fp.value(o.validation_texels).value(o.batched);
  if (o.schedule != LearningRateSchedule::Constant) fp.value(o.epochs).value(o.max_seconds);  // the schedule's length

  TrainState state;
  state.fingerprint = fp.digest();
  Floats latents;
  if (o.resume && std::filesystem::exists(o.checkpoint)) {
    WEFT_TRY(auto loaded, training_detail::load_checkpoint(o.checkpoint));
    if (loaded.fingerprint != state.fingerprint)
      return fail(ErrorKind::InvalidArgument,
                  "checkpoint {} belongs to other data or options (BTF, clusters, seed, batch, learning rate, "
                  "optimizer, schedule, hold-out, directions per texel or network differ)",
                  o.checkpoint.string());
    const std::size_t P = net.parameters.size(), LL = d.latent_count * L;
    auto sized = [](const Floats& v, std::size_t n) { return v.empty() || v.size() == n; };
    if (loaded.parameters.size() != P || loaded.running_mean.size() != net.running_mean.size() ||
        (loaded.finetuning && loaded.latents.size() != LL) || !sized(loaded.moment1, P) ||
        !sized(loaded.moment2, P) || !sized(loaded.latent_moment1, LL) || !sized(loaded.latent_moment2, LL) ||
        !sized(loaded.best_parameters, P) || !sized(loaded.best_latents, LL))
      return fail(ErrorKind::InvalidArgument, "checkpoint {}: sizes do not match the network", o.checkpoint.string());
    state = std::move(loaded);
    net.parameters = state.parameters;
    net.running_mean = state.running_mean;
    net.running_var = state.running_var;
    latents = state.latents;
  }
  if (adam) {
    if (state.moment1.empty()) state.moment1.assign(net.parameters.size(), 0.0f);
    if (state.moment2.empty()) state.moment2.assign(net.parameters.size(), 0.0f);
  }

  WorkerPool pool(o.batched ? o.threads : 1);
  const ParallelFn parallel = [&pool](std::size_t count, const std::function<void(std::size_t)>& body) { pool.run(count, body); };
  // Decoder blocks: on the pool (batched), or on threads started per step (the first schedule).
  auto run_blocks = [&](std::size_t count, const std::function<void(std::size_t)>& body) {
    if (o.batched) {
      pool.run(count, body);
    } else {
      cluster::parallel_each(count, o.threads, body);
    }
  };
  const ParallelFn encoder_parallel = o.batched ? parallel : ParallelFn{};

  auto encode_into = [&](std::span<const std::uint32_t> which, Floats& out) {
    std::vector<const float*> all(which.size());
    for (std::size_t i = 0; i < which.size(); ++i) all[i] = d.encoder_inputs.data() + std::size_t(which[i]) * d.floats;
    batch_norm_population(net, all, 64, encoder_parallel);
    out.assign(which.size() * L, 0.0f);
    auto cache = make_encoder_cache();
    for (std::size_t i = 0; i < which.size(); i += 16) {
      const std::size_t n = std::min<std::size_t>(16, which.size() - i);
      encode_batch(net, std::span<const float* const>(all).subspan(i, n), false, *cache,
                   std::span<float>(out).subspan(i * L, n * L), encoder_parallel);
    }
  };
  auto encode_all = [&] {  // inference-mode latents of every encoder input, population statistics
    std::vector<std::uint32_t> every(d.latent_count);
    std::iota(every.begin(), every.end(), 0u);
    encode_into(every, latents);
  };

  // Early stopping's measure: RMSE (the data's units) of the model as it stands on the held-out
  // pairs of a seeded draw of texels, clamped at 0 as decode() clamps.
  std::vector<std::uint32_t> validation_texels;
  if (!held_pairs.empty()) {
    validation_texels.resize(d.texels);
    std::iota(validation_texels.begin(), validation_texels.end(), 0u);
    std::mt19937_64 rng(mix(o.seed, 0x5eed));
    std::shuffle(validation_texels.begin(), validation_texels.end(), rng);
    validation_texels.resize(std::min<std::size_t>(o.validation_texels, d.texels));
    std::sort(validation_texels.begin(), validation_texels.end());
  }
  auto validation_rmse = [&]() -> double {
    Floats vl;
    if (!state.finetuning) {
      std::vector<std::uint32_t> which(validation_texels.size());
      for (std::size_t i = 0; i < which.size(); ++i) which[i] = d.latent_of[validation_texels[i]];
      encode_into(which, vl);
    }
    const std::size_t n = held_pairs.size(), in = L + 4;
    std::vector<double> sums(validation_texels.size(), 0.0);
    run_blocks(validation_texels.size(), [&](std::size_t i) {
      const std::uint32_t t = validation_texels[i];
      const float* latent = state.finetuning ? latents.data() + std::size_t(d.latent_of[t]) * L : vl.data() + i * L;
      Floats x(in * n), y(3 * n);
      for (std::size_t j = 0; j < n; ++j) {
        float* col = x.data() + j * in;
        std::copy_n(latent, L, col);
        const vec2 li = d.light_stereo[held_pairs[j] / d.views], vo = d.view_stereo[held_pairs[j] % d.views];
        col[L] = li.x, col[L + 1] = li.y, col[L + 2] = vo.x, col[L + 3] = vo.y;
      }
      decoder_forward(net, x, n, y);
      const float scale = d.scales.empty() ? 1.0f : d.scales[t];
      const float* tt = d.targets.data() + std::size_t(t) * d.floats;
      double sq = 0.0;
      for (std::size_t j = 0; j < n; ++j)
        for (std::size_t c = 0; c < 3; ++c) {
          const double e = double(std::max(y[j * 3 + c], 0.0f) * scale) - double(tt[std::size_t(held_pairs[j]) * 3 + c]);
          sq += e * e;
        }
      sums[i] = sq;
    });
    double total = 0.0;
    for (double v : sums) total += v;
    return std::sqrt(total / double(3 * n * validation_texels.size())) * double(result.preprocessing.target_max);
  };

  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return state.elapsed_s + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  auto write_checkpoint = [&]() -> Result<void> {
    if (o.checkpoint.empty()) return {};
    state.parameters = net.parameters;
    state.running_mean = net.running_mean;
    state.running_var = net.running_var;
    state.latents = state.finetuning ? latents : Floats{};
    const double now = elapsed();
    const double before = state.elapsed_s;
    state.elapsed_s = now;
    auto ok = training_detail::save_checkpoint(o.checkpoint, state);
    state.elapsed_s = before;
    return ok;
  };
  auto keep_best = [&] {
    state.best_parameters = net.parameters;
    state.best_running_mean = net.running_mean;
    state.best_running_var = net.running_var;
    state.best_finetuning = state.finetuning;
    state.best_latents = state.finetuning ? latents : Floats{};
  };
  auto restore_best = [&] {
    net.parameters = state.best_parameters;
    net.running_mean = state.best_running_mean;
    net.running_var = state.best_running_var;
    if (state.best_finetuning) latents = state.best_latents;
  };
  auto start_finetuning = [&] {
    encode_all();
    state.finetuning = true;
    if (adam) {
      state.latent_moment1.assign(latents.size(), 0.0f);
      state.latent_moment2.assign(latents.size(), 0.0f);
    }
    state.stale = 0;
  };

  std::vector<std::uint32_t> order(d.texels);
  std::size_t order_epoch = std::size_t(-1);
  Floats gradient(net.parameters.size());
  std::vector<Floats> chunk_gradients;
  std::vector<Floats> chunk_latent_gradients;
  std::vector<double> chunk_loss;
  std::vector<std::uint32_t> pair_index(trainable);
  auto cache = make_encoder_cache();
  double last_report = -1e30;
  std::size_t steps_this_run = 0;
  double step_rate = lr;

  double outside_steps = 0.0;  // validation time, kept out of step_seconds
  while (state.epoch < o.epochs) {
    const double now = elapsed();
    if (o.max_seconds > 0.0 && now >= o.max_seconds) break;
    if (o.stop_after_steps && steps_this_run >= o.stop_after_steps) break;
    // Stage 2 begins after the autoencoder epochs or the autoencoder's share of the time.
    const bool want_finetune = o.finetune_fraction > 0.0f &&
                               (state.epoch >= autoencoder_epochs ||
                                (o.max_seconds > 0.0 && now >= o.max_seconds * (1.0 - o.finetune_fraction)));
    if (want_finetune && !state.finetuning) start_finetuning();
    if (order_epoch != state.epoch) {
      std::iota(order.begin(), order.end(), 0u);
      std::mt19937_64 shuffle_rng(mix(o.seed, state.epoch));
      std::shuffle(order.begin(), order.end(), shuffle_rng);
      order_epoch = state.epoch;
    }
    const std::size_t first = state.step * o.batch;
    const std::size_t batch = std::min<std::size_t>(o.batch, d.texels - first);
    std::vector<std::uint32_t> texels(order.begin() + std::ptrdiff_t(first),
                                      order.begin() + std::ptrdiff_t(first + batch));
    // Latents of the batch: the encoder's (stage 1) or the stored ones (stage 2).
    Floats batch_latents(batch * L);
    if (!state.finetuning) {
      std::vector<const float*> ptrs(batch);
      for (std::size_t b = 0; b < batch; ++b) ptrs[b] = d.encoder_inputs.data() + std::size_t(d.latent_of[texels[b]]) * d.floats;
      encode_batch(net, ptrs, true, *cache, batch_latents, encoder_parallel);
    } else {
      for (std::size_t b = 0; b < batch; ++b)
        std::copy_n(latents.data() + std::size_t(d.latent_of[texels[b]]) * L, L, batch_latents.data() + b * L);
    }
    // The samples of each texel: every trainable pair, or a seeded draw without replacement.
    std::vector<std::vector<std::uint32_t>> pairs(batch);
    for (std::size_t b = 0; b < batch; ++b) {
      if (per_texel == trainable) {
        pairs[b] = train_pairs;
      } else {
        std::iota(pair_index.begin(), pair_index.end(), 0u);
        std::mt19937_64 rng(mix(mix(o.seed, state.epoch), state.step * 977 + b));
        for (std::size_t i = 0; i < per_texel; ++i) {
          std::uniform_int_distribution<std::size_t> pick(i, trainable - 1);
          std::swap(pair_index[i], pair_index[pick(rng)]);
        }
        pairs[b].resize(per_texel);
        for (std::size_t i = 0; i < per_texel; ++i) pairs[b][i] = train_pairs[pair_index[i]];
      }
    }
    // The step's samples, item-major, in blocks: fixed-size across texels (batched) or within one
    // texel (the first schedule). Each block: one matrix product per layer, its own gradient.
    std::vector<Chunk> chunks;
    const std::size_t total = batch * per_texel;
    if (o.batched) {
      const std::size_t blocks = (total + kBlock - 1) / kBlock, size = (total + blocks - 1) / blocks;
      for (std::size_t s0 = 0; s0 < total; s0 += size) chunks.push_back({s0, std::min(total, s0 + size)});
    } else {
      for (std::size_t b = 0; b < batch; ++b)
        for (std::size_t s0 = 0; s0 < per_texel; s0 += kChunk)
          chunks.push_back({b * per_texel + s0, b * per_texel + std::min(per_texel, s0 + kChunk)});
    }
    chunk_gradients.resize(chunks.size());
    chunk_latent_gradients.resize(chunks.size());
    chunk_loss.assign(chunks.size(), 0.0);
    const float weight = 1.0f / float(3 * batch * per_texel);
    const std::size_t in = L + 4;
    run_blocks(chunks.size(), [&](std::size_t ci) {
      const Chunk& c = chunks[ci];
      const std::size_t n = c.end - c.begin, first_item = c.begin / per_texel;
      Floats x(in * n), target(3 * n), dx(in * n), scales;
      if (!d.scales.empty()) scales.resize(n);
      for (std::size_t j = 0; j < n; ++j) {
        const std::size_t sample = c.begin + j, item = sample / per_texel, t = texels[item];
        const std::uint32_t pair = pairs[item][sample % per_texel];
        float* col = x.data() + j * in;
        std::copy_n(batch_latents.data() + item * L, L, col);
        const vec2 li = d.light_stereo[pair / d.views], vo = d.view_stereo[pair % d.views];
        col[L] = li.x, col[L + 1] = li.y, col[L + 2] = vo.x, col[L + 3] = vo.y;
        std::copy_n(d.targets.data() + t * d.floats + std::size_t(pair) * 3, 3, target.data() + j * 3);
        if (!scales.empty()) scales[j] = d.scales[t];
      }
      auto& g = chunk_gradients[ci];
      g.assign(net.decoder_parameters(), 0.0f);  // the decoder's part: blocks do not touch the encoder
      chunk_loss[ci] = decoder_loss_gradient(net, x, target, scales, n, weight, g, dx);
      // Latent gradients of the items this block covers (from first_item on).
      auto& dl = chunk_latent_gradients[ci];
      dl.assign(((c.end - 1) / per_texel - first_item + 1) * L, 0.0f);
      for (std::size_t j = 0; j < n; ++j) {
        const std::size_t item = (c.begin + j) / per_texel - first_item;
        for (std::size_t k = 0; k < L; ++k) dl[item * L + k] += dx[j * in + k];
      }
    });
    std::fill(gradient.begin(), gradient.end(), 0.0f);
    Floats latent_gradient(batch * L, 0.0f);
    for (std::size_t ci = 0; ci < chunks.size(); ++ci) {
      const auto& g = chunk_gradients[ci];
      float* decoder_gradient = gradient.data() + net.decoder_begin;
      for (std::size_t i = 0; i < g.size(); ++i) decoder_gradient[i] += g[i];
      const std::size_t first_item = chunks[ci].begin / per_texel;
      const auto& dl = chunk_latent_gradients[ci];
      for (std::size_t k = 0; k < dl.size(); ++k) latent_gradient[first_item * L + k] += dl[k];
      state.epoch_loss += chunk_loss[ci];
      state.epoch_count += double(3 * (chunks[ci].end - chunks[ci].begin));
    }
    if (!state.finetuning) encoder_backward(net, *cache, latent_gradient, gradient, encoder_parallel);
    // The schedule's rate for this step.
    double rate = lr;
    if (o.schedule == LearningRateSchedule::Cosine) {
      double done = (double(state.epoch) + double(state.step) / double(steps_per_epoch)) / double(o.epochs);
      if (o.max_seconds > 0.0) done = std::max(done, now / o.max_seconds);
      done = std::clamp(done, 0.0, 1.0);
      rate = lr * (o.schedule_floor + (1.0 - o.schedule_floor) * 0.5 * (1.0 + std::cos(pi * done)));
    }
    step_rate = rate;
    double clip = 1.0;  // the factor that brings the gradient's norm down to max_gradient_norm
    if (o.max_gradient_norm > 0.0f) {
      double norm2 = 0.0;
      for (float g : gradient) norm2 += double(g) * g;
      if (state.finetuning)
        for (float g : latent_gradient) norm2 += double(g) * g;
      const double norm = std::sqrt(norm2);
      if (norm > double(o.max_gradient_norm)) clip = double(o.max_gradient_norm) / norm;
    }
    if (!adam) {
      const float step = float(rate * clip);
      for (std::size_t i = 0; i < gradient.size(); ++i) net.parameters[i] -= step * gradient[i];
      if (state.finetuning)
        for (std::size_t b = 0; b < batch; ++b)
          for (std::size_t k = 0; k < L; ++k)
            latents[std::size_t(d.latent_of[texels[b]]) * L + k] -= step * latent_gradient[b * L + k];
    } else {
      ++state.adam_steps;
      const double b1 = o.adam_beta1, b2 = o.adam_beta2, t = double(state.adam_steps);
      const float step = float(rate * std::sqrt(1.0 - std::pow(b2, t)) / (1.0 - std::pow(b1, t)));
      const float c1 = float(b1), c2 = float(b2), eps = o.adam_epsilon, scale = float(clip);
      auto update = [&](float& w, float& m, float& v, float g) {
        g *= scale;
        m = c1 * m + (1.0f - c1) * g;
        v = c2 * v + (1.0f - c2) * g * g;
        w -= step * m / (std::sqrt(v) + eps);
      };
      // The encoder is frozen while fine-tuning: its moments stay as they were.
      for (std::size_t i = state.finetuning ? net.decoder_begin : 0; i < gradient.size(); ++i)
        update(net.parameters[i], state.moment1[i], state.moment2[i], gradient[i]);
      if (state.finetuning) {
        // A latent shared by several texels of the batch (clusters) gets one update of their sum.
        std::vector<std::uint32_t> touched;
        Floats summed;
        for (std::size_t b = 0; b < batch; ++b) {
          const std::uint32_t id = d.latent_of[texels[b]];
          auto at = std::find(touched.begin(), touched.end(), id);
          std::size_t slot = std::size_t(at - touched.begin());
          if (at == touched.end()) {
            touched.push_back(id);
            summed.resize(summed.size() + L, 0.0f);
          }
          for (std::size_t k = 0; k < L; ++k) summed[slot * L + k] += latent_gradient[b * L + k];
        }
        for (std::size_t u = 0; u < touched.size(); ++u)
          for (std::size_t k = 0; k < L; ++k) {
            const std::size_t at = std::size_t(touched[u]) * L + k;
            update(latents[at], state.latent_moment1[at], state.latent_moment2[at], summed[u * L + k]);
          }
      }
    }
    if (!std::isfinite(state.epoch_loss))
      return fail(ErrorKind::InvalidArgument,
                  "training diverged at epoch {} step {} (loss {}): lower the learning rate ({}) or clip the gradient "
                  "(max_gradient_norm {})",
                  state.epoch + 1, state.step + 1, state.epoch_loss, rate, o.max_gradient_norm);
    ++steps_this_run;
    ++result.steps_done;
    result.samples_done += total;
    ++state.step;
    const bool epoch_end = state.step == steps_per_epoch;
    bool stop_now = false;
    if (epoch_end) {
      state.last_epoch_loss = state.epoch_count > 0.0 ? state.epoch_loss / state.epoch_count : 0.0;
      state.epoch_loss = state.epoch_count = 0.0;
      state.step = 0;
      ++state.epoch;
      if (!held_pairs.empty()) {
        const auto v0 = std::chrono::steady_clock::now();
        state.last_rmse = validation_rmse();
        outside_steps += std::chrono::duration<double>(std::chrono::steady_clock::now() - v0).count();
        if (state.best_rmse < 0.0 || state.last_rmse < state.best_rmse) {
          state.best_rmse = state.last_rmse;
          state.best_epoch = state.epoch;
          state.stale = 0;
          keep_best();
        } else if (++state.stale >= o.patience && o.patience > 0) {
          // Patience spent: the autoencoder hands its best weights to fine-tuning, or training ends.
          restore_best();
          if (!state.finetuning && o.finetune_fraction > 0.0f) {
            start_finetuning();
          } else {
            stop_now = true;
            result.stopped_early = true;
          }
        }
      }
    }
    const double t = elapsed();
    if (o.progress && (epoch_end || t - last_report >= o.progress_interval_s)) {
      last_report = t;
      TrainProgress p;
      p.epoch = epoch_end ? state.epoch - 1 : state.epoch;
      p.epochs = o.epochs;
      p.step = epoch_end ? steps_per_epoch : state.step;
      p.steps_per_epoch = steps_per_epoch;
      p.finetuning = state.finetuning;
      p.loss = epoch_end ? state.last_epoch_loss : (state.epoch_count > 0.0 ? state.epoch_loss / state.epoch_count : 0.0);
      p.learning_rate = step_rate;
      p.validation_rmse = state.last_rmse;
      p.elapsed_s = t;
      const double done = double(state.epoch) + double(state.step) / double(steps_per_epoch);
      double fraction = done / double(o.epochs);
      if (o.max_seconds > 0.0) fraction = std::max(fraction, t / o.max_seconds);
      p.fraction = std::min(1.0, fraction);
      p.eta_s = p.fraction > 0.0 ? t * (1.0 - p.fraction) / p.fraction : 0.0;
      o.progress(p);
    }
    if (epoch_end && o.checkpoint_every && state.epoch % o.checkpoint_every == 0)
      WEFT_TRY_VOID(write_checkpoint());
    if (stop_now) break;
  }
  result.step_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() - outside_steps;
  // Early stopping keeps the best model it measured, whether or not patience ran out.
  const bool finished = state.epoch >= o.epochs || result.stopped_early ||
                        (o.max_seconds > 0.0 && elapsed() >= o.max_seconds);
  if (finished && !held_pairs.empty() && state.best_rmse >= 0.0) {
    restore_best();
    state.finetuning = state.best_finetuning;
  }
  if (!state.finetuning) encode_all();
  WEFT_TRY_VOID(write_checkpoint());

  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.epochs_done = state.epoch;
  result.validation_rmse = state.best_rmse;
  result.best_epoch = std::size_t(state.best_epoch);
  // A run that ends inside an epoch (a time budget, stop_after_steps) reports that epoch so far.
  result.final_loss = state.epoch_count > 0.0 ? state.epoch_loss / state.epoch_count : state.last_epoch_loss;
  NeuralBtf& m = result.model;
  m.width = btf.width;
  m.height = btf.height;
  m.latent_size = std::uint32_t(L);
  m.decoder = decoder_of(net);
  m.latents.assign(latents.begin(), latents.end());
  if (o.clusters) m.cluster_ids = d.latent_of;
  m.texel_scales = d.scales;
  m.output_scale = result.preprocessing.target_max;
  result.network = std::move(net);
  return result;
}

}  // namespace weft::btf
