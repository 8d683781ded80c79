// weft — render scenes, inspect their graphs, bake assets, study speed against accuracy.
#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <exception>
#include <new>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>
#include "commands.h"
import weft.core;
import weft.builtin_features;
import weft.pipeline;

namespace {

// CLI11 2.1 reads an unsigned option with strtoull(text, base 0): "-1" became 4294967295 (or
// 18446744073709551615), "99999999999999999999999" the largest value, "010" eight and "0x10"
// sixteen; and a floating-point one with strtod, so "nan", "inf" and "1e999" got through every
// CLI::Range (NaN compares false). Every option of every command (the features' bakes too)
// gets a check in front: unsigned values are decimal digits that fit in 64 bits, leading zeros
// dropped; floating-point values are finite (issue 33).
std::string unsigned_problem(std::string& text) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos)
    return "'" + text + "' is not a whole number (decimal digits only)";
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size()) return "'" + text + "' is too large";
  text = std::to_string(value);  // "010" is ten, not CLI11's octal eight
  return {};
}

std::string float_problem(const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size()) return "'" + text + "' is not a number";
  if (!std::isfinite(value) || errno == ERANGE) return "'" + text + "' is not a finite number";
  return {};
}

void harden_numbers(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    const std::string type = option->get_type_name();
    if (type.starts_with("UINT")) option->transform(CLI::Validator(unsigned_problem, "", "digits"));
    else if (type.starts_with("FLOAT")) option->check(CLI::Validator(float_problem, "", "finite"));
  }
  for (CLI::App* sub : app.get_subcommands({})) harden_numbers(*sub);
}

}  // namespace

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
  // An empty argument (`--size ""`, `--pipeline=`, `weft render "$SCENE"` with SCENE unset) was
  // read as "not given" and the command went on without it (issue 33): refused, named.
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg.empty()) {
      const bool after_option = i > 1 && argv[i - 1][0] == '-' && std::string_view(argv[i - 1]).find('=') == std::string_view::npos;
      if (after_option)
        std::fprintf(stderr, "weft: %s was given an empty value (give one, or leave the option out)\n", argv[i - 1]);
      else
        std::fprintf(stderr, "weft: argument %d is empty (an unset variable?)\n", i);
      return 2;
    }
    if (arg.starts_with("-") && arg.size() > 1 && arg.ends_with("=")) {
      std::fprintf(stderr, "weft: %.*s was given an empty value (give one, or leave the option out)\n", int(arg.size() - 1),
                   arg.data());
      return 2;
    }
  }
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
  harden_numbers(app);
  // CLI11 answers a mistyped command with "A subcommand is required"; name the word instead.
  const auto subcommands = app.get_subcommands({});
  const auto names = [&](const std::string& word) {
    return std::any_of(subcommands.begin(), subcommands.end(), [&](CLI::App* sub) { return sub->check_name(word); });
  };
  // Options before the command: --plugin PATH and --help only (CLI11 said "A subcommand is
  // required" for `weft --frobnicate`).
  for (int i = 1; i < argc && argv[i][0] == '-'; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--plugin") ++i;
    else if (!arg.starts_with("--plugin=") && arg != "--help" && arg != "-h" && arg != "--help-all") {
      std::fprintf(stderr, "weft: unknown option '%s' before the command (weft --help lists the commands and options)\n",
                   argv[i]);
      return 2;
    }
  }
  // `weft bake nosuch`, `weft farm nosuch`: name the word, as for the commands themselves.
  if (argc > 2 && argv[2][0] != '-')
    for (CLI::App* sub : subcommands)
      if (sub->check_name(argv[1]) && sub->get_require_subcommand_min() > 0) {
        const auto inner = sub->get_subcommands({});
        if (std::none_of(inner.begin(), inner.end(), [&](CLI::App* s) { return s->check_name(argv[2]); })) {
          std::string known;
          for (const CLI::App* s : inner) known += (known.empty() ? "" : ", ") + s->get_name();
          std::fprintf(stderr, "weft %s: unknown %s '%s' (%s)\n", argv[1], argv[1], argv[2], known.c_str());
          return 2;
        }
      }
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
