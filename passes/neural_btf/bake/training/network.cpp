// The encoder and decoder, forward and backward by hand. Convolutions run directly on
// zero-padded planes (one multiply-add pass per tap; no im2col matrix), with sums in a fixed
// order whatever the buffers' alignment; the fully connected layers and the decoder are Eigen
// matrix products. Batch norm normalises over the batch and the pixels of each channel (the
// standard convolutional batch norm), so its backward pass couples the batch.
module;
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <expected>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <span>
#include <vector>
#include <Eigen/Dense>
module weft.btf.training;

namespace weft::btf {
namespace {

using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using ColMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor>;
using RowMap = Eigen::Map<RowMatrix>;
using ConstRowMap = Eigen::Map<const RowMatrix>;
using ColMap = Eigen::Map<ColMatrix>;
using ConstColMap = Eigen::Map<const ColMatrix>;
using VectorMap = Eigen::Map<Eigen::VectorXf>;
using ConstVectorMap = Eigen::Map<const Eigen::VectorXf>;

constexpr float kBatchNormEpsilon = 1e-5f;
constexpr float kBatchNormMomentum = 0.1f;

std::uint32_t pooled(std::uint32_t n) { return (n + 2) / 3; }  // max-pool 3 stride 3, partial windows kept

// A stage's input as the convolution reads it: each channel a plane of (rows + 2) x (cols + 2)
// with a border of zeros (the 3x3 kernel's padding of 1). The convolution's output keeps the
// padded row length: output pixel (y, x) sits at y * width + x, and the two columns past cols in
// each row are spare. The kernels below work in whole strips of outputs, so every plane has
// zeros to spare up to a whole number of strips (`strips`: the outputs a kernel computes).
constexpr std::size_t kStrip = 128;  // outputs per register-blocked strip (8 x 16 lanes)
struct Planes {
  std::size_t width, span, strips, size;  // padded row length; outputs; outputs rounded up to strips; floats per input plane
};
Planes planes_of(const Network::Conv& c) {
  const std::size_t width = std::size_t(c.cols) + 2, span = std::size_t(c.rows) * width;
  const std::size_t strips = (span + kStrip - 1) / kStrip * kStrip;
  return {width, span, strips, 2 * width + 2 + strips};
}
std::size_t tap_offset(const Planes& p, std::size_t tap) { return (tap / 3) * p.width + tap % 3; }

// The convolution's kernels below keep their partial sums in fixed lanes (kLanes per
// accumulator) and add them up in a fixed order, so the order follows from the code alone, not
// from where a buffer lies or how many lanes a vector has; a strip of lanes stays in registers
// across all the taps. (Builds with FMA fuse each multiply-add, so their last bits differ from
// a baseline build's, as Eigen's do.)
constexpr std::size_t kLanes = 16;
static_assert(kStrip % kLanes == 0);

inline float madd(float a, float b, float c) {
#ifdef __FMA__
  return std::fma(a, b, c);
#else
  return a * b + c;
#endif
}

float reduce_lanes(float* acc) {  // pairwise over kLanes partial sums
  for (std::size_t w = kLanes / 2; w > 0; w /= 2)
    for (std::size_t l = 0; l < w; ++l) acc[l] += acc[l + w];
  return acc[0];
}

// The kernels below run over `strips` outputs: Planes::strips, a whole number of kStrip (and so
// of kLanes), which every plane and gradient buffer is padded to. No tails.

float sum(const float* __restrict a, std::size_t strips) {
  float acc[kLanes] = {};
  for (std::size_t i = 0; i < strips; i += kLanes)
    for (std::size_t l = 0; l < kLanes; ++l) acc[l] += a[i + l];
  return reduce_lanes(acc);
}

// out[q] = start + Σ_t w[t] · src[t][q] over `taps` shifted planes, t in order: one fused
// multiply-add chain per output. (Sharing each source strip between several outputs spilled
// the accumulators and ran slower.)
void weighted_taps(const float* const* src, const float* w, std::size_t taps, float start, std::size_t strips,
                   float* __restrict out) {
  for (std::size_t q = 0; q < strips; q += kStrip) {
    float acc[kStrip];
    std::fill_n(acc, kStrip, start);
    for (std::size_t t = 0; t < taps; ++t) {
      const float wt = w[t];
      const float* __restrict s = src[t] + q;
      for (std::size_t l = 0; l < kStrip; ++l) acc[l] = madd(wt, s[l], acc[l]);
    }
    std::copy_n(acc, kStrip, out + q);
  }
}

// z[co] = bias[co] + Σ_{ci, tap} w[co][ci * 9 + tap] · (input plane ci shifted by the tap).
void conv_forward(const float* weights, const float* bias, const float* input, const Network::Conv& c, float* z) {
  const Planes p = planes_of(c);
  std::vector<const float*> src(std::size_t(c.in) * 9);
  for (std::uint32_t ci = 0; ci < c.in; ++ci)
    for (std::size_t tap = 0; tap < 9; ++tap) src[ci * 9 + tap] = input + ci * p.size + tap_offset(p, tap);
  for (std::uint32_t co = 0; co < c.out; ++co)
    weighted_taps(src.data(), weights + std::size_t(co) * c.in * 9, src.size(), bias[co], p.strips, z + co * p.strips);
}

// Max-pool 3 stride 3 of one channel's convolution output (padded rows), keeping each window's
// winner: first down the window's rows per column (vectorised; a column's first row wins ties),
// then across its columns (the first column wins). Windows at the border are partial.
void max_pool(const float* z, const Network::Conv& c, const Planes& p, float* out, std::uint32_t* argmax) {
  std::vector<float> best(c.cols);
  std::vector<std::uint32_t> row(c.cols);
  for (std::uint32_t py = 0; py < c.pooled_rows; ++py) {
    const std::uint32_t y0 = py * 3, y1 = std::min(y0 + 3, c.rows);
    std::copy_n(z + y0 * p.width, c.cols, best.data());
    std::fill(row.begin(), row.end(), y0);
    for (std::uint32_t y = y0 + 1; y < y1; ++y) {
      const float* zr = z + y * p.width;
      for (std::uint32_t x = 0; x < c.cols; ++x) {
        const bool more = zr[x] > best[x];
        best[x] = more ? zr[x] : best[x];
        row[x] = more ? y : row[x];
      }
    }
    for (std::uint32_t px = 0; px < c.pooled_cols; ++px) {
      const std::uint32_t x0 = px * 3, x1 = std::min(x0 + 3, c.cols);
      std::uint32_t wx = x0;
      float top = best[x0];
      for (std::uint32_t x = x0 + 1; x < x1; ++x) {  // selects, not branches: the data is noise to a predictor
        const bool more = best[x] > top;
        top = more ? best[x] : top;
        wx = more ? x : wx;
      }
      out[py * c.pooled_cols + px] = top;
      argmax[py * c.pooled_cols + px] = std::uint32_t(row[wx] * p.width + wx);
    }
  }
}

// dw[tap] = Σ_q dz[q] · (plane shifted by the tap)[q] for the 9 taps at once: each lane sums
// its q in order, then the lanes pairwise.
void tap_dots(const float* __restrict dz, const float* plane, const Planes& p, float* dw) {
  float acc[9][kLanes] = {};
  const float* s[9];
  for (std::size_t tap = 0; tap < 9; ++tap) s[tap] = plane + tap_offset(p, tap);
  for (std::size_t q = 0; q < p.strips; q += kLanes)
    for (std::size_t tap = 0; tap < 9; ++tap)
      for (std::size_t l = 0; l < kLanes; ++l) acc[tap][l] = madd(dz[q + l], s[tap][q + l], acc[tap][l]);
  for (std::size_t tap = 0; tap < 9; ++tap) dw[tap] = reduce_lanes(acc[tap]);
}

}  // namespace

// What backward needs from one training-mode forward pass, per stage and per batch item.
struct EncoderCache {
  std::size_t batch = 0;
  struct Stage {
    std::vector<Floats> input;                        // per item: the padded input planes (Planes)
    std::vector<std::vector<std::uint32_t>> argmax;   // per item: pooled index -> conv output index (padded rows)
    std::vector<RowMatrix> xhat;                      // per item: normalised pooled (C x P)
    Floats inv_std;                       // per channel
  };
  std::array<Stage, 3> stages;
  std::vector<Eigen::VectorXf> flat;  // per item: the fully connected layer's input
  // Per item, reused from step to step: allocating these each time (hundreds of KiB) cost more
  // in page faults and zeroing than the arithmetic on them.
  // Buffers whose zeros matter (the planes' borders, dz between the winners) are zeroed once
  // when allocated and kept so: only their interiors, or the winners, are written and reset.
  mutable std::vector<Floats> conv_out, dx;
  mutable std::array<std::vector<Floats>, 3> dz;  // per stage, per item
};

void EncoderCacheDeleter::operator()(EncoderCache* cache) const { delete cache; }
EncoderCachePtr make_encoder_cache() { return EncoderCachePtr(new EncoderCache()); }

Result<Network> make_network(const NetworkShape& shape, std::uint64_t seed) {
  if (shape.lights == 0 || shape.views == 0)
    return fail(ErrorKind::InvalidArgument, "network for {} lights x {} views (both must be at least 1)", shape.lights,
                shape.views);
  for (std::size_t i = 0; i < 3; ++i)
    if (shape.channels[i] == 0) return fail(ErrorKind::InvalidArgument, "encoder stage {} has 0 channels", i + 1);
  if (shape.latent == 0) return fail(ErrorKind::InvalidArgument, "latent size 0");
  for (std::size_t i = 0; i < shape.hidden.size(); ++i)
    if (shape.hidden[i] == 0) return fail(ErrorKind::InvalidArgument, "decoder hidden layer {} has 0 units", i + 1);

  Network n;
  n.shape = shape;
  std::size_t offset = 0;
  auto take = [&offset](std::size_t count) {
    const std::size_t at = offset;
    offset += count;
    return at;
  };
  std::uint32_t in = 3, rows = shape.lights, cols = shape.views;
  for (std::size_t s = 0; s < 3; ++s) {
    auto& c = n.conv[s];
    c.in = in;
    c.out = shape.channels[s];
    c.rows = rows;
    c.cols = cols;
    c.pooled_rows = pooled(rows);
    c.pooled_cols = pooled(cols);
    c.weights = take(std::size_t(c.out) * c.in * 9);
    c.bias = take(c.out);
    c.gamma = take(c.out);
    c.beta = take(c.out);
    in = c.out;
    rows = c.pooled_rows;
    cols = c.pooled_cols;
  }
  n.fc_inputs = std::size_t(in) * rows * cols;
  n.fc_weights = take(std::size_t(shape.latent) * n.fc_inputs);
  n.fc_bias = take(shape.latent);
  n.decoder_begin = offset;
  std::uint32_t width = shape.latent + 4;
  std::vector<std::uint32_t> outs = shape.hidden;
  outs.push_back(3);
  for (std::uint32_t out : outs) {
    Network::Dense d{};
    d.in = width;
    d.out = out;
    d.weights = take(std::size_t(out) * width);
    d.bias = take(out);
    n.dense.push_back(d);
    width = out;
  }
  n.parameters.assign(offset, 0.0f);

  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  auto he = [&](std::size_t at, std::size_t count, std::size_t fan_in) {
    const float limit = std::sqrt(6.0f / float(fan_in));  // He-uniform: unit-variance activations
    for (std::size_t i = 0; i < count; ++i) n.parameters[at + i] = unit(rng) * limit;
  };
  for (const auto& c : n.conv) {
    he(c.weights, std::size_t(c.out) * c.in * 9, std::size_t(c.in) * 9);
    std::fill_n(n.parameters.begin() + std::ptrdiff_t(c.gamma), c.out, 1.0f);
  }
  // The latent layer is linear: Glorot-like scale keeps latents O(1) at the start.
  he(n.fc_weights, std::size_t(shape.latent) * n.fc_inputs, n.fc_inputs * 2);
  for (const auto& d : n.dense) he(d.weights, std::size_t(d.out) * d.in, d.in);
  std::size_t bn_channels = 0;
  for (const auto& c : n.conv) bn_channels += c.out;
  n.running_mean.assign(bn_channels, 0.0f);
  n.running_var.assign(bn_channels, 1.0f);
  return n;
}

Decoder decoder_of(const Network& network) {
  Decoder decoder;
  for (const auto& d : network.dense) {
    DenseLayer layer{d.in, d.out, {}, {}};
    const auto w = network.parameters.begin() + std::ptrdiff_t(d.weights);
    layer.weights.assign(w, w + std::ptrdiff_t(std::size_t(d.in) * d.out));
    const auto b = network.parameters.begin() + std::ptrdiff_t(d.bias);
    layer.bias.assign(b, b + d.out);
    decoder.layers.push_back(std::move(layer));
  }
  return decoder;
}

namespace {
// Runs body(i) for i in [0, count): on the caller's pool, or inline.
void each(const ParallelFn& parallel, std::size_t count, const std::function<void(std::size_t)>& body) {
  if (parallel && count > 1) {
    parallel(count, body);
  } else {
    for (std::size_t i = 0; i < count; ++i) body(i);
  }
}

// The encoder's stages over a batch. With `stop` < 3, returns after stage `stop`'s conv and
// max-pool with its pre-batch-norm output in `pre_norm` (for batch_norm_population);
// otherwise runs through the fully connected layer into `latents`. Batch items run in
// parallel; what couples them (batch norm's sums) is summed per item, then over items in
// order, so the result does not depend on the thread count.
void run_encoder(Network& network, std::span<const float* const> inputs, bool training, EncoderCache& cache,
                 std::span<float> latents, std::size_t stop, std::vector<RowMatrix>* pre_norm, const ParallelFn& parallel) {
  const std::size_t batch = inputs.size();
  const auto& shape = network.shape;
  const float* p = network.parameters.data();
  cache.batch = batch;
  if (cache.conv_out.size() < batch) cache.conv_out.resize(batch);
  for (auto& st : cache.stages)
    if (st.input.size() < batch) st.input.resize(batch), st.argmax.resize(batch), st.xhat.resize(batch);
  // Stage 1's input: the ABRDF's channels as zero-padded planes.
  each(parallel, batch, [&](std::size_t b) {
    const Planes pl = planes_of(network.conv[0]);
    Floats& in = cache.stages[0].input[b];
    if (in.size() != 3 * pl.size) in.assign(3 * pl.size, 0.0f);  // the interior is overwritten below
    const float* from = inputs[b];
    for (std::size_t l = 0; l < shape.lights; ++l) {
      float* to = in.data() + (l + 1) * pl.width + 1;
      for (std::size_t v = 0; v < shape.views; ++v, from += 3)
        for (std::size_t c = 0; c < 3; ++c) to[c * pl.size + v] = from[c];
    }
  });
  std::size_t bn_offset = 0;
  cache.flat.resize(batch);
  for (std::size_t s = 0; s < 3; ++s) {
    const auto& conv = network.conv[s];
    auto& st = cache.stages[s];
    const Planes pl = planes_of(conv);
    const std::size_t out_pixels = std::size_t(conv.pooled_rows) * conv.pooled_cols;
    std::vector<RowMatrix> pooled_out(batch);
    // Per item and channel: the sum, then the squared deviations about the batch mean.
    std::vector<double> sums(batch * conv.out, 0.0), squares(batch * conv.out, 0.0);
    each(parallel, batch, [&](std::size_t b) {
      Floats& z = cache.conv_out[b];
      z.resize(std::size_t(conv.out) * pl.strips);
      conv_forward(p + conv.weights, p + conv.bias, st.input[b].data(), conv, z.data());
      RowMatrix& out = pooled_out[b];
      out.resize(conv.out, Eigen::Index(out_pixels));
      st.argmax[b].resize(std::size_t(conv.out) * out_pixels);
      for (std::uint32_t c = 0; c < conv.out; ++c)
        max_pool(z.data() + c * pl.strips, conv, pl, out.row(c).data(), st.argmax[b].data() + std::size_t(c) * out_pixels);
      for (std::uint32_t c = 0; c < conv.out; ++c) sums[b * conv.out + c] = double(out.row(c).sum());
    });
    if (s == stop) {
      *pre_norm = std::move(pooled_out);
      return;
    }
    // Batch norm per channel over (batch, pixels).
    st.inv_std.assign(conv.out, 0.0f);
    const double count = double(batch * out_pixels);
    Floats mean(conv.out), var(conv.out);
    for (std::uint32_t c = 0; c < conv.out; ++c) {
      mean[c] = network.running_mean[bn_offset + c], var[c] = network.running_var[bn_offset + c];
      if (training) {
        double total = 0.0;
        for (std::size_t b = 0; b < batch; ++b) total += sums[b * conv.out + c];
        mean[c] = float(total / count);
      }
    }
    if (training) {
      each(parallel, batch, [&](std::size_t b) {
        for (std::uint32_t c = 0; c < conv.out; ++c)
          squares[b * conv.out + c] = double((pooled_out[b].row(c).array() - mean[c]).square().sum());
      });
      for (std::uint32_t c = 0; c < conv.out; ++c) {
        double sq = 0.0;
        for (std::size_t b = 0; b < batch; ++b) sq += squares[b * conv.out + c];
        var[c] = float(sq / count);
        network.running_mean[bn_offset + c] =
            (1.0f - kBatchNormMomentum) * network.running_mean[bn_offset + c] + kBatchNormMomentum * mean[c];
        network.running_var[bn_offset + c] =
            (1.0f - kBatchNormMomentum) * network.running_var[bn_offset + c] + kBatchNormMomentum * var[c];
      }
    }
    for (std::uint32_t c = 0; c < conv.out; ++c) st.inv_std[c] = 1.0f / std::sqrt(var[c] + kBatchNormEpsilon);
    each(parallel, batch, [&](std::size_t b) {
      st.xhat[b].resize(conv.out, Eigen::Index(out_pixels));
      for (std::uint32_t c = 0; c < conv.out; ++c) {
        const float gamma = p[conv.gamma + c], beta = p[conv.beta + c];
        st.xhat[b].row(c) = (pooled_out[b].row(c).array() - mean[c]) * st.inv_std[c];
        pooled_out[b].row(c) = st.xhat[b].row(c).array() * gamma + beta;
      }
      if (s + 1 < 3) {  // the next stage's padded planes
        const Planes next = planes_of(network.conv[s + 1]);
        Floats& in = cache.stages[s + 1].input[b];
        if (in.size() != std::size_t(conv.out) * next.size) in.assign(std::size_t(conv.out) * next.size, 0.0f);
        for (std::uint32_t c = 0; c < conv.out; ++c)
          for (std::uint32_t y = 0; y < conv.pooled_rows; ++y)
            std::copy_n(pooled_out[b].row(c).data() + std::size_t(y) * conv.pooled_cols, conv.pooled_cols,
                        in.data() + c * next.size + (y + 1) * next.width + 1);
      } else {
        cache.flat[b] = Eigen::Map<const Eigen::VectorXf>(pooled_out[b].data(), pooled_out[b].size());  // row-major = CHW
      }
    });
    bn_offset += conv.out;
  }
  const ConstRowMap fc(p + network.fc_weights, shape.latent, Eigen::Index(network.fc_inputs));
  const ConstVectorMap fc_bias(p + network.fc_bias, shape.latent);
  for (std::size_t b = 0; b < batch; ++b)
    VectorMap(latents.data() + b * shape.latent, shape.latent) = fc * cache.flat[b] + fc_bias;
}

void encode_stages(Network& network, std::span<const float* const> inputs, std::size_t stage, EncoderCache& cache,
                   std::vector<RowMatrix>& pre_norm, const ParallelFn& parallel) {
  run_encoder(network, inputs, false, cache, {}, stage, &pre_norm, parallel);
}
}  // namespace

void encode_batch(Network& network, std::span<const float* const> inputs, bool training, EncoderCache& cache,
                  std::span<float> latents, const ParallelFn& parallel) {
  run_encoder(network, inputs, training, cache, latents, 3, nullptr, parallel);
}

void batch_norm_population(Network& network, std::span<const float* const> inputs, std::size_t chunk,
                           const ParallelFn& parallel) {
  if (inputs.empty()) return;
  chunk = std::max<std::size_t>(1, chunk);
  std::size_t bn_offset = 0;
  auto cache = make_encoder_cache();
  for (std::size_t s = 0; s < 3; ++s) {
    const auto& conv = network.conv[s];
    // One pass over the data: each chunk's mean and squared deviations about it (exact,
    // two-pass within the chunk), merged into the running totals by Chan et al.'s update, so
    // the variance of large, nearly constant activations is not lost as in E[x²] − E[x]².
    std::vector<double> mean(conv.out, 0.0), m2(conv.out, 0.0);
    double count = 0.0;
    const double per_input = double(conv.pooled_rows) * double(conv.pooled_cols);
    for (std::size_t i = 0; i < inputs.size(); i += chunk) {
      const std::size_t n = std::min(chunk, inputs.size() - i);
      std::vector<RowMatrix> pooled_out;
      encode_stages(network, inputs.subspan(i, n), s, *cache, pooled_out, parallel);
      const double chunk_count = double(n) * per_input, total = count + chunk_count;
      for (std::uint32_t c = 0; c < conv.out; ++c) {
        double sum = 0.0;
        for (const auto& m : pooled_out) sum += double(m.row(c).sum());
        const double chunk_mean = sum / chunk_count;
        double chunk_m2 = 0.0;
        for (const auto& m : pooled_out) chunk_m2 += double((m.row(c).array() - float(chunk_mean)).square().sum());
        const double delta = chunk_mean - mean[c];
        mean[c] += delta * chunk_count / total;
        m2[c] += chunk_m2 + delta * delta * count * chunk_count / total;
      }
      count = total;
    }
    for (std::uint32_t c = 0; c < conv.out; ++c) {
      network.running_mean[bn_offset + c] = float(mean[c]);
      network.running_var[bn_offset + c] = float(m2[c] / count);
    }
    bn_offset += conv.out;
  }
}

void encoder_backward(const Network& network, const EncoderCache& cache, std::span<const float> latent_gradient,
                      std::span<float> gradient, const ParallelFn& parallel) {
  const std::size_t batch = cache.batch;
  const auto& shape = network.shape;
  const float* p = network.parameters.data();
  float* g = gradient.data();
  const ConstRowMap fc(p + network.fc_weights, shape.latent, Eigen::Index(network.fc_inputs));
  RowMap dfc(g + network.fc_weights, shape.latent, Eigen::Index(network.fc_inputs));
  VectorMap dfc_bias(g + network.fc_bias, shape.latent);
  // dy: gradient w.r.t. each stage's output (after batch norm), per item, C x P row-major.
  std::vector<RowMatrix> dy(batch);
  const auto& last = network.conv[2];
  for (std::size_t b = 0; b < batch; ++b) {
    const ConstVectorMap dl(latent_gradient.data() + b * shape.latent, shape.latent);
    dfc.noalias() += dl * cache.flat[b].transpose();
    dfc_bias += dl;
    Eigen::VectorXf df = fc.transpose() * dl;
    dy[b] = Eigen::Map<RowMatrix>(df.data(), last.out, Eigen::Index(last.pooled_rows) * last.pooled_cols);
  }
  // Per item: its share of each stage's weight and bias gradients, summed over items in order.
  if (cache.dx.size() < batch) cache.dx.resize(batch);
  for (auto& per_item : cache.dz)
    if (per_item.size() < batch) per_item.resize(batch);
  std::vector<RowMatrix> item_dweights(batch);
  std::vector<Eigen::VectorXf> item_dbias(batch);
  for (int s = 2; s >= 0; --s) {
    const auto& conv = network.conv[std::size_t(s)];
    const auto& st = cache.stages[std::size_t(s)];
    const Planes pl = planes_of(conv);
    const std::size_t out_pixels = std::size_t(conv.pooled_rows) * conv.pooled_cols;
    const double count = double(batch * out_pixels);
    // Batch norm backward: dx = γ/σ (dy − mean(dy) − x̂ mean(dy x̂)), means over (batch, pixels).
    std::vector<double> item_dy(batch * conv.out), item_dy_xhat(batch * conv.out);
    each(parallel, batch, [&](std::size_t b) {
      for (std::uint32_t c = 0; c < conv.out; ++c) {
        item_dy[b * conv.out + c] = double(dy[b].row(c).sum());
        item_dy_xhat[b * conv.out + c] = double((dy[b].row(c).array() * st.xhat[b].row(c).array()).sum());
      }
    });
    Floats mean_dy(conv.out), mean_dy_xhat(conv.out), k(conv.out);
    for (std::uint32_t c = 0; c < conv.out; ++c) {
      double sum_dy = 0.0, sum_dy_xhat = 0.0;
      for (std::size_t b = 0; b < batch; ++b) {
        sum_dy += item_dy[b * conv.out + c];
        sum_dy_xhat += item_dy_xhat[b * conv.out + c];
      }
      g[conv.gamma + c] += float(sum_dy_xhat);
      g[conv.beta + c] += float(sum_dy);
      k[c] = p[conv.gamma + c] * st.inv_std[c];
      mean_dy[c] = float(sum_dy / count), mean_dy_xhat[c] = float(sum_dy_xhat / count);
    }
    // dz per output channel, with zeros around it for the input gradient's shifted reads.
    const std::size_t dz_guard = 2 * pl.width + 2, dz_stride = pl.strips + 3 * pl.width + 2;
    // The weights by input channel: [ci][co * 9 + tap], the order the input gradient sums in.
    Floats weights_by_input(std::size_t(conv.in) * conv.out * 9);
    for (std::uint32_t co = 0; co < conv.out; ++co)
      for (std::uint32_t ci = 0; ci < conv.in; ++ci)
        for (std::size_t tap = 0; tap < 9; ++tap)
          weights_by_input[(std::size_t(ci) * conv.out + co) * 9 + tap] = p[conv.weights + (std::size_t(co) * conv.in + ci) * 9 + tap];
    RowMap dweights(g + conv.weights, conv.out, Eigen::Index(conv.in) * 9);
    VectorMap dbias(g + conv.bias, conv.out);
    each(parallel, batch, [&](std::size_t b) {
      for (std::uint32_t c = 0; c < conv.out; ++c)
        dy[b].row(c) = k[c] * (dy[b].row(c).array() - mean_dy[c] - st.xhat[b].row(c).array() * mean_dy_xhat[c]);
      // Max-pool backward: each pooled gradient goes to the output pixel that won (padded rows;
      // the spare columns stay 0).
      Floats& dz = cache.dz[std::size_t(s)][b];  // all zeros here (reset at the end)
      if (dz.size() != std::size_t(conv.out) * dz_stride) dz.assign(std::size_t(conv.out) * dz_stride, 0.0f);
      for (std::uint32_t c = 0; c < conv.out; ++c)
        for (std::size_t q = 0; q < out_pixels; ++q)
          dz[c * dz_stride + dz_guard + st.argmax[b][c * out_pixels + q]] += dy[b](c, Eigen::Index(q));
      // Weights: dW[co][ci, tap] = Σ dz[co] · (input ci shifted by the tap); bias: Σ dz[co].
      RowMatrix& dw = item_dweights[b];
      dw.resize(conv.out, Eigen::Index(conv.in) * 9);
      item_dbias[b].resize(conv.out);
      const float* input = st.input[b].data();
      for (std::uint32_t co = 0; co < conv.out; ++co)
        item_dbias[b][co] = sum(dz.data() + co * dz_stride + dz_guard, pl.strips);  // zeros past span
      for (std::uint32_t co = 0; co < conv.out; ++co)
        for (std::uint32_t ci = 0; ci < conv.in; ++ci)
          tap_dots(dz.data() + co * dz_stride + dz_guard, input + ci * pl.size, pl, &dw(co, Eigen::Index(ci * 9)));
      if (s > 0) {
        // The input's gradient at padded rows 1..rows: dx[ci][q] = Σ_{co, tap} w · dz[co][q − tap],
        // gathered (dz has zeros around it); the border columns are the padding's, dropped, and
        // the rest is the previous stage's output gradient.
        Floats& dx = cache.dx[b];
        dx.resize(std::size_t(conv.in) * pl.strips);
        std::vector<const float*> src(std::size_t(conv.out) * 9);
        for (std::uint32_t co = 0; co < conv.out; ++co)
          for (std::size_t tap = 0; tap < 9; ++tap)
            src[co * 9 + tap] = dz.data() + co * dz_stride + dz_guard + pl.width - tap_offset(pl, tap);
        for (std::uint32_t ci = 0; ci < conv.in; ++ci)
          weighted_taps(src.data(), weights_by_input.data() + std::size_t(ci) * conv.out * 9, src.size(), 0.0f, pl.strips,
                        dx.data() + ci * pl.strips);
        dy[b].resize(conv.in, Eigen::Index(std::size_t(conv.rows) * conv.cols));
        for (std::uint32_t ci = 0; ci < conv.in; ++ci)
          for (std::uint32_t y = 0; y < conv.rows; ++y)
            std::copy_n(dx.data() + ci * pl.strips + std::size_t(y) * pl.width + 1, conv.cols,
                        dy[b].row(ci).data() + std::size_t(y) * conv.cols);
      }
      for (std::uint32_t c = 0; c < conv.out; ++c)  // back to all zeros for the next step
        for (std::size_t q = 0; q < out_pixels; ++q) dz[c * dz_stride + dz_guard + st.argmax[b][c * out_pixels + q]] = 0.0f;
    });
    for (std::size_t b = 0; b < batch; ++b) {
      dweights += item_dweights[b];
      dbias += item_dbias[b];
    }
  }
}

void decoder_forward(const Network& network, std::span<const float> inputs, std::size_t count, std::span<float> outputs) {
  const float* p = network.parameters.data();
  ColMatrix a = ConstColMap(inputs.data(), network.dense.front().in, Eigen::Index(count));
  for (std::size_t l = 0; l < network.dense.size(); ++l) {
    const auto& d = network.dense[l];
    ColMatrix z = ConstRowMap(p + d.weights, d.out, d.in) * a;
    z.colwise() += ConstVectorMap(p + d.bias, d.out);
    if (l + 1 < network.dense.size()) z = z.cwiseMax(0.0f);
    a = std::move(z);
  }
  ColMap(outputs.data(), 3, Eigen::Index(count)) = a;
}

double decoder_loss_gradient(const Network& network, std::span<const float> inputs, std::span<const float> targets,
                             std::span<const float> sample_scales, std::size_t count, float weight,
                             std::span<float> gradient, std::span<float> input_gradient) {
  const float* p = network.parameters.data();
  // A decoder-only gradient holds the parameters from decoder_begin on: shift the offsets.
  const std::size_t shift = gradient.size() == network.parameters.size() ? 0 : network.decoder_begin;
  auto g = [&](std::size_t offset) { return gradient.data() + (offset - shift); };
  const std::size_t layers = network.dense.size();
  // Samples down the rows (count x width, column-major): the products' long dimension is then
  // the one Eigen's kernel blocks by 48 rows, and the hidden width (106) only the short one.
  std::vector<ColMatrix> act(layers + 1);  // act[0] = inputs, act[l+1] = layer l's output (post-ReLU)
  act[0] = ConstColMap(inputs.data(), network.dense.front().in, Eigen::Index(count)).transpose();
  for (std::size_t l = 0; l < layers; ++l) {
    const auto& d = network.dense[l];
    act[l + 1].noalias() = act[l] * ConstRowMap(p + d.weights, d.out, d.in).transpose();
    act[l + 1].rowwise() += ConstVectorMap(p + d.bias, d.out).transpose();
    if (l + 1 < layers) act[l + 1] = act[l + 1].cwiseMax(0.0f);
  }
  ColMatrix residual = act[layers];
  if (!sample_scales.empty()) residual = ConstVectorMap(sample_scales.data(), Eigen::Index(count)).asDiagonal() * residual;
  residual -= ConstColMap(targets.data(), 3, Eigen::Index(count)).transpose();
  const double loss = double(residual.squaredNorm());
  // d/dy of w (s y − t)²: 2 w s (s y − t).
  ColMatrix dz = (2.0f * weight) * residual;
  if (!sample_scales.empty()) dz = ConstVectorMap(sample_scales.data(), Eigen::Index(count)).asDiagonal() * dz;
  for (std::size_t l = layers; l-- > 0;) {
    const auto& d = network.dense[l];
    RowMap(g(d.weights), d.out, d.in).noalias() += dz.transpose() * act[l];
    VectorMap(g(d.bias), d.out) += dz.colwise().sum().transpose();
    if (l == 0 && input_gradient.empty()) break;
    ColMatrix da = dz * ConstRowMap(p + d.weights, d.out, d.in);
    if (l == 0) {
      ColMap(input_gradient.data(), d.in, Eigen::Index(count)) = da.transpose();
      break;
    }
    dz = (act[l].array() > 0.0f).select(da, 0.0f);
  }
  return loss;
}

}  // namespace weft::btf
