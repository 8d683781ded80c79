// weft — render scenes, inspect their graphs, bake assets, study speed against accuracy.
#include <cstdio>
#include <exception>
#include <vector>
#include "commands.h"
import weft.core;
import weft.builtin_features;

int main(int argc, char** argv) {
  // Scene files name these features' material types; `weft tradeoff` sweeps their knobs.
  if (auto ok = weft::register_builtin_features(); !ok) {
    std::fprintf(stderr, "weft: %s\n", ok.error().what().c_str());
    return 70;
  }
  CLI::App app{"weft: a render-graph engine over Vulkan"};
  app.require_subcommand(1);
  std::vector<std::pair<CLI::App*, weft::cli::Command>> commands;
  auto add = [&](weft::cli::Command (*make)(CLI::App&)) {
    const std::size_t before = app.get_subcommands({}).size();
    auto command = make(app);
    commands.emplace_back(app.get_subcommands({})[before], std::move(command));
  };
  add(weft::cli::add_info);
  add(weft::cli::add_render);
  add(weft::cli::add_graph);
  add(weft::cli::add_bake);
  add(weft::cli::add_tradeoff);
  add(weft::cli::add_view);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  for (auto& [sub, run] : commands)
    if (sub->parsed()) {
      try {
        return run();
      } catch (const std::exception& e) {
        std::fprintf(stderr, "weft %s: unexpected exception: %s\n", sub->get_name().c_str(), e.what());
        return 70;
      }
    }
  return 1;
}
