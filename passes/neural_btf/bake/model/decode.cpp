module;
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <cstddef>
#include <span>
#include <vector>
#include <glm/glm.hpp>
module weft.btf.model;

namespace weft::btf {

vec2 stereographic(const vec3& direction) {
  const float len = glm::length(direction);
  if (!(len > 0.0f)) return vec2(0.0f);
  const vec3 d = direction / len;
  return vec2(d.x, d.y) / (1.0f + d.z);
}

std::size_t Decoder::parameter_count() const {
  std::size_t n = 0;
  for (const DenseLayer& l : layers) n += l.weights.size() + l.bias.size();
  return n;
}

std::span<const float> NeuralBtf::latent_of_texel(std::size_t texel) const {
  const std::size_t index = clustered() ? cluster_ids[texel] : texel;
  return std::span<const float>(latents).subspan(index * latent_size, latent_size);
}

vec3 evaluate(const Decoder& decoder, std::span<const float> input) {
  std::vector<float> a(input.begin(), input.end()), b;
  for (std::size_t li = 0; li < decoder.layers.size(); ++li) {
    const DenseLayer& layer = decoder.layers[li];
    b.assign(layer.outputs, 0.0f);
    for (std::uint32_t o = 0; o < layer.outputs; ++o) {
      float sum = layer.bias[o];
      const float* w = layer.weights.data() + std::size_t(o) * layer.inputs;
      for (std::uint32_t i = 0; i < layer.inputs; ++i) sum += w[i] * a[i];
      b[o] = (li + 1 < decoder.layers.size()) ? std::max(sum, 0.0f) : sum;
    }
    std::swap(a, b);
  }
  return a.size() >= 3 ? vec3(a[0], a[1], a[2]) : vec3(0.0f);
}

vec3 decode(const NeuralBtf& model, std::size_t texel, const vec3& light, const vec3& view) {
  std::vector<float> input(model.latent_size + 4);
  const std::span<const float> latent = model.latent_of_texel(texel);
  std::copy(latent.begin(), latent.end(), input.begin());
  const vec2 si = stereographic(light), so = stereographic(view);
  input[model.latent_size + 0] = si.x;
  input[model.latent_size + 1] = si.y;
  input[model.latent_size + 2] = so.x;
  input[model.latent_size + 3] = so.y;
  const float scale = model.output_scale * (model.texel_scales.empty() ? 1.0f : model.texel_scales[texel]);
  return glm::max(evaluate(model.decoder, input), vec3(0.0f)) * scale;
}

NeuralBtf random_model(const RandomModelOptions& options) {
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  NeuralBtf model;
  model.width = options.width;
  model.height = options.height;
  model.latent_size = options.latent_size;
  model.output_scale = options.output_scale;
  std::uint32_t inputs = options.latent_size + 4;
  std::vector<std::uint32_t> widths = options.hidden;
  widths.push_back(3);
  for (std::uint32_t outputs : widths) {
    DenseLayer layer{inputs, outputs, std::vector<float>(std::size_t(inputs) * outputs), std::vector<float>(outputs)};
    const float limit = std::sqrt(6.0f / float(inputs));  // He-uniform keeps ReLU activations O(1)
    for (float& w : layer.weights) w = unit(rng) * limit;
    for (float& b : layer.bias) b = 0.1f * unit(rng);
    model.decoder.layers.push_back(std::move(layer));
    inputs = outputs;
  }
  const std::size_t texels = model.texels();
  const std::size_t count = options.clusters ? options.clusters : texels;
  model.latents.resize(count * options.latent_size);
  for (float& v : model.latents) v = unit(rng);
  if (options.clusters) {
    model.cluster_ids.resize(texels);
    for (std::size_t t = 0; t < texels; ++t) model.cluster_ids[t] = std::uint32_t(rng() % options.clusters);
  }
  if (options.scales) {
    model.texel_scales.resize(texels);
    for (float& s : model.texel_scales) s = 1.0f + 0.5f * unit(rng);
  }
  return model;
}

}  // namespace weft::btf
