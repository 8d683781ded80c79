// `weft bake <asset> ...`: offline precomputes written to files. Each bake belongs to a
// feature (FeatureDescriptor::bakes: the skin LUT, the SSDF, the neural BTF's training, and any
// plugin's), which gives its command its options; this file only lists them.
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>
#include "commands.h"
import weft.core;
import weft.feature;

namespace weft::cli {

Command add_bake(CLI::App& app) {
  auto* bake = app.add_subcommand("bake", "Precompute an asset into a file (LUTs, baked data): each feature's bakes");
  bake->require_subcommand(1);
  auto targets = std::make_shared<std::vector<std::pair<CLI::App*, std::function<int()>>>>();
  for (const FeatureDescriptor* feature : feature_registry().all())
    for (const BakeCommand& b : feature->bakes) {
      auto* sub = bake->add_subcommand(b.name, b.summary + " (feature " + feature->name + ")");
      targets->emplace_back(sub, b.add(*sub));
    }
  return [targets] {
    for (auto& [sub, run] : *targets)
      if (sub->parsed()) return run();
    return 1;
  };
}

}  // namespace weft::cli
