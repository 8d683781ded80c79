// Reads `weft view --script FILE`: every line is checked before the session starts, so a
// typo on line 40 does not surface after a minute of rendering.
module;
#include <charconv>
#include <cmath>
#include <expected>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>
#include <nlohmann/json.hpp>
module weft.viewer;
import weft.core;

namespace weft::viewer {

namespace {
struct Arity {
  std::size_t min, max;
  const char* usage;
};
const std::map<std::string, Arity, std::less<>>& commands() {
  static const std::map<std::string, Arity, std::less<>> table = {
      {"orbit", {2, 2, "orbit DYAW DPITCH"}},   {"pan", {2, 2, "pan RIGHT UP"}},
      {"zoom", {1, 1, "zoom FACTOR"}},          {"fly", {3, 3, "fly FORWARD RIGHT UP"}},
      {"reset", {0, 0, "reset"}},               {"knob", {3, 3, "knob MATERIAL FIELD VALUE"}},
      {"quality", {1, 1, "quality PRESET"}},    {"ui", {1, 1, "ui on|off"}},
      {"resize", {2, 2, "resize W H"}},         {"minimize", {0, 0, "minimize"}},
      {"restore", {0, 0, "restore"}},           {"wait", {1, 1, "wait FRAMES"}},
      {"refine", {0, 0, "refine"}},             {"screenshot", {1, 1, "screenshot PATH"}},
      {"copy", {2, 2, "copy FROM TO"}},         {"compare", {1, 1, "compare MATERIAL"}},
      {"overlay", {1, 1, "overlay on|off"}},         {"quit", {0, 0, "quit"}},
      {"budget", {1, 1, "budget MILLISECONDS"}}, {"show", {1, 1, "show RESOURCE|frame"}},
      {"option", {3, 3, "option PASS OPTION VALUE"}},
      {"accumulate", {1, 1, "accumulate SAMPLES"}}, {"settle", {0, 0, "settle"}},
  };
  return table;
}

bool is_number(const std::string& s) {
  float v = 0;
  auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  // 1e39 is a number, if not a float: is_finite_number refuses it with the better message.
  return (ec == std::errc() || ec == std::errc::result_out_of_range) && end == s.data() + s.size();
}

// from_chars also reads "nan", "inf" and "-infinity", which no camera move, size or budget
// can mean (`orbit nan nan` left the view's pose NaN; issue 33).
bool is_finite_number(const std::string& s) {
  float v = 0;
  auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && end == s.data() + s.size() && std::isfinite(v);
}
// The value of an argument is_finite_number accepted (no exception: from_chars, not stoi).
double value_of(const std::string& s) {
  double v = 0;
  std::from_chars(s.data(), s.data() + s.size(), v);
  return v;
}
// A whole number within [lo, hi]: `resize 99999999999 5` was an uncaught std::out_of_range
// from std::stoi (a crash; issue 33).
bool whole_within(const std::string& s, double lo, double hi) {
  const double v = value_of(s);
  return v >= lo && v <= hi && v == std::floor(v);
}
}  // namespace

Result<Script> parse_script(const std::filesystem::path& path, const std::string& text) {
  Script script{path, {}};
  std::istringstream in(text);
  std::string line;
  int number = 0;
  auto bad = [&](const std::string& why) -> Result<Script> {
    return fail(ErrorKind::Parse, "{}:{}: {}", path.string(), number, why);
  };
  while (std::getline(in, line)) {
    ++number;
    if (auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream words(line);
    ScriptCommand command{{}, {}, number};
    if (!(words >> command.name)) continue;
    for (std::string w; words >> w;) command.args.push_back(w);
    auto it = commands().find(command.name);
    if (it == commands().end()) {
      std::string known;
      for (const auto& [name, _] : commands()) known += (known.empty() ? "" : ", ") + name;
      return bad("unknown command '" + command.name + "' (known: " + known + ")");
    }
    const Arity& a = it->second;
    if (command.args.size() < a.min || command.args.size() > a.max)
      return bad("'" + command.name + "' takes " + std::to_string(a.min) +
                 (a.max != a.min ? "+" : "") + " argument(s): " + a.usage);
    const std::string& n = command.name;
    const bool numeric = n == "orbit" || n == "pan" || n == "zoom" || n == "fly" || n == "resize" || n == "wait" || n == "budget" ||
                         n == "accumulate";
    if (numeric)
      for (const auto& arg : command.args) {
        if (!is_number(arg)) return bad("'" + n + "' expects numbers, got '" + arg + "': " + a.usage);
        if (!is_finite_number(arg)) return bad("'" + n + "' expects finite numbers, got '" + arg + "': " + a.usage);
      }
    if (n == "zoom" && value_of(command.args[0]) <= 0.0) return bad("zoom factor must be > 0");
    if (n == "budget" && !(value_of(command.args[0]) > 0.0)) return bad("budget must be a positive number of milliseconds");
    if (n == "resize" && (!whole_within(command.args[0], 1, 16384) || !whole_within(command.args[1], 1, 16384)))
      return bad("resize needs whole sizes within 1..16384");
    if (n == "accumulate" && !whole_within(command.args[0], 1, 4096))
      return bad("accumulate needs a whole number of samples within 1..4096 (1: off)");
    if (n == "wait" && !whole_within(command.args[0], 0, 1e6)) return bad("wait needs a whole number of frames within 0..1000000");
    // The presets renderer::quality_from_string reads (issue 33: `quality ultra` passed the check
    // and failed only when the line ran, after the window opened).
    if (n == "quality" && command.args[0] != "low" && command.args[0] != "medium" && command.args[0] != "high" &&
        command.args[0] != "reference")
      return bad("quality takes low, medium, high or reference, got '" + command.args[0] + "'");
    if ((n == "ui" || n == "overlay") && command.args[0] != "on" && command.args[0] != "off")
      return bad(n + " takes on or off");
    if (n == "option" && !nlohmann::json::accept(command.args[2]))
      return bad("option value '" + command.args[2] + "' is not JSON (numbers, true/false, or \"quoted\" text)");
    if (n == "knob" && !nlohmann::json::accept(command.args[2]))
      return bad("knob value '" + command.args[2] + "' is not JSON (numbers, true/false, or \"quoted\" text)");
    script.commands.push_back(std::move(command));
  }
  return script;
}

}  // namespace weft::viewer
