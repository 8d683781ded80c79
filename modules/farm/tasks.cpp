// The task list file and the cache folder's layout: CACHE/<kind>/<id>.* (task outputs),
// CACHE/logs/<id>.log (each task's output), CACHE/farm/<list>.tasks.json (lists handed to runners).
module;
#include <algorithm>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <fstream>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <nlohmann/json.hpp>
#include <weft/try.h>
#include <weft/text_input.h>
module weft.farm;
import weft.core;

namespace weft::farm {

using json = nlohmann::json;

std::filesystem::path default_cache_dir() {
  if (const char* dir = std::getenv("WEFT_CACHE_DIR"); dir && *dir) return std::filesystem::absolute(dir);
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::filesystem::path(xdg) / "weft" / "farm";
  if (const char* home = std::getenv("HOME"); home && *home) return std::filesystem::path(home) / ".cache" / "weft" / "farm";
  return {};
}

json to_json(const TaskList& list) {
  json tasks = json::array();
  for (const auto& t : list.tasks)
    tasks.push_back({{"id", t.id}, {"label", t.label}, {"command", t.command}, {"outputs", t.outputs}});
  return {{"version", 1}, {"what", list.what}, {"cache", list.cache.string()}, {"tasks", tasks}, {"reduce", list.reduce}};
}

std::string to_text(const TaskList& list) { return to_json(list).dump(2) + "\n"; }

namespace {

bool is_string_array(const json& v) {
  return v.is_array() && std::all_of(v.begin(), v.end(), [](const json& s) { return s.is_string(); });
}

bool is_id(const std::string& id) {
  return !id.empty() && id.size() <= 64 &&
         std::all_of(id.begin(), id.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

// A relative path that stays inside the cache folder.
bool is_inside(const std::string& p) {
  if (p.empty()) return false;
  const std::filesystem::path path(p);
  if (path.is_absolute()) return false;
  for (const auto& part : path)
    if (part == "..") return false;
  return true;
}

}  // namespace

Result<TaskList> parse_task_list(std::string_view text, std::string_view source) {
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::parse_error& e) {
    return fail(ErrorKind::Parse, "{}: not JSON ({})", source, e.what());
  }
  const auto bad = [&](std::string_view path, std::string_view why) {
    return fail(ErrorKind::Parse, "{}: {}: {}", source, path, why);
  };
  if (!doc.is_object()) return bad("$", "expected an object with \"version\", \"cache\", \"tasks\"");
  for (const auto& [key, value] : doc.items())
    if (key != "version" && key != "what" && key != "cache" && key != "tasks" && key != "reduce")
      return bad("$." + key, "unknown field (known: version, what, cache, tasks, reduce)");
  if (!doc.contains("version") || doc["version"] != 1) return bad("$.version", "expected 1");
  TaskList list;
  if (doc.contains("what")) {
    if (!doc["what"].is_string()) return bad("$.what", "expected a string");
    list.what = doc["what"].get<std::string>();
  }
  if (!doc.contains("cache") || !doc["cache"].is_string() || doc["cache"].get<std::string>().empty())
    return bad("$.cache", "expected the cache folder's path");
  list.cache = doc["cache"].get<std::string>();
  if (!doc.contains("tasks") || !doc["tasks"].is_array()) return bad("$.tasks", "expected an array of tasks");
  std::set<std::string> ids;
  for (std::size_t i = 0; i < doc["tasks"].size(); ++i) {
    const json& t = doc["tasks"][i];
    const std::string at = weft::format("$.tasks[{}]", i);
    if (!t.is_object()) return bad(at, "expected an object with \"id\", \"command\", \"outputs\"");
    for (const auto& [key, value] : t.items())
      if (key != "id" && key != "label" && key != "command" && key != "outputs")
        return bad(at + "." + key, "unknown field (known: id, label, command, outputs)");
    Task task;
    if (!t.contains("id") || !t["id"].is_string() || !is_id(t["id"].get<std::string>()))
      return bad(at + ".id", "expected a content hash (lower-case hex digits)");
    task.id = t["id"].get<std::string>();
    if (!ids.insert(task.id).second) return bad(at + ".id", weft::format("task '{}' is listed twice", task.id));
    if (t.contains("label")) {
      if (!t["label"].is_string()) return bad(at + ".label", "expected a string");
      task.label = t["label"].get<std::string>();
    }
    if (!t.contains("command") || !is_string_array(t["command"]) || t["command"].empty())
      return bad(at + ".command", "expected a non-empty array of strings (the program and its arguments)");
    task.command = t["command"].get<std::vector<std::string>>();
    if (!t.contains("outputs") || !is_string_array(t["outputs"]) || t["outputs"].empty())
      return bad(at + ".outputs", "expected a non-empty array of paths inside the cache folder");
    task.outputs = t["outputs"].get<std::vector<std::string>>();
    for (std::size_t k = 0; k < task.outputs.size(); ++k)
      if (!is_inside(task.outputs[k]))
        return bad(weft::format("{}.outputs[{}]", at, k),
                   weft::format("'{}' is not a relative path inside the cache folder", task.outputs[k]));
    list.tasks.push_back(std::move(task));
  }
  if (doc.contains("reduce")) {
    const json& r = doc["reduce"];
    if (!r.is_array()) return bad("$.reduce", "expected an array of commands");
    for (std::size_t i = 0; i < r.size(); ++i) {
      if (!is_string_array(r[i]) || r[i].empty())
        return bad(weft::format("$.reduce[{}]", i), "expected a non-empty array of strings");
      list.reduce.push_back(r[i].get<std::vector<std::string>>());
    }
  }
  return list;
}

Result<TaskList> read_task_list(const std::filesystem::path& path) {
  if (auto why = binary_text_input(path, "task list")) return fail(ErrorKind::Parse, "{}", *why);
  auto bytes = read_input_file(path, "task list");
  if (!bytes) return std::unexpected(bytes.error());
  return parse_task_list(std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size()), path.string());
}

Result<std::filesystem::path> save_task_list(const TaskList& list) {
  const std::string text = to_text(list);
  const auto dir = list.cache / "farm";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return fail(ErrorKind::Io, "cannot create the cache folder '{}': {}", dir.string(), ec.message());
  const auto file = dir / (hex64(Hasher{}.str(text).digest()) + ".tasks.json");
  WEFT_TRY_VOID(write_file_atomically(file, {std::as_bytes(std::span(text))}, "task list"));
  return file;
}

void append(TaskList& a, const TaskList& b) {
  std::set<std::string> ids;
  for (const auto& t : a.tasks) ids.insert(t.id);
  for (const auto& t : b.tasks)
    if (ids.insert(t.id).second) a.tasks.push_back(t);
  a.reduce.insert(a.reduce.end(), b.reduce.begin(), b.reduce.end());
  if (a.what.empty()) a.what = b.what;
  else if (!b.what.empty()) a.what += "; " + b.what;
  if (a.cache.empty()) a.cache = b.cache;
}

std::filesystem::path output_path(const TaskList& list, std::string_view output) { return list.cache / output; }

std::filesystem::path log_path(const TaskList& list, const Task& task) { return list.cache / "logs" / (task.id + ".log"); }

bool is_done(const TaskList& list, const Task& task) {
  std::error_code ec;
  return std::all_of(task.outputs.begin(), task.outputs.end(),
                     [&](const std::string& o) { return std::filesystem::is_regular_file(output_path(list, o), ec); });
}

std::vector<std::size_t> missing_tasks(const TaskList& list) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < list.tasks.size(); ++i)
    if (!is_done(list, list.tasks[i])) out.push_back(i);
  return out;
}

std::string last_log_line(const TaskList& list, const Task& task) {
  std::ifstream in(log_path(list, task));
  if (!in) return "no log: the task never started";
  std::string line, last;
  while (std::getline(in, line))
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  return last.empty() ? "its log is empty" : last;
}

std::string describe_missing(const TaskList& list, const std::vector<std::size_t>& missing) {
  std::string out;
  constexpr std::size_t shown = 8;  // one line a person reads; the rest by count
  for (std::size_t n = 0; n < missing.size(); ++n) {
    if (n == shown) {
      out += weft::format("; and {} more (their logs are in {})", missing.size() - shown, (list.cache / "logs").string());
      break;
    }
    const Task& t = list.tasks[missing[n]];
    out += weft::format("{}'{}' (task {}, log {}: {})", out.empty() ? "" : "; ", t.label, t.id, log_path(list, t).string(),
                        last_log_line(list, t));
  }
  return out;
}

}  // namespace weft::farm
