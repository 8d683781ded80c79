module;
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>
module weft.graph_testing;
import weft.core;
import weft.gpu;
import weft.graph;
import weft.pipeline;
import weft.scene;
import weft.renderer;

namespace weft::testing {
namespace {

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out.empty() ? "(none)" : out;
}

std::vector<std::string> run_order(const CompiledGraph& graph) {
  std::vector<std::string> out;
  for (auto index : graph.order()) out.emplace_back(graph.passes()[index].name);
  return out;
}

std::optional<std::uint32_t> resource_index(const CompiledGraph& graph, std::string_view name) {
  return graph.find_resource(name);
}

}  // namespace

Failure expect_order(const CompiledGraph& graph, const std::vector<std::string>& passes) {
  const auto order = run_order(graph);
  std::size_t at = 0;
  for (const auto& want : passes) {
    const auto it = std::find(order.begin(), order.end(), want);
    if (it == order.end()) return weft::format("pass '{}' does not run (order: {})", want, join(order));
    const auto position = std::size_t(it - order.begin());
    if (position < at) return weft::format("pass '{}' runs too early (order: {}; expected {} in that order)", want, join(order), join(passes));
    at = position;
  }
  return std::nullopt;
}

Failure expect_culled(const CompiledGraph& graph, const std::vector<std::string>& culled) {
  std::vector<std::string> actual;
  for (const auto& p : graph.passes())
    if (p.culled) actual.emplace_back(p.name);
  auto want = culled;
  std::sort(actual.begin(), actual.end());
  std::sort(want.begin(), want.end());
  if (actual == want) return std::nullopt;
  return weft::format("culled: {}; expected {}", join(actual), join(want));
}

Failure expect_barrier(const CompiledGraph& graph, std::string_view pass, std::string_view resource, gpu::Access before,
                       gpu::Access after) {
  const auto p = graph.find_pass(pass);
  if (!p) return weft::format("no pass '{}'", pass);
  const auto r = resource_index(graph, resource);
  if (!r) return weft::format("no resource '{}'", resource);
  std::string seen;
  for (const auto& b : graph.barriers_before(*p)) {
    if (b.resource != *r) continue;
    if (b.before == before && b.after == after) return std::nullopt;
    seen += weft::format(" {} -> {}", gpu::to_string(b.before), gpu::to_string(b.after));
  }
  return weft::format("before pass '{}', '{}' has no barrier {} -> {} (its barriers there:{})", pass, resource,
                      gpu::to_string(before), gpu::to_string(after), seen.empty() ? " none" : seen);
}

Failure expect_no_barrier(const CompiledGraph& graph, std::string_view pass, std::string_view resource) {
  const auto p = graph.find_pass(pass);
  if (!p) return weft::format("no pass '{}'", pass);
  const auto r = resource_index(graph, resource);
  if (!r) return weft::format("no resource '{}'", resource);
  for (const auto& b : graph.barriers_before(*p))
    if (b.resource == *r)
      return weft::format("before pass '{}', '{}' has a barrier {} -> {}", pass, resource, gpu::to_string(b.before),
                          gpu::to_string(b.after));
  return std::nullopt;
}

Failure expect_aliased(const CompiledGraph& graph, std::string_view a, std::string_view b, bool aliased) {
  const auto ra = resource_index(graph, a), rb = resource_index(graph, b);
  if (!ra) return weft::format("no resource '{}'", a);
  if (!rb) return weft::format("no resource '{}'", b);
  const auto& x = graph.resources()[*ra];
  const auto& y = graph.resources()[*rb];
  const bool shared = x.alias_group != invalid_index && x.alias_group == y.alias_group;
  if (shared == aliased) return std::nullopt;
  return weft::format("'{}' and '{}' {} memory (alias groups {} and {})", a, b, shared ? "share" : "do not share",
                      x.alias_group == invalid_index ? std::string("none") : std::to_string(x.alias_group),
                      y.alias_group == invalid_index ? std::string("none") : std::to_string(y.alias_group));
}

Failure expect_transient_bytes_at_most(const CompiledGraph& graph, std::uint64_t bytes) {
  if (graph.memory().aliased_bytes <= bytes) return std::nullopt;
  return weft::format("the transients take {} bytes aliased ({} unaliased); expected at most {}", graph.memory().aliased_bytes,
                      graph.memory().unaliased_bytes, bytes);
}

Failure expect_error(const GraphErrors& errors, GraphErrorKind kind, const std::vector<std::string>& passes,
                     const std::vector<std::string>& resources, std::string_view message_part) {
  for (const auto& e : errors.errors) {
    if (e.kind != kind) continue;
    const auto names_all = [](const std::vector<std::string>& have, const std::vector<std::string>& want) {
      return std::all_of(want.begin(), want.end(),
                         [&](const std::string& w) { return std::find(have.begin(), have.end(), w) != have.end(); });
    };
    if (names_all(e.passes, passes) && names_all(e.resources, resources) &&
        e.message.find(message_part) != std::string::npos)
      return std::nullopt;
  }
  return weft::format("no {} error naming passes {} and resources {}{}; the errors were:\n{}", to_string(kind), join(passes),
                      join(resources), message_part.empty() ? "" : weft::format(" with '{}'", message_part),
                      errors.to_string());
}

Failure expect_golden_dot(const CompiledGraph& graph, const std::filesystem::path& golden) {
  const std::string dot = graph.to_dot();
  if (const char* update = std::getenv("WEFT_UPDATE_GOLDEN"); update && std::string_view(update) == "1") {
    std::ofstream out(golden, std::ios::binary);
    out << dot;
    if (!out) return weft::format("cannot write the golden file '{}'", golden.string());
    return std::nullopt;
  }
  std::ifstream in(golden, std::ios::binary);
  if (!in) return weft::format("no golden file '{}' (WEFT_UPDATE_GOLDEN=1 writes it)", golden.string());
  std::stringstream text;
  text << in.rdbuf();
  if (text.str() == dot) return std::nullopt;
  // The first line that differs, to read in a test log.
  std::istringstream want(text.str()), have(dot);
  std::string a, b;
  for (int line = 1;; ++line) {
    const bool more_a = bool(std::getline(want, a)), more_b = bool(std::getline(have, b));
    if (!more_a && !more_b) break;
    if (!more_a || !more_b || a != b)
      return weft::format("'{}' differs at line {}: expected '{}', got '{}' (WEFT_UPDATE_GOLDEN=1 rewrites it)", golden.string(),
                          line, more_a ? a : "(end)", more_b ? b : "(end)");
  }
  return "the DOT differs from the golden file";
}

Failure expect_pipeline_valid(const std::filesystem::path& file) {
  auto p = pipeline::load_pipeline(file);
  if (p) return std::nullopt;
  return p.error().what();
}

Failure expect_pipeline_error(const std::filesystem::path& file, std::string_view message) {
  auto p = pipeline::load_pipeline(file);
  if (p) return weft::format("'{}' was accepted; expected: {}", file.string(), message);
  std::string what = p.error().what();
  const std::string folder = file.parent_path().string() + "/";
  for (auto at = what.find(folder); !folder.empty() && folder != "/" && at != std::string::npos; at = what.find(folder))
    what.erase(at, folder.size());
  if (what == message) return std::nullopt;
  return weft::format("'{}': expected\n{}\ngot\n{}", file.string(), message, what);
}

Failure expect_scene_frame(const scene::Scene& scene, const renderer::RenderOptions& options,
                           const std::function<Failure(const CompiledGraph&)>& check) {
  Failure failure;
  auto report = renderer::describe(scene, options, [&](const CompiledGraph& graph) {
    if (check) failure = check(graph);
  });
  if (!report) return weft::format("the frame does not compile: {}", report.error().what());
  return failure;
}

Failure expect_scene_frame_error(const scene::Scene& scene, const renderer::RenderOptions& options,
                                 std::string_view message_part) {
  auto report = renderer::describe(scene, options);
  if (report) return weft::format("the frame compiled; expected an error containing '{}'", message_part);
  const std::string what = report.error().what();
  if (what.find(message_part) == std::string::npos)
    return weft::format("the frame's error does not contain '{}': {}", message_part, what);
  return std::nullopt;
}

}  // namespace weft::testing
