// The .wbtf file: encode with the chosen storage precision, and a decoder that checks every
// size before reading it and names the file and the section in each error (truncation,
// magic, version, checksums, inconsistent counts, ids out of range, non-finite numbers).
module;
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <expected>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <glm/glm.hpp>
#include <glm/gtc/packing.hpp>
#include <weft/try.h>
module weft.btf.model;

namespace weft::btf {
namespace {
static_assert(std::endian::native == std::endian::little, "the .wbtf writer assumes a little-endian host");

constexpr std::array<char, 8> kMagic{'W', 'E', 'F', 'T', 'N', 'B', 'T', 'F'};
constexpr std::uint32_t kHeaderBytes = 72;
constexpr std::uint32_t kSections = 4;
constexpr std::uint32_t kClustered = 1u, kScales = 2u;
constexpr std::uint32_t kMaxLayerWidth = 65536;  // a decoder layer wider than this is corruption
constexpr std::array<std::uint32_t, 4> kTags{0x00504c4du /* MLP */, 0x0054414cu /* LAT */, 0x00534449u /* IDS */,
                                             0x004c4353u /* SCL */};
constexpr std::array<std::string_view, 4> kSectionNames{"MLP", "LAT", "IDS", "SCL"};

std::size_t float_bytes(FloatStorage s) { return s == FloatStorage::Fp16 ? 2 : 4; }
std::size_t id_bytes(IdStorage s) { return s == IdStorage::U8 ? 1 : s == IdStorage::U16 ? 2 : 4; }

// The id width `Auto` resolves to for a model with `count` latents.
IdStorage resolve_ids(IdStorage requested, std::size_t count) {
  if (requested != IdStorage::Auto) return requested;
  if (count <= 256) return IdStorage::U8;
  if (count <= 65536) return IdStorage::U16;
  return IdStorage::U32;
}

// fp16 round trip (glm rounds to nearest); finite floats beyond ±65504 do not fit.
bool fits_half(float v) { return std::isfinite(glm::unpackHalf1x16(glm::packHalf1x16(v))); }

// The .wbtf float encodings: fp32 as it is, fp16 rounded to nearest by glm.
class Writer : public BinaryWriter {
 public:
  void put_floats(std::span<const float> values, FloatStorage storage) {
    for (float v : values) {
      if (storage == FloatStorage::Fp16)
        put(glm::packHalf1x16(v));
      else
        put(v);
    }
  }
};

std::vector<float> floats_of(std::span<const std::byte> bytes, FloatStorage storage) {
  std::vector<float> values(bytes.size() / float_bytes(storage));
  if (storage == FloatStorage::Fp32) {
    if (!values.empty()) std::memcpy(values.data(), bytes.data(), values.size() * sizeof(float));
  } else {
    for (std::size_t i = 0; i < values.size(); ++i) {
      std::uint16_t h;
      std::memcpy(&h, bytes.data() + 2 * i, 2);
      values[i] = glm::unpackHalf1x16(h);
    }
  }
  return values;
}

// The first non-finite value's index, or npos.
std::size_t first_non_finite(std::span<const float> values) {
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!std::isfinite(values[i])) return i;
  return std::size_t(-1);
}

// The 8-bit scale code of v for the range [lo, hi].
std::uint8_t quantize_scale(float v, float lo, float hi) {
  if (!(hi > lo)) return 0;
  return std::uint8_t(std::clamp(std::round((v - lo) / (hi - lo) * 255.0f), 0.0f, 255.0f));
}
float dequantize_scale(std::uint8_t code, float lo, float hi) { return lo + (hi - lo) * (float(code) / 255.0f); }
}  // namespace

std::string_view to_string(FloatStorage s) { return s == FloatStorage::Fp16 ? "fp16" : "fp32"; }
std::string_view to_string(IdStorage s) {
  switch (s) {
    case IdStorage::Auto: return "auto";
    case IdStorage::U8: return "u8";
    case IdStorage::U16: return "u16";
    case IdStorage::U32: return "u32";
  }
  return "?";
}
std::string_view to_string(ScaleStorage s) {
  switch (s) {
    case ScaleStorage::Fp32: return "fp32";
    case ScaleStorage::Fp16: return "fp16";
    case ScaleStorage::U8: return "u8";
  }
  return "?";
}

Result<void> validate(const NeuralBtf& model) {
  if (model.width == 0 || model.height == 0)
    return fail(ErrorKind::InvalidArgument, "neural BTF: the texel grid is {} x {}", model.width, model.height);
  if (model.latent_size == 0) return fail(ErrorKind::InvalidArgument, "neural BTF: latent size 0");
  const auto& layers = model.decoder.layers;
  if (layers.empty()) return fail(ErrorKind::InvalidArgument, "neural BTF: the decoder has no layers");
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const DenseLayer& l = layers[i];
    const std::uint32_t expected_inputs = i == 0 ? model.latent_size + 4 : layers[i - 1].outputs;
    if (l.inputs != expected_inputs)
      return fail(ErrorKind::InvalidArgument, "neural BTF: decoder layer {} has {} inputs, expected {}", i, l.inputs,
                  expected_inputs);
    if (l.outputs == 0 || l.outputs > kMaxLayerWidth || l.inputs > kMaxLayerWidth)
      return fail(ErrorKind::InvalidArgument, "neural BTF: decoder layer {} is {} -> {} (1 .. {} each)", i, l.inputs,
                  l.outputs, kMaxLayerWidth);
    if (l.weights.size() != std::size_t(l.inputs) * l.outputs || l.bias.size() != l.outputs)
      return fail(ErrorKind::InvalidArgument, "neural BTF: decoder layer {} ({} -> {}) has {} weights and {} biases",
                  i, l.inputs, l.outputs, l.weights.size(), l.bias.size());
    if (const auto at = first_non_finite(l.weights); at != std::size_t(-1))
      return fail(ErrorKind::InvalidArgument, "neural BTF: decoder layer {} weight {} is {}", i, at, l.weights[at]);
    if (const auto at = first_non_finite(l.bias); at != std::size_t(-1))
      return fail(ErrorKind::InvalidArgument, "neural BTF: decoder layer {} bias {} is {}", i, at, l.bias[at]);
  }
  if (layers.back().outputs != 3)
    return fail(ErrorKind::InvalidArgument, "neural BTF: the decoder's last layer has {} outputs, not 3 (RGB)",
                layers.back().outputs);
  if (model.latents.empty() || model.latents.size() % model.latent_size != 0)
    return fail(ErrorKind::InvalidArgument, "neural BTF: {} latent values are not whole latents of {}",
                model.latents.size(), model.latent_size);
  if (const auto at = first_non_finite(model.latents); at != std::size_t(-1))
    return fail(ErrorKind::InvalidArgument, "neural BTF: latent value {} is {}", at, model.latents[at]);
  const std::size_t texels = model.texels();
  if (model.clustered()) {
    if (model.cluster_ids.size() != texels)
      return fail(ErrorKind::InvalidArgument, "neural BTF: {} cluster ids for {} texels", model.cluster_ids.size(), texels);
    for (std::size_t t = 0; t < texels; ++t)
      if (model.cluster_ids[t] >= model.latent_count())
        return fail(ErrorKind::InvalidArgument, "neural BTF: texel {} has cluster id {}, but there are {} latents", t,
                    model.cluster_ids[t], model.latent_count());
  } else if (model.latent_count() != texels) {
    return fail(ErrorKind::InvalidArgument, "neural BTF: {} latents for {} texels (and no cluster ids)",
                model.latent_count(), texels);
  }
  if (!model.texel_scales.empty() && model.texel_scales.size() != texels)
    return fail(ErrorKind::InvalidArgument, "neural BTF: {} texel scales for {} texels", model.texel_scales.size(), texels);
  if (const auto at = first_non_finite(model.texel_scales); at != std::size_t(-1))
    return fail(ErrorKind::InvalidArgument, "neural BTF: texel scale {} is {}", at, model.texel_scales[at]);
  if (!std::isfinite(model.output_scale) || model.output_scale < 0.0f)
    return fail(ErrorKind::InvalidArgument, "neural BTF: output scale {} (finite, >= 0)", model.output_scale);
  return {};
}

ModelBytes model_bytes(const NeuralBtf& model, const WbtfOptions& options) {
  ModelBytes b;
  b.decoder = model.decoder.parameter_count() * float_bytes(options.weights);
  b.latents = model.latents.size() * float_bytes(options.latents);
  if (model.clustered()) b.ids = model.cluster_ids.size() * id_bytes(resolve_ids(options.ids, model.latent_count()));
  if (!model.texel_scales.empty())
    b.scales = options.scales == ScaleStorage::U8 ? 8 + model.texel_scales.size()
                                                  : model.texel_scales.size() * (options.scales == ScaleStorage::Fp16 ? 2 : 4);
  return b;
}

Result<std::vector<std::byte>> encode_wbtf(const NeuralBtf& model, const WbtfOptions& options) {
  WEFT_TRY_VOID(validate(model));
  const IdStorage ids = resolve_ids(options.ids, model.latent_count());
  if (model.clustered() && ids != IdStorage::U32 && model.latent_count() > (ids == IdStorage::U8 ? 256u : 65536u))
    return fail(ErrorKind::InvalidArgument, "neural BTF: {} clusters do not fit {} cluster ids", model.latent_count(),
                to_string(ids));
  auto check_half = [](std::span<const float> values, FloatStorage storage, std::string_view what) -> Result<void> {
    if (storage != FloatStorage::Fp16) return {};
    for (std::size_t i = 0; i < values.size(); ++i)
      if (!fits_half(values[i]))
        return fail(ErrorKind::InvalidArgument, "neural BTF: {} value {} ({}) does not fit fp16 (|x| <= 65504)", what, i,
                    values[i]);
    return {};
  };
  Writer mlp;
  for (std::size_t i = 0; i < model.decoder.layers.size(); ++i) {
    const DenseLayer& l = model.decoder.layers[i];
    if (auto ok = check_half(l.weights, options.weights, weft::format("decoder layer {} weight", i)); !ok)
      return std::unexpected(ok.error());
    if (auto ok = check_half(l.bias, options.weights, weft::format("decoder layer {} bias", i)); !ok)
      return std::unexpected(ok.error());
    mlp.put(l.inputs);
    mlp.put(l.outputs);
    mlp.put_floats(l.weights, options.weights);
    mlp.put_floats(l.bias, options.weights);
  }
  WEFT_TRY_VOID(check_half(model.latents, options.latents, "latent"));
  Writer latents;
  latents.put_floats(model.latents, options.latents);
  Writer id_section;
  for (std::uint32_t id : model.cluster_ids) {
    switch (ids) {
      case IdStorage::U8: id_section.put(std::uint8_t(id)); break;
      case IdStorage::U16: id_section.put(std::uint16_t(id)); break;
      default: id_section.put(id); break;
    }
  }
  Writer scales;
  if (!model.texel_scales.empty()) {
    switch (options.scales) {
      case ScaleStorage::Fp32: scales.put_floats(model.texel_scales, FloatStorage::Fp32); break;
      case ScaleStorage::Fp16:
        if (auto ok = check_half(model.texel_scales, FloatStorage::Fp16, "texel scale"); !ok)
          return std::unexpected(ok.error());
        scales.put_floats(model.texel_scales, FloatStorage::Fp16);
        break;
      case ScaleStorage::U8: {
        const auto [lo, hi] = std::minmax_element(model.texel_scales.begin(), model.texel_scales.end());
        scales.put(*lo);
        scales.put(*hi);
        for (float v : model.texel_scales) scales.put(quantize_scale(v, *lo, *hi));
        break;
      }
    }
  }

  Writer out;
  for (char ch : kMagic) out.put(ch);
  out.put(kWbtfVersion);
  out.put(kHeaderBytes);
  out.put(model.width);
  out.put(model.height);
  out.put(model.latent_size);
  out.put(std::uint32_t(model.latent_count()));
  out.put(std::uint32_t(model.decoder.layers.size()));
  out.put((model.clustered() ? kClustered : 0u) | (model.texel_scales.empty() ? 0u : kScales));
  out.put(std::uint32_t(options.weights));
  out.put(std::uint32_t(options.latents));
  out.put(std::uint32_t(ids));
  out.put(std::uint32_t(options.scales));
  out.put(model.output_scale);
  out.put(kSections);
  out.put(hash_bytes(out.bytes));
  const std::vector<std::byte>* payloads[kSections] = {&mlp.bytes, &latents.bytes, &id_section.bytes, &scales.bytes};
  for (std::uint32_t s = 0; s < kSections; ++s) {
    out.put(kTags[s]);
    out.put(std::uint32_t{0});
    out.put(std::uint64_t(payloads[s]->size()));
    out.put(hash_bytes(*payloads[s]));
    out.bytes.insert(out.bytes.end(), payloads[s]->begin(), payloads[s]->end());
  }
  return std::move(out.bytes);
}

Result<NeuralBtf> decode_wbtf(std::span<const std::byte> bytes, std::string_view source) {
  WEFT_TRY_VOID(check_file_header(bytes, source, {.magic = {kMagic.data(), kMagic.size()}, .kind = "neural BTF",
                                                  .version = kWbtfVersion, .header_bytes = kHeaderBytes}));
  BinaryReader header(bytes.first(kHeaderBytes), source, "header");
  (void)header.take(12, "magic and version");
  std::uint32_t f[13];
  for (auto& v : f) v = *header.get<std::uint32_t>("a header field");
  const std::uint64_t stored_sum = *header.get<std::uint64_t>("the header checksum");
  if (const std::uint64_t sum = hash_bytes(bytes.first(kHeaderBytes - 8)); sum != stored_sum)
    return fail(ErrorKind::Parse, "{}: header checksum mismatch (stored {}, computed {}): the file is corrupt", source,
                hex64(stored_sum), hex64(sum));
  const std::uint32_t header_size = f[0], width = f[1], height = f[2], latent_size = f[3], latent_count = f[4],
                      layer_count = f[5], flags = f[6], weight_format = f[7], latent_format = f[8], id_format = f[9],
                      scale_format = f[10], sections = f[12];
  const float output_scale = std::bit_cast<float>(f[11]);
  if (header_size != kHeaderBytes)
    return fail(ErrorKind::Parse, "{}: header size {} (version 1 has {})", source, header_size, kHeaderBytes);
  if (sections != kSections) return fail(ErrorKind::Parse, "{}: {} sections (version 1 has {})", source, sections, kSections);
  if ((flags & ~(kClustered | kScales)) != 0) return fail(ErrorKind::Parse, "{}: unknown header flags {:#x}", source, flags);
  if (weight_format > 1 || latent_format > 1)
    return fail(ErrorKind::Parse, "{}: unknown storage format (weights {}, latents {}; 0 fp32, 1 fp16)", source,
                weight_format, latent_format);
  if (id_format < 1 || id_format > 3 || scale_format > 2)
    return fail(ErrorKind::Parse, "{}: unknown storage format (ids {}, scales {})", source, id_format, scale_format);
  if (width == 0 || height == 0 || latent_size == 0 || latent_count == 0 || layer_count == 0)
    return fail(ErrorKind::Parse, "{}: header: {} x {} texels, latent size {}, {} latents, {} layers (none may be 0)",
                source, width, height, latent_size, latent_count, layer_count);
  if (!std::isfinite(output_scale) || output_scale < 0.0f)
    return fail(ErrorKind::Parse, "{}: header: output scale {} (finite, >= 0)", source, output_scale);
  const bool clustered = (flags & kClustered) != 0, has_scales = (flags & kScales) != 0;
  const std::uint64_t texels = std::uint64_t(width) * height;
  if (!clustered && latent_count != texels)
    return fail(ErrorKind::Parse, "{}: header: {} latents for {} x {} texels without cluster ids", source, latent_count,
                width, height);
  const auto weights = FloatStorage(weight_format), latent_storage = FloatStorage(latent_format);
  const auto ids = IdStorage(id_format);
  const auto scales = ScaleStorage(scale_format);

  BinaryReader in(bytes, source);
  (void)in.take(kHeaderBytes, "the header");
  std::array<std::span<const std::byte>, kSections> payloads;
  for (std::uint32_t s = 0; s < kSections; ++s) {
    const std::string what = weft::format("section '{}'", kSectionNames[s]);
    WEFT_TRY(auto tag, in.get<std::uint32_t>(what + "'s tag"));
    if (tag != kTags[s]) {
      std::string found;
      for (int i = 0; i < 4; ++i)
        if (const char c = char((tag >> (8 * i)) & 0xffu); c) found += (c >= 32 && c < 127) ? c : '?';
      return fail(ErrorKind::Parse, "{}: found section '{}' where '{}' belongs", source, found, kSectionNames[s]);
    }
    (void)in.get<std::uint32_t>(what + "'s reserved field");
    WEFT_TRY(auto size, in.get<std::uint64_t>(what + "'s size"));
    WEFT_TRY(auto sum, in.get<std::uint64_t>(what + "'s checksum"));
    if (size > in.remaining())
      return fail(ErrorKind::Parse, "{}: truncated: section '{}' needs {} bytes, but only {} remain", source,
                  kSectionNames[s], size, in.remaining());
    payloads[s] = *in.take(std::size_t(size), what);
    if (const std::uint64_t computed = hash_bytes(payloads[s]); computed != sum)
      return fail(ErrorKind::Parse, "{}: section '{}' checksum mismatch (stored {}, computed {}): the file is corrupt",
                  source, kSectionNames[s], hex64(sum), hex64(computed));
  }
  if (in.remaining() != 0)
    return fail(ErrorKind::Parse, "{}: {} unexpected bytes after the last section", source, in.remaining());

  NeuralBtf model;
  model.width = width;
  model.height = height;
  model.latent_size = latent_size;
  model.output_scale = output_scale;

  // MLP: shapes chain from latent + 4 to 3; each layer's numbers are checked to fit first.
  BinaryReader mlp(payloads[0], source, "MLP");
  std::uint32_t expected_inputs = latent_size + 4;
  for (std::uint32_t i = 0; i < layer_count; ++i) {
    WEFT_TRY(auto inputs, mlp.get<std::uint32_t>(weft::format("layer {}'s input count", i)));
    WEFT_TRY(auto outputs, mlp.get<std::uint32_t>(weft::format("layer {}'s output count", i)));
    if (inputs != expected_inputs || outputs == 0 || outputs > kMaxLayerWidth)
      return fail(ErrorKind::Parse, "{}: section 'MLP': layer {} is {} -> {}, but its input must be {} and its output 1 .. {}",
                  source, i, inputs, outputs, expected_inputs, kMaxLayerWidth);
    const std::size_t count = std::size_t(inputs) * outputs + outputs;
    WEFT_TRY(auto numbers, mlp.take(count * float_bytes(weights), weft::format("layer {}'s weights and bias", i)));
    std::vector<float> values = floats_of(numbers, weights);
    if (const auto at = first_non_finite(values); at != std::size_t(-1))
      return fail(ErrorKind::Parse, "{}: section 'MLP': layer {} has a non-finite {} ({} at index {})", source, i,
                  at < std::size_t(inputs) * outputs ? "weight" : "bias", values[at], at);
    DenseLayer layer{inputs, outputs, {}, {}};
    layer.bias.assign(values.end() - outputs, values.end());
    values.resize(values.size() - outputs);
    layer.weights = std::move(values);
    model.decoder.layers.push_back(std::move(layer));
    expected_inputs = outputs;
  }
  if (expected_inputs != 3)
    return fail(ErrorKind::Parse, "{}: section 'MLP': the last layer has {} outputs, not 3 (RGB)", source, expected_inputs);
  if (mlp.remaining() != 0)
    return fail(ErrorKind::Parse, "{}: section 'MLP' has {} bytes left over after {} layers", source, mlp.remaining(),
                layer_count);

  const std::uint64_t latent_bytes = std::uint64_t(latent_count) * latent_size * float_bytes(latent_storage);
  if (payloads[1].size() != latent_bytes)
    return fail(ErrorKind::Parse, "{}: section 'LAT' has {} bytes, {} latents of {} {} values need {}", source,
                payloads[1].size(), latent_count, latent_size, to_string(latent_storage), latent_bytes);
  model.latents = floats_of(payloads[1], latent_storage);
  if (const auto at = first_non_finite(model.latents); at != std::size_t(-1))
    return fail(ErrorKind::Parse, "{}: section 'LAT': latent {} value {} is {}", source, at / latent_size,
                at % latent_size, model.latents[at]);

  const std::uint64_t id_payload = clustered ? texels * id_bytes(ids) : 0;
  if (payloads[2].size() != id_payload)
    return fail(ErrorKind::Parse, "{}: section 'IDS' has {} bytes, {} needs {}", source, payloads[2].size(),
                clustered ? weft::format("{} texels of {} ids", texels, to_string(ids)) : std::string("an unclustered model"),
                id_payload);
  if (clustered) {
    model.cluster_ids.resize(std::size_t(texels));
    const std::byte* p = payloads[2].data();
    for (std::size_t t = 0; t < texels; ++t) {
      std::uint32_t id = 0;
      std::memcpy(&id, p + t * id_bytes(ids), id_bytes(ids));  // little-endian: the low bytes
      if (id >= latent_count)
        return fail(ErrorKind::Parse, "{}: section 'IDS': texel {} has cluster id {}, but there are {} latents", source, t,
                    id, latent_count);
      model.cluster_ids[t] = id;
    }
  }

  const std::uint64_t scale_payload =
      !has_scales ? 0 : scales == ScaleStorage::U8 ? 8 + texels : texels * (scales == ScaleStorage::Fp16 ? 2 : 4);
  if (payloads[3].size() != scale_payload)
    return fail(ErrorKind::Parse, "{}: section 'SCL' has {} bytes, {} needs {}", source, payloads[3].size(),
                has_scales ? weft::format("{} texels of {} scales", texels, to_string(scales)) : std::string("a model without scales"),
                scale_payload);
  if (has_scales) {
    if (scales == ScaleStorage::U8) {
      float range[2];
      std::memcpy(range, payloads[3].data(), 8);
      if (!std::isfinite(range[0]) || !std::isfinite(range[1]) || range[1] < range[0])
        return fail(ErrorKind::Parse, "{}: section 'SCL': 8-bit scale range [{}, {}] is not a finite interval", source,
                    range[0], range[1]);
      model.texel_scales.resize(std::size_t(texels));
      for (std::size_t t = 0; t < texels; ++t)
        model.texel_scales[t] = dequantize_scale(std::to_integer<std::uint8_t>(payloads[3][8 + t]), range[0], range[1]);
    } else {
      model.texel_scales = floats_of(payloads[3], scales == ScaleStorage::Fp16 ? FloatStorage::Fp16 : FloatStorage::Fp32);
      if (const auto at = first_non_finite(model.texel_scales); at != std::size_t(-1))
        return fail(ErrorKind::Parse, "{}: section 'SCL': texel {}'s scale is {}", source, at, model.texel_scales[at]);
    }
  }
  return model;
}

Result<void> save_wbtf(const NeuralBtf& model, const std::filesystem::path& path, const WbtfOptions& options) {
  auto bytes = encode_wbtf(model, options);
  if (!bytes) return with_context(weft::format("writing '{}'", path.string()), bytes.error());
  return write_file_atomically(path, {std::span<const std::byte>(*bytes)}, "neural BTF");
}

Result<NeuralBtf> load_wbtf(const std::filesystem::path& path) {
  WEFT_TRY(auto data, read_input_file(path, "neural BTF file"));
  return decode_wbtf(std::as_bytes(std::span(data)), path.string());
}

}  // namespace weft::btf
