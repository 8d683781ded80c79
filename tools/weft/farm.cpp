// `weft farm`: task lists (weft.farm, docs/farm.md) and their runners.
//   weft farm plan SPEC.json [-o tasks.json]       a sweep spec -> one task list
//   weft farm run LIST|SPEC --farm local -j N      every task not done, then the reduce steps
//   weft farm run LIST|SPEC --farm slurm [...]     one job array + a reduce job (afterok)
//   weft farm task LIST I                          task I (what an array task runs)
//   weft farm reduce LIST                          the reduce steps, once every task is done
//   weft farm place FROM TO                        a bake's reduce step: its output placed atomically
//   weft farm status|wait|collect JOB              a submitted Slurm job
// Commands that farm their own work (`weft tradeoff --farm`) come through run_farm too, so
// every runner has one semantics. Nothing here names a feature: tasks are command lines.
#include <cstdio>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>
#include <unistd.h>
#include "commands.h"
#include <weft/text_input.h>
import weft.core;
import weft.farm;

namespace weft::cli {
// farm_slurm.cpp
std::optional<std::string> slurm_problem(const FarmOptions& options);
int submit_slurm(const farm::TaskList& list, const std::filesystem::path& list_file, const FarmOptions& options,
                 std::string* array_id);
int slurm_status(const std::filesystem::path& cache, const std::string& id, bool quiet, bool* all_finished,
                 std::string* reduce_state);
int slurm_wait(const std::filesystem::path& cache, const std::string& id, double timeout_s);
Result<std::filesystem::path> job_list(const std::filesystem::path& cache, const std::string& id);
// tradeoff.cpp
Result<farm::TaskList> tradeoff_tasks_for(const farm::StudySpec& spec, const std::filesystem::path& cache);

std::string self_path() {
  std::error_code ec;
  const auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("weft") : p.string();
}

void add_farm_options(CLI::App& command, FarmOptions& o) {
  command.add_option("--farm", o.runner, "Run the work as independent tasks: local (processes here) or slurm (a job array)")
      ->check(CLI::IsMember({"local", "slurm"}));
  command.add_option("-j,--jobs", o.jobs, "--farm local: tasks at once")->check(CLI::Range(1u, 1024u))->capture_default_str();
  command.add_option("--partition", o.partition, "--farm slurm: the partition (sbatch --partition)");
  command.add_option("--max-parallel", o.max_parallel, "--farm slurm: array tasks at once (sbatch --array=0-N%K)")
      ->check(CLI::Range(1u, 100000u));
  command.add_option("--sbatch-arg", o.sbatch_args, "--farm slurm: passed to sbatch as it is (repeatable), e.g. --sbatch-arg=--time=30")
      ->allow_extra_args(false);
  command.add_flag("--wait", o.wait, "--farm slurm: wait for the jobs and check every task's output");
}

std::optional<std::string> check_farm_options(const FarmOptions& o) {
  if (o.runner != "slurm" && (!o.partition.empty() || o.max_parallel || !o.sbatch_args.empty() || o.wait))
    return std::string("--partition, --max-parallel, --sbatch-arg and --wait are for --farm slurm");
  if (o.runner == "slurm") return slurm_problem(o);
  return std::nullopt;
}

namespace {

int failed(const char* what, const Error& e) {
  std::fprintf(stderr, "%s: %s\n", what, e.what().c_str());
  return 1;
}

int reduce(const farm::TaskList& list, const char* what) {
  const auto missing = farm::missing_tasks(list);
  if (!missing.empty()) {
    std::fprintf(stderr, "%s: %zu of %zu tasks have no output in '%s', so nothing was reduced: %s\n", what, missing.size(),
                 list.tasks.size(), list.cache.c_str(), farm::describe_missing(list, missing).c_str());
    return 1;
  }
  for (const auto& command : list.reduce) {
    auto rc = farm::run_command(command);
    if (!rc) return failed(what, rc.error());
    if (*rc != 0) {
      std::fprintf(stderr, "%s: the reduce step '%s ...' failed (exit %d)\n", what, command.size() > 1 ? command[1].c_str() : "",
                   *rc);
      return *rc;
    }
  }
  return 0;
}

}  // namespace

int run_farm(const farm::TaskList& list, const FarmOptions& options, const std::string& command_name) {
  const std::string what = command_name + " --farm " + options.runner;
  auto file = farm::save_task_list(list);
  if (!file) return failed(what.c_str(), file.error());
  if (options.runner == "slurm") {
    std::string array;
    const int rc = submit_slurm(list, *file, options, &array);
    if (rc != 0 || !options.wait) return rc;
    return slurm_wait(list.cache, array, 0);
  }
  log::info(weft::format("farm: {} tasks, list {}, logs in {}", list.tasks.size(), file->string(),
                         (list.cache / "logs").string()));
  auto run = farm::run_local(list, options.jobs);
  if (!run) return failed(what.c_str(), run.error());
  if (!run->failed.empty()) {
    std::fprintf(stderr, "%s: %zu of %zu tasks failed, so nothing was reduced: %s\n", what.c_str(), run->failed.size(),
                 list.tasks.size(), farm::describe_missing(list, run->failed).c_str());
    return 1;
  }
  return reduce(list, what.c_str());
}

namespace {

struct FarmArgs {
  std::string input, out, cache, job;
  std::size_t index = 0;
  double timeout = 0;
  FarmOptions options;
};

std::filesystem::path cache_of(const FarmArgs& a) {
  return a.cache.empty() ? farm::default_cache_dir() : std::filesystem::absolute(a.cache);
}

// A sweep spec (it has "studies") or a task list, as a task list.
Result<farm::TaskList> load(const FarmArgs& a) {
  if (auto why = binary_text_input(a.input, "task list or sweep spec")) return fail(ErrorKind::Parse, "{}", *why);
  auto bytes = read_input_file(a.input, "task list or sweep spec");
  if (!bytes) return std::unexpected(bytes.error());
  const auto doc = nlohmann::json::parse(bytes->begin(), bytes->end(), nullptr, false);
  if (!doc.is_discarded() && doc.is_object() && (doc.contains("studies") || doc.contains("bakes"))) {
    auto specs = farm::read_sweep_spec(a.input);
    if (!specs) return std::unexpected(specs.error());
    const auto cache = cache_of(a);
    if (cache.empty()) return fail(ErrorKind::InvalidArgument, "no cache folder: give --cache DIR or set WEFT_CACHE_DIR");
    farm::TaskList all;
    all.cache = cache;
    for (const auto& spec : specs->studies) {
      auto list = tradeoff_tasks_for(spec, cache);
      if (!list) return with_context(a.input, list.error());
      farm::append(all, *list);
    }
    // A bake is `weft bake NAME ARGS -o CACHE/bake/<id><ext>`, placed at its output by the reduce.
    for (const auto& b : specs->bakes) {
      const std::string file = "bake/" + b.id + b.output.extension().string();
      farm::Task task{.id = b.id, .label = "bake " + b.bake + " -> " + b.output.filename().string(), .command = {self_path(), "bake", b.bake}};
      task.command.insert(task.command.end(), b.args.begin(), b.args.end());
      task.command.insert(task.command.end(), {"-o", (cache / file).string()});
      task.outputs = {file};
      farm::TaskList one;
      one.cache = cache;
      one.what = "weft bake " + b.bake + " -o " + b.output.string();
      one.tasks.push_back(std::move(task));
      one.reduce.push_back({self_path(), "farm", "place", (cache / file).string(), b.output.string()});
      farm::append(all, one);
    }
    return all;
  }
  return farm::read_task_list(a.input);
}

}  // namespace

Command add_farm(CLI::App& app) {
  auto* farm_cmd = app.add_subcommand("farm", "Run studies and bakes as independent tasks: locally or as Slurm job arrays (docs/farm.md)");
  farm_cmd->require_subcommand(1);
  auto a = std::make_shared<FarmArgs>();
  const auto cache_option = [&](CLI::App* sub) {
    sub->add_option("--cache", a->cache, "The cache folder (default: $WEFT_CACHE_DIR, else ~/.cache/weft/farm)")->type_name("DIR");
  };
  auto* plan = farm_cmd->add_subcommand("plan", "Read a sweep spec (JSON) and write its task list");
  plan->add_option("spec", a->input, "The sweep spec (docs/farm.md#sweep-specs)")->required();
  plan->add_option("-o,--out", a->out, "The task list file (default: print it)");
  cache_option(plan);
  auto* run = farm_cmd->add_subcommand("run", "Run a task list or a sweep spec: every task not done, then its reduce steps");
  run->add_option("input", a->input, "A task list or a sweep spec")->required();
  cache_option(run);
  add_farm_options(*run, a->options);
  auto* task = farm_cmd->add_subcommand("task", "Run one task of a list (skipped when its outputs exist): what a job array task runs");
  task->add_option("list", a->input, "The task list")->required();
  task->add_option("index", a->index, "The task's index (0 = the first; $SLURM_ARRAY_TASK_ID)")->required();
  auto* red = farm_cmd->add_subcommand("reduce", "Run a task list's reduce steps, once every task's output is in the cache");
  red->add_option("list", a->input, "The task list")->required();
  auto* place = farm_cmd->add_subcommand("place", "Copy a task's output from the cache to where it belongs, atomically (a bake's reduce step)");
  place->add_option("from", a->input, "The file in the cache")->required();
  place->add_option("to", a->out, "Where it goes (folders made as needed)")->required();
  auto* status = farm_cmd->add_subcommand("status", "Say how far a submitted Slurm job has got");
  auto* wait = farm_cmd->add_subcommand("wait", "Wait for a submitted Slurm job and its reduce job; exit 0 when every task's output is there");
  auto* collect = farm_cmd->add_subcommand("collect", "Gather a submitted job's results: run its reduce steps here from the cache");
  for (auto* sub : {status, wait, collect}) {
    sub->add_option("job", a->job, "The array job's id (`--farm slurm` printed it)")->required();
    cache_option(sub);
  }
  wait->add_option("--timeout", a->timeout, "Give up after this many seconds (0: never)")->check(CLI::Range(0.0, 1e7));
  return [a, plan, run, task, red, place, status, wait, collect]() -> int {
    if (plan->parsed()) {
      auto list = load(*a);
      if (!list) return failed("weft farm plan", list.error());
      const std::string text = farm::to_text(*list);
      if (a->out.empty()) {
        std::fputs(text.c_str(), stdout);
        return 0;
      }
      if (auto ok = write_file_atomically(a->out, {std::as_bytes(std::span(text))}, "task list"); !ok)
        return failed("weft farm plan", ok.error());
      std::printf("wrote %s: %zu tasks, %zu reduce steps\n", a->out.c_str(), list->tasks.size(), list->reduce.size());
      return 0;
    }
    if (run->parsed()) {
      if (a->options.runner.empty()) {
        std::fprintf(stderr, "weft farm run: --farm local or --farm slurm is required\n");
        return 2;
      }
      if (auto problem = check_farm_options(a->options)) {
        std::fprintf(stderr, "weft farm run: %s\n", problem->c_str());
        return 2;
      }
      auto list = load(*a);
      if (!list) return failed("weft farm run", list.error());
      return run_farm(*list, a->options, "weft farm run");
    }
    if (task->parsed()) {
      auto list = farm::read_task_list(a->input);
      if (!list) return failed("weft farm task", list.error());
      auto r = farm::run_task(*list, a->index);
      if (!r) return failed("weft farm task", r.error());
      if (r->skipped) std::printf("task %zu (%s) is done already: its outputs are in the cache\n", a->index, list->tasks[a->index].label.c_str());
      else if (r->exit_code != 0)
        std::fprintf(stderr, "weft farm task: task %zu (%s) failed (exit %d); log %s: %s\n", a->index,
                     list->tasks[a->index].label.c_str(), r->exit_code, farm::log_path(*list, list->tasks[a->index]).c_str(),
                     farm::last_log_line(*list, list->tasks[a->index]).c_str());
      return r->exit_code;
    }
    if (red->parsed()) {
      auto list = farm::read_task_list(a->input);
      if (!list) return failed("weft farm reduce", list.error());
      return reduce(*list, "weft farm reduce");
    }
    if (place->parsed()) {
      auto bytes = read_input_file(a->input, "task output");
      if (!bytes) return failed("weft farm place", bytes.error());
      const std::filesystem::path to = a->out;
      std::error_code ec;
      if (to.has_parent_path()) std::filesystem::create_directories(to.parent_path(), ec);
      if (ec) return failed("weft farm place", {ErrorKind::Io, weft::format("cannot create '{}': {}", to.parent_path().string(), ec.message())});
      if (auto ok = write_file_atomically(to, {std::as_bytes(std::span(*bytes))}, "baked file"); !ok) return failed("weft farm place", ok.error());
      std::printf("placed %s (%zu bytes, from %s)\n", to.c_str(), bytes->size(), a->input.c_str());
      return 0;
    }
    const auto cache = cache_of(*a);
    if (status->parsed()) return slurm_status(cache, a->job, false, nullptr, nullptr);
    if (wait->parsed()) return slurm_wait(cache, a->job, a->timeout);
    if (collect->parsed()) {
      auto file = job_list(cache, a->job);
      if (!file) return failed("weft farm collect", file.error());
      auto list = farm::read_task_list(*file);
      if (!list) return failed("weft farm collect", list.error());
      return reduce(*list, "weft farm collect");
    }
    return 1;
  };
}

}  // namespace weft::cli
