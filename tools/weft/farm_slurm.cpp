// `--farm slurm`: a task list as one Slurm job array (task i runs `weft farm task LIST i`, so
// $SLURM_ARRAY_TASK_ID picks it) plus a reduce job that depends on it (afterok), and
// `weft farm status|wait` following them. Jobs are recorded in CACHE/farm/jobs/<array id>.json.
// Slurm's client commands (sbatch, scontrol, scancel, sinfo) are run as programs; nothing
// here links Slurm.
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <sys/wait.h>
#include <weft/try.h>
#include "commands.h"
import weft.core;
import weft.farm;

namespace weft::cli {

namespace {
using json = nlohmann::json;

std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

struct Captured {
  int exit_code = -1;
  std::string output;
};

Captured capture(const std::vector<std::string>& argv) {
  std::string command;
  for (const auto& a : argv) command += (command.empty() ? "" : " ") + quote(a);
  Captured r;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe)) r.output += buffer.data();
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
  return s;
}

bool on_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::string p = path ? path : "";
  std::size_t start = 0;
  while (start <= p.size()) {
    const auto end = p.find(':', start);
    const std::string dir = p.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!dir.empty() && ::access((std::filesystem::path(dir) / program).c_str(), X_OK) == 0) return true;
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return false;
}

// "1234" or "1234;cluster" (sbatch --parsable) -> "1234".
std::optional<std::string> job_id(const std::string& output) {
  std::string line = trimmed(output);
  if (const auto nl = line.rfind('\n'); nl != std::string::npos) line = line.substr(nl + 1);
  line = line.substr(0, line.find(';'));
  if (line.empty() || line.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
  return line;
}

Result<std::string> sbatch(std::vector<std::string> args) {
  args.insert(args.begin(), {"sbatch", "--parsable"});
  const auto r = capture(args);
  const auto id = job_id(r.output);
  if (r.exit_code != 0 || !id) return fail(ErrorKind::Io, "sbatch refused the job: {}", trimmed(r.output));
  return *id;
}

Result<void> write_script(const std::filesystem::path& file, const std::string& text) {
  WEFT_TRY_VOID(write_file_atomically(file, {std::as_bytes(std::span(text))}, "job script"));
  ::chmod(file.c_str(), 0755);
  return {};
}

// The state of each job of an array (or one job) as scontrol sees it: task -> (state, reason).
struct JobState {
  std::string state, reason;
};
std::map<std::string, JobState> job_states(const std::string& id) {
  std::map<std::string, JobState> out;
  const auto r = capture({"scontrol", "show", "job", id, "-o"});
  if (r.exit_code != 0) return out;  // purged from the controller: finished long ago
  std::size_t start = 0;
  while (start < r.output.size()) {
    auto end = r.output.find('\n', start);
    if (end == std::string::npos) end = r.output.size();
    const std::string line = r.output.substr(start, end - start);
    start = end + 1;
    const auto field = [&](const std::string& key) {
      const auto at = line.find(key + "=");
      if (at == std::string::npos) return std::string();
      const auto from = at + key.size() + 1;
      return line.substr(from, line.find(' ', from) - from);
    };
    const std::string task = field("ArrayTaskId");
    if (field("JobState").empty()) continue;
    out[task.empty() ? field("JobId") : task] = {field("JobState"), field("Reason")};
  }
  return out;
}

bool finished(const std::string& state) {
  return state == "COMPLETED" || state == "FAILED" || state == "CANCELLED" || state == "TIMEOUT" ||
         state == "NODE_FAIL" || state == "OUT_OF_MEMORY" || state == "BOOT_FAIL" || state == "DEADLINE" || state == "PREEMPTED";
}

std::filesystem::path record_path(const std::filesystem::path& cache, const std::string& id) {
  return cache / "farm" / "jobs" / (id + ".json");
}

struct Record {
  std::filesystem::path list;
  std::string array, reduce;
};

Result<Record> read_record(const std::filesystem::path& cache, const std::string& id) {
  if (id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
    return fail(ErrorKind::InvalidArgument, "'{}' is not a Slurm job id (the array job's number `--farm slurm` printed)", id);
  const auto file = record_path(cache, id);
  auto bytes = read_input_file(file, "farm job record");
  if (!bytes)
    return fail(ErrorKind::NotFound, "no farm job {} in the cache '{}' (no {}; give the --cache the job was submitted with)",
                id, cache.string(), file.string());
  const json j = json::parse(bytes->begin(), bytes->end(), nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("list") || !j.contains("array") || !j.contains("reduce"))
    return fail(ErrorKind::Parse, "farm job record '{}' is damaged", file.string());
  return Record{j["list"].get<std::string>(), j["array"].get<std::string>(), j["reduce"].get<std::string>()};
}

Result<void> write_record(const std::filesystem::path& cache, const Record& r) {
  const std::string text = json{{"list", r.list.string()}, {"array", r.array}, {"reduce", r.reduce}}.dump(2) + "\n";
  std::error_code ec;
  std::filesystem::create_directories(record_path(cache, r.array).parent_path(), ec);
  return write_file_atomically(record_path(cache, r.array), {std::as_bytes(std::span(text))}, "farm job record");
}

Result<std::string> submit_reduce(const std::filesystem::path& list_file, const farm::TaskList& list,
                                  const FarmOptions& options, const std::string& dependency) {
  const auto script = list_file.parent_path() / (list_file.stem().stem().string() + ".reduce.sh");
  WEFT_TRY_VOID(write_script(script, "#!/bin/sh\n# the reduce step of " + list.what + "\nexec " + quote(self_path()) +
                                         " farm reduce " + quote(list_file.string()) + "\n"));
  std::vector<std::string> args = {"--job-name=weft-reduce", "--output=" + (list.cache / "logs" / "slurm-reduce-%j.out").string()};
  if (!dependency.empty()) args.push_back("--dependency=" + dependency);
  if (!options.partition.empty()) args.push_back("--partition=" + options.partition);
  args.insert(args.end(), options.sbatch_args.begin(), options.sbatch_args.end());
  args.push_back(script.string());
  return sbatch(args);
}

}  // namespace

std::optional<std::string> slurm_problem(const FarmOptions& options) {
  for (const char* tool : {"sbatch", "scontrol"})
    if (!on_path(tool))
      return weft::format("--farm slurm: '{}' is not on PATH (install Slurm's client commands, e.g. apt-get install "
                          "slurm-client, and point SLURM_CONF at the cluster's slurm.conf)", tool);
  if (!options.partition.empty()) {
    const auto r = capture({"sinfo", "-h", "-o", "%R", "-p", options.partition});
    if (r.exit_code != 0) return weft::format("--partition {}: sinfo failed: {}", options.partition, trimmed(r.output));
    if (trimmed(r.output).empty()) {
      const auto all = capture({"sinfo", "-h", "-o", "%R"});
      std::string known = trimmed(all.output);
      for (auto& c : known)
        if (c == '\n') c = ' ';
      return weft::format("--partition {}: the cluster has no such partition (its partitions: {})", options.partition,
                          known.empty() ? "none" : known);
    }
  }
  return std::nullopt;
}

int submit_slurm(const farm::TaskList& list, const std::filesystem::path& list_file, const FarmOptions& options,
                 std::string* array_id) {
  if (auto problem = slurm_problem(options)) {
    std::fprintf(stderr, "weft farm: %s\n", problem->c_str());
    return 2;
  }
  if (list.tasks.empty()) {
    std::fprintf(stderr, "weft farm: the task list '%s' has no tasks\n", list_file.c_str());
    return 1;
  }
  std::error_code ec;
  std::filesystem::create_directories(list.cache / "logs", ec);
  const auto script = list_file.parent_path() / (list_file.stem().stem().string() + ".array.sh");
  if (auto ok = write_script(script, "#!/bin/sh\n# one task of " + list.what + " per array index\nexec " + quote(self_path()) +
                                         " farm task " + quote(list_file.string()) + " \"$SLURM_ARRAY_TASK_ID\"\n");
      !ok) {
    std::fprintf(stderr, "weft farm: %s\n", ok.error().what().c_str());
    return 1;
  }
  std::string range = weft::format("0-{}", list.tasks.size() - 1);
  if (options.max_parallel) range += weft::format("%{}", options.max_parallel);
  std::vector<std::string> args = {"--array=" + range, "--requeue", "--job-name=weft-tasks",
                                   "--output=" + (list.cache / "logs" / "slurm-%A_%a.out").string()};
  if (!options.partition.empty()) args.push_back("--partition=" + options.partition);
  args.insert(args.end(), options.sbatch_args.begin(), options.sbatch_args.end());
  args.push_back(script.string());
  auto array = sbatch(args);
  if (!array) {
    std::fprintf(stderr, "weft farm: %s\n", array.error().message.c_str());
    return 1;
  }
  auto reduce = submit_reduce(list_file, list, options, "afterok:" + *array);
  if (!reduce) {
    (void)capture({"scancel", *array});
    std::fprintf(stderr, "weft farm: %s (array job %s cancelled)\n", reduce.error().message.c_str(), array->c_str());
    return 1;
  }
  if (auto ok = write_record(list.cache, {list_file, *array, *reduce}); !ok) {
    std::fprintf(stderr, "weft farm: %s\n", ok.error().what().c_str());
    return 1;
  }
  if (array_id) *array_id = *array;
  std::printf("submitted array job %s (%zu tasks) and reduce job %s (afterok:%s)\n"
              "follow: weft farm status|wait|collect %s --cache %s\n",
              array->c_str(), list.tasks.size(), reduce->c_str(), array->c_str(), array->c_str(), list.cache.c_str());
  std::fflush(stdout);
  return 0;
}

// Counts of the array's tasks by state, the reduce job's state, and the tasks done in the cache.
int slurm_status(const std::filesystem::path& cache, const std::string& id, bool quiet, bool* all_finished,
                 std::string* reduce_state) {
  auto record = read_record(cache, id);
  if (!record) {
    std::fprintf(stderr, "weft farm status: %s\n", record.error().message.c_str());
    return 2;
  }
  auto list = farm::read_task_list(record->list);
  if (!list) {
    std::fprintf(stderr, "weft farm status: %s\n", list.error().what().c_str());
    return 1;
  }
  std::map<std::string, int> counts;
  bool busy = false;
  for (const auto& [task, s] : job_states(record->array)) {
    ++counts[s.state];
    busy = busy || !finished(s.state);
  }
  const auto reduce = job_states(record->reduce);
  const JobState r = reduce.empty() ? JobState{"PURGED", ""} : reduce.begin()->second;
  const std::size_t done = list->tasks.size() - farm::missing_tasks(*list).size();
  if (!quiet) {
    std::string states;
    for (const auto& [state, n] : counts) states += weft::format("{}{} {}", states.empty() ? "" : ", ", n, state);
    std::printf("array job %s: %zu of %zu tasks done in the cache; %s; reduce job %s: %s%s\n", id.c_str(), done,
                list->tasks.size(), states.empty() ? "no task in the controller" : states.c_str(), record->reduce.c_str(),
                r.state.c_str(), r.reason.empty() || r.reason == "None" ? "" : (" (" + r.reason + ")").c_str());
  }
  if (all_finished) *all_finished = !busy;
  if (reduce_state) *reduce_state = r.state + (r.reason.empty() ? "" : ":" + r.reason);
  return 0;
}

int slurm_wait(const std::filesystem::path& cache, const std::string& id, double timeout_s) {
  auto record = read_record(cache, id);
  if (!record) {
    std::fprintf(stderr, "weft farm wait: %s\n", record.error().message.c_str());
    return 2;
  }
  const auto start = std::chrono::steady_clock::now();
  std::string last;
  for (;;) {
    bool tasks_finished = false;
    std::string reduce;
    if (int rc = slurm_status(cache, id, true, &tasks_finished, &reduce); rc != 0) return rc;
    if (reduce != last) {
      slurm_status(cache, id, false, nullptr, nullptr);
      last = reduce;
    }
    const std::string state = reduce.substr(0, reduce.find(':'));
    // A cancelled array task fails afterok for good, even once it is requeued and succeeds:
    // when every task has finished and the reduce job waits on that, it is submitted again.
    if (state == "PENDING" && reduce.find("DependencyNeverSatisfied") != std::string::npos && tasks_finished) {
      auto list = farm::read_task_list(record->list);
      if (!list) {
        std::fprintf(stderr, "weft farm wait: %s\n", list.error().what().c_str());
        return 1;
      }
      (void)capture({"scancel", record->reduce});
      auto again = submit_reduce(record->list, *list, {}, "");
      if (!again) {
        std::fprintf(stderr, "weft farm wait: %s\n", again.error().message.c_str());
        return 1;
      }
      std::printf("a task was cancelled, so afterok can never hold: reduce job %s cancelled, %s submitted after the "
                  "array finished\n", record->reduce.c_str(), again->c_str());
      record->reduce = *again;
      if (auto ok = write_record(cache, *record); !ok) {
        std::fprintf(stderr, "weft farm wait: %s\n", ok.error().what().c_str());
        return 1;
      }
      continue;
    }
    if (finished(state) || state == "PURGED") {
      if (state == "COMPLETED" || state == "PURGED") {
        auto list = farm::read_task_list(record->list);
        if (list) {
          const auto missing = farm::missing_tasks(*list);
          if (!missing.empty()) {
            std::fprintf(stderr, "weft farm wait: %zu tasks have no output: %s\n", missing.size(),
                         farm::describe_missing(*list, missing).c_str());
            return 1;
          }
        }
        std::printf("array job %s done; reduce job %s %s (its log: %s)\n", id.c_str(), record->reduce.c_str(),
                    state.c_str(), (cache / "logs" / ("slurm-reduce-" + record->reduce + ".out")).c_str());
        return 0;
      }
      std::string missing_text;
      if (auto list = farm::read_task_list(record->list)) {
        const auto missing = farm::missing_tasks(*list);
        if (!missing.empty())
          missing_text = weft::format("; {} tasks have no output: {}", missing.size(), farm::describe_missing(*list, missing));
      }
      std::fprintf(stderr, "weft farm wait: reduce job %s ended %s; its log: %s%s\n", record->reduce.c_str(), reduce.c_str(),
                   (cache / "logs" / ("slurm-reduce-" + record->reduce + ".out")).c_str(), missing_text.c_str());
      return 1;
    }
    if (timeout_s > 0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > timeout_s) {
      std::fprintf(stderr, "weft farm wait: job %s still running after %.0f s (reduce %s)\n", id.c_str(), timeout_s,
                   reduce.c_str());
      return 124;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
}

Result<std::filesystem::path> job_list(const std::filesystem::path& cache, const std::string& id) {
  auto record = read_record(cache, id);
  if (!record) return std::unexpected(record.error());
  return record->list;
}

}  // namespace weft::cli
