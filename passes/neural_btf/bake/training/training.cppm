// weft.btf.training — trains a neural BTF on the CPU (Eigen, std::thread): the paper's
// convolutional encoder (ABRDF image -> 8-D latent) and MLP decoder (latent + two
// stereographic directions -> RGB) as one autoencoder, then the plain model (one latent per
// texel) or the clustered one (one latent per cluster's median ABRDF, a cluster id and a
// luminance scale per texel). Forward and backward passes are written by hand and checked
// against finite differences in tests/neural_btf/test_btf_training.cpp. docs/neural-btf.md,
// "Training", says what is the paper's and what is ours.
module;
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <new>
#include <span>
#include <string>
#include <string_view>
#include <vector>
export module weft.btf.training;
import weft.core;
import weft.btf;
import weft.btf.model;

export namespace weft::btf {

// ---- the network ---------------------------------------------------------------------------
//
// Encoder: the preprocessed ABRDF as a 3-channel image (light rows x view columns), then
// [conv 3x3 stride 1 pad 1 -> max-pool 3 stride 3 (partial windows at the border, so any
// size works) -> batch norm] x 3 -> fully connected -> latent. No other non-linearity: the
// paper names none, the max-pools are one. Decoder: (latent, stereo(ω_i), stereo(ω_o)) ->
// hidden layers with ReLU -> RGB (linear; decode() clamps at 0).
struct NetworkShape {
  std::uint32_t lights = 81, views = 81;            // the encoder's image: rows x columns
  std::array<std::uint32_t, 3> channels{8, 16, 32};  // conv output channels per stage
  std::uint32_t latent = 8;
  std::vector<std::uint32_t> hidden{106, 106, 106};  // the paper's decoder (24,383 parameters)
};

// Storage for the numbers the training hands to Eigen: 64-byte aligned. With AVX, Eigen does a
// misaligned vector's head and tail on another code path than its middle, so with malloc's
// 16-byte alignment a result would depend on where a buffer happened to land (and so on the
// thread count, or on a checkpoint resume). tests/neural_btf/misaligned_new.cpp checks it.
template <class T>
struct SimdAllocator {
  using value_type = T;
  static constexpr std::align_val_t alignment{64};
  SimdAllocator() = default;
  template <class U>
  SimdAllocator(const SimdAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), alignment)); }
  void deallocate(T* p, std::size_t) noexcept { ::operator delete(p, alignment); }
  template <class U>
  bool operator==(const SimdAllocator<U>&) const noexcept { return true; }
};
using Floats = std::vector<float, SimdAllocator<float>>;

// Every trainable number lives in one flat vector (SGD, gradients, checkpoints and the
// gradient check treat it as one), with offsets into it; batch norm's running statistics
// (used when encoding after training) are kept apart because they are not trained.
struct Network {
  NetworkShape shape;
  Floats parameters;
  Floats running_mean, running_var;  // per batch-norm channel, stages concatenated

  // Offsets into `parameters`; filled by make_network.
  struct Conv { std::size_t weights, bias, gamma, beta; std::uint32_t in, out, rows, cols, pooled_rows, pooled_cols; };
  std::array<Conv, 3> conv{};
  std::size_t fc_weights = 0, fc_bias = 0, fc_inputs = 0;
  struct Dense { std::size_t weights, bias; std::uint32_t in, out; };
  std::vector<Dense> dense;  // the decoder's layers
  std::size_t decoder_begin = 0;  // parameters from here on are the decoder's

  [[nodiscard]] std::size_t encoder_parameters() const { return decoder_begin; }
  [[nodiscard]] std::size_t decoder_parameters() const { return parameters.size() - decoder_begin; }
};

// He-uniform weights, zero biases, batch norm γ = 1, β = 0, from `seed`. InvalidArgument for
// a zero size or channel count.
[[nodiscard]] Result<Network> make_network(const NetworkShape& shape, std::uint64_t seed);

// The decoder as the model stores it (weights copied out of the flat vector).
[[nodiscard]] Decoder decoder_of(const Network& network);

// Runs body(i) for every i in [0, count), in any order and on any threads (the trainer's
// pool); empty: inline. The encoder's items run through it; what couples them is summed in
// item order afterwards, so results do not depend on how it runs them.
using ParallelFn = std::function<void(std::size_t count, const std::function<void(std::size_t)>& body)>;

// Encoder forward pass over a batch. `inputs[b]` is one preprocessed ABRDF (lights * views * 3
// floats in Btf's layout). Training mode normalises with the batch's statistics (over batch
// and pixels) and updates the running ones (momentum 0.1); inference mode uses the running
// ones. The cache holds what backward needs.
struct EncoderCache;
struct EncoderCacheDeleter { void operator()(EncoderCache* cache) const; };
using EncoderCachePtr = std::unique_ptr<EncoderCache, EncoderCacheDeleter>;
[[nodiscard]] EncoderCachePtr make_encoder_cache();
void encode_batch(Network& network, std::span<const float* const> inputs, bool training, EncoderCache& cache,
                  std::span<float> latents, const ParallelFn& parallel = {});  // latents: batch * latent
// Sets batch norm's running statistics to the population's: each channel's mean and
// variance over every input (stage by stage, in chunks of `chunk` inputs). Training ends
// with this before the latents are encoded, so inference normalises with the statistics of
// the data rather than a momentum average of the last batches (whose inputs, in a
// clustered model's batches, repeat and make the batch variance small).
void batch_norm_population(Network& network, std::span<const float* const> inputs, std::size_t chunk = 64,
                           const ParallelFn& parallel = {});
// Adds d(loss)/d(encoder parameters) to `gradient` (parameters.size() floats) from
// d(loss)/d(latents), using the cache of the last training-mode encode_batch.
void encoder_backward(const Network& network, const EncoderCache& cache, std::span<const float> latent_gradient,
                      std::span<float> gradient, const ParallelFn& parallel = {});

// The decoder over `count` samples. `inputs` is column-major (input_size x count: each
// sample's latent, stereo(ω_i), stereo(ω_o) contiguous). Returns outputs (3 x count,
// column-major) in `outputs`.
void decoder_forward(const Network& network, std::span<const float> inputs, std::size_t count, std::span<float> outputs);
// Forward + backward for the loss Σ w (s_j · y_j − t_j)² (s_j a per-sample scale, w the
// common weight, e.g. 1 / (3 × samples)); adds d/d(decoder parameters) to `gradient` (all the
// parameters, or decoder_parameters() floats: the decoder's part alone) and
// writes d/d(inputs) to `input_gradient` (same layout as inputs) when it is not empty.
// Returns the unweighted sum of squares.
double decoder_loss_gradient(const Network& network, std::span<const float> inputs, std::span<const float> targets,
                             std::span<const float> sample_scales, std::size_t count, float weight,
                             std::span<float> gradient, std::span<float> input_gradient);

// ---- training -------------------------------------------------------------------------------

struct TrainProgress {
  std::size_t epoch = 0, epochs = 0;  // epoch in progress (0-based) and the planned total
  std::size_t step = 0, steps_per_epoch = 0;
  bool finetuning = false;            // stage 2: decoder + latents, encoder frozen
  double loss = 0.0;                  // mean squared error of the epoch so far (targets' units)
  double learning_rate = 0.0;         // this step's (the schedule's)
  double validation_rmse = -1.0;      // the last held-out RMSE (the data's units); < 0: none yet
  double elapsed_s = 0.0, eta_s = 0.0, fraction = 0.0;
};
using ProgressFn = std::function<void(const TrainProgress&)>;

// The paper trains with plain SGD; Adam (Kingma & Ba) is what the field uses now.
enum class Optimizer : std::uint8_t { Sgd, Adam };
// Constant: the learning rate throughout (the paper's). Cosine: lr * (f + (1 - f) (1 + cos(π p)) / 2)
// with p the fraction of the planned training done (epochs, or the time budget) and f the floor.
enum class LearningRateSchedule : std::uint8_t { Constant, Cosine };
[[nodiscard]] std::string_view to_string(Optimizer optimizer);
[[nodiscard]] std::string_view to_string(LearningRateSchedule schedule);

struct TrainOptions {
  // 0: the plain neural BTF (a latent per texel). k > 0: PCA + k-means++ (weft::btf::cluster_abrdfs)
  // and a latent per cluster, from the cluster's median ABRDF.
  std::uint32_t clusters = 0;
  std::uint32_t pca_components = 16;
  bool texel_scales = true;           // clustered: the per-texel luminance scale (the paper's fix)
  NetworkShape network{};             // lights / views are taken from the BTF
  Optimizer optimizer = Optimizer::Sgd;
  // 0: the paper's for SGD (0.05 plain, 0.08 clustered); 0.001 for Adam.
  float learning_rate = 0.0f;
  float adam_beta1 = 0.9f, adam_beta2 = 0.999f, adam_epsilon = 1e-8f;
  LearningRateSchedule schedule = LearningRateSchedule::Constant;
  float schedule_floor = 0.05f;       // cosine: the last step's rate as a fraction of learning_rate
  std::uint32_t batch = 5;            // texels per step (each with its directions); the paper's 5
  // Light/view pairs per texel in a step, drawn without replacement; 0: all of them (the
  // paper's loss over the whole ABRDF).
  std::uint32_t directions_per_texel = 0;
  std::uint32_t epochs = 10;          // an epoch visits every texel once, in a seeded shuffle
  // Early stopping on held-out directions: every holdout_every-th light/view pair (l * views + v
  // ≡ holdout_every / 2 mod holdout_every) is never trained on; at each epoch end the model's RMSE
  // on those pairs of up to validation_texels texels (a seeded draw) is measured, and the best
  // model so far is kept. After `patience` epochs without a better one, the autoencoder stage
  // ends (the best weights restored; fine-tuning starts) or, fine-tuning, training ends. The
  // result is the best model seen. 0: no held-out pairs (every pair trains), no early stopping.
  std::uint32_t holdout_every = 0;
  std::uint32_t patience = 3;         // with holdout_every; 0: keep the best, never stop early
  std::uint32_t validation_texels = 512;
  // Ours, not the paper's: a step whose gradient (parameters and latents together) is longer
  // than this is scaled down to it. Batch norm over a batch of near-equal inputs divides by
  // a tiny deviation, and one such step can throw SGD off; the clip keeps it finite. 0: off.
  float max_gradient_norm = 1.0f;
  double max_seconds = 0.0;           // a time budget (0: none); training stops at the next step
  // The last fraction of the epochs (or of the time budget) trains the decoder and the
  // stored latents directly, the encoder frozen: the latents become free parameters (the
  // issue's "fine-tuned cluster latents"). 0: stop after the autoencoder.
  float finetune_fraction = 0.25f;
  std::uint64_t seed = 1;
  std::size_t threads = 0;            // 0: all cores; results do not depend on it
  // How a step uses the threads. true: the step's samples go through the decoder as one
  // matrix product per layer cut into fixed 256-sample blocks (across texels), the encoder's
  // batch items run in parallel, on a pool of threads kept for the whole training. false:
  // the first implementation's schedule (blocks of at most 512 samples of one texel, the
  // encoder on one thread, threads started per step), kept as the benchmark's baseline. The
  // two round differently; each is deterministic whatever the thread count.
  bool batched = true;
  std::filesystem::path checkpoint;   // empty: none. Written at epoch ends and when stopping.
  std::uint32_t checkpoint_every = 1; // epochs
  bool resume = false;                // continue from `checkpoint` when it exists
  // Run at most this many steps now, then checkpoint and return the model so far (0: no
  // limit): splits a long training over sessions; resuming continues exactly.
  std::size_t stop_after_steps = 0;
  ProgressFn progress;                // called about every progress_interval_s and at epoch ends
  double progress_interval_s = 5.0;
};

struct TrainResult {
  NeuralBtf model;
  Network network;
  Preprocessing preprocessing;        // what the encoder's inputs were standardised with
  std::size_t epochs_done = 0, steps_done = 0;
  std::size_t samples_done = 0;       // decoder samples (texel, light, view) of this run's steps
  double final_loss = 0.0;            // the last (or the unfinished) epoch's mean squared error (targets' units)
  double seconds = 0.0;               // this run's training time (clustering excluded)
  double step_seconds = 0.0;          // of which in steps (no final encoding, no validation)
  double cluster_seconds = 0.0;
  std::uint32_t clusters = 0;         // clusters actually used (k-means drops empty ones)
  // With holdout_every: the kept model's held-out RMSE (the data's units), the epoch it was
  // measured at (1-based), and whether patience ended the training.
  double validation_rmse = -1.0;
  std::size_t best_epoch = 0;
  bool stopped_early = false;
};

// Trains on `btf` (validated first). InvalidArgument for a bad option (named, with its
// value), an invalid BTF, or a checkpoint that belongs to other data or options.
[[nodiscard]] Result<TrainResult> train_neural_btf(const Btf& btf, const TrainOptions& options);

// ---- evaluation ------------------------------------------------------------------------------

// RMSE of the model's decode() against the BTF's samples (the model must have its texel
// grid), over every light/view pair, or only over those with `pairs[l * views + v]` true.
// Batched (Eigen) and multi-threaded; equal to weft::btf::rmse with decode() up to rounding.
[[nodiscard]] Result<double> model_rmse(const NeuralBtf& model, const Btf& btf, std::span<const bool> pairs = {},
                                        std::size_t threads = 0);

// "12 min 5 s", "3.2 s": for progress lines.
[[nodiscard]] std::string describe_seconds(double seconds);

// The SIMD width the training was compiled for ("baseline", "avx2" or "avx512": CMake's
// WEFT_TRAINING_SIMD). Eigen sums in another order at each, so a bake's bytes depend on it.
[[nodiscard]] std::string_view training_simd_width();

}  // namespace weft::btf

// Shared by the implementation files (train.cpp, checkpoint.cpp); exported only so that
// tests and the checkpoint fuzzer (tests/fuzz) reach the reader. Not API.
export namespace weft::btf::training_detail {
// Where a training run stands; what a checkpoint stores besides a fingerprint of the data
// and the options.
struct TrainState {
  std::uint64_t fingerprint = 0;
  std::size_t epoch = 0, step = 0;   // the next step to run
  bool finetuning = false;
  double elapsed_s = 0.0;            // training time of earlier runs
  double epoch_loss = 0.0, epoch_count = 0.0;
  double last_epoch_loss = 0.0;
  Floats parameters, running_mean, running_var, latents;
  // Adam: the step count and the moments of the parameters and (fine-tuning) the latents.
  std::uint64_t adam_steps = 0;
  Floats moment1, moment2, latent_moment1, latent_moment2;
  // Early stopping: the best held-out RMSE so far, its epoch, epochs since, and that model.
  double best_rmse = -1.0, last_rmse = -1.0;
  std::uint64_t best_epoch = 0, stale = 0;
  bool best_finetuning = false;
  Floats best_parameters, best_running_mean, best_running_var, best_latents;
};
Result<void> save_checkpoint(const std::filesystem::path& file, const TrainState& state);
Result<TrainState> load_checkpoint(const std::filesystem::path& file);
}  // namespace weft::btf::training_detail
