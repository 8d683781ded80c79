// The pipeline file (docs/pipelines.md): read with weft.scene's JsonReader so every problem
// of a file is reported at once at its JSON path, then checked as a frame -- types, options,
// slots, formats and sizes of connected slots, required inputs, cycles, outputs, passes that
// reach no output -- before anything is created.
module;
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <exception>
#include <expected>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include <nlohmann/json.hpp>
module weft.pipeline;
import weft.core;
import weft.gpu;
import weft.scene;

namespace weft::pipeline {

std::optional<SlotRef> parse_slot_ref(std::string_view text) {
  const auto trim = [](std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
  };
  text = trim(text);
  const auto dot = text.rfind('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 == text.size()) return std::nullopt;
  return SlotRef{std::string(trim(text.substr(0, dot))), std::string(trim(text.substr(dot + 1)))};
}

const PipelinePass* Pipeline::find(std::string_view pass) const {
  for (const auto& p : passes)
    if (p.name == pass) return &p;
  return nullptr;
}

std::optional<SlotRef> Pipeline::source_of(const SlotRef& input) const {
  for (const auto& c : connections)
    if (c.to == input) return c.from;
  return std::nullopt;
}

std::optional<gpu::Format> Pipeline::format_of(const SlotRef& output) const {
  SlotRef at = output;
  for (std::size_t hops = 0; hops <= passes.size(); ++hops) {
    const PipelinePass* p = find(at.pass);
    if (!p) return std::nullopt;
    const Slot* slot = find_output(*p->type, at.slot);
    if (!slot) return std::nullopt;
    if (slot->same_as.empty()) return slot->formats.front();
    auto from = source_of({at.pass, slot->same_as});
    if (!from) return std::nullopt;
    at = *from;
  }
  return std::nullopt;  // a cycle: reported by the reader
}

namespace {

constexpr std::size_t max_pipeline_depth = 64;

bool identifier(std::string_view s) {
  return !s.empty() && !std::isdigit(static_cast<unsigned char>(s[0])) &&
         std::all_of(s.begin(), s.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

std::string formats_text(const std::vector<gpu::Format>& formats) {
  std::string out;
  for (auto f : formats) out += (out.empty() ? "" : ", ") + std::string(gpu::to_string(f));
  return out;
}

std::string slot_names(const std::vector<Slot>& slots) {
  std::string out;
  for (const auto& s : slots) out += (out.empty() ? "" : ", ") + s.name;
  return out.empty() ? "none" : out;
}

// Reads one option with its table entry's kind and range (or choices).
nlohmann::json read_option(scene::JsonReader& r, const PassOption& o) {
  switch (o.kind) {
    case KnobKind::Number:
      return r.number(o.name, o.default_value.get<double>(), {.min = o.min, .max = o.max});
    case KnobKind::Integer:
      return r.integer(o.name, std::int64_t(o.default_value.get<double>()), {.min = o.min, .max = o.max});
    case KnobKind::Boolean:
      return r.boolean(o.name, o.default_value.get<bool>());
    case KnobKind::Choice: {
      const nlohmann::json* v = r.value(o.name);
      if (!v) return o.default_value;
      if (!v->is_string() || std::find(o.choices.begin(), o.choices.end(), v->get<std::string>()) == o.choices.end()) {
        std::string list;
        for (const auto& c : o.choices) list += (list.empty() ? "'" : ", '") + c + "'";
        r.error_at(o.name, weft::format("expected one of {}, got {}", list, v->dump()));
        return o.default_value;
      }
      return *v;
    }
  }
  return o.default_value;
}

struct Reading {
  scene::JsonErrors errors;
  Pipeline pipeline;
  std::map<std::string, std::string, std::less<>> pass_path;  // pass -> "$.passes.name"
  std::vector<std::string> connection_path;                   // by connection
};

void read_passes(scene::JsonReader& root, const std::vector<std::string>& order, Reading& reading) {
  auto passes = root.object("passes");
  if (!passes) {
    if (!root.has("passes")) root.error_at("passes", "missing required field (the frame's passes, by name)");
    return;
  }
  auto members = passes->members();
  std::stable_sort(members.begin(), members.end(), [&](const auto& a, const auto& b) {
    return std::find(order.begin(), order.end(), a.first) < std::find(order.begin(), order.end(), b.first);
  });
  if (members.empty()) passes->error("a pipeline needs at least one pass");
  for (auto& [name, r] : members) {
    reading.pass_path[name] = r.json_path();
    if (!identifier(name)) {
      r.error("a pass name is letters, digits and '_' (connections write it as 'pass.slot')");
      continue;
    }
    if (!r.is_object()) {
      r.error(weft::format("expected an object with \"type\", got {}", scene::json_type_name(r.json())));
      continue;
    }
    if (!r.require("type")) continue;
    const std::string type = r.string("type");
    PipelinePass pass{name, pass_type_registry().find(type), {}};
    if (!pass.type) {
      r.error_at("type", weft::format("unknown pass type '{}' (registered: {}; plugins loaded: {}; --plugin or "
                                      "WEFT_PLUGIN_PATH loads more)",
                                      type, pass_type_registry().names(), loaded_plugin_names()));
      (void)r.value("options");
      r.finish();
      continue;
    }
    nlohmann::json values = nlohmann::json::object();
    auto options = r.object("options");
    for (const auto& o : pass.type->options) {
      if (options) values[o.name] = read_option(*options, o);
      else values[o.name] = o.default_value;
    }
    if (options) options->finish();
    r.finish();
    pass.options = PassOptions(std::move(values));
    reading.pipeline.passes.push_back(std::move(pass));
  }
}

void read_connections(scene::JsonReader& root, Reading& reading) {
  for (scene::JsonReader& c : root.array("connections")) {
    const auto& v = c.json();
    const std::string text = v.is_string() ? v.get<std::string>() : std::string{};
    const auto arrow = text.find("->");
    std::optional<SlotRef> from, to;
    if (arrow != std::string::npos) {
      from = parse_slot_ref(std::string_view(text).substr(0, arrow));
      to = parse_slot_ref(std::string_view(text).substr(arrow + 2));
    }
    if (!v.is_string() || !from || !to) {
      c.error(weft::format("a connection is a string \"pass.output -> pass.input\", got {}", v.dump()));
      continue;
    }
    reading.pipeline.connections.push_back({*from, *to});
    reading.connection_path.push_back(c.json_path());
  }
}

void read_outputs(scene::JsonReader& root, Reading& reading) {
  if (!root.has("outputs")) {
    root.error_at("outputs", "missing required field (the frame's image, e.g. [\"tonemap.color\"])");
    return;
  }
  auto outputs = root.array("outputs");
  if (outputs.empty() && root.json().at("outputs").is_array()) root.error_at("outputs", "name at least one output");
  for (scene::JsonReader& o : outputs) {
    const auto& v = o.json();
    auto ref = v.is_string() ? parse_slot_ref(v.get<std::string>()) : std::nullopt;
    if (!ref) {
      o.error(weft::format("an output is a string \"pass.slot\", got {}", v.dump()));
      continue;
    }
    const PipelinePass* p = reading.pipeline.find(ref->pass);
    if (!p) {
      if (!reading.pass_path.contains(ref->pass)) o.error(weft::format("no pass is called '{}'", ref->pass));
      continue;
    }
    if (!find_output(*p->type, ref->slot)) {
      o.error(weft::format("pass '{}' ({}) has no output '{}' (outputs: {})", ref->pass, p->type->name, ref->slot,
                           slot_names(p->type->outputs)));
      continue;
    }
    reading.pipeline.outputs.push_back(*ref);
  }
}

// Each connection's two ends exist and are an output and an input; an input takes one
// connection. Bad connections are dropped (their problem reported) so later checks see only
// good ones.
void check_connections(Reading& reading) {
  auto& p = reading.pipeline;
  std::vector<Connection> good;
  std::vector<std::string> good_paths;
  std::map<std::string, std::string> connected;  // "pass.input" -> its connection's path
  for (std::size_t i = 0; i < p.connections.size(); ++i) {
    const auto& c = p.connections[i];
    const std::string& at = reading.connection_path[i];
    bool ok = true;
    const auto check_end = [&](const SlotRef& ref, bool output) {
      const PipelinePass* pass = p.find(ref.pass);
      if (!pass) {
        if (!reading.pass_path.contains(ref.pass)) {
          std::string names;
          for (const auto& [n, path] : reading.pass_path) names += (names.empty() ? "" : ", ") + n;
          reading.errors.add(at, weft::format("no pass is called '{}' (passes: {})", ref.pass, names.empty() ? "none" : names));
        }
        ok = false;  // a pass whose own entry is broken has its error there
        return;
      }
      const auto& type = *pass->type;
      if (output ? find_output(type, ref.slot) : find_input(type, ref.slot)) return;
      ok = false;
      if (output && find_input(type, ref.slot))
        reading.errors.add(at, weft::format("'{}' is an input of {}; a connection goes from an output to an input",
                                            ref.text(), type.name));
      else if (!output && find_output(type, ref.slot))
        reading.errors.add(at, weft::format("'{}' is an output of {}; a connection goes from an output to an input",
                                            ref.text(), type.name));
      else
        reading.errors.add(at, weft::format("pass '{}' ({}) has no {} '{}' ({}s: {})", ref.pass, type.name,
                                            output ? "output" : "input", ref.slot, output ? "output" : "input",
                                            slot_names(output ? type.outputs : type.inputs)));
    };
    check_end(c.from, true);
    check_end(c.to, false);
    if (!ok) continue;
    auto [it, inserted] = connected.emplace(c.to.text(), at);
    if (!inserted) {
      reading.errors.add(at, weft::format("input '{}' is connected already (by {}); an input takes one connection",
                                          c.to.text(), it->second));
      continue;
    }
    good.push_back(c);
    good_paths.push_back(at);
  }
  p.connections = std::move(good);
  reading.connection_path = std::move(good_paths);
}

// Passes in an order where every pass comes after the passes feeding it (file order where
// that leaves a choice); a cycle is named pass by pass and slot by slot.
void order_passes(Reading& reading) {
  auto& p = reading.pipeline;
  const std::size_t n = p.passes.size();
  std::map<std::string, std::size_t, std::less<>> index;
  for (std::size_t i = 0; i < n; ++i) index[p.passes[i].name] = i;
  std::vector<std::vector<std::size_t>> feeds(n);  // connection indices leaving each pass
  std::vector<std::size_t> waiting(n, 0);
  for (std::size_t c = 0; c < p.connections.size(); ++c) {
    feeds[index.at(p.connections[c].from.pass)].push_back(c);
    ++waiting[index.at(p.connections[c].to.pass)];
  }
  std::vector<std::size_t> order;
  std::vector<bool> placed(n, false);
  for (bool progress = true; progress && order.size() < n;) {
    progress = false;
    for (std::size_t i = 0; i < n; ++i) {
      if (placed[i] || waiting[i] != 0) continue;
      placed[i] = true;
      order.push_back(i);
      for (std::size_t c : feeds[i]) --waiting[index.at(p.connections[c].to.pass)];
      progress = true;
      break;  // restart from the top: file order among the ready ones
    }
  }
  if (order.size() < n) {
    // Walk back from a pass still waiting along connections between unplaced passes until a
    // pass repeats: that loop is a cycle.
    std::size_t at = 0;
    while (placed[at]) ++at;
    std::vector<std::size_t> trail_conn;
    std::vector<std::size_t> seen_at(n, ~std::size_t(0));
    for (std::size_t step = 0;; ++step) {
      if (seen_at[at] != ~std::size_t(0)) break;
      seen_at[at] = step;
      std::size_t via = ~std::size_t(0);
      for (std::size_t c = 0; c < p.connections.size(); ++c)
        if (p.connections[c].to.pass == p.passes[at].name && !placed[index.at(p.connections[c].from.pass)]) {
          via = c;
          break;
        }
      trail_conn.push_back(via);
      at = index.at(p.connections[via].from.pass);
    }
    // trail_conn[k] enters the pass met at step k; the cycle starts where `at` was first met.
    std::vector<std::size_t> cycle(trail_conn.begin() + std::ptrdiff_t(seen_at[at]), trail_conn.end());
    std::reverse(cycle.begin(), cycle.end());
    std::string text, passes_in;
    for (std::size_t c : cycle) {
      text += (text.empty() ? "" : ", ") + p.connections[c].from.text() + " -> " + p.connections[c].to.text();
      passes_in += (passes_in.empty() ? "'" : ", '") + p.connections[c].to.pass + "'";
    }
    reading.errors.add(reading.connection_path[cycle.front()],
                       weft::format("the passes {} feed each other in a cycle: {}", passes_in, text));
    return;
  }
  std::vector<PipelinePass> sorted;
  for (std::size_t i : order) sorted.push_back(std::move(p.passes[i]));
  p.passes = std::move(sorted);
}

// What an output's texture is sized by, following same_as back to its source.
SlotSize size_of(const Pipeline& p, SlotRef at) {
  for (std::size_t hops = 0; hops <= p.passes.size(); ++hops) {
    const PipelinePass* pass = p.find(at.pass);
    const Slot* slot = pass ? find_output(*pass->type, at.slot) : nullptr;
    if (!slot) return SlotSize::Any;
    if (slot->same_as.empty()) return slot->size;
    auto from = p.source_of({at.pass, slot->same_as});
    if (!from) return SlotSize::Any;
    at = *from;
  }
  return SlotSize::Any;
}

void check_frame(Reading& reading) {
  auto& p = reading.pipeline;
  for (const auto& pass : p.passes)
    for (const auto& in : pass.type->inputs)
      if (!in.optional && !p.source_of({pass.name, in.name}))
        reading.errors.add(reading.pass_path.at(pass.name),
                           weft::format("required input '{}' of {} is not connected (add a connection \"PASS.OUTPUT -> {}.{}\")",
                                        in.name, pass.type->name, pass.name, in.name));
  for (std::size_t i = 0; i < p.connections.size(); ++i) {
    const auto& c = p.connections[i];
    const Slot& in = *find_input(*p.find(c.to.pass)->type, c.to.slot);
    const auto format = p.format_of(c.from);
    if (format && !in.formats.empty() && std::find(in.formats.begin(), in.formats.end(), *format) == in.formats.end())
      reading.errors.add(reading.connection_path[i],
                         weft::format("format mismatch: '{}' is {}, but '{}' takes {}", c.from.text(),
                                      gpu::to_string(*format), c.to.text(), formats_text(in.formats)));
    if (in.size == SlotSize::Frame && size_of(p, c.from) != SlotSize::Frame)
      reading.errors.add(reading.connection_path[i],
                         weft::format("size mismatch: '{}' is not the frame's size (its pass sizes it), but '{}' "
                                      "needs a texture of the frame's size",
                                      c.from.text(), c.to.text()));
  }
  if (!p.outputs.empty()) {
    const auto format = p.format_of(p.outputs.front());
    if (format && *format != gpu::Format::RGBA8Unorm)
      reading.errors.add("$.outputs[0]", weft::format("the frame's image '{}' is {}; it must be rgba8unorm (end the "
                                                      "frame with a tonemap pass, and name other resources after it)",
                                                      p.outputs.front().text(), gpu::to_string(*format)));
  }
  // An input that gets an accepted format its pass is not made for (Slot::intended_formats).
  for (const auto& pass : p.passes)
    for (const Slot& slot : pass.type->inputs) {
      if (slot.intended_formats.empty()) continue;
      const auto from = p.source_of(SlotRef{pass.name, slot.name});
      const auto format = from ? p.format_of(*from) : std::nullopt;
      if (!format || std::find(slot.intended_formats.begin(), slot.intended_formats.end(), *format) !=
                         slot.intended_formats.end())
        continue;
      p.warnings.push_back(weft::format("{}: {}: pass '{}' ({}) gets {} from '{}' in its input '{}': {}", p.source,
                                        reading.pass_path.at(pass.name), pass.name, pass.type->name,
                                        gpu::to_string(*format), from->text(), slot.name, slot.intended_why));
    }
  // Passes from which no output can be reached are culled by the graph: say so now.
  std::set<std::string> reaches;
  for (const auto& o : p.outputs) reaches.insert(o.pass);
  for (auto it = p.passes.rbegin(); it != p.passes.rend(); ++it)
    for (const auto& c : p.connections)
      if (c.from.pass == it->name && reaches.contains(c.to.pass)) reaches.insert(it->name);
  for (const auto& pass : p.passes)
    if (!reaches.contains(pass.name))
      p.warnings.push_back(weft::format("{}: {}: pass '{}' reaches no output; it is culled", p.source,
                                        reading.pass_path.at(pass.name), pass.name));
}

std::string json_error_text(const std::exception& e) {
  std::string text = e.what();
  if (text.starts_with("[json.exception.")) {
    const auto close = text.find("] ");
    if (close != std::string::npos) text = text.substr(close + 2);
  }
  return text;
}

}  // namespace

Result<Pipeline> parse_pipeline(std::string_view text, std::string_view source) {
  if (auto ok = scene::check_json_text(text, max_pipeline_depth); !ok)
    return fail(ErrorKind::Parse, "{}: {}", source, ok.error().message);
  nlohmann::json root;
  std::vector<std::string> order;  // the file's order of $.passes
  try {
    root = nlohmann::json::parse(text.begin(), text.end());
    const auto ordered = nlohmann::ordered_json::parse(text.begin(), text.end());
    if (ordered.is_object() && ordered.contains("passes") && ordered["passes"].is_object())
      for (const auto& [name, value] : ordered["passes"].items()) order.push_back(name);
  } catch (const std::exception& e) {
    return fail(ErrorKind::Parse, "{}: invalid JSON: {}", source, json_error_text(e));
  }
  Reading reading;
  reading.pipeline.source = std::string(source);
  if (!root.is_object()) {
    reading.errors.add("$", weft::format("a pipeline file is a JSON object, got {}", scene::json_type_name(root)));
    return std::unexpected(reading.errors.to_error(source));
  }
  scene::JsonReader r(root, "$", reading.errors);
  reading.pipeline.description = r.string("description");
  (void)r.string("$schema");
  read_passes(r, order, reading);
  read_connections(r, reading);
  read_outputs(r, reading);
  r.finish();
  check_connections(reading);
  if (reading.errors.size() == 0) order_passes(reading);
  if (reading.errors.size() == 0) check_frame(reading);
  if (reading.errors.size() != 0) return std::unexpected(reading.errors.to_error(source));
  Hasher h;
  h.bytes(text.data(), text.size());
  reading.pipeline.content_hash = h.digest();
  return std::move(reading.pipeline);
}

Result<Pipeline> load_pipeline(const std::filesystem::path& path) {
  auto bytes = scene::read_text_file(path, "pipeline file");
  if (!bytes) return std::unexpected(bytes.error());
  return parse_pipeline(*bytes, path.string());
}

Result<Pipeline> default_pipeline() { return parse_pipeline(default_pipeline_text(), "(default pipeline)"); }

std::string to_json(const Pipeline& p) {
  nlohmann::ordered_json root = nlohmann::ordered_json::object();
  if (!p.description.empty()) root["description"] = p.description;
  nlohmann::ordered_json passes = nlohmann::ordered_json::object();
  for (const auto& pass : p.passes) {
    nlohmann::ordered_json entry = {{"type", pass.type->name}};
    nlohmann::ordered_json options = nlohmann::ordered_json::object();
    for (const auto& o : pass.type->options) options[o.name] = pass.options.json().at(o.name);
    if (!options.empty()) entry["options"] = std::move(options);
    passes[pass.name] = std::move(entry);
  }
  root["passes"] = std::move(passes);
  nlohmann::ordered_json connections = nlohmann::ordered_json::array();
  for (const auto& c : p.connections) connections.push_back(c.from.text() + " -> " + c.to.text());
  root["connections"] = std::move(connections);
  nlohmann::ordered_json outputs = nlohmann::ordered_json::array();
  for (const auto& o : p.outputs) outputs.push_back(o.text());
  root["outputs"] = std::move(outputs);
  return root.dump(2) + "\n";
}

Result<Pipeline> with_options(const Pipeline& pipeline, std::string_view pass, const nlohmann::json& values) {
  if (!pipeline.find(pass))
    return fail(ErrorKind::NotFound, "{}: no pass '{}' to set options of", pipeline.source, pass);
  if (!values.is_object())
    return fail(ErrorKind::InvalidArgument, "{}: options of pass '{}' must be an object of name: value", pipeline.source, pass);
  auto root = nlohmann::ordered_json::parse(to_json(pipeline));
  auto& options = root["passes"][std::string(pass)]["options"];
  for (const auto& [name, value] : values.items()) options[name] = value;
  auto changed = parse_pipeline(root.dump(2), pipeline.source);
  if (!changed) return std::unexpected(changed.error());
  return changed;
}

std::string pass_types_markdown() {
  std::string out;
  const auto kind_text = [](const PassOption& o) -> std::string {
    switch (o.kind) {
      case KnobKind::Number: return weft::format("number [{}, {}]", o.min, o.max);
      case KnobKind::Integer: return weft::format("integer [{}, {}]", o.min, o.max);
      case KnobKind::Boolean: return "boolean";
      case KnobKind::Choice: {
        std::string c;
        for (const auto& x : o.choices) c += (c.empty() ? "" : " \\| ") + x;
        return "one of " + c;
      }
    }
    return "";
  };
  const auto slot_text = [](const Slot& s, bool input) {
    std::string formats = s.same_as.empty() ? formats_text(s.formats) : "as `" + s.same_as + "`";
    if (formats.empty()) formats = "any format";
    std::string size = s.same_as.empty() ? (s.size == SlotSize::Frame ? "frame size" : "any size") : "";
    std::string extra = input && s.optional ? ", optional" : "";
    if (input && !s.intended_formats.empty())
      extra += weft::format(", made for {} (other formats warn)", formats_text(s.intended_formats));
    return weft::format("`{}` ({}{}{}){}", s.name, formats, size.empty() ? "" : ", " + size, extra,
                        s.meaning.empty() ? "" : ": " + s.meaning);
  };
  for (const auto* d : pass_type_registry().all()) {
    out += weft::format("### `{}`\n\n{}\n\n", d->name, d->summary);
    out += "- inputs: ";
    if (d->inputs.empty()) out += "none";
    for (std::size_t i = 0; i < d->inputs.size(); ++i) out += (i ? "; " : "") + slot_text(d->inputs[i], true);
    out += "\n- outputs: ";
    for (std::size_t i = 0; i < d->outputs.size(); ++i) out += (i ? "; " : "") + slot_text(d->outputs[i], false);
    if (d->temporal)
      out += "\n- temporal: blends frames over time; a single frame (`weft render` without `--accumulate N`) shows "
             "sample 0 only";
    out += "\n\n";
    if (!d->options.empty()) {
      out += "| option | values | default | meaning |\n|:--|:--|:--|:--|\n";
      for (const auto& o : d->options)
        out += weft::format("| `{}` | {} | `{}` | {} |\n", o.name, kind_text(o), o.default_value.dump(), o.meaning);
      out += "\n";
    }
    if (!d->reference.empty()) {
      std::string sweeps;
      for (const auto& o : d->options) {
        if (o.sweep.empty()) continue;
        std::string values;
        for (const auto& v : o.sweep) values += (values.empty() ? "" : ", ") + v.dump();
        sweeps += weft::format("{}`{}` {}", sweeps.empty() ? "" : "; ", o.name, values);
      }
      out += weft::format("Studied by `weft tradeoff SCENE --pass {}` (docs/tradeoffs.md): reference `{}` ({}); "
                          "sweeps {}.\n\n",
                          d->name, d->reference.dump(), d->reference_why, sweeps.empty() ? "none" : sweeps);
    }
  }
  return out;
}

}  // namespace weft::pipeline
