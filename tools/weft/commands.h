// Sub-commands of the `weft` command line; each registers itself on the CLI11 app and
// returns the process exit code when run (0 ok, non-zero with a one-line reason on stderr).
#pragma once
#include <CLI/CLI.hpp>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>

namespace weft::cli {
using Command = std::function<int()>;
Command add_info(CLI::App& app);
Command add_render(CLI::App& app);
Command add_graph(CLI::App& app);
Command add_bake(CLI::App& app);  // bake.cpp: `weft bake <asset>`, the registered features' bakes
Command add_tradeoff(CLI::App& app);  // tradeoff.cpp: `weft tradeoff SCENE --feature F`
Command add_view(CLI::App& app);      // view.cpp: `weft view SCENE` (the live viewer)

// "1280x720" -> {1280, 720}; nothing unless both sides are plain numbers in 1..max_side.
struct Size {
  std::uint32_t width = 0, height = 0;
};
std::optional<Size> parse_size(const std::string& text, std::uint32_t max_side);
// Why `--exposure` cannot be this value (it must lie in (0, 1e6]), or nothing.
std::optional<std::string> exposure_problem(float exposure);
}  // namespace weft::cli
