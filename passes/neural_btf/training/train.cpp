// The training loop: SGD over batches of texels, each texel contributing its (light, view)
// samples; the samples of a step are cut into fixed chunks that threads run in any order,
// each writing its own gradient buffer, summed in chunk order — so the weights do not depend
// on the thread count. Stage 1 trains encoder + decoder end to end; stage 2 (the last
// finetune_fraction) encodes the latents once and trains them with the decoder directly.
module;
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <numeric>
#include <random>
#include <span>
#include <string>
#include <vector>
module weft.btf.training;
import weft.core;
import weft.btf;
import weft.btf.model;
import weft.cluster;

namespace weft::btf {
namespace {

using training_detail::TrainState;

constexpr std::size_t kChunk = 512;  // samples per decoder work item

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
  std::size_t item, begin, end;  // batch item and its sample range
};

}  // namespace

std::string describe_seconds(double s) {
  if (!(s >= 0.0) || !std::isfinite(s)) return "?";
  if (s < 60.0) return weft::format("{:.1f} s", s);
  const auto total = static_cast<std::uint64_t>(s + 0.5);
  if (total < 3600) return weft::format("{} min {} s", total / 60, total % 60);
  return weft::format("{} h {} min", total / 3600, total / 60 % 60);
}

Result<TrainResult> train_neural_btf(const Btf& btf, const TrainOptions& o) {
  if (auto ok = validate(btf, "training data"); !ok) return std::unexpected(ok.error());
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
      auto clustering = cluster_abrdfs(btf, co);
      if (!clustering) return std::unexpected(clustering.error());
      result.cluster_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count();
      const std::size_t k = clustering->count();
      result.clusters = std::uint32_t(k);
      d.latent_count = k;
      d.latent_of = clustering->ids;
      d.encoder_inputs.resize(k * d.floats);
      for (std::size_t c = 0; c < k; ++c)
        preprocess_input(pre.constants, std::span<const float>(clustering->medians).subspan(c * d.floats, d.floats),
                         std::span<float>(d.encoder_inputs).subspan(c * d.floats, d.floats));
      if (o.texel_scales) {
        // The paper's fix for blotchy clusters: texel luminance / its cluster median's. A dark
        // median (no luminance to divide by) keeps scale 1.
        std::vector<float> median_lum(k);
        for (std::size_t c = 0; c < k; ++c)
          median_lum[c] = abrdf_luminance(std::span<const float>(clustering->medians).subspan(c * d.floats, d.floats));
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
  auto made = make_network(shape, o.seed);
  if (!made) return std::unexpected(made.error());
  Network net = std::move(*made);
  const std::size_t L = shape.latent;
  const float lr = o.learning_rate > 0.0f ? o.learning_rate : (o.clusters ? 0.08f : 0.05f);
  const std::size_t per_texel = (o.directions_per_texel == 0 || o.directions_per_texel >= d.pairs)
                                    ? d.pairs
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

  TrainState state;
  state.fingerprint = fp.digest();
  std::vector<float> latents;
  if (o.resume && std::filesystem::exists(o.checkpoint)) {
    auto loaded = training_detail::load_checkpoint(o.checkpoint);
    if (!loaded) return std::unexpected(loaded.error());
    if (loaded->fingerprint != state.fingerprint)
      return fail(ErrorKind::InvalidArgument,
                  "checkpoint {} belongs to other data or options (BTF, clusters, seed, batch, learning rate, "
                  "directions per texel or network differ)",
                  o.checkpoint.string());
    if (loaded->parameters.size() != net.parameters.size() || loaded->running_mean.size() != net.running_mean.size() ||
        (loaded->finetuning && loaded->latents.size() != d.latent_count * L))
      return fail(ErrorKind::InvalidArgument, "checkpoint {}: sizes do not match the network", o.checkpoint.string());
    state = std::move(*loaded);
    net.parameters = state.parameters;
    net.running_mean = state.running_mean;
    net.running_var = state.running_var;
    latents = state.latents;
  }

  auto encode_all = [&] {  // inference-mode latents of every encoder input, population statistics
    std::vector<const float*> all(d.latent_count);
    for (std::size_t i = 0; i < d.latent_count; ++i) all[i] = d.encoder_inputs.data() + i * d.floats;
    batch_norm_population(net, all);
    latents.assign(d.latent_count * L, 0.0f);
    auto cache = make_encoder_cache();
    for (std::size_t i = 0; i < d.latent_count; i += 16) {
      const std::size_t n = std::min<std::size_t>(16, d.latent_count - i);
      encode_batch(net, std::span<const float* const>(all).subspan(i, n), false, *cache,
                   std::span<float>(latents).subspan(i * L, n * L));
    }
  };

  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] { return state.elapsed_s + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  auto write_checkpoint = [&]() -> Result<void> {
    if (o.checkpoint.empty()) return {};
    state.parameters = net.parameters;
    state.running_mean = net.running_mean;
    state.running_var = net.running_var;
    state.latents = state.finetuning ? latents : std::vector<float>{};
    const double now = elapsed();
    const double before = state.elapsed_s;
    state.elapsed_s = now;
    auto ok = training_detail::save_checkpoint(o.checkpoint, state);
    state.elapsed_s = before;
    return ok;
  };

  std::vector<std::uint32_t> order(d.texels);
  std::size_t order_epoch = std::size_t(-1);
  std::vector<float> gradient(net.parameters.size());
  std::vector<std::vector<float>> chunk_gradients;
  std::vector<std::vector<float>> chunk_latent_gradients;
  std::vector<double> chunk_loss;
  std::vector<std::uint32_t> pair_index(d.pairs);
  auto cache = make_encoder_cache();
  double last_report = -1e30;
  std::size_t steps_this_run = 0;

  while (state.epoch < o.epochs) {
    const double now = elapsed();
    if (o.max_seconds > 0.0 && now >= o.max_seconds) break;
    if (o.stop_after_steps && steps_this_run >= o.stop_after_steps) break;
    // Stage 2 begins after the autoencoder epochs or the autoencoder's share of the time.
    const bool want_finetune = o.finetune_fraction > 0.0f &&
                               (state.epoch >= autoencoder_epochs ||
                                (o.max_seconds > 0.0 && now >= o.max_seconds * (1.0 - o.finetune_fraction)));
    if (want_finetune && !state.finetuning) {
      encode_all();
      state.finetuning = true;
    }
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
    std::vector<float> batch_latents(batch * L);
    if (!state.finetuning) {
      std::vector<const float*> ptrs(batch);
      for (std::size_t b = 0; b < batch; ++b) ptrs[b] = d.encoder_inputs.data() + std::size_t(d.latent_of[texels[b]]) * d.floats;
      encode_batch(net, ptrs, true, *cache, batch_latents);
    } else {
      for (std::size_t b = 0; b < batch; ++b)
        std::copy_n(latents.data() + std::size_t(d.latent_of[texels[b]]) * L, L, batch_latents.data() + b * L);
    }
    // The samples of each texel: every pair, or a seeded draw without replacement.
    std::vector<std::vector<std::uint32_t>> pairs(batch);
    for (std::size_t b = 0; b < batch; ++b) {
      if (per_texel == d.pairs) {
        pairs[b].resize(d.pairs);
        std::iota(pairs[b].begin(), pairs[b].end(), 0u);
      } else {
        std::iota(pair_index.begin(), pair_index.end(), 0u);
        std::mt19937_64 rng(mix(mix(o.seed, state.epoch), state.step * 977 + b));
        for (std::size_t i = 0; i < per_texel; ++i) {
          std::uniform_int_distribution<std::size_t> pick(i, d.pairs - 1);
          std::swap(pair_index[i], pair_index[pick(rng)]);
        }
        pairs[b].assign(pair_index.begin(), pair_index.begin() + std::ptrdiff_t(per_texel));
      }
    }
    std::vector<Chunk> chunks;
    for (std::size_t b = 0; b < batch; ++b)
      for (std::size_t s = 0; s < per_texel; s += kChunk) chunks.push_back({b, s, std::min(per_texel, s + kChunk)});
    chunk_gradients.resize(chunks.size());
    chunk_latent_gradients.resize(chunks.size());
    chunk_loss.assign(chunks.size(), 0.0);
    const float weight = 1.0f / float(3 * batch * per_texel);
    const std::size_t in = L + 4;
    cluster::parallel_each(chunks.size(), o.threads, [&](std::size_t ci) {
      const Chunk& c = chunks[ci];
      const std::size_t n = c.end - c.begin, t = texels[c.item];
      std::vector<float> x(in * n), target(3 * n), dx(in * n), scales;
      const float* latent = batch_latents.data() + c.item * L;
      const float* tt = d.targets.data() + t * d.floats;
      for (std::size_t j = 0; j < n; ++j) {
        const std::uint32_t pair = pairs[c.item][c.begin + j];
        float* col = x.data() + j * in;
        std::copy_n(latent, L, col);
        const vec2 li = d.light_stereo[pair / d.views], vo = d.view_stereo[pair % d.views];
        col[L] = li.x, col[L + 1] = li.y, col[L + 2] = vo.x, col[L + 3] = vo.y;
        std::copy_n(tt + std::size_t(pair) * 3, 3, target.data() + j * 3);
      }
      if (!d.scales.empty()) scales.assign(n, d.scales[t]);
      auto& g = chunk_gradients[ci];
      g.assign(net.parameters.size(), 0.0f);
      chunk_loss[ci] = decoder_loss_gradient(net, x, target, scales, n, weight, g, dx);
      auto& dl = chunk_latent_gradients[ci];
      dl.assign(L, 0.0f);
      for (std::size_t j = 0; j < n; ++j)
        for (std::size_t k = 0; k < L; ++k) dl[k] += dx[j * in + k];
    });
    std::fill(gradient.begin(), gradient.end(), 0.0f);
    std::vector<float> latent_gradient(batch * L, 0.0f);
    for (std::size_t ci = 0; ci < chunks.size(); ++ci) {
      const auto& g = chunk_gradients[ci];
      for (std::size_t i = net.decoder_begin; i < g.size(); ++i) gradient[i] += g[i];
      for (std::size_t k = 0; k < L; ++k) latent_gradient[chunks[ci].item * L + k] += chunk_latent_gradients[ci][k];
      state.epoch_loss += chunk_loss[ci];
      state.epoch_count += double(3 * (chunks[ci].end - chunks[ci].begin));
    }
    if (!state.finetuning) encoder_backward(net, *cache, latent_gradient, gradient);
    float step = lr;
    if (o.max_gradient_norm > 0.0f) {
      double norm2 = 0.0;
      for (float g : gradient) norm2 += double(g) * g;
      if (state.finetuning)
        for (float g : latent_gradient) norm2 += double(g) * g;
      const double norm = std::sqrt(norm2);
      if (norm > double(o.max_gradient_norm)) step = float(double(lr) * double(o.max_gradient_norm) / norm);
    }
    for (std::size_t i = 0; i < gradient.size(); ++i) net.parameters[i] -= step * gradient[i];
    if (state.finetuning)
      for (std::size_t b = 0; b < batch; ++b)
        for (std::size_t k = 0; k < L; ++k)
          latents[std::size_t(d.latent_of[texels[b]]) * L + k] -= step * latent_gradient[b * L + k];
    if (!std::isfinite(state.epoch_loss))
      return fail(ErrorKind::InvalidArgument,
                  "training diverged at epoch {} step {} (loss {}): lower the learning rate ({}) or clip the gradient "
                  "(max_gradient_norm {})",
                  state.epoch + 1, state.step + 1, state.epoch_loss, lr, o.max_gradient_norm);
    ++steps_this_run;
    ++result.steps_done;
    ++state.step;
    const bool epoch_end = state.step == steps_per_epoch;
    if (epoch_end) {
      state.last_epoch_loss = state.epoch_count > 0.0 ? state.epoch_loss / state.epoch_count : 0.0;
      state.epoch_loss = state.epoch_count = 0.0;
      state.step = 0;
      ++state.epoch;
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
      p.elapsed_s = t;
      const double done = double(state.epoch) + double(state.step) / double(steps_per_epoch);
      double fraction = done / double(o.epochs);
      if (o.max_seconds > 0.0) fraction = std::max(fraction, t / o.max_seconds);
      p.fraction = std::min(1.0, fraction);
      p.eta_s = p.fraction > 0.0 ? t * (1.0 - p.fraction) / p.fraction : 0.0;
      o.progress(p);
    }
    if (epoch_end && o.checkpoint_every && state.epoch % o.checkpoint_every == 0)
      if (auto ok = write_checkpoint(); !ok) return std::unexpected(ok.error());
  }
  if (!state.finetuning) encode_all();
  if (auto ok = write_checkpoint(); !ok) return std::unexpected(ok.error());

  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.epochs_done = state.epoch;
  // A run that ends inside an epoch (a time budget, stop_after_steps) reports that epoch so far.
  result.final_loss = state.epoch_count > 0.0 ? state.epoch_loss / state.epoch_count : state.last_epoch_loss;
  NeuralBtf& m = result.model;
  m.width = btf.width;
  m.height = btf.height;
  m.latent_size = std::uint32_t(L);
  m.decoder = decoder_of(net);
  m.latents = latents;
  if (o.clusters) m.cluster_ids = d.latent_of;
  m.texel_scales = d.scales;
  m.output_scale = result.preprocessing.target_max;
  result.network = std::move(net);
  return result;
}

}  // namespace weft::btf
