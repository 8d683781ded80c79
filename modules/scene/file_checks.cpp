// Checks of mesh files before OpenMesh reads them. Debian's OpenMesh 9 readers trust their
// input: on some corrupt files they loop forever (a PLY header that ends early, an OFF file
// with garbage counts), allocate without bound (a PLY list length of -3) or abort on an
// assertion (an OBJ face corner without a vertex index). Each check walks the file's
// grammar, strictly, and turns what would hurt into a Parse error naming file and line.
module;
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>
#include <fmt/format.h>
module weft.scene;
import weft.core;

namespace weft::scene {
namespace detail {

int ply_type_size(std::string_view t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

// A binary integer of PLY type `t` (a count type) at `p`.
long long ply_binary_integer(const unsigned char* p, std::string_view t, bool big_endian) {
  const int size = ply_type_size(t);
  std::uint64_t u = 0;
  for (int i = 0; i < size; ++i) u |= std::uint64_t(p[big_endian ? i : size - 1 - i]) << (8 * (size - 1 - i));
  const bool is_signed = t == "char" || t == "int8" || t == "short" || t == "int16" || t == "int" || t == "int32";
  if (is_signed && size < 8 && (u >> (8 * size - 1)) != 0) return static_cast<long long>(u) - (1ll << (8 * size));
  return static_cast<long long>(u);
}

// OpenMesh's PLY reader loops forever on a header that ends early or is malformed, and
// trusts every list count in the body (a corrupt count of -3 becomes a 4-billion-entry
// list and the process runs out of memory). So the whole file is checked against the PLY
// grammar first: magic, format, comment/obj_info, element and property lines up to
// end_header; then every element's values, ASCII tokens or binary bytes, with list counts
// from 0 to 4096 (a 'tristrips' element's list, which weft turns into faces itself, may be
// as long as the file).
Result<PlyLayout> check_ply(const std::filesystem::path& path) {
  auto file = weft::read_input_file(path, "mesh file");
  if (!file) return std::unexpected(file.error());
  PlyLayout layout;
  layout.bytes = std::move(*file);
  const std::vector<unsigned char>* bytes = &layout.bytes;
  const std::string_view text(reinterpret_cast<const char*>(bytes->data()), bytes->size());
  const auto bad = [&](std::size_t line, std::string_view why) -> Result<PlyLayout> {
    return fail(ErrorKind::Parse, "'{}': PLY header line {}: {}", path.string(), line, why);
  };
  std::size_t pos = 0, line_number = 0;
  std::string_view format;
  std::vector<PlyLayout::Element>& elements = layout.elements;
  bool header_done = false;
  while (!header_done) {
    const std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos || end > (1u << 16)) return bad(line_number + 1, "the header has no end_header line");
    std::string_view line = text.substr(pos, end - pos);
    const std::size_t line_begin = pos;
    pos = end + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    for (char c : line) {
      if (static_cast<unsigned char>(c) < 0x20 && c != '\t') return bad(line_number, "control character in the header");
    }
    std::vector<std::string_view> words;
    for (std::size_t i = 0; i < line.size();) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
      if (j > i) words.push_back(line.substr(i, j - i));
      i = j;
    }
    if (line_number == 1) {
      if (line != "ply") return bad(1, "not a PLY file (no 'ply' magic)");
      continue;
    }
    if (line_number == 2) {
      if (words.size() != 3 || words[0] != "format" ||
          (words[1] != "ascii" && words[1] != "binary_little_endian" && words[1] != "binary_big_endian") ||
          words[2] != "1.0") {
        return bad(2, "expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
      }
      format = words[1];
      continue;
    }
    if (words.empty()) return bad(line_number, "empty line");
    if (words[0] == "comment" || words[0] == "obj_info") continue;
    if (words[0] == "end_header") {
      if (words.size() != 1) return bad(line_number, "text after end_header");
      if (elements.empty()) return bad(line_number, "no element declared");
      elements.back().header_end = line_begin;
      header_done = true;
    } else if (words[0] == "element") {
      if (words.size() != 3 || words[2].empty() || words[2].size() > 10 ||
          !std::all_of(words[2].begin(), words[2].end(), [](char c) { return c >= '0' && c <= '9'; })) {
        return bad(line_number, "expected 'element <name> <count>'");
      }
      PlyLayout::Element e;
      e.name = words[1];
      e.header_begin = line_begin;
      if (!elements.empty()) elements.back().header_end = line_begin;
      e.count = std::stoull(std::string(words[2]));
      if (e.count > bytes->size()) return bad(line_number, "the element count is larger than the file could hold");
      elements.push_back(std::move(e));
    } else if (words[0] == "property") {
      if (elements.empty()) return bad(line_number, "a property before any element");
      const bool scalar = words.size() == 3 && ply_type_size(words[1]) > 0;
      const bool list = words.size() == 5 && words[1] == "list" && ply_type_size(words[2]) > 0 &&
                        ply_type_size(words[3]) > 0 && words[2] != "float" && words[2] != "double" &&
                        words[2] != "float32" && words[2] != "float64";
      if (!scalar && !list) return bad(line_number, "expected 'property <type> <name>' or 'property list <integer type> <type> <name>'");
      elements.back().properties.push_back(list ? PlyLayout::Property{true, std::string(words[2]), std::string(words[3]), std::string(words[4])}
                                                : PlyLayout::Property{false, {}, std::string(words[1]), std::string(words[2])});
    } else {
      return bad(line_number, "unknown keyword");
    }
  }

  layout.format = std::string(format);
  layout.body_begin = pos;
  constexpr long long max_face_list = 4096;
  const auto body_error = [&](std::string_view why) -> Result<PlyLayout> {
    return fail(ErrorKind::Parse, "'{}': PLY data: {}", path.string(), why);
  };
  if (format == "ascii") {
    const auto next_token = [&]() -> std::string_view {
      while (pos < text.size() && (text[pos] == ' ' || text[pos] == '\t' || text[pos] == '\r' || text[pos] == '\n')) ++pos;
      const std::size_t start = pos;
      while (pos < text.size() && text[pos] != ' ' && text[pos] != '\t' && text[pos] != '\r' && text[pos] != '\n') ++pos;
      return text.substr(start, pos - start);
    };
    const auto number = [](std::string_view t) {
      double v = 0.0;
      const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
      return !t.empty() && ec == std::errc() && ptr == t.data() + t.size();
    };
    for (std::size_t e = 0; e < elements.size(); ++e) {
      elements[e].body_begin = pos;
      const long long max_list = elements[e].name == "tristrips" ? static_cast<long long>(text.size()) : max_face_list;
      for (std::size_t item = 0; item < elements[e].count; ++item) {
        for (const PlyLayout::Property& prop : elements[e].properties) {
          long long n = 1;
          if (prop.list) {
            const std::string_view t = next_token();
            const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), n);
            if (t.empty() || ec != std::errc() || ptr != t.data() + t.size() || n < 0 || n > max_list) {
              return body_error(fmt::format("element '{}' item {}: '{}' is not a list length (0 to {})", elements[e].name, item, t.substr(0, 20), max_list));
            }
          }
          for (long long k = 0; k < n; ++k) {
            const std::string_view t = next_token();
            if (t.empty()) return body_error(fmt::format("the file ends in element '{}' item {}", elements[e].name, item));
            if (!number(t)) return body_error(fmt::format("element '{}' item {}: '{}' is not a number", elements[e].name, item, t.substr(0, 20)));
          }
        }
      }
      elements[e].body_end = pos;
    }
  } else {
    const bool big_endian = format == "binary_big_endian";
    for (std::size_t e = 0; e < elements.size(); ++e) {
      elements[e].body_begin = pos;
      const long long max_list = elements[e].name == "tristrips" ? static_cast<long long>(bytes->size()) : max_face_list;
      for (std::size_t item = 0; item < elements[e].count; ++item) {
        for (const PlyLayout::Property& prop : elements[e].properties) {
          long long n = 1;
          if (prop.list) {
            const auto size = std::size_t(ply_type_size(prop.count_type));
            if (bytes->size() - pos < size) return body_error(fmt::format("the file ends in element '{}' item {}", elements[e].name, item));
            n = ply_binary_integer(bytes->data() + pos, prop.count_type, big_endian);
            pos += size;
            if (n < 0 || n > max_list) {
              return body_error(fmt::format("element '{}' item {}: list length {} is outside 0 to {}", elements[e].name, item, n, max_list));
            }
          }
          const std::size_t size = std::size_t(n) * std::size_t(ply_type_size(prop.type));
          if (bytes->size() - pos < size) return body_error(fmt::format("the file ends in element '{}' item {}", elements[e].name, item));
          pos += size;
        }
      }
      elements[e].body_end = pos;
    }
  }
  return layout;
}

// The numbers of an OBJ "v", "vt" or "vn" line (up to a '#' comment): each a finite number.
static Result<void> check_obj_numbers(const std::filesystem::path& path, std::size_t line_number, std::string_view line) {
  const std::size_t comment = line.find('#');
  if (comment != std::string_view::npos) line = line.substr(0, comment);
  const std::size_t keyword_end = line.find_first_of(" \t");
  const std::string_view keyword = line.substr(0, keyword_end);
  for (std::size_t i = keyword_end; i < line.size();) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    std::size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
    if (j == i) break;
    const std::string_view token = line.substr(i, j - i);
    i = j;
    const std::string_view digits = token.starts_with('+') ? token.substr(1) : token;
    double value = 0.0;
    const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
    if (ec != std::errc() || ptr != digits.data() + digits.size() || !std::isfinite(value)) {
      return fail(ErrorKind::Parse, "'{}': line {}: '{}' in a '{}' line is not a finite number", path.string(), line_number,
                  token.substr(0, 40), keyword);
    }
  }
  return {};
}

// Debian's OpenMesh is built with assertions, and its OBJ reader asserts (aborting the
// process) on a face corner without a vertex index ("f /1/1 ..."); every face line is
// checked first: each corner is v, v/vt, v//vn or v/vt/vn with integer indices. OpenMesh
// also drops a vertex it cannot read ("v nan nan nan"), so that its faces later look out of
// range: every v, vt and vn number must be a finite number.
Result<void> check_obj(const std::filesystem::path& path) {
  auto bytes = weft::read_input_file(path, "mesh file");
  if (!bytes) return std::unexpected(bytes.error());
  const std::string_view text(reinterpret_cast<const char*>(bytes->data()), bytes->size());
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; };
  // An optionally negative integer of 1 to 9 digits.
  const auto is_index = [](std::string_view t) {
    if (!t.empty() && t.front() == '-') t.remove_prefix(1);
    return !t.empty() && t.size() <= 9 && std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  std::size_t pos = 0, line_number = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    std::size_t i = 0;
    while (i < line.size() && is_space(line[i])) ++i;
    const std::string_view rest = line.substr(i);
    if (rest.starts_with("v ") || rest.starts_with("v\t") || rest.starts_with("vt ") || rest.starts_with("vn ")) {
      if (auto ok = check_obj_numbers(path, line_number, rest); !ok) return ok;
      continue;
    }
    if (i + 1 >= line.size() || line[i] != 'f' || !is_space(line[i + 1])) continue;
    for (i += 1; i < line.size();) {
      while (i < line.size() && is_space(line[i])) ++i;
      std::size_t j = i;
      while (j < line.size() && !is_space(line[j])) ++j;
      if (j == i) break;
      const std::string_view corner = line.substr(i, j - i);
      i = j;
      const std::size_t a = corner.find('/');
      const std::size_t b = a == std::string_view::npos ? a : corner.find('/', a + 1);
      bool ok = is_index(corner.substr(0, a));
      if (ok && a != std::string_view::npos) {
        const std::string_view vt = corner.substr(a + 1, b == std::string_view::npos ? std::string_view::npos : b - a - 1);
        ok = vt.empty() ? b != std::string_view::npos : is_index(vt);
        if (ok && b != std::string_view::npos) ok = is_index(corner.substr(b + 1));
      }
      if (!ok) {
        return fail(ErrorKind::Parse, "'{}': line {}: bad face corner '{}' (expected v, v/vt, v//vn or v/vt/vn)",
                    path.string(), line_number, corner.substr(0, 40));
      }
    }
  }
  return {};
}

// OpenMesh's OFF reader trusts the counts line (and reads garbage counts from a file that
// ends before it), looping billions of times; the file is checked first: the OFF keyword
// with its optional prefixes, counts the file could hold, then the vertex and face lines.
Result<void> check_off(const std::filesystem::path& path) {
  auto bytes = weft::read_input_file(path, "mesh file");
  if (!bytes) return std::unexpected(bytes.error());
  const std::string_view text(reinterpret_cast<const char*>(bytes->data()), bytes->size());
  const auto bad = [&](std::string_view why) -> Result<void> {
    return fail(ErrorKind::Parse, "'{}': OFF header: {}", path.string(), why);
  };
  std::size_t pos = 0;
  // The next whitespace-separated word, skipping '#' comments.
  const auto next_word = [&]() -> std::string_view {
    while (pos < text.size()) {
      const char c = text[pos];
      if (c == '#') {
        while (pos < text.size() && text[pos] != '\n') ++pos;
      } else if (c == ' ' || c == '\t' || c == '\r' || c == '\n') {
        ++pos;
      } else {
        break;
      }
    }
    const std::size_t start = pos;
    while (pos < text.size() && text[pos] != ' ' && text[pos] != '\t' && text[pos] != '\r' && text[pos] != '\n') ++pos;
    return text.substr(start, pos - start);
  };
  std::string_view keyword = next_word();
  if (keyword.size() < 3 || keyword.substr(keyword.size() - 3) != "OFF") return bad("the file does not start with OFF");
  std::string_view prefix = keyword.substr(0, keyword.size() - 3);
  if (prefix.starts_with("ST")) prefix.remove_prefix(2);
  for (char flag : {'C', 'N', '4', 'n'}) {
    if (!prefix.empty() && prefix.front() == flag) prefix.remove_prefix(1);
  }
  if (!prefix.empty()) return bad(fmt::format("unknown keyword '{}'", keyword));
  const std::size_t line_end = text.find('\n', pos);
  const bool binary = text.substr(pos, line_end == std::string_view::npos ? text.size() - pos : line_end - pos).find("BINARY") !=
                      std::string_view::npos;
  if (binary) return bad("binary OFF is not read by weft");
  if (keyword.find('n') != std::string_view::npos) (void)next_word();  // the dimension of nOFF
  // What a vertex line holds, as OpenMesh reads it token by token (a short line makes it read
  // the next line's numbers and lose its place: a hang found by fuzz_off): the position, a
  // normal for N, a colour of 3 or 4 components for C, a texture coordinate for ST.
  const std::string_view flags = keyword.substr(0, keyword.size() - 3);
  const bool free_dimension = flags.find('n') != std::string_view::npos;
  const std::size_t vertex_numbers = (flags.find('4') != std::string_view::npos ? 4 : 3) +
                                     (flags.find('N') != std::string_view::npos ? 3 : 0) +
                                     (flags.find('C') != std::string_view::npos ? 3 : 0) + (flags.starts_with("ST") ? 2 : 0);
  const bool colour = flags.find('C') != std::string_view::npos;
  std::size_t counts[3] = {0, 0, 0};
  int c = 0;
  std::size_t counts_start = 0;
  for (const char* what : {"vertex", "face", "edge"}) {
    const std::string_view word = next_word();
    if (c == 0) counts_start = pos - word.size();
    if (word.empty() || word.size() > 10 || !std::all_of(word.begin(), word.end(), [](char ch) { return ch >= '0' && ch <= '9'; })) {
      return bad(fmt::format("expected the {} count, got '{}'", what, word.substr(0, 20)));
    }
    counts[c] = std::stoull(std::string(word));
    if (counts[c++] > bytes->size()) return bad(fmt::format("the {} count is larger than the file could hold", what));
  }
  // OpenMesh reads the three counts from one line; spread over two it reads other numbers as
  // counts and never returns ("OFF 1\n1 5\n...": found by fuzz_off).
  if (text.substr(counts_start, pos - counts_start).find('\n') != std::string_view::npos)
    return bad("the vertex, face and edge counts must stand on one line");
  // An empty mesh is of no use to a scene, and OpenMesh's reader never returns from one whose
  // counts share the keyword's line with nothing after it ("OFF 0 0 0\n": found by fuzz_off).
  if (counts[0] == 0 || counts[1] == 0)
    return bad(fmt::format("the mesh is empty: {} vertices, {} faces", counts[0], counts[1]));

  // The body, line by line: OpenMesh reads it token by token and trusts every count in it
  // (a face "6-4" makes the next face's corner count -4, read four billion times).
  const auto fail_at = [&](std::size_t line, std::string_view why) -> Result<void> {
    return fail(ErrorKind::Parse, "'{}': OFF line {}: {}", path.string(), line, why);
  };
  std::size_t line_number = 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + std::ptrdiff_t(pos), '\n'));
  const std::size_t first_line_end = text.find('\n', pos);
  pos = first_line_end == std::string_view::npos ? text.size() : first_line_end + 1;
  std::size_t vertices_seen = 0, faces_seen = 0;
  std::vector<std::string_view> tokens;
  while (faces_seen < counts[1] || vertices_seen < counts[0]) {
    if (pos >= text.size()) {
      return fail_at(line_number + 1, vertices_seen < counts[0]
                                          ? fmt::format("the file ends after {} of {} vertices", vertices_seen, counts[0])
                                          : fmt::format("the file ends after {} of {} faces", faces_seen, counts[1]));
    }
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    tokens.clear();
    for (std::size_t i = 0; i < line.size();) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
      if (j > i) tokens.push_back(line.substr(i, j - i));
      i = j;
    }
    if (tokens.empty() || tokens[0].front() == '#') continue;
    for (std::size_t k = 0; k < tokens.size(); ++k)
      if (tokens[k].front() == '#') tokens.resize(k);  // a comment at the end of the line
    if (vertices_seen < counts[0]) {
      if (tokens.size() < 3) return fail_at(line_number, "a vertex needs 3 coordinates");
      const bool numbers_fit = tokens.size() == vertex_numbers || (colour && tokens.size() == vertex_numbers + 1);
      if (!free_dimension && !numbers_fit)
        return fail_at(line_number, fmt::format("a {} vertex is {} numbers{}, this line has {}", keyword, vertex_numbers,
                                                colour ? " (or one more: the colour's alpha)" : "", tokens.size()));
      const std::size_t check = free_dimension ? 3 : tokens.size();
      for (std::size_t k = 0; k < check; ++k) {
        float value = 0.0f;
        const auto [ptr, ec] = std::from_chars(tokens[k].data(), tokens[k].data() + tokens[k].size(), value);
        if (ec != std::errc() || ptr != tokens[k].data() + tokens[k].size()) {
          return fail_at(line_number, fmt::format("'{}' is not a number", tokens[k].substr(0, 20)));
        }
      }
      ++vertices_seen;
      continue;
    }
    const auto integer = [](std::string_view t, long long& out) {
      const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), out);
      return ec == std::errc() && ptr == t.data() + t.size();
    };
    long long corners = 0;
    if (!integer(tokens[0], corners) || corners < 1 || corners > 4096) {
      return fail_at(line_number, fmt::format("'{}' is not a face's corner count", tokens[0].substr(0, 20)));
    }
    if (corners < 3) return fail_at(line_number, fmt::format("a face of {} corners (a face needs 3 or more)", corners));
    if (tokens.size() < std::size_t(corners) + 1) return fail_at(line_number, "the face has fewer indices than its count");
    for (long long k = 1; k <= corners; ++k) {
      long long index = 0;
      if (!integer(tokens[std::size_t(k)], index) || index < 0 || std::size_t(index) >= counts[0]) {
        return fail_at(line_number, fmt::format("'{}' is not a vertex index below {}", tokens[std::size_t(k)].substr(0, 20), counts[0]));
      }
    }
    ++faces_seen;
  }
  return {};
}

}  // namespace detail

}  // namespace weft::scene
