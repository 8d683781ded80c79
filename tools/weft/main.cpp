// weft — render scenes, inspect their graphs, bake assets, study speed against accuracy.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <new>
#include <string>
#include <string_view>
#include <vector>
#include "commands.h"
import weft.core;
import weft.builtin_features;
import weft.pipeline;

int main(int argc, char** argv) {
  // Scene files name these features' material types; `weft tradeoff` sweeps their knobs.
  if (auto ok = weft::register_builtins(); !ok) {
    std::fprintf(stderr, "weft: %s\n", ok.error().what().c_str());
    return 70;
  }
  // Plugins load before the commands are made, so their features' bakes are `weft bake`
  // commands and their pass types and material types are known to every reader. A plugin named
  // on the command line must load (the user asked for it); a bad one found on WEFT_PLUGIN_PATH
  // is a warning and the rest go on.
  for (const auto& w : weft::pipeline::load_plugins_from_environment()) weft::log::warn(w);
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    std::string path;
    if (arg == "--plugin" && i + 1 < argc) path = argv[++i];
    else if (arg.starts_with("--plugin=")) path = std::string(arg.substr(9));
    else if (!arg.starts_with("-")) break;  // the command: its own arguments follow
    if (path.empty()) continue;
    if (auto ok = weft::pipeline::load_plugin(path); !ok) {
      std::fprintf(stderr, "weft: %s\n", ok.error().what().c_str());
      return 2;
    }
  }
  CLI::App app{"weft: a render-graph engine over Vulkan"};
  app.require_subcommand(1);
  std::vector<std::string> plugins;
  app.add_option("--plugin", plugins,
                 "Load this plugin (a shared library registering pass types or features; docs/pipelines.md#plugins) "
                 "before the command runs; repeatable. WEFT_PLUGIN_PATH (':'-separated files and folders) adds more")
      ->type_name("PATH");
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
  add(weft::cli::add_farm);
  // CLI11 answers a mistyped command with "A subcommand is required"; name the word instead.
  const auto subcommands = app.get_subcommands({});
  const auto names = [&](const std::string& word) {
    return std::any_of(subcommands.begin(), subcommands.end(), [&](CLI::App* sub) { return sub->check_name(word); });
  };
  if (argc > 1 && argv[1][0] != '-' && !names(argv[1])) {
    std::string known;
    for (const CLI::App* sub : subcommands) known += (known.empty() ? "" : ", ") + sub->get_name();
    std::fprintf(stderr, "weft: unknown command '%s' (commands: %s; weft --help describes them)\n", argv[1], known.c_str());
    return 2;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  for (auto& [sub, run] : commands)
    if (sub->parsed()) {
      try {
        return run();
      } catch (const std::bad_alloc&) {
        std::fprintf(stderr, "weft %s: out of memory (the inputs or sizes asked for more than this machine has)\n",
                     sub->get_name().c_str());
        return 70;
      } catch (const std::exception& e) {
        std::fprintf(stderr, "weft %s: unexpected exception: %s\n", sub->get_name().c_str(), e.what());
        return 70;
      }
    }
  return 1;
}
