// Device-free: passes that use mips and layers of one texture apart (TextureRange) -- the
// declaration rules, the ordering (hazards per subresource, not per texture), the barriers
// (per block of mips and layers), and a property test that simulates random frames
// subresource by subresource against a reference built from the declarations alone.
#include <doctest/doctest.h>
#include <algorithm>
#include <cstdint>
#include <map>
#include <random>
#include <string>
#include <vector>
#include "graph_test_util.hpp"
import weft.core;
import weft.gpu;
import weft.graph;

using namespace weft;
using graph_test::contains;

namespace {

using A = gpu::Access;

const CompileOptions options{.output_extent = {64, 64, 1}};

TextureDesc chain_desc(std::uint32_t mips) {
  return {.size = gpu::Extent3D{64, 64, 1}, .format = gpu::Format::RGBA8Unorm, .mip_level_count = mips};
}
TextureDesc cube_desc() {
  return {.size = gpu::Extent3D{16, 16, 6}, .format = gpu::Format::RGBA8Unorm, .dimension = gpu::TextureDimension::Cube};
}

// The barriers before a pass that move `resource` (not those of other resources).
std::vector<PlannedBarrier> barriers_of(const CompiledGraph& g, std::string_view pass, std::uint32_t resource) {
  const auto p = g.find_pass(pass);
  REQUIRE(p);
  std::vector<PlannedBarrier> out;
  for (const PlannedBarrier& b : g.barriers_before(*p))
    if (b.resource == resource && b.previous_occupant == invalid_index) out.push_back(b);
  return out;
}

}  // namespace

TEST_SUITE("graph subresources") {
  TEST_CASE("a pass samples one mip while it renders the next: a mip chain in one texture, one barrier a step") {
    constexpr std::uint32_t mips = 4;
    RenderGraph graph("mip chain");
    auto out = graph.import_texture("out", gpu::TextureDescriptor{.label = "out", .size = {64, 64, 1},
                                                                  .usage = gpu::TextureUsage::ColorAttachment},
                                    A::Undefined);
    TextureHandle chain;
    graph.add_pass("base", [&](PassBuilder& b) {
      chain = b.write(b.create_texture("chain", chain_desc(mips)), TextureUse::ColorAttachment, TextureRange::mip(0));
    });
    for (std::uint32_t m = 1; m < mips; ++m) {
      graph.add_pass("mip " + std::to_string(m), [&, m](PassBuilder& b) {
        b.read(chain, TextureUse::Sampled, TextureRange::mip(m - 1));
        chain = b.write(chain, TextureUse::ColorAttachment, TextureRange::mip(m));
      });
    }
    CHECK(chain.version == mips);  // each step made the next version of the whole texture
    graph.add_pass("use", [&](PassBuilder& b) {
      b.read(chain, TextureUse::Sampled);
      out = b.write(out, TextureUse::ColorAttachment);
    });
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK(compiled->order().size() == mips + 1);

    // base: the texture placed whole, from Undefined, in the state of its first use.
    auto base = barriers_of(*compiled, "base", chain.index);
    REQUIRE(base.size() == 1);
    CHECK(base[0].before == A::Undefined);
    CHECK(base[0].after == A::ColorAttachment);
    CHECK(base[0].range == TextureRange{});
    // Each step moves only the mip it samples; the mip it renders was untouched since then,
    // already in the attachment layout.
    for (std::uint32_t m = 1; m < mips; ++m) {
      auto step = barriers_of(*compiled, "mip " + std::to_string(m), chain.index);
      REQUIRE_MESSAGE(step.size() == 1, compiled->dump());
      CHECK(step[0].before == A::ColorAttachment);
      CHECK(step[0].after == A::ShaderRead);
      CHECK(step[0].range == TextureRange{m - 1, 1, 0, 1});
    }
    // The whole read: only the last mip is not yet in ShaderRead.
    auto use = barriers_of(*compiled, "use", chain.index);
    REQUIRE(use.size() == 1);
    CHECK(use[0].range == TextureRange{mips - 1, 1, 0, 1});
    CHECK(use[0].before == A::ColorAttachment);
    CHECK(use[0].after == A::ShaderRead);
    CHECK(contains(compiled->dump(), "barrier chain, mip 3: color-attachment -> shader-read"));
    // The view a pass renders into has its mip's size.
    const ResourceInfo& info = compiled->resources()[chain.index];
    CHECK(info.mip_level_count == mips);
    CHECK(gpu::has(info.texture_usage, gpu::TextureUsage::Sampled | gpu::TextureUsage::ColorAttachment));
  }

  TEST_CASE("bloom in one texture: down the mip chain and back up, each up pass blending into the mip above") {
    constexpr std::uint32_t mips = 5;
    RenderGraph graph("bloom");
    TextureHandle chain;
    graph.add_pass("bright", [&](PassBuilder& b) {
      chain = b.write(b.create_texture("bloom", chain_desc(mips)), TextureUse::ColorAttachment, TextureRange::mip(0));
    });
    for (std::uint32_t m = 1; m < mips; ++m)
      graph.add_pass("down " + std::to_string(m), [&, m](PassBuilder& b) {
        b.read(chain, TextureUse::Sampled, TextureRange::mip(m - 1));
        chain = b.write(chain, TextureUse::ColorAttachment, TextureRange::mip(m));
      });
    for (std::uint32_t m = mips - 1; m-- > 0;)
      graph.add_pass("up " + std::to_string(m), [&, m](PassBuilder& b) {
        b.read(chain, TextureUse::Sampled, TextureRange::mip(m + 1));
        chain = b.write(chain, TextureUse::ColorAttachment, TextureRange::mip(m));  // loads and blends
      });
    graph.add_pass("composite", [&](PassBuilder& b) {
      b.read(chain, TextureUse::Sampled, TextureRange::mip(0));
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK(compiled->order().size() == 2 * mips);
    // Up m: the mip below moves to sampling (the last down pass rendered it, or the last up
    // pass blended it), and the mip it blends into moves back from sampling to rendering.
    for (std::uint32_t m = mips - 1; m-- > 0;) {
      auto up = barriers_of(*compiled, "up " + std::to_string(m), chain.index);
      CAPTURE(m);
      REQUIRE_MESSAGE(up.size() == 2, compiled->dump());
      for (const PlannedBarrier& b : up) {
        if (b.range.base_mip == m + 1) {
          CHECK(b.before == A::ColorAttachment);
          CHECK(b.after == A::ShaderRead);
        } else {
          CHECK(b.range.base_mip == m);
          CHECK(b.before == A::ShaderRead);
          CHECK(b.after == A::ColorAttachment);
        }
      }
    }
  }

  TEST_CASE("a copy from one mip into the next of one texture in one pass: two transfer states, no conflict") {
    RenderGraph graph;
    TextureHandle t;
    graph.add_pass("upload", [&](PassBuilder& b) {
      t = b.write(b.create_texture("t", chain_desc(3)), TextureUse::CopyDst, TextureRange::mip(0));
    });
    for (std::uint32_t m = 1; m < 3; ++m)
      graph.add_pass("blit " + std::to_string(m), [&, m](PassBuilder& b) {
        b.read(t, TextureUse::CopySrc, TextureRange::mip(m - 1));
        t = b.write(t, TextureUse::CopyDst, TextureRange::mip(m));
        b.side_effect();
      });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    auto blit2 = barriers_of(*compiled, "blit 2", t.index);
    REQUIRE(blit2.size() == 1);
    CHECK(blit2[0].before == A::CopyDst);
    CHECK(blit2[0].after == A::CopySrc);
    CHECK(blit2[0].range == TextureRange{1, 1, 0, 1});
  }

  TEST_CASE("six passes render six faces of a cube with no barrier between them; a read of the cube waits for all") {
    RenderGraph graph;
    TextureHandle cube;
    graph.add_pass("create", [&](PassBuilder& b) {
      cube = b.write(b.create_texture("cube", cube_desc()), TextureUse::ColorAttachment, TextureRange::layer(0));
    });
    for (std::uint32_t face = 1; face < 6; ++face)
      graph.add_pass("face " + std::to_string(face), [&, face](PassBuilder& b) {
        cube = b.write(cube, TextureUse::ColorAttachment, TextureRange::layer(face));
      });
    graph.add_pass("sample", [&](PassBuilder& b) {
      b.read(cube, TextureUse::Sampled);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    for (std::uint32_t face = 1; face < 6; ++face)
      CHECK_MESSAGE(barriers_of(*compiled, "face " + std::to_string(face), cube.index).empty(), compiled->dump());
    auto sample = barriers_of(*compiled, "sample", cube.index);
    REQUIRE(sample.size() == 1);  // the six faces are one block in one state
    CHECK(sample[0].range == TextureRange{0, 1, 0, 6});
    CHECK(sample[0].before == A::ColorAttachment);
    CHECK(sample[0].after == A::ShaderRead);
  }

  TEST_CASE("faces are not ordered by their cube: what is a cycle for whole textures is an order for faces") {
    // 'late' reads face 0 as 'face 0' left it (a handle older than face 1's write) and writes
    // y, which 'face 1' reads first. Whole textures: late before face 1 (it reads what face 1
    // overwrites) and face 1 before late (it reads y before late writes it): a cycle. Faces:
    // face 1 writes only layer 1, so late may run after it.
    for (const bool ranged : {true, false}) {
      CAPTURE(ranged);
      RenderGraph graph;
      TextureHandle cube, face0, y;
      auto use_face = [&](PassBuilder& b, TextureHandle h, std::uint32_t face, bool write) {
        if (ranged)
          return write ? b.write(h, TextureUse::ColorAttachment, TextureRange::layer(face))
                       : b.read(h, TextureUse::Sampled, TextureRange::layer(face));
        return write ? b.write(h, TextureUse::ColorAttachment) : b.read(h, TextureUse::Sampled);
      };
      graph.add_pass("make y", [&](PassBuilder& b) { y = b.write(b.create_texture("y", chain_desc(1)), TextureUse::StorageWrite); });
      graph.add_pass("face 0", [&](PassBuilder& b) { face0 = cube = use_face(b, b.create_texture("cube", cube_desc()), 0, true); });
      graph.add_pass("face 1", [&](PassBuilder& b) {
        b.read(y, TextureUse::Sampled);
        cube = use_face(b, cube, 1, true);
        b.side_effect();
      });
      graph.add_pass("late", [&](PassBuilder& b) {
        use_face(b, face0, 0, false);
        y = b.write(y, TextureUse::StorageWrite);
        b.side_effect();
      });
      auto compiled = graph.compile(options);
      if (!ranged) {
        REQUIRE_FALSE(compiled);
        CHECK(compiled.error().count(GraphErrorKind::Cycle) == 1);
        continue;
      }
      REQUIRE_MESSAGE(compiled, compiled.error().to_string());
      CHECK(std::vector<std::uint32_t>(compiled->order().begin(), compiled->order().end()) ==
            std::vector<std::uint32_t>{0, 1, 2, 3});
    }
  }

  TEST_CASE("overlapping ranges used two ways in one pass are refused, naming both; read the same way they are one state") {
    RenderGraph graph;
    TextureHandle t;
    graph.add_pass("init", [&](PassBuilder& b) { t = b.write(b.create_texture("t", chain_desc(4)), TextureUse::CopyDst); });
    graph.add_pass("reads", [&](PassBuilder& b) {
      b.read(t, TextureUse::Sampled, TextureRange::mips(0, 3));
      b.read(t, TextureUse::Sampled, TextureRange::mip(2));
      b.side_effect();
    });
    REQUIRE(graph.compile(options));
    graph.add_pass("clash", [&](PassBuilder& b) {
      b.read(t, TextureUse::Sampled, TextureRange::mips(0, 3));
      (void)b.write(t, TextureUse::ColorAttachment, TextureRange::mip(2));
      b.side_effect();
    });
    auto refused = graph.compile(options);
    REQUIRE_FALSE(refused);
    REQUIRE(refused.error().size() == 1);
    const GraphError& e = refused.error().errors.front();
    CHECK(e.kind == GraphErrorKind::ConflictingUsage);
    CHECK_MESSAGE(contains(e.message, "pass 'clash'"), e.message);
    CHECK_MESSAGE(contains(e.message, "uses mips 0-2 of texture 't' as sampled and mip 2 of it as color-attachment"), e.message);
    CHECK(e.passes == std::vector<std::string>{"clash"});
    CHECK(e.resources == std::vector<std::string>{"t"});
  }

  TEST_CASE("the whole texture beside a part of it in one pass: refused unless both are read the same way") {
    RenderGraph graph;
    TextureHandle t;
    graph.add_pass("init", [&](PassBuilder& b) { t = b.write(b.create_texture("t", chain_desc(2)), TextureUse::CopyDst); });
    graph.add_pass("both", [&](PassBuilder& b) {
      (void)b.write(t, TextureUse::ColorAttachment, TextureRange::mip(1));
      b.read(t, TextureUse::Sampled);
      b.side_effect();
    });
    auto refused = graph.compile(options);
    REQUIRE_FALSE(refused);
    CHECK(refused.error().count(GraphErrorKind::ConflictingUsage) == 1);
    CHECK(contains(refused.error().to_string(), "overlap"));
  }

  TEST_CASE("a range past a texture's mips or layers is an error naming the texture and its counts") {
    RenderGraph graph;
    graph.add_pass("bad", [&](PassBuilder& b) {
      auto t = b.create_texture("small", chain_desc(2));
      (void)b.write(t, TextureUse::ColorAttachment, TextureRange::mip(2));
      (void)b.write(b.create_texture("cube", cube_desc()), TextureUse::ColorAttachment, TextureRange::layer(6));
      b.side_effect();
    });
    auto refused = graph.compile(options);
    REQUIRE_FALSE(refused);
    CHECK(refused.error().count(GraphErrorKind::InvalidDescriptor) == 2);
    const std::string text = refused.error().to_string();
    CHECK_MESSAGE(contains(text, "pass 'bad': writes mip 2 of texture 'small', which has 2 mips and 1 layer"), text);
    CHECK_MESSAGE(contains(text, "writes layer 6 of texture 'cube', which has 1 mip and 6 layers"), text);
  }

  TEST_CASE("a range naming the whole texture is the whole texture (same access, same plan as without it)") {
    RenderGraph graph;
    TextureHandle t;
    graph.add_pass("init", [&](PassBuilder& b) {
      t = b.write(b.create_texture("t", chain_desc(2)), TextureUse::StorageWrite, TextureRange::mips(0, 2));
    });
    graph.add_pass("read", [&](PassBuilder& b) {
      b.read(t, TextureUse::Sampled, TextureRange::layer(0));
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    auto read = barriers_of(*compiled, "read", t.index);
    REQUIRE(read.size() == 1);
    CHECK(read[0].range == TextureRange{});
  }

  TEST_CASE("an attachment of mip 1 has mip 1's size: beside a half-size depth it is no mismatch, beside a full one it is") {
    for (const std::uint32_t depth_size : {32u, 64u}) {
      CAPTURE(depth_size);
      RenderGraph graph;
      TextureHandle chain;
      graph.add_pass("base", [&](PassBuilder& b) {
        chain = b.write(b.create_texture("chain", chain_desc(2)), TextureUse::ColorAttachment, TextureRange::mip(0));
      });
      graph.add_pass("mip 1", [&](PassBuilder& b) {
        b.read(chain, TextureUse::Sampled, TextureRange::mip(0));
        chain = b.write(chain, TextureUse::ColorAttachment, TextureRange::mip(1));
        (void)b.write(b.create_texture("depth", {.size = gpu::Extent3D{depth_size, depth_size, 1},
                                                 .format = gpu::Format::Depth32Float}),
                      TextureUse::DepthAttachment);
        b.side_effect();
      });
      auto compiled = graph.compile(options);
      if (depth_size == 32) {
        CHECK_MESSAGE(compiled, compiled.error().to_string());
        continue;
      }
      REQUIRE_FALSE(compiled);
      CHECK(compiled.error().count(GraphErrorKind::MismatchedAttachmentSizes) == 1);
      CHECK_MESSAGE(contains(compiled.error().to_string(), "32x32"), compiled.error().to_string());
    }
  }

  TEST_CASE("a frame repeating its ranges reuses the plan; another range is another plan") {
    GraphMemory memory;
    RenderGraph graph("frames", memory);
    auto frame = [&](std::uint32_t mip) {
      graph.reset();
      TextureHandle t;
      graph.add_pass("init", [&](PassBuilder& b) { t = b.write(b.create_texture("t", chain_desc(3)), TextureUse::CopyDst); });
      graph.add_pass("read", [&](PassBuilder& b) {
        b.read(t, TextureUse::Sampled, TextureRange::mip(mip));
        b.side_effect();
      });
      auto compiled = graph.compile(options);
      REQUIRE_MESSAGE(compiled, compiled.error().to_string());
      return compiled->plan_reused();
    };
    CHECK_FALSE(frame(1));
    CHECK(frame(1));
    CHECK_FALSE(frame(2));
    CHECK(frame(2));
  }

  TEST_CASE("random frames over the mips and layers of one texture: every read sees its writer, every hazard has a barrier") {
    // A reference from the declarations alone: for each subresource, its writes in version
    // order; a read of version v sees the last write at or before v and must run before the
    // next write. The compiled order must keep that, and the barriers replayed subresource by
    // subresource must put each one in the state its access declares, with a barrier between
    // a write and any later access (and between reads and a later write).
    std::mt19937 rng(20261207);
    auto pick = [&](std::uint32_t n) { return std::uniform_int_distribution<std::uint32_t>(0, n - 1)(rng); };
    constexpr TextureUse reads[] = {TextureUse::Sampled, TextureUse::CopySrc, TextureUse::StorageRead};
    constexpr TextureUse writes[] = {TextureUse::ColorAttachment, TextureUse::StorageWrite, TextureUse::CopyDst};
    int compiled_graphs = 0, checked_accesses = 0, reordered = 0;
    for (int seed = 0; seed < 300; ++seed) {
      const std::uint32_t mips = 1 + pick(4), layers = 1 + pick(4), passes = 6 + pick(8);
      struct Use {
        std::uint32_t pass;
        TextureRange range;  // exact counts
        bool write;
        TextureUse use;
        std::uint32_t version;  // read: the version read; write: the version made
      };
      std::vector<Use> uses;
      RenderGraph graph("random");
      TextureHandle t;
      std::vector<TextureHandle> aux(2);
      std::vector<TextureHandle> versions;  // of t, by version
      auto random_range = [&] {
        const std::uint32_t m0 = pick(mips), l0 = pick(layers);
        return TextureRange{m0, 1 + pick(mips - m0), l0, 1 + pick(layers - l0)};
      };
      auto apart = [](const TextureRange& a, const TextureRange& b) {
        return a.base_mip + a.mip_count <= b.base_mip || b.base_mip + b.mip_count <= a.base_mip ||
               a.base_layer + a.layer_count <= b.base_layer || b.base_layer + b.layer_count <= a.base_layer;
      };
      for (std::uint32_t p = 0; p < passes; ++p) {
        graph.add_pass("p" + std::to_string(p), [&](PassBuilder& b) {
          if (p == 0) {
            t = b.create_texture("t", {.size = gpu::Extent3D{16, 16, layers}, .format = gpu::Format::RGBA8Unorm,
                                       .mip_level_count = mips,
                                       .dimension = layers > 1 ? gpu::TextureDimension::D2Array : gpu::TextureDimension::D2});
            for (std::uint32_t i = 0; i < aux.size(); ++i)
              aux[i] = b.write(b.create_texture("aux" + std::to_string(i), {.size = gpu::Extent3D{16, 16, 1}}),
                               TextureUse::StorageWrite);
            versions.push_back(t);
          }
          // One or two ranges of t, apart.
          std::vector<TextureRange> ranges{random_range()};
          if (pick(2)) {
            const TextureRange second = random_range();
            if (apart(ranges[0], second)) ranges.push_back(second);
          }
          const TextureHandle input = versions.back();
          for (const TextureRange& range : ranges) {
            // The first pass writes; later ones write or read -- reads sometimes of an older
            // version (a stale handle: the order then has to be worked out).
            const bool write = p == 0 || pick(2);
            if (write) {
              const TextureUse use = writes[pick(3)];
              const TextureHandle made = b.write(input, use, range);
              if (versions.back().version != made.version) versions.push_back(made);
              uses.push_back({p, range, true, use, made.version});
            } else {
              // (version 0 has nothing in it: never read)
              const TextureHandle seen =
                  pick(3) == 0 && versions.size() > 2 ? versions[1 + pick(std::uint32_t(versions.size()) - 1)] : input;
              const TextureUse use = reads[pick(3)];
              b.read(seen, use, range);
              uses.push_back({p, range, false, use, seen.version});
            }
          }
          // The auxiliary textures tie passes together in other ways.
          if (p > 0 && pick(2)) {
            const std::uint32_t i = pick(2);
            if (pick(2)) aux[i] = b.write(aux[i], TextureUse::StorageWrite);
            else b.read(aux[i], TextureUse::Sampled);
          }
          b.side_effect();
        });
      }
      auto compiled = graph.compile(options);
      if (!compiled) {
        // A read of an older version in the same pass as the newer write, or a cycle
        // through the auxiliary textures: refused, never planned wrong.
        for (const GraphError& e : compiled.error().errors)
          CHECK_MESSAGE((e.kind == GraphErrorKind::Cycle || e.kind == GraphErrorKind::ConflictingUsage ||
                         e.kind == GraphErrorKind::MismatchedAttachmentSizes),
                        e.message);
        continue;
      }
      ++compiled_graphs;
      const auto order = compiled->order();
      REQUIRE(order.size() == passes);
      std::vector<std::uint32_t> position(passes);
      for (std::uint32_t i = 0; i < order.size(); ++i) position[order[i]] = i;
      for (std::uint32_t i = 0; i + 1 < order.size(); ++i) reordered += order[i] > order[i + 1] ? 1 : 0;

      // The reference: per subresource, the writes in version order.
      auto sub = [&](std::uint32_t m, std::uint32_t l) { return m * layers + l; };
      std::vector<std::map<std::uint32_t, std::uint32_t>> writes_of(mips * layers);  // version -> pass
      for (const Use& u : uses)
        if (u.write)
          for (std::uint32_t m = u.range.base_mip; m < u.range.base_mip + u.range.mip_count; ++m)
            for (std::uint32_t l = u.range.base_layer; l < u.range.base_layer + u.range.layer_count; ++l)
              writes_of[sub(m, l)][u.version] = u.pass;
      for (const Use& u : uses) {
        for (std::uint32_t m = u.range.base_mip; m < u.range.base_mip + u.range.mip_count; ++m) {
          for (std::uint32_t l = u.range.base_layer; l < u.range.base_layer + u.range.layer_count; ++l) {
            const auto& w = writes_of[sub(m, l)];
            if (u.write) {
              auto it = w.find(u.version);
              if (it != w.begin()) CHECK(position[std::prev(it)->second] < position[u.pass]);
              continue;
            }
            auto next = w.upper_bound(u.version);  // the first write after the version read
            if (next != w.begin()) CHECK(position[std::prev(next)->second] < position[u.pass]);
            if (next != w.end()) CHECK(position[u.pass] < position[next->second]);
          }
        }
      }

      // Replaying the barriers: states, and a barrier between every hazard.
      struct Sub {
        A state = A::Undefined;
        bool accessed = false, last_write = false, synced = false;
      };
      std::vector<Sub> subs(mips * layers);
      auto apply = [&](const TextureRange& r0, A before, A after) {
        const TextureRange r{r0.base_mip, r0.mips_of(mips), r0.base_layer, r0.layers_of(layers)};
        for (std::uint32_t m = r.base_mip; m < r.base_mip + r.mip_count; ++m)
          for (std::uint32_t l = r.base_layer; l < r.base_layer + r.layer_count; ++l) {
            Sub& s = subs[sub(m, l)];
            CHECK_MESSAGE(s.state == before, compiled->dump());
            s.state = after;
            s.synced = true;
          }
      };
      for (const std::uint32_t p : order) {
        for (const PlannedBarrier& b : compiled->barriers_before(p)) {
          if (b.resource == t.index && b.previous_occupant == invalid_index) apply(b.range, b.before, b.after);
          if (b.previous_occupant == t.index) apply(b.range, b.occupant_before, b.occupant_after);
        }
        for (const Use& u : uses) {
          if (u.pass != p) continue;
          for (std::uint32_t m = u.range.base_mip; m < u.range.base_mip + u.range.mip_count; ++m)
            for (std::uint32_t l = u.range.base_layer; l < u.range.base_layer + u.range.layer_count; ++l) {
              Sub& s = subs[sub(m, l)];
              CHECK(s.state == access_of(u.use));
              if (s.accessed && (s.last_write || u.write)) CHECK_MESSAGE(s.synced, compiled->dump());
              s.accessed = true;
              s.last_write = u.write;
              s.synced = false;
              ++checked_accesses;
            }
        }
      }
    }
    MESSAGE(compiled_graphs, " of 300 random frames compiled; ", checked_accesses, " subresource accesses checked; ",
            reordered, " passes run out of declaration order");
    CHECK(compiled_graphs >= 150);
    CHECK(reordered > 0);
  }
}
