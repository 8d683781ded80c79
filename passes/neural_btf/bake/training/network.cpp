// The encoder and decoder, forward and backward by hand on Eigen matrices. Convolutions are
// im2col + one matrix product; batch norm normalises over the batch and the pixels of each
// channel (the standard convolutional batch norm), so its backward pass couples the batch.
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

// im2col for a 3x3 kernel, stride 1, zero padding 1: row (ci*9 + ky*3 + kx), column y*W + x.
// Each row is the image shifted by (ky - 1, kx - 1): per image row, one copy of the columns
// that stay inside and zeros at the one-pixel border.
void im2col(const float* x, std::uint32_t channels, std::uint32_t rows, std::uint32_t cols, RowMatrix& out) {
  out.resize(Eigen::Index(channels) * 9, Eigen::Index(rows) * cols);
  const int W = int(cols);
  for (std::uint32_t c = 0; c < channels; ++c)
    for (int ky = 0; ky < 3; ++ky)
      for (int kx = 0; kx < 3; ++kx) {
        float* dst = out.row(Eigen::Index(c * 9 + ky * 3 + kx)).data();
        const int x0 = std::max(0, 1 - kx), x1 = std::min(W, W + 1 - kx);  // columns whose source is inside
        for (std::uint32_t y = 0; y < rows; ++y) {
          float* d = dst + std::size_t(y) * cols;
          const int sy = int(y) + ky - 1;
          if (sy < 0 || sy >= int(rows) || x1 <= x0) {
            std::fill_n(d, cols, 0.0f);
            continue;
          }
          const float* src = x + (std::size_t(c) * rows + std::size_t(sy)) * cols + (kx - 1);
          std::fill(d, d + x0, 0.0f);
          std::copy(src + x0, src + x1, d + x0);
          std::fill(d + x1, d + W, 0.0f);
        }
      }
}

// The adjoint of im2col: scatters column gradients back onto the image.
void col2im(const RowMatrix& dcols, std::uint32_t channels, std::uint32_t rows, std::uint32_t cols, float* dx) {
  std::fill_n(dx, std::size_t(channels) * rows * cols, 0.0f);
  const int W = int(cols);
  for (std::uint32_t c = 0; c < channels; ++c)
    for (int ky = 0; ky < 3; ++ky)
      for (int kx = 0; kx < 3; ++kx) {
        const float* src = dcols.row(Eigen::Index(c * 9 + ky * 3 + kx)).data();
        const int x0 = std::max(0, 1 - kx), x1 = std::min(W, W + 1 - kx);
        for (std::uint32_t y = 0; y < rows; ++y) {
          const int sy = int(y) + ky - 1;
          if (sy < 0 || sy >= int(rows)) continue;
          float* d = dx + (std::size_t(c) * rows + std::size_t(sy)) * cols + (kx - 1);
          const float* s = src + std::size_t(y) * cols;
          for (int xx = x0; xx < x1; ++xx) d[xx] += s[xx];
        }
      }
}

}  // namespace

// What backward needs from one training-mode forward pass, per stage and per batch item.
struct EncoderCache {
  std::size_t batch = 0;
  struct Stage {
    std::vector<RowMatrix> cols;                      // im2col of the stage input, per item
    std::vector<std::vector<std::uint32_t>> argmax;   // per item: pooled index -> conv pixel
    std::vector<RowMatrix> xhat;                      // per item: normalised pooled (C x P)
    Floats inv_std;                       // per channel
  };
  std::array<Stage, 3> stages;
  std::vector<Eigen::VectorXf> flat;  // per item: the fully connected layer's input
  // Per item, reused from step to step: allocating these each time (hundreds of KiB) cost more
  // in page faults and zeroing than the arithmetic on them.
  std::vector<Floats> input;  // a stage's input, CHW
  mutable std::vector<RowMatrix> conv_out, dz, dcols, dx;
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
  // Stage input per item, CHW.
  auto& x = cache.input;
  if (x.size() < batch) x.resize(batch);
  if (cache.conv_out.size() < batch) cache.conv_out.resize(batch);
  const std::size_t pixels = std::size_t(shape.lights) * shape.views;
  each(parallel, batch, [&](std::size_t b) {
    x[b].resize(3 * pixels);
    for (std::size_t i = 0; i < pixels; ++i)
      for (std::size_t c = 0; c < 3; ++c) x[b][c * pixels + i] = inputs[b][i * 3 + c];
  });
  std::size_t bn_offset = 0;
  for (std::size_t s = 0; s < 3; ++s) {
    const auto& conv = network.conv[s];
    auto& st = cache.stages[s];
    st.cols.resize(batch);
    st.argmax.resize(batch);
    st.xhat.resize(batch);
    const std::size_t out_pixels = std::size_t(conv.pooled_rows) * conv.pooled_cols;
    const ConstRowMap weights(p + conv.weights, conv.out, Eigen::Index(conv.in) * 9);
    const ConstVectorMap bias(p + conv.bias, conv.out);
    std::vector<RowMatrix> pooled_out(batch);
    // Per item and channel: the sum, then the squared deviations about the batch mean.
    std::vector<double> sums(batch * conv.out, 0.0), squares(batch * conv.out, 0.0);
    each(parallel, batch, [&](std::size_t b) {
      im2col(x[b].data(), conv.in, conv.rows, conv.cols, st.cols[b]);
      RowMatrix& z = cache.conv_out[b];
      z.resize(conv.out, Eigen::Index(std::size_t(conv.rows) * conv.cols));
      z.noalias() = weights * st.cols[b];
      z.colwise() += bias;
      RowMatrix& out = pooled_out[b];
      out.resize(conv.out, Eigen::Index(out_pixels));
      st.argmax[b].resize(std::size_t(conv.out) * out_pixels);
      for (std::uint32_t c = 0; c < conv.out; ++c) {
        const float* zc = z.row(c).data();
        float* oc = out.row(c).data();
        std::uint32_t* ac = st.argmax[b].data() + std::size_t(c) * out_pixels;
        for (std::uint32_t py = 0; py < conv.pooled_rows; ++py)
          for (std::uint32_t px = 0; px < conv.pooled_cols; ++px) {
            // The first pixel of the window wins ties (and a window of NaNs).
            std::uint32_t at = py * 3 * conv.cols + px * 3;
            float best = zc[at];
            for (std::uint32_t y = py * 3; y < std::min(py * 3 + 3, conv.rows); ++y)
              for (std::uint32_t xx = px * 3; xx < std::min(px * 3 + 3, conv.cols); ++xx) {
                const float v = zc[y * conv.cols + xx];
                if (v > best) best = v, at = y * conv.cols + xx;
              }
            oc[py * conv.pooled_cols + px] = best;
            ac[py * conv.pooled_cols + px] = at;
          }
      }
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
        double sum = 0.0;
        for (std::size_t b = 0; b < batch; ++b) sum += sums[b * conv.out + c];
        mean[c] = float(sum / count);
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
      x[b].assign(pooled_out[b].data(), pooled_out[b].data() + pooled_out[b].size());  // row-major = CHW
    });
    bn_offset += conv.out;
  }
  const ConstRowMap fc(p + network.fc_weights, shape.latent, Eigen::Index(network.fc_inputs));
  const ConstVectorMap fc_bias(p + network.fc_bias, shape.latent);
  cache.flat.resize(batch);
  for (std::size_t b = 0; b < batch; ++b) {
    cache.flat[b] = ConstVectorMap(x[b].data(), Eigen::Index(network.fc_inputs));
    VectorMap(latents.data() + b * shape.latent, shape.latent) = fc * cache.flat[b] + fc_bias;
  }
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
  if (cache.dz.size() < batch) cache.dz.resize(batch), cache.dcols.resize(batch), cache.dx.resize(batch);
  std::vector<RowMatrix> item_dweights(batch);
  std::vector<Eigen::VectorXf> item_dbias(batch);
  for (int s = 2; s >= 0; --s) {
    const auto& conv = network.conv[std::size_t(s)];
    const auto& st = cache.stages[std::size_t(s)];
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
    const ConstRowMap weights(p + conv.weights, conv.out, Eigen::Index(conv.in) * 9);
    RowMap dweights(g + conv.weights, conv.out, Eigen::Index(conv.in) * 9);
    VectorMap dbias(g + conv.bias, conv.out);
    const std::size_t in_pixels = std::size_t(conv.rows) * conv.cols;
    each(parallel, batch, [&](std::size_t b) {
      for (std::uint32_t c = 0; c < conv.out; ++c)
        dy[b].row(c) = k[c] * (dy[b].row(c).array() - mean_dy[c] - st.xhat[b].row(c).array() * mean_dy_xhat[c]);
      // Max-pool backward: each pooled gradient goes to the pixel that won.
      RowMatrix& dz = cache.dz[b];
      dz.setZero(conv.out, Eigen::Index(in_pixels));
      for (std::uint32_t c = 0; c < conv.out; ++c)
        for (std::size_t q = 0; q < out_pixels; ++q)
          dz(c, Eigen::Index(st.argmax[b][c * out_pixels + q])) += dy[b](c, Eigen::Index(q));
      item_dweights[b].noalias() = dz * st.cols[b].transpose();
      item_dbias[b] = dz.rowwise().sum();
      if (s > 0) {
        RowMatrix& dcols = cache.dcols[b];
        dcols.resize(Eigen::Index(conv.in) * 9, Eigen::Index(in_pixels));
        dcols.noalias() = weights.transpose() * dz;
        RowMatrix& dx = cache.dx[b];
        dx.resize(conv.in, Eigen::Index(in_pixels));
        col2im(dcols, conv.in, conv.rows, conv.cols, dx.data());
        dy[b] = dx;
      }
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
  float* g = gradient.data();
  const std::size_t layers = network.dense.size();
  std::vector<ColMatrix> act(layers + 1);  // act[0] = inputs, act[l+1] = layer l's output (post-ReLU)
  act[0] = ConstColMap(inputs.data(), network.dense.front().in, Eigen::Index(count));
  for (std::size_t l = 0; l < layers; ++l) {
    const auto& d = network.dense[l];
    act[l + 1].noalias() = ConstRowMap(p + d.weights, d.out, d.in) * act[l];
    act[l + 1].colwise() += ConstVectorMap(p + d.bias, d.out);
    if (l + 1 < layers) act[l + 1] = act[l + 1].cwiseMax(0.0f);
  }
  const ConstColMap t(targets.data(), 3, Eigen::Index(count));
  ColMatrix residual = act[layers];
  if (!sample_scales.empty()) residual = residual * ConstVectorMap(sample_scales.data(), Eigen::Index(count)).asDiagonal();
  residual -= t;
  const double loss = double(residual.squaredNorm());
  // d/dy of w (s y − t)²: 2 w s (s y − t).
  ColMatrix dz = (2.0f * weight) * residual;
  if (!sample_scales.empty()) dz = dz * ConstVectorMap(sample_scales.data(), Eigen::Index(count)).asDiagonal();
  for (std::size_t l = layers; l-- > 0;) {
    const auto& d = network.dense[l];
    RowMap(g + d.weights, d.out, d.in).noalias() += dz * act[l].transpose();
    VectorMap(g + d.bias, d.out) += dz.rowwise().sum();
    if (l == 0 && input_gradient.empty()) break;
    ColMatrix da = ConstRowMap(p + d.weights, d.out, d.in).transpose() * dz;
    if (l == 0) {
      ColMap(input_gradient.data(), d.in, Eigen::Index(count)) = da;
      break;
    }
    dz = (act[l].array() > 0.0f).select(da, 0.0f);
  }
  return loss;
}

}  // namespace weft::btf
