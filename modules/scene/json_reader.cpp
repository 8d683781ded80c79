// JsonReader: typed, defaulted, range-checked reads of JSON objects, with every problem
// recorded at its JSON path so a whole file is reported at once.
module;
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
module weft.scene;
import weft.core;

namespace weft::scene {
namespace {

bool identifier(std::string_view key) {
  if (key.empty() || std::isdigit(static_cast<unsigned char>(key[0]))) return false;
  return std::all_of(key.begin(), key.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

// "[1, 256]" / "(0, 180)" for intervals, ": must be > 0" for one-sided ranges.
std::string describe_range(const Range& r) {
  const bool has_min = std::isfinite(r.min), has_max = std::isfinite(r.max);
  if (has_min && has_max) {
    return fmt::format(" {}{}, {}{}", r.min_exclusive ? '(' : '[', r.min, r.max, r.max_exclusive ? ')' : ']');
  }
  if (has_min) return fmt::format(": must be {} {}", r.min_exclusive ? ">" : ">=", r.min);
  if (has_max) return fmt::format(": must be {} {}", r.max_exclusive ? "<" : "<=", r.max);
  return ": must be finite";
}

// Scene values are stored as 32-bit floats: a larger finite number would become infinity.
constexpr double max_float = double(std::numeric_limits<float>::max());
std::string too_large(double v) {
  return fmt::format("{} is too large: the limit is {:.3g} in magnitude (values are stored as 32-bit floats)", v, max_float);
}

bool in_range(double v, const Range& r) {
  if (!std::isfinite(v)) return false;
  if (r.min_exclusive ? !(v > r.min) : !(v >= r.min)) return false;
  if (r.max_exclusive ? !(v < r.max) : !(v <= r.max)) return false;
  return true;
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      const bool same = std::tolower(static_cast<unsigned char>(a[i - 1])) == std::tolower(static_cast<unsigned char>(b[j - 1]));
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (same ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

}  // namespace

std::string_view json_type_name(const nlohmann::json& value) { return value.type_name(); }

void JsonErrors::add(std::string_view json_path, std::string_view message) {
  lines_.push_back(fmt::format("{}: {}", json_path, message));
}

Error JsonErrors::to_error(std::string_view source) const {
  return Error{ErrorKind::Parse, fmt::format("{}: {} problem{}:\n{}", source, lines_.size(), lines_.size() == 1 ? "" : "s",
                                             fmt::join(lines_, "\n"))};
}

JsonReader::JsonReader(const nlohmann::json& value, std::string json_path, JsonErrors& errors, std::filesystem::path base_dir)
    : value_(&value), path_(std::move(json_path)), errors_(&errors), base_dir_(std::move(base_dir)) {}

std::string JsonReader::path_of(std::string_view key) const {
  if (identifier(key)) return fmt::format("{}.{}", path_, key);
  std::string escaped;
  for (char c : key) {
    if (c == '\'' || c == '\\') escaped.push_back('\\');
    escaped.push_back(c);
  }
  return fmt::format("{}['{}']", path_, escaped);
}

bool JsonReader::expect_object() {
  if (value_->is_object()) return true;
  if (!reported_not_object_) {
    reported_not_object_ = true;
    error(fmt::format("expected an object, got {}", json_type_name(*value_)));
  }
  return false;
}

const nlohmann::json* JsonReader::find(std::string_view key) {
  known_.emplace(key);
  if (!expect_object()) return nullptr;
  const auto it = value_->find(std::string(key));
  return it == value_->end() ? nullptr : &*it;
}

bool JsonReader::has(std::string_view key) { return find(key) != nullptr; }

bool JsonReader::require(std::string_view key) {
  if (find(key) != nullptr) return true;
  if (value_->is_object()) error_at(key, "missing required field");
  return false;
}

const nlohmann::json* JsonReader::value(std::string_view key) { return find(key); }

double JsonReader::number(std::string_view key, double fallback, Range range) {
  const nlohmann::json* v = find(key);
  if (v == nullptr) return fallback;
  if (!v->is_number()) {
    error_at(key, fmt::format("expected a number, got {}", json_type_name(*v)));
    return fallback;
  }
  const double d = v->get<double>();
  if (std::isfinite(d) && std::abs(d) > max_float) {
    error_at(key, too_large(d));
    return fallback;
  }
  if (!in_range(d, range)) {
    error_at(key, fmt::format("{} is out of range{}", d, describe_range(range)));
    return fallback;
  }
  return d;
}

std::int64_t JsonReader::integer(std::string_view key, std::int64_t fallback, Range range) {
  const nlohmann::json* v = find(key);
  if (v == nullptr) return fallback;
  if (!v->is_number()) {
    error_at(key, fmt::format("expected an integer, got {}", json_type_name(*v)));
    return fallback;
  }
  double d = 0.0;
  if (v->is_number_unsigned()) {
    d = static_cast<double>(v->get<std::uint64_t>());
  } else if (v->is_number_integer()) {
    d = static_cast<double>(v->get<std::int64_t>());
  } else {
    d = v->get<double>();
    if (!std::isfinite(d) || d != std::floor(d)) {
      error_at(key, fmt::format("expected an integer, got {}", d));
      return fallback;
    }
  }
  if (!in_range(d, range) || std::abs(d) > 9.0e15) {
    error_at(key, fmt::format("{} is out of range{}", d, describe_range(range)));
    return fallback;
  }
  return static_cast<std::int64_t>(d);
}

bool JsonReader::boolean(std::string_view key, bool fallback) {
  const nlohmann::json* v = find(key);
  if (v == nullptr) return fallback;
  if (!v->is_boolean()) {
    error_at(key, fmt::format("expected true or false, got {}", json_type_name(*v)));
    return fallback;
  }
  return v->get<bool>();
}

std::string JsonReader::string(std::string_view key, std::string fallback, std::initializer_list<std::string_view> choices) {
  const nlohmann::json* v = find(key);
  if (v == nullptr) return fallback;
  if (!v->is_string()) {
    error_at(key, fmt::format("expected a string, got {}", json_type_name(*v)));
    return fallback;
  }
  std::string s = v->get<std::string>();
  if (choices.size() > 0 && std::find(choices.begin(), choices.end(), std::string_view(s)) == choices.end()) {
    error_at(key, fmt::format("'{}' is not one of: {}", s, fmt::join(choices, ", ")));
    return fallback;
  }
  return s;
}

namespace {

// Reads an array of exactly N numbers into `out`; records problems through the reader.
template <int N>
bool read_numbers(JsonReader& reader, std::string_view key, const nlohmann::json& v, const Range& range, float* out) {
  if (!v.is_array() || v.size() != std::size_t(N)) {
    if (v.is_array()) {
      reader.error_at(key, fmt::format("expected an array of {} numbers, got an array of {}", N, v.size()));
    } else {
      reader.error_at(key, fmt::format("expected an array of {} numbers, got {}", N, json_type_name(v)));
    }
    return false;
  }
  bool ok = true;
  for (int i = 0; i < N; ++i) {
    const nlohmann::json& e = v[std::size_t(i)];
    const std::string at = fmt::format("{}[{}]", reader.path_of(key), i);
    if (!e.is_number()) {
      reader.errors().add(at, fmt::format("expected a number, got {}", json_type_name(e)));
      ok = false;
      continue;
    }
    const double d = e.get<double>();
    if (std::isfinite(d) && std::abs(d) > max_float) {
      reader.errors().add(at, too_large(d));
      ok = false;
      continue;
    }
    if (!in_range(d, range)) {
      reader.errors().add(at, fmt::format("{} is out of range{}", d, describe_range(range)));
      ok = false;
      continue;
    }
    out[i] = static_cast<float>(d);
  }
  return ok;
}

}  // namespace

vec2 JsonReader::vec2_of(std::string_view key, vec2 fallback, Range range) {
  const nlohmann::json* v = find(key);
  vec2 out = fallback;
  if (v == nullptr || !read_numbers<2>(*this, key, *v, range, &out.x)) return fallback;
  return out;
}

vec3 JsonReader::vec3_of(std::string_view key, vec3 fallback, Range range) {
  const nlohmann::json* v = find(key);
  vec3 out = fallback;
  if (v == nullptr || !read_numbers<3>(*this, key, *v, range, &out.x)) return fallback;
  return out;
}

vec4 JsonReader::vec4_of(std::string_view key, vec4 fallback, Range range) {
  const nlohmann::json* v = find(key);
  vec4 out = fallback;
  if (v == nullptr || !read_numbers<4>(*this, key, *v, range, &out.x)) return fallback;
  return out;
}

std::filesystem::path JsonReader::path(std::string_view key, bool must_exist) {
  const nlohmann::json* v = find(key);
  if (v == nullptr) return {};
  if (!v->is_string()) {
    error_at(key, fmt::format("expected a path (a string), got {}", json_type_name(*v)));
    return {};
  }
  const std::string text = v->get<std::string>();
  if (text.empty()) {
    error_at(key, "the path is empty");
    return {};
  }
  std::filesystem::path p(text);
  if (p.is_relative()) p = base_dir_ / p;
  p = p.lexically_normal();
  std::error_code ec;
  if (must_exist && !std::filesystem::exists(p, ec)) {
    error_at(key, fmt::format("file not found: '{}'", p.string()));
    return {};
  }
  // A FIFO or a device would block or never end when read: refused here, with the field's
  // JSON path. A folder passes (a BTF image set is one); its reader says when it wants a file.
  if (must_exist && !std::filesystem::is_directory(p, ec)) {
    if (auto ok = weft::check_input_file(p, "file"); !ok) {
      error_at(key, ok.error().message);
      return {};
    }
  }
  return p;
}

std::optional<JsonReader> JsonReader::object(std::string_view key) {
  const nlohmann::json* v = find(key);
  if (v == nullptr) return std::nullopt;
  if (!v->is_object()) {
    error_at(key, fmt::format("expected an object, got {}", json_type_name(*v)));
    return std::nullopt;
  }
  return JsonReader(*v, path_of(key), *errors_, base_dir_);
}

std::vector<JsonReader> JsonReader::array(std::string_view key) {
  const nlohmann::json* v = find(key);
  std::vector<JsonReader> out;
  if (v == nullptr) return out;
  if (!v->is_array()) {
    error_at(key, fmt::format("expected an array, got {}", json_type_name(*v)));
    return out;
  }
  const std::string base = path_of(key);
  out.reserve(v->size());
  for (std::size_t i = 0; i < v->size(); ++i) out.emplace_back((*v)[i], fmt::format("{}[{}]", base, i), *errors_, base_dir_);
  return out;
}

std::vector<std::pair<std::string, JsonReader>> JsonReader::members() {
  std::vector<std::pair<std::string, JsonReader>> out;
  if (!expect_object()) return out;
  for (const auto& [name, v] : value_->items()) {
    known_.insert(name);
    out.emplace_back(name, JsonReader(v, path_of(name), *errors_, base_dir_));
  }
  return out;
}

nlohmann::json JsonReader::rest(std::initializer_list<std::string_view> except) {
  nlohmann::json out = nlohmann::json::object();
  if (!expect_object()) return out;
  for (const auto& [name, v] : value_->items()) {
    known_.insert(name);
    if (std::find(except.begin(), except.end(), std::string_view(name)) == except.end()) out[name] = v;
  }
  return out;
}

void JsonReader::error_at(std::string_view key, std::string_view message) { errors_->add(path_of(key), message); }

void JsonReader::error(std::string_view message) { errors_->add(path_, message); }

void JsonReader::finish() {
  if (!value_->is_object()) return;
  for (const auto& [name, v] : value_->items()) {
    if (known_.contains(name)) continue;
    std::string_view best;
    std::size_t best_distance = std::numeric_limits<std::size_t>::max();
    for (const std::string& k : known_) {
      const std::size_t d = edit_distance(name, k);
      if (d < best_distance) {
        best_distance = d;
        best = k;
      }
    }
    const std::size_t allowed = std::max<std::size_t>(2, name.size() / 3);
    if (!best.empty() && best_distance <= allowed) {
      error_at(name, fmt::format("unknown field (did you mean '{}'?)", best));
    } else if (!known_.empty()) {
      error_at(name, fmt::format("unknown field (known fields: {})", fmt::join(known_, ", ")));
    } else {
      error_at(name, "unknown field");
    }
  }
}

}  // namespace weft::scene
