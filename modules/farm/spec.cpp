// The sweep spec reader: trade-off studies (scenes x one feature x knob values, listed or
// crossed) checked against the feature registry's knob tables before anything runs. Every
// problem is collected and reported at once, each at its JSON path.
module;
#include <algorithm>
#include <cmath>
#include <expected>
#include <filesystem>
#include <set>
#include <string>
#include <string_view>
#include <vector>
#include <nlohmann/json.hpp>
#include <weft/text_input.h>
module weft.farm;
import weft.core;
import weft.tradeoff;
import weft.feature;

namespace weft::farm {

using json = nlohmann::json;

namespace {

struct Problems {
  std::vector<std::string> lines;
  void add(std::string path, std::string why) { lines.push_back(std::move(path) + ": " + std::move(why)); }
};

void replace_all(std::string& s, std::string_view what, std::string_view with) {
  for (std::size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + with.size()))
    s.replace(at, what.size(), with);
}

// "values"/"cross": {knob: [v, ...]} -> "knob=v1,v2" for `weft tradeoff`.
std::vector<std::string> knob_lists(const tradeoff::Study& study, const json& node, const std::string& at,
                                    Problems& problems) {
  std::vector<std::string> out;
  if (!node.is_object()) {
    problems.add(at, "expected an object of knob name -> array of values");
    return out;
  }
  for (const auto& [name, values] : node.items()) {
    const std::string path = at + "." + name;
    auto knob = tradeoff::find_knob(study, name);
    if (!knob) {
      problems.add(path, knob.error().message);
      continue;
    }
    if (!values.is_array() || values.empty()) {
      problems.add(path, "expected a non-empty array of values");
      continue;
    }
    std::string text = name + "=";
    bool ok = true;
    for (std::size_t i = 0; i < values.size(); ++i) {
      json v = values[i];
      // 4.0 for an integer knob is 4; anything else is the knob's check to judge.
      if ((*knob)->kind == tradeoff::KnobKind::Integer && v.is_number_float() && std::isfinite(v.get<double>()) &&
          std::floor(v.get<double>()) == v.get<double>() && std::abs(v.get<double>()) < 1e15)
        v = std::int64_t(v.get<double>());
      if (auto checked = tradeoff::check_knob_value(**knob, v); !checked) {
        problems.add(weft::format("{}[{}]", path, i), checked.error().message);
        ok = false;
        continue;
      }
      const std::string t = tradeoff::value_text(v);
      if (t.find(',') != std::string::npos) {
        problems.add(weft::format("{}[{}]", path, i), "a value may not contain ','");
        ok = false;
        continue;
      }
      text += (i ? "," : "") + t;
    }
    if (ok) out.push_back(text);
  }
  return out;
}

// Hashes a file's bytes, or a folder's files (names, then bytes) in name order.
void hash_input(Hasher& h, const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec)) {
    if (auto bytes = read_input_file(path, "bake input")) h.bytes(bytes->data(), bytes->size());
    return;
  }
  std::vector<std::filesystem::path> files;
  for (std::filesystem::recursive_directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec))
    if (it->is_regular_file(ec)) files.push_back(it->path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    h.str(std::filesystem::relative(f, path, ec).string());
    hash_input(h, f);
  }
}

void read_bakes(const json& node, const std::filesystem::path& base_dir, Problems& problems, std::vector<BakeSpec>& out) {
  if (!node.is_array() || node.empty()) {
    problems.add("$.bakes", "expected a non-empty array of bakes");
    return;
  }
  std::string known;
  std::set<std::string> names;
  for (const FeatureDescriptor* f : feature_registry().all())
    for (const BakeCommand& b : f->bakes)
      if (names.insert(b.name).second) known += (known.empty() ? "" : ", ") + b.name;
  std::set<std::string> outputs;
  for (std::size_t i = 0; i < node.size(); ++i) {
    const std::string at = weft::format("$.bakes[{}]", i);
    const json& b = node[i];
    if (!b.is_object()) {
      problems.add(at, "expected an object with \"bake\", \"args\" and \"output\"");
      continue;
    }
    for (const auto& [key, value] : b.items())
      if (key != "bake" && key != "args" && key != "output") problems.add(at + "." + key, "unknown field (known: bake, args, output)");
    BakeSpec spec;
    spec.json_path = at;
    if (!b.contains("bake") || !b["bake"].is_string() || !names.contains(b["bake"].get<std::string>()))
      problems.add(at + ".bake", weft::format("expected one of the registered bakes ({}), got {}", known,
                                              b.contains("bake") ? b["bake"].dump() : "nothing"));
    else
      spec.bake = b["bake"].get<std::string>();
    Hasher h;
    h.str("weft bake task 1").str(spec.bake);
    if (b.contains("args")) {
      const json& args = b["args"];
      if (!args.is_array()) {
        problems.add(at + ".args", "expected an array of strings (the bake's options, `weft bake NAME --help`)");
      } else {
        for (std::size_t k = 0; k < args.size(); ++k) {
          const std::string p = weft::format("{}.args[{}]", at, k);
          if (!args[k].is_string()) {
            problems.add(p, "expected a string");
            continue;
          }
          std::string arg = args[k].get<std::string>();
          if (arg == "-o" || arg == "--output" || arg.starts_with("--output=") || (arg.starts_with("-o") && arg.size() > 2 && arg[2] != '-')) {
            problems.add(p, "the farm names the bake's output: give it as \"output\"");
            continue;
          }
          h.str(arg);
          std::error_code ec;
          const std::filesystem::path file = std::filesystem::path(arg).is_absolute() ? std::filesystem::path(arg) : base_dir / arg;
          if (!arg.empty() && arg[0] != '-' && std::filesystem::exists(file, ec)) {
            arg = std::filesystem::absolute(file, ec).string();
            hash_input(h, file);
          }
          spec.args.push_back(std::move(arg));
        }
      }
    }
    if (!b.contains("output") || !b["output"].is_string() || b["output"].get<std::string>().empty() ||
        !std::filesystem::path(b["output"].get<std::string>()).has_extension()) {
      problems.add(at + ".output", "expected the baked file's path, with its extension (.wbtf, .wssdf, .exr)");
    } else {
      const std::filesystem::path o = b["output"].get<std::string>();
      spec.output = std::filesystem::absolute(o.is_absolute() ? o : base_dir / o);
      if (!outputs.insert(spec.output.lexically_normal().string()).second)
        problems.add(at + ".output", weft::format("'{}' is the output of an earlier bake too", o.string()));
      h.str(spec.output.extension().string());
    }
    spec.id = hex64(h.digest());
    out.push_back(std::move(spec));
  }
}

}  // namespace

Result<SweepSpec> parse_sweep_spec(std::string_view text, std::string_view source, const std::filesystem::path& base_dir) {
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::parse_error& e) {
    return fail(ErrorKind::Parse, "{}: not JSON ({})", source, e.what());
  }
  Problems problems;
  SweepSpec sweep;
  std::vector<StudySpec>& out = sweep.studies;
  if (!doc.is_object()) return fail(ErrorKind::Parse, "{}: $: expected an object with \"version\" and \"studies\" or \"bakes\"", source);
  for (const auto& [key, value] : doc.items())
    if (key != "version" && key != "studies" && key != "bakes") problems.add("$." + key, "unknown field (known: version, studies, bakes)");
  if (!doc.contains("version") || doc["version"] != 1) problems.add("$.version", "expected 1");
  if (doc.contains("bakes")) read_bakes(doc["bakes"], base_dir, problems, sweep.bakes);
  if (!doc.contains("studies") && doc.contains("bakes")) {
    // a bake-only spec
  } else if (!doc.contains("studies") || !doc["studies"].is_array() || doc["studies"].empty()) {
    problems.add("$.studies", "expected a non-empty array of studies");
  } else {
    const json& studies = doc["studies"];
    for (std::size_t i = 0; i < studies.size(); ++i) {
      const std::string at = weft::format("$.studies[{}]", i);
      const json& s = studies[i];
      if (!s.is_object()) {
        problems.add(at, "expected an object with \"scenes\" and \"feature\"");
        continue;
      }
      static const std::set<std::string> known = {"scene", "scenes", "feature", "size", "frames", "exposure",
                                                  "values", "cross", "out"};
      for (const auto& [key, value] : s.items())
        if (!known.contains(key))
          problems.add(at + "." + key, "unknown field (known: scene, scenes, feature, size, frames, exposure, values, cross, out)");
      StudySpec base;
      base.json_path = at;
      const tradeoff::Study* study = nullptr;
      if (!s.contains("feature") || !s["feature"].is_string()) {
        problems.add(at + ".feature", "expected the feature's name (weft tradeoff --list)");
      } else if (auto found = tradeoff::find_study(s["feature"].get<std::string>()); !found) {
        problems.add(at + ".feature", found.error().message);
      } else {
        study = *found;
        base.feature = study->feature;
      }
      if (s.contains("size")) {
        const json& v = s["size"];
        const auto x = v.is_string() ? v.get<std::string>().find('x') : std::string::npos;
        bool good = x != std::string::npos;
        if (good) {
          const std::string t = v.get<std::string>();
          for (std::size_t k = 0; k < t.size(); ++k) good = good && (k == x || (t[k] >= '0' && t[k] <= '9'));
          good = good && x > 0 && x + 1 < t.size() && x <= 5 && t.size() - x - 1 <= 5;
          if (good) {
            const int w = std::stoi(t.substr(0, x)), h = std::stoi(t.substr(x + 1));
            good = w >= 1 && h >= 1 && w <= 16384 && h <= 16384;
          }
        }
        if (!good) problems.add(at + ".size", weft::format("expected \"WxH\" with each side 1 to 16384, got {}", v.dump()));
        else base.size = v.get<std::string>();
      }
      if (s.contains("frames")) {
        const json& v = s["frames"];
        if (!v.is_number_integer() || v.get<std::int64_t>() < 1 || v.get<std::int64_t>() > 1000)
          problems.add(at + ".frames", weft::format("expected an integer in [1, 1000], got {}", v.dump()));
        else base.frames = unsigned(v.get<std::int64_t>());
      }
      if (s.contains("exposure")) {
        const json& v = s["exposure"];
        if (!v.is_number() || !(v.get<double>() > 0.0) || v.get<double>() > 1e6)
          problems.add(at + ".exposure", weft::format("expected a number in (0, 1e6], got {}", v.dump()));
        else base.exposure = v.get<double>();
      }
      if (study) {
        if (s.contains("values")) base.values = knob_lists(*study, s["values"], at + ".values", problems);
        if (s.contains("cross")) base.cross = knob_lists(*study, s["cross"], at + ".cross", problems);
      }
      std::vector<std::pair<std::string, std::string>> scenes;  // path, JSON path
      if (s.contains("scene") && s.contains("scenes")) problems.add(at + ".scene", "give \"scene\" or \"scenes\", not both");
      if (s.contains("scene")) {
        if (!s["scene"].is_string() || s["scene"].get<std::string>().empty()) problems.add(at + ".scene", "expected a scene file's path");
        else scenes.emplace_back(s["scene"].get<std::string>(), at + ".scene");
      } else if (s.contains("scenes")) {
        const json& list = s["scenes"];
        if (!list.is_array() || list.empty()) problems.add(at + ".scenes", "expected a non-empty array of scene files");
        else
          for (std::size_t k = 0; k < list.size(); ++k) {
            const std::string p = weft::format("{}.scenes[{}]", at, k);
            if (!list[k].is_string() || list[k].get<std::string>().empty()) problems.add(p, "expected a scene file's path");
            else scenes.emplace_back(list[k].get<std::string>(), p);
          }
      } else {
        problems.add(at + ".scenes", "expected the scene files to study");
      }
      std::string out_pattern = "tradeoff-{feature}-{scene}";
      if (s.contains("out")) {
        if (!s["out"].is_string() || s["out"].get<std::string>().empty()) problems.add(at + ".out", "expected a folder's path");
        else out_pattern = s["out"].get<std::string>();
      }
      if (scenes.size() > 1 && out_pattern.find("{scene}") == std::string::npos)
        problems.add(at + ".out", "several scenes write one folder: put \"{scene}\" in it");
      for (const auto& [scene, path] : scenes) {
        StudySpec spec = base;
        spec.json_path = path;
        spec.scene = std::filesystem::path(scene).is_absolute() ? std::filesystem::path(scene) : base_dir / scene;
        if (auto ok = check_input_file(spec.scene, "scene file"); !ok) problems.add(path, ok.error().message);
        std::string o = out_pattern;
        replace_all(o, "{scene}", spec.scene.stem().string());
        replace_all(o, "{feature}", base.feature);
        spec.out = std::filesystem::path(o).is_absolute() ? std::filesystem::path(o) : base_dir / o;
        out.push_back(std::move(spec));
      }
    }
  }
  if (!problems.lines.empty()) {
    std::string message;
    for (const auto& l : problems.lines) message += (message.empty() ? "" : "; ") + l;
    return fail(ErrorKind::Parse, "{}: {}", source, message);
  }
  return sweep;
}

Result<SweepSpec> read_sweep_spec(const std::filesystem::path& path) {
  if (auto why = binary_text_input(path, "sweep spec")) return fail(ErrorKind::Parse, "{}", *why);
  auto bytes = read_input_file(path, "sweep spec");
  if (!bytes) return std::unexpected(bytes.error());
  return parse_sweep_spec(std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size()), path.string(),
                          path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path());
}

}  // namespace weft::farm
