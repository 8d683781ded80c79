// A check of a JSON text's shape before a reader builds values from it: nesting depth
// (tinygltf converts JSON into its own values recursively, so a glTF nested 20,000 deep
// overflows the stack) and repeated keys in one object (nlohmann::json keeps the last one
// silently; JSON readers disagree on which wins, and glTF 2.0 forbids them). It walks the
// text with nlohmann's SAX parser, which keeps its own stack on the heap; syntax errors are
// left to the reader that follows, which reports them in its own words.
module;
#include <cstddef>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <string>
#include <string_view>
#include <unordered_set>
#include <vector>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <weft/text_input.h>
module weft.scene;
import weft.core;

namespace weft::scene::detail {
namespace {

class StructureCheck {
 public:
  explicit StructureCheck(std::size_t max_depth) : max_depth_(max_depth) {}

  bool null() { return value(); }
  bool boolean(bool) { return value(); }
  bool number_integer(std::int64_t) { return value(); }
  bool number_unsigned(std::uint64_t) { return value(); }
  bool number_float(double, const std::string&) { return value(); }
  bool string(std::string&) { return value(); }
  bool binary(nlohmann::json::binary_t&) { return value(); }
  bool start_object(std::size_t) { return open(true); }
  bool start_array(std::size_t) { return open(false); }
  bool end_object() { return close(); }
  bool end_array() { return close(); }
  bool key(std::string& name) {
    Frame& f = frames_.back();
    if (!f.keys.insert(name).second) {
      f.key.clear();  // the path names the object
      problem_ = fmt::format("{}: the key '{}' appears twice in one object (JSON keys must be unique)", path(), name);
      return false;
    }
    f.key = name;
    return true;
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::json::exception&) { return false; }

  [[nodiscard]] const std::string& problem() const { return problem_; }

 private:
  struct Frame {
    bool object = false;
    std::size_t index = 0;  // arrays: the number of elements seen so far
    std::string key;        // objects: the key being read
    std::unordered_set<std::string> keys;
  };

  // Counts an element of the enclosing array (so a path names it).
  bool value() {
    if (!frames_.empty() && !frames_.back().object) ++frames_.back().index;
    return true;
  }
  bool open(bool object) {
    value();
    if (frames_.size() >= max_depth_) {
      problem_ = fmt::format("{}: nested deeper than {} levels", path(), max_depth_);
      return false;
    }
    frames_.push_back(Frame{object, 0, {}, {}});
    return true;
  }
  bool close() {
    frames_.pop_back();
    return true;
  }
  // "$.nodes[3].extras" for where the walk is.
  std::string path() const {
    std::string out = "$";
    for (const Frame& f : frames_) {
      if (out.size() > 200) return out + "...";
      if (f.object && !f.key.empty()) out += "." + f.key;
      else if (f.index > 0) out += fmt::format("[{}]", f.index - 1);
    }
    return out;
  }

  std::size_t max_depth_;
  std::vector<Frame> frames_;
  std::string problem_;
};

}  // namespace

Result<void> check_json_structure(std::string_view text, std::size_t max_depth) {
  StructureCheck check(max_depth);
  try {
    (void)nlohmann::json::sax_parse(text.begin(), text.end(), &check);
  } catch (const std::exception&) {
    return {};  // the reader reports the syntax error
  }
  if (!check.problem().empty()) return fail(ErrorKind::Parse, "{}", check.problem());
  return {};
}

}  // namespace weft::scene::detail

namespace weft::scene {
Result<void> check_json_text(std::string_view text, std::size_t max_depth) { return detail::check_json_structure(text, max_depth); }
Result<std::string> read_text_file(const std::filesystem::path& path, std::string_view what) {
  if (auto why = weft::binary_text_input(path, what)) return fail(ErrorKind::Parse, "{}", *why);
  auto bytes = weft::read_input_file(path, what);
  if (!bytes) return std::unexpected(bytes.error());
  return std::string(reinterpret_cast<const char*>(bytes->data()), bytes->size());
}
}  // namespace weft::scene
