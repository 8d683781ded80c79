// Randomized graphs (fixed seeds): hundreds of random DAGs, each checked against a model the
// test keeps of its own declarations — culling, order, lifetimes, memory and barriers.
#include <doctest/doctest.h>
#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>
import weft.core;
import weft.gpu;
import weft.graph;

using namespace weft;

namespace {

struct Decl {
  std::uint32_t pass;
  std::uint32_t resource;
  std::uint32_t in_version;
  std::int64_t out_version;  // -1: read only
  gpu::Access access;
};

struct Model {
  std::vector<Decl> decls;
  std::vector<bool> side_effect;
  std::set<std::uint32_t> imported;
  std::map<std::uint32_t, gpu::Access> initial;
  std::set<std::uint32_t> textures;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> outputs;  // (resource, version)
  std::uint32_t passes = 0;
};

struct PoolEntry {
  std::uint32_t index;
  std::uint32_t version;
  bool texture;
  bool readable;  // the latest version has contents (written, or imported)
  std::uint32_t size;
};

template <class T>
T pick(std::mt19937& rng, std::initializer_list<T> items) {
  std::uniform_int_distribution<std::size_t> d(0, items.size() - 1);
  return *(items.begin() + d(rng));
}

bool chance(std::mt19937& rng, double p) { return std::uniform_real_distribution<double>(0, 1)(rng) < p; }

bool contains_text(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

// `stale`: the chance that a read names an older version of a resource than its latest
// (its readers then come before the writes that followed it, against declaration order).
Model build(RenderGraph& graph, std::uint32_t seed, double stale = 0.0) {
  std::mt19937 rng(seed);
  Model model;
  std::vector<PoolEntry> pool;
  using TU = gpu::TextureUsage;
  const int imported_textures = std::uniform_int_distribution<int>(0, 2)(rng);
  for (int i = 0; i < imported_textures; ++i) {
    const gpu::Access initial = pick(rng, {gpu::Access::Undefined, gpu::Access::ShaderRead, gpu::Access::CopyDst});
    auto h = graph.import_texture("import" + std::to_string(i),
                                  gpu::TextureDescriptor{.label = "import", .size = {32, 32, 1},
                                                         .format = gpu::Format::RGBA8Unorm,
                                                         .usage = TU::Sampled | TU::Storage | TU::ColorAttachment |
                                                                  TU::CopySrc | TU::CopyDst},
                                  initial);
    model.imported.insert(h.index);
    model.textures.insert(h.index);
    model.initial[h.index] = initial;
    pool.push_back({h.index, h.version, true, true, 32});
  }
  if (chance(rng, 0.5)) {
    auto h = graph.import_buffer("import_buffer", gpu::BufferDescriptor{.label = "ib", .size = 4096}, gpu::Access::CopyDst);
    model.imported.insert(h.index);
    model.initial[h.index] = gpu::Access::CopyDst;
    pool.push_back({h.index, h.version, false, true, 0});
  }

  const int passes = std::uniform_int_distribution<int>(3, 40)(rng);
  model.passes = std::uint32_t(passes);
  for (int p = 0; p < passes; ++p) {
    graph.add_pass("p" + std::to_string(p), [&](PassBuilder& b) {
      std::set<std::uint32_t> used;
      std::uint32_t attachment_size = 0;
      auto texture_write_use = [&](std::uint32_t size) {
        TextureUse use = pick(rng, {TextureUse::StorageWrite, TextureUse::ColorAttachment, TextureUse::CopyDst});
        if (use == TextureUse::ColorAttachment) {
          if (attachment_size != 0 && attachment_size != size) use = TextureUse::StorageWrite;
          else attachment_size = size;
        }
        return use;
      };
      auto write_entry = [&](PoolEntry& e) {
        used.insert(e.index);
        if (e.texture) {
          const TextureUse use = texture_write_use(e.size);
          const TextureHandle out = b.write(TextureHandle{e.index, e.version}, use);
          model.decls.push_back({std::uint32_t(p), e.index, e.version, out.version, access_of(use)});
          e.version = out.version;
        } else {
          const BufferUse use = pick(rng, {BufferUse::StorageWrite, BufferUse::CopyDst});
          const BufferHandle out = b.write(BufferHandle{e.index, e.version}, use);
          model.decls.push_back({std::uint32_t(p), e.index, e.version, out.version, access_of(use)});
          e.version = out.version;
        }
        e.readable = true;
      };
      // Reads of existing contents.
      const int reads = std::uniform_int_distribution<int>(0, 3)(rng);
      for (int r = 0; r < reads && !pool.empty(); ++r) {
        PoolEntry& e = pool[std::uniform_int_distribution<std::size_t>(0, pool.size() - 1)(rng)];
        if (!e.readable || used.count(e.index)) continue;
        used.insert(e.index);
        std::uint32_t version = e.version;
        const std::uint32_t first_with_contents = model.imported.count(e.index) ? 0 : 1;
        if (stale > 0.0 && chance(rng, stale) && e.version > first_with_contents)
          version = std::uniform_int_distribution<std::uint32_t>(first_with_contents, e.version - 1)(rng);
        if (e.texture) {
          const TextureUse use = pick(rng, {TextureUse::Sampled, TextureUse::StorageRead, TextureUse::CopySrc});
          b.read(TextureHandle{e.index, version}, use);
          model.decls.push_back({std::uint32_t(p), e.index, version, -1, access_of(use)});
        } else {
          const BufferUse use = pick(rng, {BufferUse::Uniform, BufferUse::StorageRead, BufferUse::Vertex,
                                           BufferUse::Index, BufferUse::Indirect, BufferUse::CopySrc});
          b.read(BufferHandle{e.index, version}, use);
          model.decls.push_back({std::uint32_t(p), e.index, version, -1, access_of(use)});
        }
      }
      // Writes of existing resources.
      const int writes = std::uniform_int_distribution<int>(0, 1)(rng);
      for (int w = 0; w < writes && !pool.empty(); ++w) {
        PoolEntry& e = pool[std::uniform_int_distribution<std::size_t>(0, pool.size() - 1)(rng)];
        if (used.count(e.index)) continue;
        write_entry(e);
      }
      // New transients.
      const int creates = std::uniform_int_distribution<int>(0, 2)(rng);
      for (int c = 0; c < creates; ++c) {
        if (chance(rng, 0.75)) {
          const std::uint32_t size = pick(rng, {16u, 32u, 64u});
          auto h = b.create_texture("t" + std::to_string(p) + "_" + std::to_string(c),
                                    {.size = gpu::Extent3D{size, size, 1},
                                     .format = pick(rng, {gpu::Format::RGBA8Unorm, gpu::Format::RGBA16Float,
                                                          gpu::Format::R32Float})});
          model.textures.insert(h.index);
          pool.push_back({h.index, h.version, true, false, size});
        } else {
          auto h = b.create_buffer("b" + std::to_string(p) + "_" + std::to_string(c),
                                   {.size = pick(rng, {256ull, 4096ull, 100000ull})});
          pool.push_back({h.index, h.version, false, false, 0});
        }
        write_entry(pool.back());
      }
      model.side_effect.push_back(chance(rng, 0.1));
      if (model.side_effect.back()) b.side_effect();
    });
  }
  // Outputs: a few resources that were written, at their latest version.
  std::vector<std::size_t> written;
  for (std::size_t i = 0; i < pool.size(); ++i)
    if (pool[i].version > 0) written.push_back(i);
  std::shuffle(written.begin(), written.end(), rng);
  for (std::size_t i = 0; i < std::min<std::size_t>(written.size(), 2); ++i) {
    const PoolEntry& e = pool[written[i]];
    if (e.texture) graph.mark_output(TextureHandle{e.index, e.version});
    else graph.mark_output(BufferHandle{e.index, e.version});
    model.outputs.push_back({e.index, e.version});
  }
  return model;
}

// The test's own statement of the release rule: a different layout, with shader stages.
gpu::Access release_state_of(gpu::Access last) {
  using A = gpu::Access;
  return last == A::StorageRead || last == A::StorageWrite ? A::ShaderRead : A::StorageRead;
}

bool needs_barrier(gpu::Access before, gpu::Access after) {
  return before != after || gpu::is_write(before) || gpu::is_write(after);
}

// Whether the model's ordering edges (producer before user, reader before the next writer
// of what it read) form a cycle among any passes, culled or not.
bool has_cycle(const Model& m) {
  std::vector<std::vector<std::uint32_t>> next(m.passes);
  std::vector<std::uint32_t> indegree(m.passes, 0);
  auto edge = [&](std::uint32_t from, std::uint32_t to) {
    if (from == to) return;
    next[from].push_back(to);
    ++indegree[to];
  };
  for (const Decl& d : m.decls)
    for (const Decl& w : m.decls) {
      if (w.resource != d.resource || w.out_version < 0) continue;
      if (std::uint32_t(w.out_version) == d.in_version) edge(w.pass, d.pass);         // producer first
      if (d.out_version < 0 && w.in_version == d.in_version) edge(d.pass, w.pass);  // reader first
    }
  std::vector<std::uint32_t> ready;
  for (std::uint32_t p = 0; p < m.passes; ++p)
    if (indegree[p] == 0) ready.push_back(p);
  std::uint32_t placed = 0;
  while (!ready.empty()) {
    const std::uint32_t p = ready.back();
    ready.pop_back();
    ++placed;
    for (std::uint32_t q : next[p])
      if (--indegree[q] == 0) ready.push_back(q);
  }
  return placed < m.passes;
}

void check(const Model& m, const CompiledGraph& g, std::uint32_t seed) {
  INFO("seed " << seed);
  // Producers of every version, from the model.
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> producer;
  for (const Decl& d : m.decls)
    if (d.out_version >= 0) producer[{d.resource, std::uint32_t(d.out_version)}] = d.pass;

  // Culling: closure from side effects, imported writes and output producers.
  std::vector<bool> alive(m.passes, false);
  std::vector<std::uint32_t> stack;
  auto keep = [&](std::uint32_t p) {
    if (!alive[p]) {
      alive[p] = true;
      stack.push_back(p);
    }
  };
  for (std::uint32_t p = 0; p < m.passes; ++p)
    if (m.side_effect[p]) keep(p);
  for (const Decl& d : m.decls)
    if (d.out_version >= 0 && m.imported.count(d.resource)) keep(d.pass);
  for (auto [r, v] : m.outputs) keep(producer.at({r, v}));
  while (!stack.empty()) {
    const std::uint32_t p = stack.back();
    stack.pop_back();
    for (const Decl& d : m.decls)
      if (d.pass == p)
        if (auto it = producer.find({d.resource, d.in_version}); it != producer.end()) keep(it->second);
  }
  for (std::uint32_t p = 0; p < m.passes; ++p) CHECK_MESSAGE(g.passes()[p].culled == !alive[p], "pass p" << p);

  // Order: every edge between alive passes is respected.
  std::vector<std::uint32_t> position(m.passes, ~0u);
  for (std::uint32_t i = 0; i < g.order().size(); ++i) position[g.order()[i]] = i;
  for (std::uint32_t p = 0; p < m.passes; ++p) CHECK(alive[p] == (position[p] != ~0u));
  for (const Decl& d : m.decls) {
    if (!alive[d.pass]) continue;
    if (auto it = producer.find({d.resource, d.in_version}); it != producer.end() && it->second != d.pass)
      CHECK_MESSAGE(position[it->second] < position[d.pass], "producer before user of resource " << d.resource);
    if (d.out_version >= 0)  // readers of the version this write replaces come first
      for (const Decl& r : m.decls)
        if (alive[r.pass] && r.pass != d.pass && r.resource == d.resource && r.in_version == d.in_version &&
            r.out_version < 0)
          CHECK_MESSAGE(position[r.pass] < position[d.pass], "write after read of resource " << d.resource);
  }

  // Lifetimes and memory: nothing live at the same time overlaps in memory.
  const auto resources = g.resources();
  for (std::size_t x = 0; x < resources.size(); ++x) {
    const ResourceInfo& p = resources[x];
    if (p.heap == invalid_index) continue;
    CHECK(p.bytes > 0);
    for (std::size_t y = x + 1; y < resources.size(); ++y) {
      const ResourceInfo& q = resources[y];
      if (q.heap != p.heap) continue;
      const bool live_together = p.first_use <= q.last_use && q.first_use <= p.last_use;
      const bool overlap = p.offset < q.offset + q.bytes && q.offset < p.offset + p.bytes;
      CHECK_FALSE_MESSAGE((live_together && overlap), p.name, " and ", q.name);
    }
  }
  CHECK(g.memory().aliased_bytes <= g.memory().unaliased_bytes + 64 * 1024 * g.memory().heaps.size());

  // Barriers: walk each resource's accesses in order; every hazard has its barrier, equal
  // reads have none, and a resource taking over memory waits on the resources it replaces.
  std::map<std::uint32_t, std::vector<std::uint32_t>> takeovers;  // resource -> previous occupants
  std::map<std::uint32_t, int> releases;  // texture -> times it was moved out of its last state
  for (std::uint32_t pos = 0; pos < g.order().size(); ++pos)
    for (const PlannedBarrier& b : g.barriers_before(g.order()[pos])) {
      if (b.previous_occupant == invalid_index) continue;
      takeovers[b.resource].push_back(b.previous_occupant);
      CHECK(resources[b.previous_occupant].last_use < pos);
      if (m.textures.count(b.previous_occupant) && b.occupant_before != b.occupant_after) {
        ++releases[b.previous_occupant];
        CHECK(b.occupant_after == release_state_of(b.occupant_before));
      }
    }
  for (auto [occupant, count] : releases) CHECK_MESSAGE(count == 1, "texture " << occupant << " released " << count << " times");
  std::map<std::uint32_t, gpu::Access> state;
  for (std::uint32_t pos = 0; pos < g.order().size(); ++pos) {
    const std::uint32_t p = g.order()[pos];
    const auto barriers = g.barriers_before(p);
    for (const Decl& d : m.decls) {
      if (d.pass != p) continue;
      const bool imported = m.imported.count(d.resource) > 0;
      const bool texture = m.textures.count(d.resource) > 0;
      auto found = [&](gpu::Access before) {
        return std::any_of(barriers.begin(), barriers.end(), [&](const PlannedBarrier& b) {
          return b.resource == d.resource && b.before == before && b.after == d.access;
        });
      };
      const bool first_use = !state.count(d.resource);
      const gpu::Access before = first_use ? (imported ? m.initial.at(d.resource) : gpu::Access::Undefined)
                                           : state.at(d.resource);
      if (first_use && !imported) {
        if (texture || takeovers.count(d.resource))
          CHECK_MESSAGE(found(gpu::Access::Undefined), "first use of resource " << d.resource << " at pass p" << p);
      } else if (before == gpu::Access::Undefined) {
        if (texture) CHECK_MESSAGE(found(before), "layout of imported " << d.resource);
      } else if (needs_barrier(before, d.access)) {
        CHECK_MESSAGE(found(before), "hazard on resource " << d.resource << " at pass p" << p << ": "
                                                            << gpu::to_string(before) << " -> "
                                                            << gpu::to_string(d.access));
      } else {
        CHECK_FALSE_MESSAGE(found(before), "needless barrier on resource " << d.resource);
      }
      state[d.resource] = d.access;
    }
  }
  // Every earlier user of memory a resource takes over is reachable through takeovers.
  for (std::size_t y = 0; y < resources.size(); ++y) {
    const ResourceInfo& q = resources[y];
    if (q.heap == invalid_index) continue;
    std::set<std::uint32_t> reach;
    std::vector<std::uint32_t> todo{std::uint32_t(y)};
    while (!todo.empty()) {
      const std::uint32_t r = todo.back();
      todo.pop_back();
      for (std::uint32_t o : takeovers[r])
        if (reach.insert(o).second) todo.push_back(o);
    }
    for (std::size_t x = 0; x < resources.size(); ++x) {
      const ResourceInfo& p = resources[x];
      if (x == y || p.heap != q.heap || p.last_use >= q.first_use) continue;
      const bool overlap = p.offset < q.offset + q.bytes && q.offset < p.offset + p.bytes;
      if (overlap) CHECK_MESSAGE(reach.count(std::uint32_t(x)), q.name << " takes over " << p.name << " unsynchronized");
    }
  }
}

}  // namespace

TEST_CASE("random DAGs: culling, order, memory and barriers agree with the declarations") {
  int compiled_graphs = 0, aliased = 0;
  for (std::uint32_t seed = 1; seed <= 400; ++seed) {
    RenderGraph graph("random");
    const Model model = build(graph, seed);
    auto compiled = graph.compile({.output_extent = {64, 64, 1}});
    REQUIRE_MESSAGE(compiled, "seed " << seed << ": " << compiled.error().to_string());
    check(model, *compiled, seed);
    ++compiled_graphs;
    aliased += compiled->memory().aliased_bytes < compiled->memory().unaliased_bytes ? 1 : 0;
  }
  CHECK(compiled_graphs == 400);
  CHECK(aliased > 100);  // the generator produces graphs where aliasing matters
}

TEST_CASE("random DAGs with stale reads: the general order agrees with the declarations, or the cycle is real") {
  // Reads of older versions put readers before writes declared earlier, so compile() takes
  // its general path (Kahn's algorithm) instead of declaration order.
  int cycles = 0, reordered = 0, compiled_graphs = 0;
  for (std::uint32_t seed = 5000; seed < 5400; ++seed) {
    RenderGraph graph("stale");
    const Model model = build(graph, seed, 0.35);
    auto compiled = graph.compile({.output_extent = {64, 64, 1}});
    if (!compiled) {
      CHECK_MESSAGE(has_cycle(model), "seed " << seed << ": " << compiled.error().to_string());
      for (const GraphError& e : compiled.error().errors) CHECK_MESSAGE(e.kind == GraphErrorKind::Cycle, e.message);
      ++cycles;
      continue;
    }
    CHECK_FALSE_MESSAGE(has_cycle(model), "seed " << seed);
    check(model, *compiled, seed);
    ++compiled_graphs;
    const auto order = compiled->order();
    reordered += std::is_sorted(order.begin(), order.end()) ? 0 : 1;
  }
  MESSAGE(compiled_graphs << " compiled (" << reordered << " out of declaration order), " << cycles << " cycles");
  CHECK(reordered > 50);
  CHECK(cycles > 10);
}

TEST_CASE("random DAGs: stale reads either order correctly or report a cycle naming its passes") {
  int cycles = 0, orders = 0;
  for (std::uint32_t seed = 1000; seed < 1200; ++seed) {
    std::mt19937 rng(seed);
    RenderGraph graph("stale");
    const int n = std::uniform_int_distribution<int>(3, 12)(rng);
    std::vector<TextureHandle> versions;  // every version of one texture
    std::vector<TextureHandle> others;
    graph.add_pass("init", [&](PassBuilder& b) {
      versions.push_back(b.write(b.create_texture("x", {.size = gpu::Extent3D{8, 8, 1}}), TextureUse::StorageWrite));
    });
    for (int p = 0; p < n; ++p) {
      graph.add_pass("p" + std::to_string(p), [&](PassBuilder& b) {
        if (!others.empty() && chance(rng, 0.5))
          b.read(others[std::uniform_int_distribution<std::size_t>(0, others.size() - 1)(rng)], TextureUse::Sampled);
        if (chance(rng, 0.5)) {
          versions.push_back(b.write(versions.back(), TextureUse::StorageWrite));
        } else {
          b.read(versions[std::uniform_int_distribution<std::size_t>(0, versions.size() - 1)(rng)],
                 TextureUse::Sampled);
          others.push_back(b.write(b.create_texture("o" + std::to_string(p), {.size = gpu::Extent3D{8, 8, 1}}),
                                   TextureUse::StorageWrite));
        }
        b.side_effect();
      });
    }
    auto compiled = graph.compile({.output_extent = {8, 8, 1}});
    if (compiled) {
      ++orders;
      CHECK(compiled->order().size() == std::size_t(n + 1));
      continue;
    }
    ++cycles;
    for (const GraphError& e : compiled.error().errors) {
      REQUIRE_MESSAGE(e.kind == GraphErrorKind::Cycle, e.message);
      CHECK(e.passes.size() >= 2);
      std::string expected = "cycle: ";
      for (const std::string& pass : e.passes) expected += "'" + pass + "' -> ";
      expected += "'" + e.passes.front() + "' through ";
      CHECK_MESSAGE(e.message.rfind(expected, 0) == 0, e.message);
    }
  }
  CHECK(cycles > 0);
  CHECK(orders > 0);
}

TEST_CASE("reset: a graph rebuilt after reset() compiles exactly as a new graph, of any shape") {
  // Seeds give graphs of 3 to 40 passes in turn, so reused arrays are both grown and shrunk;
  // every third compiled graph is kept alive across the next reset and rebuild.
  RenderGraph reused("random");
  std::optional<CompiledGraph> kept;
  std::string kept_dump;
  for (std::uint32_t seed = 1; seed <= 150; ++seed) {
    reused.reset();
    CHECK(reused.pass_count() == 0);
    CHECK(reused.resource_count() == 0);
    const Model model = build(reused, seed);
    GraphMemory fresh_memory;  // nothing kept: a compile from scratch
    RenderGraph fresh("random", fresh_memory);
    build(fresh, seed);
    auto compiled = reused.compile({.output_extent = {64, 64, 1}});
    auto expected = fresh.compile({.output_extent = {64, 64, 1}});
    REQUIRE_MESSAGE(compiled, "seed " << seed << ": " << compiled.error().to_string());
    REQUIRE(expected);
    check(model, *compiled, seed);
    CHECK_MESSAGE(compiled->dump() == expected->dump(), "seed " << seed);
    CHECK_MESSAGE(compiled->to_dot() == expected->to_dot(), "seed " << seed);
    if (kept) CHECK_MESSAGE(kept->dump() == kept_dump, "seed " << seed << ": a kept compiled graph changed");
    if (seed % 3 == 0) {
      kept_dump = compiled->dump();
      kept.emplace(std::move(*compiled));
    } else if (seed % 3 == 1) {
      kept.reset();
    }
  }
}

TEST_CASE("reset: an identical rebuild reuses last frame's plan, which equals a fresh compile") {
  RenderGraph graph("random");
  int reused = 0;
  for (std::uint32_t seed = 1; seed <= 120; ++seed) {
    // Frame 1 builds the graph, frame 2 builds it again: frame 2 takes frame 1's plan over.
    for (int frame = 0; frame < 2; ++frame) {
      graph.reset();
      const Model model = build(graph, seed);
      auto compiled = graph.compile({.output_extent = {64, 64, 1}});
      REQUIRE_MESSAGE(compiled, "seed " << seed << ": " << compiled.error().to_string());
      CHECK_MESSAGE(compiled->plan_reused() == (frame == 1), "seed " << seed << " frame " << frame);
      reused += compiled->plan_reused() ? 1 : 0;
      check(model, *compiled, seed);
      GraphMemory fresh_memory;  // nothing kept: a compile from scratch
      RenderGraph fresh("random", fresh_memory);
      build(fresh, seed);
      auto expected = fresh.compile({.output_extent = {64, 64, 1}});
      REQUIRE(expected);
      CHECK_FALSE(expected->plan_reused());
      CHECK_MESSAGE(compiled->dump() == expected->dump(), "seed " << seed << " frame " << frame);
      CHECK_MESSAGE(compiled->to_dot() == expected->to_dot(), "seed " << seed << " frame " << frame);
    }
  }
  CHECK(reused == 120);
}

TEST_CASE("GraphMemory: a new graph per frame compiles exactly as a graph of its own; identical frames reuse the plan") {
  // Each seed is built in two frames, each a new RenderGraph made with the memory: the first
  // plans (last frame was another seed), the second takes its plan over. Seeds give graphs
  // of 3 to 40 passes, so the kept arrays are grown and shrunk; every third compiled graph is
  // kept alive while the next graphs are built (they then get memory of their own).
  GraphMemory memory;
  std::optional<CompiledGraph> kept;
  std::string kept_dump;
  int reused = 0;
  for (std::uint32_t seed = 1; seed <= 150; ++seed) {
    for (int frame = 0; frame < 2; ++frame) {
      RenderGraph graph("random", memory);
      CHECK(graph.pass_count() == 0);
      CHECK(graph.resource_count() == 0);
      CHECK(graph.name() == "random");
      const Model model = build(graph, seed);
      auto compiled = graph.compile({.output_extent = {64, 64, 1}});
      REQUIRE_MESSAGE(compiled, "seed " << seed << ": " << compiled.error().to_string());
      check(model, *compiled, seed);
      GraphMemory fresh_memory;  // nothing kept: a compile from scratch
      RenderGraph fresh("random", fresh_memory);
      build(fresh, seed);
      auto expected = fresh.compile({.output_extent = {64, 64, 1}});
      REQUIRE(expected);
      CHECK_MESSAGE(compiled->dump() == expected->dump(), "seed " << seed << " frame " << frame);
      CHECK_MESSAGE(compiled->to_dot() == expected->to_dot(), "seed " << seed << " frame " << frame);
      if (frame == 0) CHECK_FALSE(compiled->plan_reused());
      reused += compiled->plan_reused() ? 1 : 0;
      if (kept) CHECK_MESSAGE(kept->dump() == kept_dump, "seed " << seed << ": a kept compiled graph changed");
      if (frame == 1 && seed % 3 == 0) {
        kept_dump = compiled->dump();
        kept.emplace(std::move(*compiled));
      } else if (frame == 1 && seed % 3 == 1) {
        kept.reset();
      }
    }
  }
  // Frame 1 reuses whenever frame 0's compiled graph was gone in time, which it always is here.
  CHECK(reused == 150);
}

TEST_CASE("A RenderGraph made the plain way uses its thread's memory: planned as in fresh memory, identical frames reuse the plan") {
  // `RenderGraph graph(name);` every frame, the way Filament's and Frostbite's users write it,
  // costs what a GraphMemory frame loop costs (weft-bench-graph, build "default").
  const CompileOptions options{.output_extent = {64, 64, 1}};
  GraphMemory::for_this_thread().release();
  int reused = 0;
  for (std::uint32_t seed = 1; seed <= 60; ++seed) {
    for (int frame = 0; frame < 2; ++frame) {
      std::string dump;
      {
        RenderGraph graph("random");
        CHECK(graph.pass_count() == 0);
        CHECK(graph.resource_count() == 0);
        const Model model = build(graph, seed);
        auto compiled = graph.compile(options);
        REQUIRE_MESSAGE(compiled, "seed " << seed << ": " << compiled.error().to_string());
        check(model, *compiled, seed);
        if (frame == 0) CHECK_FALSE(compiled->plan_reused());
        reused += compiled->plan_reused() ? 1 : 0;
        dump = compiled->dump();
      }
      GraphMemory cold;  // a graph in memory nobody used before
      RenderGraph fresh("random", cold);
      build(fresh, seed);
      auto expected = fresh.compile(options);
      REQUIRE(expected);
      CHECK_FALSE(expected->plan_reused());
      CHECK_MESSAGE(dump == expected->dump(), "seed " << seed << " frame " << frame);
    }
  }
  CHECK(reused == 60);
}

TEST_CASE("A thread's memory keeps nothing a frame captured, nothing a live compiled graph holds, and is per thread") {
  const CompileOptions options{.output_extent = {64, 64, 1}};
  auto frame_capturing = [](RenderGraph& graph, std::shared_ptr<int> captured) {
    struct Data {
      TextureHandle out;
    };
    auto& data = graph.add_pass<Data>(
        "capture",
        [](PassBuilder& b, Data& d) {
          d.out = b.write(b.create_texture("out", {.format = gpu::Format::RGBA8Unorm}), TextureUse::ColorAttachment);
        },
        [captured](const PassResources&, const Data&, PassContext&) { (void)*captured; });
    graph.mark_output(data.out);
  };
  SUBCASE("the graph destroyed after its compiled graph: what the pass captured goes with the graph") {
    auto object = std::make_shared<int>(1);
    const std::weak_ptr<int> watch = object;
    {
      RenderGraph graph("captures");
      frame_capturing(graph, std::move(object));
      auto compiled = graph.compile(options);
      REQUIRE(compiled);
      CHECK_FALSE(watch.expired());
    }
    CHECK(watch.expired());
  }
  SUBCASE("the compiled graph outlives its graph: the capture goes with the compiled graph, not into the memory") {
    auto object = std::make_shared<int>(2);
    const std::weak_ptr<int> watch = object;
    std::optional<CompiledGraph> compiled;
    {
      RenderGraph graph("captures");
      frame_capturing(graph, std::move(object));
      auto result = graph.compile(options);
      REQUIRE(result);
      compiled.emplace(std::move(*result));
    }
    CHECK_FALSE(watch.expired());  // the compiled graph still needs it
    compiled.reset();
    CHECK(watch.expired());
    // and the next plain graph still plans correctly
    RenderGraph next("random");
    build(next, 3);
    auto again = next.compile(options);
    REQUIRE(again);
  }
  SUBCASE("two threads building plain graphs at once each use their own memory") {
    auto run = [&](std::uint32_t first_seed, std::vector<std::string>& dumps) {
      for (std::uint32_t seed = first_seed; seed < first_seed + 40; ++seed) {
        RenderGraph graph("random");
        build(graph, seed);
        auto compiled = graph.compile(options);
        dumps.push_back(compiled ? compiled->dump() : compiled.error().to_string());
      }
    };
    std::vector<std::string> a, b;
    std::thread other([&] { run(100, b); });
    run(200, a);
    other.join();
    for (std::uint32_t i = 0; i < 40; ++i) {
      GraphMemory cold_a, cold_b;
      RenderGraph expect_a("random", cold_a), expect_b("random", cold_b);
      build(expect_a, 200 + i);
      build(expect_b, 100 + i);
      auto ea = expect_a.compile(options);
      auto eb = expect_b.compile(options);
      REQUIRE(ea);
      REQUIRE(eb);
      CHECK_MESSAGE(a[i] == ea->dump(), "seed " << 200 + i);
      CHECK_MESSAGE(b[i] == eb->dump(), "seed " << 100 + i);
    }
  }
}

TEST_CASE("GraphMemory: overlapping graphs, a memory released or destroyed before its graph, moved graphs") {
  const CompileOptions options{.output_extent = {64, 64, 1}};
  auto expected_dump = [&](std::uint32_t seed) {
    GraphMemory fresh_memory;  // nothing kept: a compile from scratch
    RenderGraph fresh("random", fresh_memory);
    build(fresh, seed);
    auto expected = fresh.compile(options);
    REQUIRE(expected);
    return expected->dump();
  };
  SUBCASE("two graphs alive at once: the second gets memory of its own, both compile as fresh graphs") {
    GraphMemory memory;
    for (int round = 0; round < 3; ++round) {
      RenderGraph first("random", memory);
      RenderGraph second("random", memory);
      build(first, 11);
      build(second, 12);
      auto a = first.compile(options);
      auto b = second.compile(options);
      REQUIRE(a);
      REQUIRE(b);
      CHECK(a->dump() == expected_dump(11));
      CHECK(b->dump() == expected_dump(12));
    }
  }
  SUBCASE("the memory destroyed while its graph lives: the graph keeps what it took") {
    std::optional<GraphMemory> memory(std::in_place);
    { RenderGraph warm("random", *memory); build(warm, 5); }
    RenderGraph graph("random", *memory);
    memory.reset();
    build(graph, 6);
    auto compiled = graph.compile(options);
    REQUIRE(compiled);
    CHECK(compiled->dump() == expected_dump(6));
  }
  SUBCASE("release() while a graph holds the memory, and between graphs") {
    GraphMemory memory;
    {
      RenderGraph graph("random", memory);
      build(graph, 7);
      memory.release();
      auto compiled = graph.compile(options);
      REQUIRE(compiled);
      CHECK(compiled->dump() == expected_dump(7));
    }
    memory.release();
    RenderGraph graph("random", memory);
    build(graph, 7);
    auto compiled = graph.compile(options);
    REQUIRE(compiled);
    CHECK_FALSE(compiled->plan_reused());  // nothing was kept to reuse
    CHECK(compiled->dump() == expected_dump(7));
  }
  SUBCASE("a graph moved into another gives the other's memory back first") {
    GraphMemory memory_a, memory_b;
    RenderGraph a("random", memory_a);
    build(a, 8);
    { REQUIRE(a.compile(options)); }
    RenderGraph b("random", memory_b);
    build(b, 9);
    b = std::move(a);  // b's arrays go back to memory_b, a's come with it
    auto compiled = b.compile(options);
    REQUIRE(compiled);
    CHECK(compiled->dump() == expected_dump(8));
    RenderGraph again("random", memory_b);  // takes what b held before the move
    build(again, 9);
    auto second = again.compile(options);
    REQUIRE(second);
    CHECK(second->dump() == expected_dump(9));
  }
}

namespace {

// A small frame with every kind of declaration a plan depends on; `change` alters one of them.
struct Variant {
  const char* what;
  int change;
};

void build_variant(RenderGraph& graph, int change, const std::string& suffix = "") {
  using TU = gpu::TextureUsage;
  auto history = graph.import_texture("history" + suffix,
                                      gpu::TextureDescriptor{.label = "history", .size = {64, 64, 1},
                                                             .format = gpu::Format::RGBA16Float,
                                                             .usage = TU::Sampled | TU::ColorAttachment},
                                      change == 1 ? gpu::Access::ShaderRead : gpu::Access::Undefined);
  TextureHandle depth, colour, blurred;
  graph.add_pass("depth" + suffix, [&](PassBuilder& b) {
    depth = b.write(b.create_texture("depth" + suffix, {.format = gpu::Format::Depth32Float}),
                    TextureUse::DepthAttachment);
  });
  graph.add_pass("shade" + suffix, [&](PassBuilder& b) {
    b.read(depth, change == 2 ? TextureUse::DepthRead : TextureUse::Sampled);
    colour = b.write(b.create_texture("colour" + suffix, {.size = RelativeSize{1.0f},
                                                          .format = change == 3 ? gpu::Format::RGBA8Unorm
                                                                                : gpu::Format::RGBA16Float}),
                     TextureUse::ColorAttachment);
  });
  graph.add_pass("blur" + suffix, [&](PassBuilder& b) {
    b.read(colour, TextureUse::Sampled);
    blurred = b.write(b.create_texture("blurred" + suffix, {.size = RelativeSize{change == 4 ? 0.25f : 0.5f}}),
                      TextureUse::StorageWrite);
    if (change == 5) b.side_effect();
  });
  graph.add_pass("resolve" + suffix, [&](PassBuilder& b) {
    b.read(blurred, TextureUse::Sampled);
    b.read(colour, TextureUse::Sampled);
    history = b.write(history, TextureUse::ColorAttachment);
    if (change == 6) b.kind(PassKind::Render);
  });
  if (change == 7) graph.add_pass("extra" + suffix, [&](PassBuilder& b) { b.read(colour, TextureUse::Sampled); b.side_effect(); });
  graph.mark_output(history, change == 8 ? gpu::Access::ColorAttachment : gpu::Access::ShaderRead);
}

}  // namespace

TEST_CASE("reset: any change to what a plan depends on makes compile() plan again") {
  const CompileOptions base{.output_extent = {64, 64, 1}};
  const std::vector<Variant> variants{
      {"an import's initial state", 1}, {"a use", 2},      {"a format", 3},     {"a relative size", 4},
      {"a side effect", 5},             {"a pass kind", 6}, {"an extra pass", 7}, {"an output's final state", 8},
      {"the output extent", 9},         {"aliasing", 10}};
  for (const Variant& v : variants) {
    INFO(v.what);
    RenderGraph graph("variants");
    graph.reset();
    build_variant(graph, 0);
    { REQUIRE(graph.compile(base)); }  // destroyed: its plan waits for the next frame
    graph.reset();
    build_variant(graph, v.change <= 8 ? v.change : 0);
    CompileOptions options = base;
    if (v.change == 9) options.output_extent = {32, 32, 1};
    if (v.change == 10) options.aliasing = false;
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK_FALSE(compiled->plan_reused());
    GraphMemory fresh_memory;  // nothing kept: a compile from scratch
    RenderGraph fresh("variants", fresh_memory);
    build_variant(fresh, v.change <= 8 ? v.change : 0);
    auto expected = fresh.compile(options);
    REQUIRE(expected);
    CHECK(compiled->dump() == expected->dump());
  }
}

TEST_CASE("reset: a reused plan shows this frame's names; a kept compiled graph is never taken over") {
  RenderGraph graph("names");
  graph.reset();
  build_variant(graph, 0, "_a");
  { REQUIRE(graph.compile({.output_extent = {64, 64, 1}})); }
  graph.reset();
  build_variant(graph, 0, "_b");
  auto second = graph.compile({.output_extent = {64, 64, 1}});
  REQUIRE(second);
  CHECK(second->plan_reused());
  CHECK(second->find_pass("shade_b").has_value());
  CHECK_FALSE(second->find_pass("shade_a").has_value());
  CHECK(second->find_resource("blurred_b").has_value());
  CHECK(contains_text(second->dump(), "blurred_b"));
  CHECK_FALSE(contains_text(second->dump(), "_a"));
  // `second` stays alive: the next frame cannot take its plan and compiles afresh, and
  // `second` is unchanged by it.
  const std::string second_dump = second->dump();
  graph.reset();
  build_variant(graph, 0, "_c");
  auto third = graph.compile({.output_extent = {64, 64, 1}});
  REQUIRE(third);
  CHECK_FALSE(third->plan_reused());
  CHECK(second->dump() == second_dump);
  // A graph compiled twice in one frame: the second compile finds no previous frame's plan
  // it may take (the first is alive) and plans again.
  auto again = graph.compile({.output_extent = {64, 64, 1}});
  REQUIRE(again);
  CHECK(again->dump() == third->dump());
}
