// Sub-commands of the `weft` command line; each registers itself on the CLI11 app and
// returns the process exit code when run (0 ok, non-zero with a one-line reason on stderr).
#pragma once
#include <CLI/CLI.hpp>
#include <functional>

namespace weft::cli {
using Command = std::function<int()>;
Command add_info(CLI::App& app);
Command add_render(CLI::App& app);
Command add_graph(CLI::App& app);
Command add_bake(CLI::App& app);  // bake.cpp: `weft bake <asset>`
}  // namespace weft::cli
