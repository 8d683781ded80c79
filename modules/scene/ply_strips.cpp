// PLY files from the Stanford and Cyberware era (igea.ply, ...) store their surface as a
// 'tristrips' element: one long vertex-index list per strip, where -1 starts a new strip.
// OpenMesh reads only 'face' elements, so such a file is rewritten in memory with the strips
// as triangles of a 'face' element (same format and byte order, every other element copied
// byte for byte) and OpenMesh reads that.
module;
#include <cstdint>
#include <expected>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>
#include <fmt/format.h>
module weft.scene;
import weft.core;

namespace weft::scene::detail {
namespace {

bool is_integer_type(std::string_view t) {
  return ply_type_size(t) > 0 && t != "float" && t != "double" && t != "float32" && t != "float64";
}

// Every strip's indices in file order, -1 kept as the restart marker.
Result<std::vector<long long>> read_strip_indices(const std::filesystem::path& path, const PlyLayout& layout,
                                                   const PlyLayout::Element& strips) {
  std::vector<long long> out;
  const auto* data = layout.bytes.data();
  if (layout.format == "ascii") {
    const std::string_view text(reinterpret_cast<const char*>(data) + strips.body_begin, strips.body_end - strips.body_begin);
    std::size_t pos = 0;
    while (pos < text.size()) {
      while (pos < text.size() && (text[pos] == ' ' || text[pos] == '\t' || text[pos] == '\r' || text[pos] == '\n')) ++pos;
      const std::size_t start = pos;
      while (pos < text.size() && text[pos] != ' ' && text[pos] != '\t' && text[pos] != '\r' && text[pos] != '\n') ++pos;
      if (pos == start) break;
      // check_ply has proven each token a number; the lists' counts come first in each item.
      const std::string token(text.substr(start, pos - start));
      double value = std::stod(token);
      if (value != static_cast<double>(static_cast<long long>(value))) {
        return fail(ErrorKind::Parse, "'{}': PLY element 'tristrips': '{}' is not a vertex index", path.string(), token);
      }
      out.push_back(static_cast<long long>(value));
    }
    // Drop each item's list length: walk items.
    std::vector<long long> indices;
    indices.reserve(out.size());
    for (std::size_t i = 0, item = 0; item < strips.count; ++item) {
      const long long n = out.at(i++);
      for (long long k = 0; k < n; ++k) indices.push_back(out.at(i++));
      indices.push_back(-1);
    }
    return indices;
  }
  const bool big_endian = layout.format == "binary_big_endian";
  const PlyLayout::Property& list = strips.properties[0];
  const auto count_size = std::size_t(ply_type_size(list.count_type));
  const auto value_size = std::size_t(ply_type_size(list.type));
  std::size_t pos = strips.body_begin;
  for (std::size_t item = 0; item < strips.count; ++item) {
    const long long n = ply_binary_integer(data + pos, list.count_type, big_endian);
    pos += count_size;
    for (long long k = 0; k < n; ++k, pos += value_size) out.push_back(ply_binary_integer(data + pos, list.type, big_endian));
    out.push_back(-1);
  }
  return out;
}

void put_int32(std::string& out, std::int32_t value, bool big_endian) {
  const auto u = static_cast<std::uint32_t>(value);
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(u >> (8 * (big_endian ? 3 - i : i))));
}

}  // namespace

Result<std::optional<std::string>> ply_strips_as_faces(const std::filesystem::path& path, const PlyLayout& layout) {
  const PlyLayout::Element* strips = nullptr;
  const PlyLayout::Element* vertices = nullptr;
  for (const auto& e : layout.elements) {
    if (e.name == "tristrips") strips = &e;
    if (e.name == "vertex") vertices = &e;
  }
  if (!strips) return std::nullopt;
  for (const auto& e : layout.elements) {
    if (e.name == "face") {
      return fail(ErrorKind::Unsupported, "'{}': PLY has both a 'face' and a 'tristrips' element (weft reads one or the other)",
                  path.string());
    }
  }
  if (!vertices) return fail(ErrorKind::Parse, "'{}': PLY element 'tristrips' needs a 'vertex' element to index", path.string());
  if (strips->properties.size() != 1 || !strips->properties[0].list || !is_integer_type(strips->properties[0].type)) {
    return fail(ErrorKind::Parse, "'{}': PLY element 'tristrips' must have exactly one property, a list of integer vertex indices",
                path.string());
  }
  auto indices = read_strip_indices(path, layout, *strips);
  if (!indices) return std::unexpected(indices.error());

  // Triangle k of a strip is (s[k], s[k+1], s[k+2]), every second one turned around so all
  // keep the strip's winding; triangles with a repeated vertex (joins between strips) are
  // dropped, as a strip renderer would draw nothing there.
  std::vector<std::int32_t> triangles;
  std::size_t in_strip = 0;
  for (std::size_t i = 0; i < indices->size(); ++i) {
    const long long v = (*indices)[i];
    if (v == -1) {
      in_strip = 0;
      continue;
    }
    if (v < 0 || static_cast<std::size_t>(v) >= vertices->count) {
      return fail(ErrorKind::Parse, "'{}': PLY element 'tristrips': vertex index {} (entry {}) is outside 0 to {}", path.string(), v,
                  i, vertices->count == 0 ? 0 : vertices->count - 1);
    }
    if (++in_strip < 3) continue;
    const auto a = std::int32_t((*indices)[i - 2]), b = std::int32_t((*indices)[i - 1]), c = std::int32_t(v);
    if (a == b || b == c || a == c) continue;
    if (in_strip % 2 == 1) triangles.insert(triangles.end(), {a, b, c});
    else triangles.insert(triangles.end(), {b, a, c});
  }

  const std::string_view text(reinterpret_cast<const char*>(layout.bytes.data()), layout.bytes.size());
  const bool ascii = layout.format == "ascii";
  const bool big_endian = layout.format == "binary_big_endian";
  const std::size_t face_count = triangles.size() / 3;
  std::string out;
  out.reserve(layout.bytes.size() + face_count * 16);
  out.append(text.substr(0, layout.elements.front().header_begin));
  for (const auto& e : layout.elements) {
    if (&e == strips) out += fmt::format("element face {}\nproperty list uchar int vertex_indices\n", face_count);
    else out.append(text.substr(e.header_begin, e.header_end - e.header_begin));
  }
  out += "end_header\n";
  for (const auto& e : layout.elements) {
    if (&e != strips) {
      out.append(text.substr(e.body_begin, e.body_end - e.body_begin));
      if (ascii) out.push_back('\n');
      continue;
    }
    for (std::size_t t = 0; t < face_count; ++t) {
      if (ascii) {
        out += fmt::format("3 {} {} {}\n", triangles[3 * t], triangles[3 * t + 1], triangles[3 * t + 2]);
      } else {
        out.push_back(3);
        for (int k = 0; k < 3; ++k) put_int32(out, triangles[3 * t + std::size_t(k)], big_endian);
      }
    }
  }
  return out;
}

}  // namespace weft::scene::detail
