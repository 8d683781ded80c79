// Sub-commands of the `weft` command line; each registers itself on the CLI11 app and
// returns the process exit code when run (0 ok, non-zero with a one-line reason on stderr).
#pragma once
#include <CLI/CLI.hpp>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace weft::cli {
using Command = std::function<int()>;
Command add_info(CLI::App& app);
Command add_render(CLI::App& app);
Command add_graph(CLI::App& app);
Command add_bake(CLI::App& app);  // bake.cpp: `weft bake <asset>`, the registered features' bakes
Command add_tradeoff(CLI::App& app);  // tradeoff.cpp: `weft tradeoff SCENE --feature F`
Command add_view(CLI::App& app);      // view.cpp: `weft view SCENE` (the live viewer)
Command add_farm(CLI::App& app);      // farm.cpp: `weft farm plan|run|task|reduce|status|wait|collect`

// How a command that can farm its work out runs it (farm.cpp): `--farm local -j N` or
// `--farm slurm [--partition P] [--max-parallel K] [--sbatch-arg A]... [--wait]`.
struct FarmOptions {
  std::string runner;  // "", "local" or "slurm"
  unsigned jobs = 2;
  std::string partition;
  unsigned max_parallel = 0;
  std::vector<std::string> sbatch_args;
  bool wait = false;
};
void add_farm_options(CLI::App& command, FarmOptions& options);
// Why these options cannot run (a runner's options without --farm, sbatch missing, an unknown
// partition), checked before anything is planned or submitted; nothing when they can.
std::optional<std::string> check_farm_options(const FarmOptions& options);
std::string self_path();  // this weft binary's absolute path (/proc/self/exe), for tasks' commands

// "1280x720" -> {1280, 720}; nothing unless both sides are plain numbers in 1..max_side.
struct Size {
  std::uint32_t width = 0, height = 0;
};
std::optional<Size> parse_size(const std::string& text, std::uint32_t max_side);
// Why `--exposure` cannot be this value (it must lie in (0, 1e6]), or nothing.
std::optional<std::string> exposure_problem(float exposure);
}  // namespace weft::cli
