// weft.btf.training: the hand-written backward passes against finite differences, training
// that converges (one texel; a tiny synthetic fabric to a bounded RMSE), the trained model's
// CPU decode() equal to the training forward pass, finite results at the data's extremes,
// k = 1 and k = M, determinism (seed, thread count) and checkpoint resume == uninterrupted.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <numbers>
#include <random>
#include <span>
#include <string>
#include <vector>
#include <glm/glm.hpp>
#include <unistd.h>
import weft.core;
import weft.btf;
import weft.btf.model;
import weft.btf.training;

using namespace weft;
using namespace weft::btf;

namespace {

// 9 directions: the normal, and θ = 30°, 60° at 4 azimuths each.
std::vector<Direction> nine_directions() {
  std::vector<Direction> d{{0.0f, 0.0f}};
  for (float theta : {30.0f, 60.0f})
    for (int k = 0; k < 4; ++k) d.push_back({theta * std::numbers::pi_v<float> / 180.0f, float(k) * std::numbers::pi_v<float> / 2.0f});
  return d;
}

template <class F>
Btf make_btf(std::uint32_t w, std::uint32_t h, F f) {
  Btf b{w, h, nine_directions(), nine_directions(), {}};
  b.rgb.resize(b.texels() * b.abrdf_floats());
  for (std::size_t t = 0; t < b.texels(); ++t)
    for (std::size_t l = 0; l < b.lights.size(); ++l)
      for (std::size_t v = 0; v < b.views.size(); ++v)
        for (std::size_t c = 0; c < 3; ++c)
          b.rgb[((t * b.lights.size() + l) * b.views.size() + v) * 3 + c] = f(t, l, v, c);
  return b;
}

// A file of this process's own: test_btf_training and test_btf_training_misaligned run at the
// same time under ctest -j, and a shared checkpoint name let one read the other's file.
std::filesystem::path own_temp_file(const std::string& name) {
  return std::filesystem::temp_directory_path() / (name + "-" + std::to_string(::getpid()));
}

Btf tiny_fabric() {
  SyntheticOptions o;
  o.width = o.height = 4;
  o.lights = o.views = nine_directions();
  o.yarn_spacing = 2.0f;
  o.subsamples = 1;
  o.seed = 3;
  auto b = synthetic_btf(o);
  REQUIRE_MESSAGE(b, (b ? "" : b.error().what()));
  return *b;
}

TrainResult trained(const Btf& btf, const TrainOptions& o) {
  auto r = train_neural_btf(btf, o);
  REQUIRE_MESSAGE(r, (r ? "" : r.error().what()));
  return std::move(*r);
}

bool all_finite(std::span<const float> v) {
  return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
}

// Loss of the whole network (encoder in training mode, then decoder) on fixed samples:
// Σ w (s y − t)², and its gradient when `gradient` is not empty.
double network_loss(Network& net, const std::vector<std::vector<float>>& abrdfs, const std::vector<float>& stereo,
                    const std::vector<float>& targets, const std::vector<float>& scales, std::size_t per_item,
                    std::span<float> gradient) {
  const std::size_t batch = abrdfs.size(), L = net.shape.latent, in = L + 4;
  std::vector<const float*> ptrs;
  for (const auto& a : abrdfs) ptrs.push_back(a.data());
  auto cache = make_encoder_cache();
  std::vector<float> latents(batch * L);
  encode_batch(net, ptrs, true, *cache, latents);
  const float weight = 0.7f;
  double loss = 0.0;
  std::vector<float> latent_gradient(batch * L, 0.0f);
  std::vector<float> scratch(net.parameters.size(), 0.0f);
  for (std::size_t b = 0; b < batch; ++b) {
    std::vector<float> x(in * per_item), dx(in * per_item);
    for (std::size_t j = 0; j < per_item; ++j) {
      std::copy_n(latents.data() + b * L, L, x.data() + j * in);
      std::copy_n(stereo.data() + j * 4, 4, x.data() + j * in + L);
    }
    std::span<const float> t(targets.data() + b * per_item * 3, per_item * 3);
    std::vector<float> s(per_item, scales[b]);
    loss += weight * decoder_loss_gradient(net, x, t, s, per_item, weight, gradient.empty() ? std::span<float>(scratch) : gradient, dx);
    for (std::size_t j = 0; j < per_item; ++j)
      for (std::size_t k = 0; k < L; ++k) latent_gradient[b * L + k] += dx[j * in + k];
  }
  if (!gradient.empty()) encoder_backward(net, *cache, latent_gradient, gradient);
  return loss;
}

}  // namespace

TEST_CASE("the paper's decoder has 24,383 parameters; the encoder's sizes follow the image") {
  auto net = make_network(NetworkShape{}, 1);
  REQUIRE(net);
  CHECK(net->decoder_parameters() == 24383);
  CHECK(decoder_of(*net).parameter_count() == 24383);
  // 81 -> 27 -> 9 -> 3 pixels per side after the pools; 32 channels x 3 x 3 into the latent.
  CHECK(net->conv[2].pooled_rows == 3);
  CHECK(net->fc_inputs == 32 * 9);
  // Odd sizes keep the partial pooling windows: 10 -> 4 -> 2 -> 1.
  NetworkShape odd;
  odd.lights = 10;
  odd.views = 7;
  auto small = make_network(odd, 1);
  REQUIRE(small);
  CHECK(small->conv[0].pooled_rows == 4);
  CHECK(small->conv[2].pooled_rows == 1);
  CHECK(small->conv[2].pooled_cols == 1);
  NetworkShape bad;
  bad.channels[1] = 0;
  auto e = make_network(bad, 1);
  REQUIRE_FALSE(e);
  CHECK(e.error().message.find("stage 2") != std::string::npos);
}

TEST_CASE("gradient check: encoder (conv, max-pool, batch norm, fc) and decoder against finite differences") {
  NetworkShape shape;
  shape.lights = 7;
  shape.views = 5;
  shape.channels = {3, 4, 2};
  shape.latent = 3;
  shape.hidden = {6, 5};
  auto made = make_network(shape, 7);
  REQUIRE(made);
  Network net = *made;
  std::mt19937 rng(11);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  // Non-trivial batch-norm affine parameters, so γ and β matter in the check.
  for (const auto& c : net.conv)
    for (std::uint32_t i = 0; i < c.out; ++i) {
      net.parameters[c.gamma + i] = 1.0f + 0.3f * normal(rng);
      net.parameters[c.beta + i] = 0.2f * normal(rng);
    }
  const std::size_t batch = 3, per_item = 6;
  std::vector<std::vector<float>> abrdfs(batch, std::vector<float>(7 * 5 * 3));
  for (auto& a : abrdfs)
    for (float& v : a) v = normal(rng);
  std::vector<float> stereo(per_item * 4), targets(batch * per_item * 3), scales{1.0f, 0.6f, 1.7f};
  for (float& v : stereo) v = 0.5f * normal(rng);
  for (float& v : targets) v = 0.3f * normal(rng);

  std::vector<float> analytic(net.parameters.size(), 0.0f);
  network_loss(net, abrdfs, stereo, targets, scales, per_item, analytic);
  std::size_t checked = 0, bad = 0;
  double worst = 0.0;
  for (std::size_t i = 0; i < net.parameters.size(); ++i) {
    const float saved = net.parameters[i];
    const float h = 1e-3f * std::max(1.0f, std::abs(saved));
    net.parameters[i] = saved + h;
    const double up = network_loss(net, abrdfs, stereo, targets, scales, per_item, {});
    net.parameters[i] = saved - h;
    const double down = network_loss(net, abrdfs, stereo, targets, scales, per_item, {});
    net.parameters[i] = saved;
    const double mid = network_loss(net, abrdfs, stereo, targets, scales, per_item, {});
    // Central difference, or a one-sided one: at a max-pool tie or a ReLU kink only the side
    // that keeps the current branch agrees with the (one-sided) analytic gradient.
    const double a = double(analytic[i]);
    double error = 1e30;
    for (double numeric : {(up - down) / (2.0 * double(h)), (up - mid) / double(h), (mid - down) / double(h)})
      error = std::min(error, std::abs(numeric - a) - 0.02 * (std::abs(numeric) + std::abs(a)));
    worst = std::max(worst, error);
    ++checked;
    // Float rounding of the loss over h leaves ~0.01 of absolute noise.
    if (error > 0.02) {
      ++bad;
      MESSAGE("parameter ", i, ": analytic ", a, ", central difference ", (up - down) / (2.0 * double(h)));
    }
  }
  INFO("parameters ", checked, ", worst excess error ", worst);
  CHECK(checked == net.parameters.size());
  CHECK(bad == 0);
  // The gradient is not trivially zero anywhere it matters.
  CHECK(std::abs(analytic[net.conv[0].weights]) + std::abs(analytic[net.fc_weights]) + std::abs(analytic[net.dense[0].weights]) > 0.0f);
}

TEST_CASE("batch_norm_population: inference on it equals training mode over the whole set, in any chunking") {
  NetworkShape shape;
  shape.lights = 9;
  shape.views = 7;
  shape.channels = {3, 4, 2};
  shape.latent = 3;
  shape.hidden = {6};
  auto made = make_network(shape, 3);
  REQUIRE(made);
  std::mt19937 rng(5);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::vector<std::vector<float>> abrdfs(7, std::vector<float>(std::size_t(9) * 7 * 3));
  for (auto& a : abrdfs)
    for (float& x : a) x = 40.0f + 0.01f * normal(rng);  // large and nearly constant: a one-pass variance loses it
  std::vector<const float*> ptrs;
  for (const auto& a : abrdfs) ptrs.push_back(a.data());
  auto cache = make_encoder_cache();
  Network batch = *made;
  std::vector<float> expected(7 * 3), got(7 * 3);
  encode_batch(batch, ptrs, true, *cache, expected);  // normalised by the statistics of all 7
  for (std::size_t chunk : {1u, 3u, 7u, 64u}) {
    CAPTURE(chunk);
    Network net = *made;
    batch_norm_population(net, ptrs, chunk);
    encode_batch(net, ptrs, false, *cache, got);
    for (std::size_t i = 0; i < got.size(); ++i) CHECK(got[i] == doctest::Approx(expected[i]).epsilon(1e-3));
  }
}

TEST_CASE("training one texel converges") {
  const Btf btf = make_btf(1, 1, [](std::size_t, std::size_t l, std::size_t v, std::size_t c) {
    const vec3 li = to_vector(nine_directions()[l]), vo = to_vector(nine_directions()[v]);
    return microfacet_reflectance(vec3(0.6f, 0.4f, 0.2f), 0.4f, 0.04f, li, vo)[int(c)];
  });
  TrainOptions o;
  o.batch = 1;
  o.epochs = 400;
  o.threads = 1;
  o.learning_rate = 0.2f;
  std::vector<double> epoch_loss;
  o.progress_interval_s = 1e9;  // epoch ends only
  o.progress = [&](const TrainProgress& p) { epoch_loss.push_back(p.loss); };
  const TrainResult r = trained(btf, o);
  CHECK(r.epochs_done == 400);
  REQUIRE(epoch_loss.size() == 400);
  auto rmse = model_rmse(r.model, btf);
  REQUIRE(rmse);
  const double flat = btf::constant_rmse(btf);
  INFO("RMSE ", *rmse, " against ", flat, " of the best constant; loss ", epoch_loss.front(), " -> ", r.final_loss);
  // Plain SGD is slow on one ABRDF (at the paper's 0.05: RMSE 0.055 after 400 epochs, 0.025
  // after 2,000) but steady: the loss falls by orders of magnitude and the fit beats any
  // constant by a wide margin.
  CHECK(r.final_loss < 0.05 * epoch_loss.front());
  CHECK(*rmse < 0.5 * flat);
}

TEST_CASE("a tiny fabric trains to a bounded RMSE and decode() equals the training forward pass") {
  const Btf btf = tiny_fabric();
  TrainOptions o;
  o.epochs = 300;
  o.learning_rate = 0.2f;  // the paper's 0.05 needs ~4x the epochs for this fit
  o.threads = 2;
  const TrainResult r = trained(btf, o);
  REQUIRE(validate(r.model));
  CHECK(r.model.latent_count() == 16);
  CHECK_FALSE(r.model.clustered());
  CHECK(r.model.output_scale == doctest::Approx(r.preprocessing.target_max));
  double sq = 0.0;
  for (float x : btf.rgb) sq += double(x) * x;
  const double rms = std::sqrt(sq / double(btf.rgb.size()));
  auto rmse = model_rmse(r.model, btf);
  REQUIRE(rmse);
  const double flat = btf::constant_rmse(btf);
  INFO("RMSE ", *rmse, ", signal RMS ", rms, ", best constant ", flat);
  CHECK(*rmse < 0.35 * flat);  // measured: 0.028 against 0.150
  // The model's CPU decode against the network's batched forward pass (with decode's clamp
  // and output scale), sample by sample.
  const std::size_t L = r.model.latent_size;
  double worst = 0.0;
  for (std::size_t t = 0; t < btf.texels(); ++t)
    for (std::size_t l = 0; l < btf.lights.size(); l += 2)
      for (std::size_t v = 0; v < btf.views.size(); v += 3) {
        const vec3 li = to_vector(btf.lights[l]), vo = to_vector(btf.views[v]);
        std::vector<float> x(L + 4), y(3);
        std::copy_n(r.model.latents.data() + t * L, L, x.data());
        const vec2 a = stereographic(li), b = stereographic(vo);
        x[L] = a.x, x[L + 1] = a.y, x[L + 2] = b.x, x[L + 3] = b.y;
        decoder_forward(r.network, x, 1, y);
        const vec3 decoded = decode(r.model, t, li, vo);
        for (int c = 0; c < 3; ++c)
          worst = std::max(worst, double(std::abs(decoded[c] - std::max(y[std::size_t(c)], 0.0f) * r.model.output_scale)));
      }
  CHECK(worst < 1e-5);
  // The batched RMSE equals the data module's RMSE of decode().
  const double reference = weft::btf::rmse(btf, [&](std::size_t t, const vec3& li, const vec3& vo) { return decode(r.model, t, li, vo); }, 1);
  CHECK(*rmse == doctest::Approx(reference).epsilon(1e-4));
  // The model survives the file.
  const auto file = own_temp_file("weft_test_btf_training.wbtf");
  REQUIRE(save_wbtf(r.model, file));
  auto back = load_wbtf(file);
  REQUIRE(back);
  const bool same = decode(*back, 5, to_vector(btf.lights[3]), to_vector(btf.views[4])) ==
                    decode(r.model, 5, to_vector(btf.lights[3]), to_vector(btf.views[4]));
  CHECK(same);
  std::filesystem::remove(file);
}

TEST_CASE("constant, all-zero and huge ABRDFs train to finite models") {
  const float values[] = {0.5f, 0.0f, 3e7f};
  for (float value : values) {
    CAPTURE(value);
    const Btf btf = make_btf(2, 2, [value](std::size_t, std::size_t, std::size_t, std::size_t) { return value; });
    for (std::uint32_t clusters : {0u, 2u}) {
      CAPTURE(clusters);
      TrainOptions o;
      o.epochs = 4;
      o.clusters = clusters;
      o.threads = 1;
      const TrainResult r = trained(btf, o);
      CHECK(validate(r.model));
      CHECK(all_finite(r.network.parameters));
      CHECK(all_finite(r.model.latents));
      CHECK(all_finite(r.model.texel_scales));
      const vec3 c = decode(r.model, 1, vec3(0, 0, 1), vec3(0.5f, 0, 0.8f));
      CHECK((std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z)));
      auto e = model_rmse(r.model, btf);
      REQUIRE(e);
      CHECK(std::isfinite(*e));
      // Targets are divided by the global max, so even 3e7 trains at unit scale: the error
      // stays a bounded fraction of the value.
      if (value > 0.0f) CHECK(*e < 2.0 * value);
    }
  }
}

TEST_CASE("clustered: k = 1 and k = M") {
  const Btf btf = tiny_fabric();
  TrainOptions o;
  o.epochs = 3;
  o.threads = 2;
  o.clusters = 1;
  const TrainResult one = trained(btf, o);
  REQUIRE(validate(one.model));
  CHECK(one.model.latent_count() == 1);
  CHECK(one.clusters == 1);
  CHECK(one.model.cluster_ids == std::vector<std::uint32_t>(16, 0u));
  REQUIRE(one.model.texel_scales.size() == 16);
  // With one cluster the scale is the texel's luminance over the median ABRDF's.
  const auto lum = mean_luminance(btf);
  CHECK(*std::max_element(one.model.texel_scales.begin(), one.model.texel_scales.end()) >
        *std::min_element(one.model.texel_scales.begin(), one.model.texel_scales.end()));
  CHECK(one.model.texel_scales[0] / one.model.texel_scales[1] == doctest::Approx(lum[0] / lum[1]).epsilon(1e-4));

  o.clusters = 16;
  const TrainResult all = trained(btf, o);
  REQUIRE(validate(all.model));
  CHECK(all.model.latent_count() == all.clusters);
  CHECK(all.clusters <= 16);
  std::vector<std::uint32_t> ids = all.model.cluster_ids;
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  CHECK(ids.size() == all.clusters);  // every cluster used
  // Each texel is its own cluster, so its median is itself and its scale 1.
  if (all.clusters == 16)
    for (float s : all.model.texel_scales) CHECK(s == doctest::Approx(1.0f).epsilon(1e-4));

  o.clusters = 17;
  auto too_many = train_neural_btf(btf, o);
  REQUIRE_FALSE(too_many);
  CHECK(too_many.error().message.find("17 clusters for 16 texels") != std::string::npos);
}

TEST_CASE("a fixed seed gives identical weights, whatever the thread count") {
  const Btf btf = tiny_fabric();
  TrainOptions o;
  o.epochs = 3;
  o.directions_per_texel = 30;
  o.clusters = 4;
  o.threads = 1;
  const TrainResult a = trained(btf, o);
  o.threads = 2;
  const TrainResult b = trained(btf, o);
  CHECK(a.network.parameters == b.network.parameters);
  CHECK(a.model.latents == b.model.latents);
  o.seed = 2;
  const TrainResult c = trained(btf, o);
  CHECK(a.network.parameters != c.network.parameters);
  // The first schedule (blocks of one texel, encoder on one thread) too, and the two schedules
  // agree up to rounding.
  o.seed = 1;
  o.batched = false;
  o.threads = 1;
  const TrainResult d = trained(btf, o);
  o.threads = 2;
  const TrainResult e = trained(btf, o);
  CHECK(d.network.parameters == e.network.parameters);
  CHECK(d.model.latents == e.model.latents);
  double worst = 0.0;
  for (std::size_t i = 0; i < d.network.parameters.size(); ++i)
    worst = std::max(worst, double(std::abs(d.network.parameters[i] - a.network.parameters[i])));
  CHECK(worst < 1e-3);
}

TEST_CASE("Adam, a cosine schedule and early stopping: thread-independent, and the kept model is the best one measured") {
  const Btf btf = tiny_fabric();
  TrainOptions o;
  o.optimizer = Optimizer::Adam;
  o.learning_rate = 0.003f;
  o.schedule = LearningRateSchedule::Cosine;
  o.epochs = 8;
  o.batch = 4;
  o.directions_per_texel = 30;
  o.holdout_every = 5;  // pairs 2, 7, 12, ... of the 81 never train
  o.patience = 2;
  o.finetune_fraction = 0.5f;
  std::vector<double> measured, rates;
  o.progress_interval_s = 1e9;
  o.progress = [&](const TrainProgress& p) {
    if (p.validation_rmse >= 0.0) measured.push_back(p.validation_rmse);
    rates.push_back(p.learning_rate);
  };
  o.threads = 1;
  const TrainResult a = trained(btf, o);
  o.progress = {};
  o.threads = 2;
  const TrainResult b = trained(btf, o);
  CHECK(a.network.parameters == b.network.parameters);
  CHECK(a.model.latents == b.model.latents);
  CHECK(a.validation_rmse == b.validation_rmse);
  REQUIRE_FALSE(measured.empty());
  // The kept model's RMSE is the lowest measured, and is what decode() scores on the held-out pairs.
  CHECK(a.validation_rmse == doctest::Approx(*std::min_element(measured.begin(), measured.end())));
  CHECK(a.best_epoch >= 1);
  CHECK(a.best_epoch <= a.epochs_done);
  double sq = 0.0;
  std::size_t n = 0;
  for (std::size_t t = 0; t < btf.texels(); ++t)
    for (std::size_t pr = 2; pr < btf.samples_per_texel(); pr += 5) {
      const std::size_t l = pr / btf.views.size(), v = pr % btf.views.size();
      const vec3 got = decode(a.model, t, to_vector(btf.lights[l]), to_vector(btf.views[v]));
      const vec3 want = sample(btf, t, l, v);
      for (int c = 0; c < 3; ++c) sq += double(got[c] - want[c]) * double(got[c] - want[c]), ++n;
    }
  CHECK(std::sqrt(sq / double(n)) == doctest::Approx(a.validation_rmse).epsilon(1e-3));
  // The cosine schedule falls from the rate towards its floor.
  REQUIRE(rates.size() >= 2);
  CHECK(rates.back() < rates.front());
  CHECK(rates.back() >= 0.05 * 0.003 * 0.999);
}

TEST_CASE("checkpoint resume equals uninterrupted training, and a foreign checkpoint is refused") {
  const Btf btf = tiny_fabric();
  const auto file = own_temp_file("weft_test_btf_training.ckpt");
  for (const bool adam : {false, true}) {
  CAPTURE(adam);
  std::filesystem::remove(file);
  TrainOptions o;
  o.epochs = 4;
  o.batch = 3;  // 6 steps per epoch, the last one short
  o.directions_per_texel = 20;
  o.finetune_fraction = 0.5f;  // epochs 0-1 autoencoder, 2-3 latents + decoder
  o.threads = 2;
  if (adam) {  // Adam's moments, the schedule and early stopping's best model survive the checkpoint too
    o.optimizer = Optimizer::Adam;
    o.schedule = LearningRateSchedule::Cosine;
    o.holdout_every = 4;
    o.patience = 0;
  }
  const TrainResult whole = trained(btf, o);

  o.checkpoint = file;
  o.resume = true;
  o.stop_after_steps = 9;  // stops inside epoch 1 (autoencoder)
  const TrainResult first = trained(btf, o);
  CHECK(first.steps_done == 9);
  o.stop_after_steps = 5;  // crosses into fine-tuning and stops inside epoch 2
  const TrainResult second = trained(btf, o);
  CHECK(second.steps_done == 5);
  o.stop_after_steps = 0;
  const TrainResult rest = trained(btf, o);
  CHECK(rest.steps_done == 24 - 14);
  CHECK(rest.epochs_done == 4);
  CHECK(rest.network.parameters == whole.network.parameters);
  CHECK(rest.network.running_mean == whole.network.running_mean);
  CHECK(rest.model.latents == whole.model.latents);
  CHECK(rest.final_loss == whole.final_loss);
  CHECK(rest.validation_rmse == whole.validation_rmse);

  o.seed = 5;  // other options: the checkpoint does not apply
  auto foreign = train_neural_btf(btf, o);
  REQUIRE_FALSE(foreign);
  CHECK(foreign.error().message.find("belongs to other data or options") != std::string::npos);
  std::filesystem::remove(file);
  }
}

TEST_CASE("bad options are named") {
  const Btf btf = tiny_fabric();
  TrainOptions o;
  o.batch = 0;
  auto r = train_neural_btf(btf, o);
  REQUIRE_FALSE(r);
  CHECK(r.error().message.find("batch 0") != std::string::npos);
  o = {};
  o.max_gradient_norm = -1.0f;
  r = train_neural_btf(btf, o);
  REQUIRE_FALSE(r);
  CHECK(r.error().message.find("gradient clip -1") != std::string::npos);
  o = {};
  o.finetune_fraction = 1.5f;
  r = train_neural_btf(btf, o);
  REQUIRE_FALSE(r);
  CHECK(r.error().message.find("1.5") != std::string::npos);
  Btf broken = btf;
  broken.rgb[100] = -1.0f;
  r = train_neural_btf(broken, TrainOptions{});
  REQUIRE_FALSE(r);
  CHECK(r.error().message.find("training data") != std::string::npos);
}
