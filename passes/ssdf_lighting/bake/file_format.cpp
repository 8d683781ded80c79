// The .wssdf file: encode, and a decoder that checks every size before reading it and
// names what is wrong (truncation, magic, version, checksums, inconsistent counts).
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
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <weft/try.h>
module weft.ssdf;

namespace weft::ssdf {
namespace {
static_assert(std::endian::native == std::endian::little, "the .wssdf writer assumes a little-endian host");

constexpr std::array<char, 8> kMagic{'W', 'E', 'F', 'T', 'S', 'S', 'D', 'F'};
constexpr std::uint32_t kHeaderBytes = 64;
constexpr std::uint32_t kCentred = 1u;
constexpr std::uint32_t kHalfBasis = 2u;
constexpr std::uint32_t kVertexTag = 0x00585456u;   // "VTX\0"
constexpr std::uint32_t kClusterTag = 0x00534c43u;  // "CLS\0"

std::uint64_t checksum(std::span<const std::byte> bytes) { return hash_bytes(bytes); }

// The .wssdf basis encodings: fp32 as it is, fp16 by weft.cluster's conversion.
class Writer : public BinaryWriter {
 public:
  void put_halves(std::span<const float> values) {
    for (float v : values) put(cluster::float_to_half(v));
  }
  void put_floats(std::span<const float> values) { put_all(values); }
};

void put_section(Writer& out, std::uint32_t tag, const std::vector<std::byte>& payload) {
  out.put(tag);
  out.put(std::uint32_t{0});
  out.put(std::uint64_t(payload.size()));
  out.put(checksum(payload));
  out.bytes.insert(out.bytes.end(), payload.begin(), payload.end());
}

std::string tag_name(std::uint32_t tag) {
  std::string name;
  for (int i = 0; i < 4; ++i)
    if (const char c = char((tag >> (8 * i)) & 0xffu); c) name += (c >= 32 && c < 127) ? c : '?';
  return name;
}

// Floats read out of a payload (memcpy: the payload need not be aligned).
std::vector<float> floats_of(std::span<const std::byte> bytes) {
  std::vector<float> values(bytes.size() / sizeof(float));
  if (!values.empty()) std::memcpy(values.data(), bytes.data(), values.size() * sizeof(float));  // not from null
  return values;
}
std::vector<float> halves_of(std::span<const std::byte> bytes) {
  std::vector<float> values(bytes.size() / 2);
  for (std::size_t i = 0; i < values.size(); ++i) {
    std::uint16_t h;
    std::memcpy(&h, bytes.data() + 2 * i, 2);
    values[i] = cluster::half_to_float(h);
  }
  return values;
}
}  // namespace

Asset make_asset(std::uint32_t resolution, const CompressOptions& options, cluster::Cpca cpca) {
  Asset asset;
  asset.resolution = resolution;
  asset.requested_clusters = std::uint32_t(std::min<std::size_t>(options.clusters, 0xffffffffu));
  asset.requested_components = std::uint32_t(std::min<std::size_t>(options.max_components, 0xffffffffu));
  asset.requested_energy = float(options.energy_fraction);
  asset.cpca = std::move(cpca);
  return asset;
}

std::vector<std::byte> encode(const Asset& asset) {
  const auto& cpca = asset.cpca;
  const bool centred = std::ranges::any_of(cpca.clusters, [](const auto& c) { return !c.mean.empty(); });
  Writer vertices;
  for (std::size_t r = 0; r < cpca.row_count; ++r) {
    vertices.put(cpca.cluster_of[r]);
    vertices.put(cpca.slot_of[r]);
  }
  Writer clusters;
  for (const auto& c : cpca.clusters) {
    const std::size_t m = c.basis.rows;
    clusters.put(std::uint32_t(c.rows.size()));
    clusters.put(std::uint32_t(m));
    auto put_basis = [&](std::span<const float> values) {
      if (cpca.half_basis)
        clusters.put_halves(values);
      else
        clusters.put_floats(values);
    };
    if (centred) put_basis(c.mean.empty() ? std::vector<float>(cpca.cols, 0.0f) : c.mean);
    put_basis(c.basis.values);
    if (cpca.format == cluster::CoefficientFormat::Unorm8) {
      clusters.put_floats(c.offset.empty() ? std::vector<float>(m, 0.0f) : c.offset);
      clusters.put_floats(c.scale.empty() ? std::vector<float>(m, 0.0f) : c.scale);
    }
    for (std::size_t i = 0; i < c.coefficients.values.size(); ++i) {
      const float v = c.coefficients.values[i];
      switch (cpca.format) {
        case cluster::CoefficientFormat::Float32: clusters.put(v); break;
        case cluster::CoefficientFormat::Float16: clusters.put(cluster::float_to_half(v)); break;
        case cluster::CoefficientFormat::Unorm8: {
          const std::size_t k = i % m;
          const float scale = c.scale[k];
          const float q = scale > 0.0f ? std::clamp(std::round((v - c.offset[k]) / scale), 0.0f, 255.0f) : 0.0f;
          clusters.put(std::uint8_t(q));
          break;
        }
      }
    }
  }
  Writer out;
  for (char ch : kMagic) out.put(ch);
  out.put(kFileVersion);
  out.put(kHeaderBytes);
  out.put(asset.resolution);
  out.put(std::uint32_t(cpca.cols));
  out.put(std::uint32_t(cpca.row_count));
  out.put(std::uint32_t(cpca.clusters.size()));
  out.put(std::uint32_t(cpca.format));
  out.put((centred ? kCentred : 0u) | (cpca.half_basis ? kHalfBasis : 0u));
  out.put(asset.requested_components);
  out.put(asset.requested_energy);
  out.put(std::uint32_t{2});  // sections
  out.put(asset.requested_clusters);
  out.put(checksum(out.bytes));
  put_section(out, kVertexTag, vertices.bytes);
  put_section(out, kClusterTag, clusters.bytes);
  return std::move(out.bytes);
}

Result<Asset> decode(std::span<const std::byte> bytes, std::string_view source) {
  BinaryReader in(bytes, source);
  auto header_bytes = in.take(std::min<std::size_t>(bytes.size(), kHeaderBytes), "the header");
  WEFT_TRY_VOID(check_file_header(bytes, source, {.magic = {kMagic.data(), kMagic.size()}, .kind = "SSDF",
                                                  .version = kFileVersion, .header_bytes = kHeaderBytes}));
  BinaryReader header(*header_bytes, source);
  std::uint32_t fields[13];
  for (auto& f : fields) f = 0;
  (void)header.take(12, "magic and version");
  for (int i = 0; i < 11; ++i) fields[i] = *header.get<std::uint32_t>("a header field");
  const std::uint64_t stored_header_sum = *header.get<std::uint64_t>("the header checksum");
  const std::uint64_t header_sum = checksum(header_bytes->first(kHeaderBytes - 8));
  if (stored_header_sum != header_sum)
    return fail(ErrorKind::Parse, "{}: header checksum mismatch (stored {}, computed {}): the file is corrupt", source,
                hex64(stored_header_sum), hex64(header_sum));
  const std::uint32_t header_size = fields[0], resolution = fields[1], cols = fields[2], vertex_count = fields[3],
                      cluster_count = fields[4], format = fields[5], flags = fields[6], sections = fields[9];
  if (header_size != kHeaderBytes)
    return fail(ErrorKind::Parse, "{}: header size {} (version 1 has {})", source, header_size, kHeaderBytes);
  if (resolution == 0 || std::uint64_t(resolution) * resolution != cols)
    return fail(ErrorKind::Parse, "{}: {} directions do not make a {} x {} grid", source, cols, resolution, resolution);
  if (format > std::uint32_t(cluster::CoefficientFormat::Unorm8))
    return fail(ErrorKind::Parse, "{}: unknown coefficient format {}", source, format);
  if (sections != 2) return fail(ErrorKind::Parse, "{}: {} sections (version 1 has 2)", source, sections);

  Asset asset;
  asset.resolution = resolution;
  asset.requested_components = fields[7];
  asset.requested_energy = std::bit_cast<float>(fields[8]);
  asset.requested_clusters = fields[10];
  auto& cpca = asset.cpca;
  cpca.cols = cols;
  cpca.row_count = vertex_count;
  cpca.format = cluster::CoefficientFormat(format);
  const bool centred = (flags & kCentred) != 0;
  cpca.half_basis = (flags & kHalfBasis) != 0;
  if ((flags & ~(kCentred | kHalfBasis)) != 0) return fail(ErrorKind::Parse, "{}: unknown flags {:#x}", source, flags);
  const std::size_t basis_value_bytes = cpca.half_basis ? 2 : 4;

  std::vector<std::span<const std::byte>> payloads;
  for (std::uint32_t expected_tag : {kVertexTag, kClusterTag}) {
    WEFT_TRY(auto tag, in.get<std::uint32_t>("a section tag"));
    if (tag != expected_tag)
      return fail(ErrorKind::Parse, "{}: found section '{}' where '{}' belongs", source, tag_name(tag),
                  tag_name(expected_tag));
    (void)in.get<std::uint32_t>("a section's reserved field");
    WEFT_TRY(auto size, in.get<std::uint64_t>("a section size"));
    WEFT_TRY(auto sum, in.get<std::uint64_t>("a section checksum"));
    if (size > in.remaining())
      return fail(ErrorKind::Parse, "{}: truncated: section '{}' needs {} bytes, but only {} remain", source,
                  tag_name(tag), size, in.remaining());
    auto payload = *in.take(std::size_t(size), "a section");
    if (const std::uint64_t computed = checksum(payload); computed != sum)
      return fail(ErrorKind::Parse, "{}: section '{}' checksum mismatch (stored {}, computed {}): the file is corrupt",
                  source, tag_name(tag), hex64(sum), hex64(computed));
    payloads.push_back(payload);
  }
  if (in.remaining() != 0) return fail(ErrorKind::Parse, "{}: {} unexpected bytes after the last section", source, in.remaining());

  // Vertices: (cluster, slot) each.
  if (payloads[0].size() != std::uint64_t(vertex_count) * 8)
    return fail(ErrorKind::Parse, "{}: section 'VTX' has {} bytes, {} vertices need {}", source, payloads[0].size(),
                vertex_count, std::uint64_t(vertex_count) * 8);
  BinaryReader vertices(payloads[0], source);
  cpca.cluster_of.resize(vertex_count);
  cpca.slot_of.resize(vertex_count);
  for (std::size_t v = 0; v < vertex_count; ++v) {
    cpca.cluster_of[v] = *vertices.get<std::uint32_t>("a vertex's cluster");
    cpca.slot_of[v] = *vertices.get<std::uint32_t>("a vertex's slot");
    if (cpca.cluster_of[v] >= cluster_count)
      return fail(ErrorKind::Parse, "{}: vertex {} is in cluster {}, but there are {}", source, v, cpca.cluster_of[v],
                  cluster_count);
  }
  // Clusters: at least 8 bytes each, checked before anything is allocated for them.
  if (std::uint64_t(cluster_count) * 8 > payloads[1].size())
    return fail(ErrorKind::Parse, "{}: {} clusters cannot fit in section 'CLS' of {} bytes", source, cluster_count,
                payloads[1].size());
  BinaryReader clusters(payloads[1], source);
  cpca.clusters.resize(cluster_count);
  std::size_t rows_total = 0;
  for (std::size_t c = 0; c < cluster_count; ++c) {
    auto rows = clusters.get<std::uint32_t>("a cluster's row count");
    WEFT_TRY(auto m, rows ? clusters.get<std::uint32_t>("a cluster's component count") : rows);
    if (*rows > vertex_count || m > cols)
      return fail(ErrorKind::Parse, "{}: cluster {} claims {} rows and {} components ({} vertices, {} directions)", source,
                  c, *rows, m, vertex_count, cols);
    rows_total += *rows;
    auto& cluster = cpca.clusters[c];
    if (centred) {
      WEFT_TRY(auto mean, clusters.take(std::size_t(cols) * basis_value_bytes, "a cluster mean"));
      cluster.mean = cpca.half_basis ? halves_of(mean) : floats_of(mean);
    }
    WEFT_TRY(auto basis, clusters.take(std::size_t(m) * cols * basis_value_bytes, "a cluster basis"));
    cluster.basis.rows = m;
    cluster.basis.cols = cols;
    cluster.basis.values = cpca.half_basis ? halves_of(basis) : floats_of(basis);
    if (cpca.format == cluster::CoefficientFormat::Unorm8) {
      WEFT_TRY(auto offset, clusters.take(std::size_t(m) * 4, "8-bit offsets"));
      WEFT_TRY(auto scale, clusters.take(std::size_t(m) * 4, "8-bit scales"));
      cluster.offset = floats_of(offset);
      cluster.scale = floats_of(scale);
    }
    const std::size_t count = std::size_t(*rows) * m;
    WEFT_TRY(auto coefficients, clusters.take(count * cluster::bytes_per_coefficient(cpca.format), "cluster coefficients"));
    cluster.coefficients.rows = *rows;
    cluster.coefficients.cols = m;
    cluster.coefficients.values.resize(count);
    const auto* p = coefficients.data();
    for (std::size_t i = 0; i < count; ++i) {
      float& out = cluster.coefficients.values[i];
      switch (cpca.format) {
        case cluster::CoefficientFormat::Float32: std::memcpy(&out, p + 4 * i, 4); break;
        case cluster::CoefficientFormat::Float16: {
          std::uint16_t h;
          std::memcpy(&h, p + 2 * i, 2);
          out = cluster::half_to_float(h);
          break;
        }
        case cluster::CoefficientFormat::Unorm8: {
          const std::size_t k = i % m;
          out = cluster.offset[k] + cluster.scale[k] * float(std::to_integer<std::uint8_t>(p[i]));
          break;
        }
      }
    }
  }
  if (clusters.remaining() != 0)
    return fail(ErrorKind::Parse, "{}: section 'CLS' has {} bytes left over", source, clusters.remaining());
  if (rows_total != vertex_count)
    return fail(ErrorKind::Parse, "{}: clusters hold {} rows, but there are {} vertices", source, rows_total, vertex_count);
  // Each vertex's slot must be free and inside its cluster; fill the clusters' row lists.
  for (auto& cluster : cpca.clusters) cluster.rows.assign(cluster.coefficients.rows, 0xffffffffu);
  for (std::size_t v = 0; v < vertex_count; ++v) {
    auto& rows = cpca.clusters[cpca.cluster_of[v]].rows;
    if (cpca.slot_of[v] >= rows.size() || rows[cpca.slot_of[v]] != 0xffffffffu)
      return fail(ErrorKind::Parse, "{}: vertex {} has slot {} in cluster {}, which is taken or out of range", source, v,
                  cpca.slot_of[v], cpca.cluster_of[v]);
    rows[cpca.slot_of[v]] = std::uint32_t(v);
  }
  return asset;
}

Result<void> write_file(const std::filesystem::path& path, const Asset& asset) {
  const auto bytes = encode(asset);
  return write_file_atomically(path, {std::span<const std::byte>(bytes)}, "SSDF file");
}

Result<Asset> read_file(const std::filesystem::path& path) {
  WEFT_TRY(auto data, read_input_file(path, "SSDF file"));
  const std::string source = path.string();
  return decode(std::as_bytes(std::span(data)), source);
}

}  // namespace weft::ssdf
