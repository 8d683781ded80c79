// weft.farm — weft's offline work as a list of independent tasks, and the cache folder that
// merges their results (docs/farm.md).
//
// A task is a plain `weft` command line whose inputs and output are named by a content hash:
// it reads its inputs, writes its output files into the cache folder with
// write_file_atomically, and exits 0. A task whose outputs all exist is done and is skipped;
// a task killed half-way leaves only its temporary files, which the next run of the task
// removes before it starts, so a pre-empted or requeued task simply computes again. The
// reduce step (also a plain command) reads every task's output from the cache and writes
// what the serial command writes; when an output is missing it names the task and its log
// and writes nothing.
//
// The same list runs on any runner: `--farm local -j N` (child processes on this machine),
// `--farm slurm` (one job array, task i = $SLURM_ARRAY_TASK_ID, plus a reduce job), or by hand.
module;
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>
#include <nlohmann/json.hpp>
export module weft.farm;
import weft.core;
import weft.tradeoff;

export namespace weft::farm {

// The cache folder: $WEFT_CACHE_DIR, else $XDG_CACHE_HOME/weft/farm, else ~/.cache/weft/farm
// (empty when none of these is set). On a cluster, a folder on the shared file system.
std::filesystem::path default_cache_dir();

struct Task {
  std::string id;                    // content hash of the task's inputs (16 hex digits): names its outputs and log
  std::string label;                 // what it computes, for people: "shell_fur layers=8"
  std::vector<std::string> command;  // the argv; command[0] is the weft binary
  std::vector<std::string> outputs;  // relative to the cache folder; done when every one exists
};

struct TaskList {
  std::string what;             // the command the list stands for: "weft tradeoff s.json --feature shell_fur"
  std::filesystem::path cache;  // absolute
  std::vector<Task> tasks;
  std::vector<std::vector<std::string>> reduce;  // argvs run in order once every task is done
};

nlohmann::json to_json(const TaskList& list);
std::string to_text(const TaskList& list);  // to_json, indented, with a final newline
// Errors name the source and the JSON path: "tasks.json: $.tasks[2].command: expected an array of strings".
Result<TaskList> parse_task_list(std::string_view text, std::string_view source);
Result<TaskList> read_task_list(const std::filesystem::path& path);
// Writes the list atomically as CACHE/farm/<list hash>.tasks.json and returns that path.
Result<std::filesystem::path> save_task_list(const TaskList& list);
// Every task of `b` appended to `a` (tasks of one id once), and b's reduce steps after a's.
void append(TaskList& a, const TaskList& b);

std::filesystem::path output_path(const TaskList& list, std::string_view output);  // CACHE/output
std::filesystem::path log_path(const TaskList& list, const Task& task);            // CACHE/logs/<id>.log
bool is_done(const TaskList& list, const Task& task);
// Indices of the tasks whose outputs are not all there.
std::vector<std::size_t> missing_tasks(const TaskList& list);
// The last non-empty line of a task's log ("no log": it never started), for messages.
std::string last_log_line(const TaskList& list, const Task& task);
// The missing tasks on one line, the first 8 named, the rest counted:
// "'layers=8' (task 0123abcd..., log CACHE/logs/0123.log: <last line>); ...; and 18 more (...)".
std::string describe_missing(const TaskList& list, const std::vector<std::size_t>& missing);

// ---- running tasks -------------------------------------------------------------------------
// Removes the temporaries a killed writer of this task's outputs left (write_file_atomically's
// "<output>.<pid>-<n>.tmp"), then starts the task's command as a child process with stdin
// closed and stdout/stderr appended to its log. Returns the child's pid.
Result<int> start_task(const TaskList& list, std::size_t index);
// Waits for the child; its exit code (128 + the signal when it was killed).
int wait_task(int pid);
// Runs task `index` unless it is done: 0 when done or it succeeded (and its outputs exist),
// otherwise the task's exit code (or 1 when it exited 0 without writing its outputs).
struct TaskRun {
  int exit_code = 0;
  bool skipped = false;
};
Result<TaskRun> run_task(const TaskList& list, std::size_t index);

// The local runner: every task not done, at most `jobs` at once, in list order. Progress is
// logged; returns the indices of the tasks that failed, in list order (their logs say why).
struct LocalRun {
  std::size_t ran = 0, skipped = 0;
  std::vector<std::size_t> failed;
};
Result<LocalRun> run_local(const TaskList& list, unsigned jobs);
// Runs a command (argv) in the foreground, its output to this process's: its exit code.
Result<int> run_command(const std::vector<std::string>& argv);

// ---- the sweep spec ------------------------------------------------------------------------
// A JSON file naming trade-off studies to run as one task list (docs/farm.md):
//   {"version": 1, "studies": [{"scenes": ["a.json", "b.json"], "feature": "shell_fur",
//     "size": "64x48", "frames": 3, "exposure": 1,
//     "values": {"layers": [1, 2, 4]},                   // listed: each knob's sweep replaced
//     "cross": {"layers": [4, 8], "fins": [true, false]}, // crossed: every combination
//     "out": "results/{feature}-{scene}"}]}
// Scenes are relative to the spec's folder; "{scene}" is the scene file's stem. Knob names
// and values are checked against the feature's knob table before anything runs.
struct StudySpec {
  std::string json_path;  // "$.studies[0]"
  std::filesystem::path scene;
  std::string feature;     // as the registry names it
  std::string size;        // "" = the scene's
  unsigned frames = 5;
  double exposure = 1.0;
  std::vector<std::string> values, cross;  // "KNOB=V1,V2" as `weft tradeoff --values/--cross` take them
  std::filesystem::path out;
};
// A bake of any registered feature (`weft bake NAME ARGS -o OUTPUT`):
//   "bakes": [{"bake": "btf", "args": ["--synthetic", "4x4", "--weave", "twill"], "output": "lib/twill.wbtf"}]
// The task writes CACHE/bake/<id><extension of output>; the reduce step places it at `output`.
// Arguments naming files that exist (relative to the spec's folder) are made absolute, and
// their bytes are part of the id.
struct BakeSpec {
  std::string json_path;          // "$.bakes[0]"
  std::string bake;               // the `weft bake` subcommand
  std::vector<std::string> args;  // without -o
  std::filesystem::path output;   // absolute
  std::string id;                 // content hash of the bake, its arguments and the files they name
};
struct SweepSpec {
  std::vector<StudySpec> studies;
  std::vector<BakeSpec> bakes;
};
// Errors: one Parse error naming every problem's JSON path, "spec.json: $.studies[0].values.layerz: ...".
Result<SweepSpec> parse_sweep_spec(std::string_view text, std::string_view source, const std::filesystem::path& base_dir);
Result<SweepSpec> read_sweep_spec(const std::filesystem::path& path);

}  // namespace weft::farm
