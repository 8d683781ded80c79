// Device-free graph suite: declaration, every error class, culling, ordering, blackboard,
// lifetimes, aliasing, barriers and DOT — no GPU, runs in milliseconds.
#include <doctest/doctest.h>
#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <random>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>
#include "graph_test_util.hpp"
import weft.core;
import weft.gpu;
import weft.graph;

using namespace weft;
using graph_test::contains;
using graph_test::has;

namespace {

TextureDesc color_desc(std::uint32_t w = 64, std::uint32_t h = 64, gpu::Format format = gpu::Format::RGBA8Unorm) {
  return {.size = gpu::Extent3D{w, h, 1}, .format = format};
}

gpu::TextureDescriptor imported_desc(std::uint32_t w = 64, std::uint32_t h = 64,
                                     gpu::TextureUsage usage = gpu::TextureUsage::ColorAttachment |
                                                               gpu::TextureUsage::CopySrc) {
  return {.label = "imported", .size = {w, h, 1}, .format = gpu::Format::RGBA8Unorm, .usage = usage};
}

const CompileOptions options{.output_extent = {64, 64, 1}};

// A graph with one error of the given kind must report exactly that kind.
const GraphError& only_error(const GraphErrors& errors) {
  REQUIRE_MESSAGE(errors.size() == 1, errors.to_string());
  return errors.errors.front();
}

}  // namespace

static_assert(!std::is_convertible_v<TextureHandle, BufferHandle>, "a texture handle is not a buffer handle");
static_assert(!std::is_convertible_v<BufferHandle, TextureHandle>, "a buffer handle is not a texture handle");

TEST_SUITE("graph reset") {
  TEST_CASE("reset() forgets passes, resources, outputs, errors and blackboard entries") {
    RenderGraph graph("frame");
    graph.add_pass("broken", [](PassBuilder& b) { b.read(TextureHandle{7, 0}, TextureUse::Sampled); });
    graph.blackboard().put("scene_color", TextureHandle{0, 1});
    REQUIRE_FALSE(graph.compile(options));
    graph.reset();
    CHECK(graph.pass_count() == 0);
    CHECK(graph.resource_count() == 0);
    CHECK(graph.blackboard().keys().empty());
    CHECK(graph.name() == "frame");

    auto output = graph.import_texture("output", imported_desc(), gpu::Access::Undefined);
    TextureHandle color;
    graph.add_pass("scene", [&](PassBuilder& b) {
      color = b.write(b.create_texture("scene_color", color_desc()), TextureUse::ColorAttachment);
    });
    graph.add_pass("present", [&](PassBuilder& b) {
      b.read(color, TextureUse::Sampled);
      output = b.write(output, TextureUse::ColorAttachment);
    });
    graph.mark_output(output);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK(compiled->order().size() == 2);
    CHECK(compiled->resources()[0].name == "output");
    CHECK(compiled->resources()[1].name == "scene_color");
    CHECK(compiled->barriers_before(0).size() == 1);

    // Errors after a reset name the new passes and resources.
    graph.reset();
    graph.add_pass("reader", [&](PassBuilder& b) {
      b.read(b.create_texture("never_written", color_desc()), TextureUse::Sampled);
      b.side_effect();
    });
    auto failed = graph.compile(options);
    REQUIRE_FALSE(failed);
    const GraphError& e = only_error(failed.error());
    CHECK(e.kind == GraphErrorKind::UnwrittenRead);
    CHECK(e.passes == std::vector<std::string>{"reader"});
    CHECK(e.resources == std::vector<std::string>{"never_written"});
  }

  TEST_CASE("reset() releases what execute callbacks captured, once no compiled graph needs it") {
    struct Data {
      TextureHandle target;
    };
    auto token = std::make_shared<int>(0);
    auto add = [&](RenderGraph& graph) {
      graph.add_pass<Data>(
          "draw",
          [](PassBuilder& b, Data& d) {
            d.target = b.write(b.create_texture("target", color_desc()), TextureUse::ColorAttachment);
            b.side_effect();
          },
          [token](const PassResources&, const Data&, PassContext&) {});
    };
    RenderGraph graph("frame");
    add(graph);
    CHECK(token.use_count() == 2);
    graph.reset();
    CHECK(token.use_count() == 1);

    add(graph);
    std::optional<CompiledGraph> kept;
    {
      auto compiled = graph.compile(options);
      REQUIRE(compiled);
      kept.emplace(std::move(*compiled));
    }
    graph.reset();  // the kept compiled graph still needs its pass
    CHECK(token.use_count() == 2);
    CHECK(kept->passes()[0].name == "draw");
    add(graph);
    CHECK(token.use_count() == 3);
    kept.reset();
    graph.reset();
    CHECK(token.use_count() == 1);
  }
}

TEST_SUITE("graph declaration") {
  TEST_CASE("writes return the next version and reads keep it") {
    RenderGraph graph;
    TextureHandle created, written, read;
    graph.add_pass("a", [&](PassBuilder& b) {
      created = b.create_texture("t", color_desc());
      written = b.write(created, TextureUse::ColorAttachment);
    });
    graph.add_pass("b", [&](PassBuilder& b) { read = b.read(written, TextureUse::Sampled); });
    CHECK(created.version == 0);
    CHECK(written.index == created.index);
    CHECK(written.version == 1);
    CHECK(read == written);
    CHECK_FALSE(TextureHandle{}.valid());
  }

  TEST_CASE("add_pass returns the pass data, filled by setup") {
    RenderGraph graph;
    struct BlurData {
      TextureHandle src, dst;
    };
    auto output = graph.import_texture("output", imported_desc(), gpu::Access::Undefined);
    auto& scene = graph.add_pass<BlurData>(
        "scene",
        [&](PassBuilder& b, BlurData& d) {
          d.dst = b.create_texture("scene_color", color_desc());
          d.dst = b.write(d.dst, TextureUse::ColorAttachment);
        },
        [](const PassResources&, const BlurData&, PassContext&) {});
    auto& blur = graph.add_pass<BlurData>(
        "blur",
        [&](PassBuilder& b, BlurData& d) {
          d.src = b.read(scene.dst, TextureUse::Sampled);
          d.dst = b.write(output, TextureUse::ColorAttachment);
        },
        [](const PassResources&, const BlurData&, PassContext&) {});
    graph.mark_output(blur.dst);
    CHECK(blur.src == scene.dst);
    CHECK(blur.dst.index == output.index);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK(compiled->order().size() == 2);
  }

  TEST_CASE("pass kinds are inferred from uses, or declared") {
    RenderGraph graph;
    auto out = graph.import_texture("out", imported_desc(), gpu::Access::Undefined);
    auto buffer = graph.import_buffer("readback", gpu::BufferDescriptor{.label = "readback", .size = 1024},
                                      gpu::Access::Undefined);
    TextureHandle t;
    graph.add_pass("compute", [&](PassBuilder& b) {
      t = b.create_texture("t", color_desc());
      t = b.write(t, TextureUse::StorageWrite);
    });
    graph.add_pass("render", [&](PassBuilder& b) {
      b.read(t, TextureUse::Sampled);
      out = b.write(out, TextureUse::ColorAttachment);
    });
    graph.add_pass("copy", [&](PassBuilder& b) {
      b.read(out, TextureUse::CopySrc);
      buffer = b.write(buffer, BufferUse::CopyDst);
    });
    graph.add_pass("declared", [&](PassBuilder& b) {
      b.kind(PassKind::Transfer);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    const auto passes = compiled->passes();
    CHECK(passes[0].kind == PassKind::Compute);
    CHECK(passes[1].kind == PassKind::Render);
    CHECK(passes[2].kind == PassKind::Transfer);
    CHECK(passes[3].kind == PassKind::Transfer);
    CHECK(passes[3].kind_declared);
    CHECK_FALSE(passes[0].kind_declared);
  }

  TEST_CASE("usage flags of a transient come from every declared use") {
    RenderGraph graph;
    auto out = graph.import_texture("out", imported_desc(), gpu::Access::Undefined);
    TextureHandle t;
    graph.add_pass("fill", [&](PassBuilder& b) {
      t = b.create_texture("t", {.size = gpu::Extent3D{64, 64, 1}, .format = gpu::Format::RGBA16Float,
                                 .extra_usage = gpu::TextureUsage::CopyDst});
      t = b.write(t, TextureUse::StorageWrite);
    });
    graph.add_pass("use", [&](PassBuilder& b) {
      b.read(t, TextureUse::Sampled);
      out = b.write(out, TextureUse::ColorAttachment);
    });
    graph.add_pass("copy", [&](PassBuilder& b) {
      b.read(t, TextureUse::CopySrc);
      b.side_effect();
    });
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    const ResourceInfo& info = compiled->resources()[t.index];
    using U = gpu::TextureUsage;
    CHECK(info.texture_usage == (U::Storage | U::Sampled | U::CopySrc | U::CopyDst));
    CHECK_FALSE(gpu::has(info.texture_usage, U::ColorAttachment));
  }

  TEST_CASE("relative sizes resolve against the output extent") {
    RenderGraph graph;
    TextureHandle half, quarter, fixed;
    graph.add_pass("p", [&](PassBuilder& b) {
      half = b.write(b.create_texture("half", {.size = RelativeSize{0.5f}}), TextureUse::StorageWrite);
      quarter = b.write(b.create_texture("quarter", {.size = RelativeSize{0.25f, 0.5f}}), TextureUse::StorageWrite);
      fixed = b.write(b.create_texture("fixed", {.size = gpu::Extent3D{7, 9, 1}}), TextureUse::StorageWrite);
      b.side_effect();
    });
    auto compiled = graph.compile({.output_extent = {1920, 1080, 1}});
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK(compiled->resources()[half.index].extent == gpu::Extent3D{960, 540, 1});
    CHECK(compiled->resources()[quarter.index].extent == gpu::Extent3D{480, 540, 1});
    CHECK(compiled->resources()[fixed.index].extent == gpu::Extent3D{7, 9, 1});
  }

  TEST_CASE("a pass declaring storage read and write of one texture is in one state") {
    RenderGraph graph;
    TextureHandle t;
    graph.add_pass("init", [&](PassBuilder& b) {
      t = b.write(b.create_texture("t", color_desc()), TextureUse::StorageWrite);
    });
    graph.add_pass("update", [&](PassBuilder& b) {
      b.read(t, TextureUse::StorageRead);
      t = b.write(t, TextureUse::StorageWrite);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    const auto barriers = compiled->barriers_before(1);
    REQUIRE(barriers.size() == 1);
    CHECK(barriers[0].before == gpu::Access::StorageWrite);
    CHECK(barriers[0].after == gpu::Access::StorageWrite);
  }
}

TEST_SUITE("graph errors") {
  TEST_CASE("cycle: names every pass in order and the resources linking them") {
    // 'b' reads version 1 of x after 'a' wrote version 2 (a stale handle): 'b' must run
    // before 'a' (write after read), but 'b' also reads y, which 'a' writes.
    RenderGraph graph;
    TextureHandle x1, y;
    graph.add_pass("init", [&](PassBuilder& b) {
      x1 = b.write(b.create_texture("x", color_desc()), TextureUse::StorageWrite);
    });
    graph.add_pass("a", [&](PassBuilder& b) {
      (void)b.write(x1, TextureUse::StorageWrite);
      y = b.write(b.create_texture("y", color_desc()), TextureUse::StorageWrite);
    });
    graph.add_pass("b", [&](PassBuilder& b) {
      b.read(x1, TextureUse::Sampled);
      b.read(y, TextureUse::StorageRead);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::Cycle);
    CHECK(e.message ==
          "cycle: 'a' -> 'b' -> 'a' through 'y', 'x'; 'b' reads version 1 of texture 'x', which 'a' overwrites, so it "
          "must run first -- if it should see 'a''s result, it holds a stale handle: read the one that write() "
          "returned");
    CHECK(e.passes == std::vector<std::string>{"a", "b"});
    CHECK(e.resources == std::vector<std::string>{"y", "x"});
  }

  TEST_CASE("cycle of three passes") {
    RenderGraph graph;
    TextureHandle x1, y, w;
    graph.add_pass("init", [&](PassBuilder& b) {
      x1 = b.write(b.create_texture("x", color_desc()), TextureUse::StorageWrite);
    });
    graph.add_pass("a", [&](PassBuilder& b) {
      (void)b.write(x1, TextureUse::StorageWrite);
      y = b.write(b.create_texture("y", color_desc()), TextureUse::StorageWrite);
    });
    graph.add_pass("b", [&](PassBuilder& b) {
      b.read(y, TextureUse::Sampled);
      w = b.write(b.create_texture("w", color_desc()), TextureUse::StorageWrite);
    });
    graph.add_pass("c", [&](PassBuilder& b) {
      b.read(w, TextureUse::Sampled);
      b.read(x1, TextureUse::Sampled);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::Cycle);
    CHECK(contains(e.message, "cycle: 'a' -> 'b' -> 'c' -> 'a' through 'y', 'w', 'x'; 'c' reads version 1 of "
                              "texture 'x', which 'a' overwrites"));
    CHECK(e.passes == std::vector<std::string>{"a", "b", "c"});
  }

  TEST_CASE("a stale read without a cycle orders the reader before the next writer") {
    RenderGraph graph;
    TextureHandle x1;
    graph.add_pass("init", [&](PassBuilder& b) {
      x1 = b.write(b.create_texture("x", color_desc()), TextureUse::StorageWrite);
    });
    graph.add_pass("overwrite", [&](PassBuilder& b) {
      (void)b.write(x1, TextureUse::StorageWrite);
      b.side_effect();
    });
    graph.add_pass("late_reader", [&](PassBuilder& b) {
      b.read(x1, TextureUse::Sampled);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK(std::vector<std::uint32_t>(compiled->order().begin(), compiled->order().end()) ==
          std::vector<std::uint32_t>{0, 2, 1});
  }

  TEST_CASE("read of a resource nobody writes or imports") {
    RenderGraph graph;
    TextureHandle bloom;
    graph.add_pass("make", [&](PassBuilder& b) { bloom = b.create_texture("bloom", color_desc()); });
    graph.add_pass("blur", [&](PassBuilder& b) {
      b.read(bloom, TextureUse::Sampled);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::UnwrittenRead);
    CHECK(e.message == "pass 'blur': reads texture 'bloom' (version 0), which no pass writes and nothing imports");
    CHECK(e.passes == std::vector<std::string>{"blur"});
    CHECK(e.resources == std::vector<std::string>{"bloom"});
  }

  TEST_CASE("reading an import needs no writer") {
    RenderGraph graph;
    auto lut = graph.import_texture("lut", imported_desc(16, 16, gpu::TextureUsage::Sampled), gpu::Access::ShaderRead);
    graph.add_pass("use", [&](PassBuilder& b) {
      b.read(lut, TextureUse::Sampled);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    CHECK_MESSAGE(compiled, compiled.error().to_string());
  }

  TEST_CASE("two writers of one version") {
    RenderGraph graph;
    TextureHandle t;
    graph.add_pass("create", [&](PassBuilder& b) {
      t = b.write(b.create_texture("gbuffer", color_desc()), TextureUse::ColorAttachment);
    });
    graph.add_pass("decals", [&](PassBuilder& b) {
      (void)b.write(t, TextureUse::ColorAttachment);
      b.side_effect();
    });
    graph.add_pass("particles", [&](PassBuilder& b) {
      (void)b.write(t, TextureUse::ColorAttachment);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::MultipleWriters);
    CHECK(contains(e.message, "texture 'gbuffer' (version 1) has two writers: pass 'decals' and pass 'particles'"));
    CHECK(e.passes == std::vector<std::string>{"decals", "particles"});
    CHECK(e.resources == std::vector<std::string>{"gbuffer"});
  }

  TEST_CASE("usage the format cannot take: storage on a depth format") {
    RenderGraph graph;
    graph.add_pass("ssao", [&](PassBuilder& b) {
      auto depth = b.create_texture("depth", color_desc(64, 64, gpu::Format::Depth32Float));
      (void)b.write(depth, TextureUse::StorageWrite);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::UnsupportedUsage);
    CHECK(contains(e.message, "pass 'ssao': uses texture 'depth' (depth32float) as storage-write"));
    CHECK(contains(e.message, "storage"));
    CHECK(e.passes == std::vector<std::string>{"ssao"});
    CHECK(e.resources == std::vector<std::string>{"depth"});
  }

  TEST_CASE("usage the format cannot take: color attachment on a depth format, depth on a color format") {
    RenderGraph graph;
    graph.add_pass("wrong", [&](PassBuilder& b) {
      (void)b.write(b.create_texture("d", color_desc(64, 64, gpu::Format::Depth32Float)), TextureUse::ColorAttachment);
      (void)b.write(b.create_texture("c", color_desc()), TextureUse::DepthAttachment);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    CHECK(compiled.error().count(GraphErrorKind::UnsupportedUsage) == 2);
  }

  TEST_CASE("imported resource created without a usage a pass needs") {
    RenderGraph graph;
    auto lut = graph.import_texture("lut", imported_desc(16, 16, gpu::TextureUsage::Sampled), gpu::Access::ShaderRead);
    graph.add_pass("bake", [&](PassBuilder& b) { (void)b.write(lut, TextureUse::StorageWrite); });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::MissingUsage);
    CHECK(contains(e.message, "pass 'bake': uses imported texture 'lut' as storage-write"));
    CHECK(contains(e.message, "without storage usage"));
  }

  TEST_CASE("imported buffer created without a usage a pass needs") {
    RenderGraph graph;
    auto params = graph.import_buffer(
        "params", gpu::BufferDescriptor{.label = "params", .size = 256, .usage = gpu::BufferUsage::Uniform},
        gpu::Access::Undefined);
    graph.add_pass("fill", [&](PassBuilder& b) {
      (void)b.write(params, BufferUse::StorageWrite);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::MissingUsage);
    CHECK(e.message ==
          "pass 'fill': uses imported buffer 'params' as storage-write, but it was created without storage usage (it "
          "has uniform)");
    CHECK(e.passes == std::vector<std::string>{"fill"});
    CHECK(e.resources == std::vector<std::string>{"params"});
  }

  TEST_CASE("two passes with one name: an error naming both, whichever is culled; a pass and a resource may share a name") {
    RenderGraph graph;
    auto out = graph.import_texture("out", imported_desc(), gpu::Access::Undefined);
    TextureHandle a;
    graph.add_pass("blur", [&](PassBuilder& b) { a = b.write(b.create_texture("blur", color_desc()), TextureUse::ColorAttachment); });
    graph.add_pass("blur", [&](PassBuilder& b) { (void)b.write(b.create_texture("unused", color_desc()), TextureUse::ColorAttachment); });
    graph.add_pass("compose", [&](PassBuilder& b) {
      b.read(a, TextureUse::Sampled);
      out = b.write(out, TextureUse::ColorAttachment);
    });
    graph.add_pass("blur", [&](PassBuilder& b) { (void)b.write(b.create_texture("unused2", color_desc()), TextureUse::ColorAttachment); });
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::DuplicateName);
    CHECK(e.message ==
          "3 passes are named 'blur' (passes #0, #1, #3 in declaration order): culled(), find_pass(), errors and dumps "
          "name passes by name, so give each its own (e.g. 'blur.2')");
    CHECK(e.passes == std::vector<std::string>{"blur", "blur", "blur"});
  }

  TEST_CASE("two resources with one name: one error per name, naming who declared each; textures and buffers alike") {
    RenderGraph graph;
    auto out = graph.import_texture("depth", imported_desc(), gpu::Access::Undefined);
    graph.add_pass("shadow", [&](PassBuilder& b) {
      (void)b.write(b.create_texture("depth", color_desc(32, 32, gpu::Format::Depth32Float)), TextureUse::DepthAttachment);
      (void)b.write(b.create_buffer("params", {.size = 256}), BufferUse::StorageWrite);
      b.side_effect();
    });
    graph.add_pass("main", [&](PassBuilder& b) {
      (void)b.write(b.create_buffer("params", {.size = 256}), BufferUse::StorageWrite);
      out = b.write(out, TextureUse::ColorAttachment);
    });
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    REQUIRE(compiled.error().size() == 2);
    const GraphError& depth = compiled.error().errors[0];
    CHECK(depth.kind == GraphErrorKind::DuplicateName);
    CHECK(depth.message ==
          "2 textures are named 'depth' (imported, created by pass 'shadow'): find_texture(), errors and dumps name "
          "resources by name, so give each its own (e.g. a suffix per pass or per object)");
    CHECK(depth.resources == std::vector<std::string>{"depth", "depth"});
    CHECK(depth.passes == std::vector<std::string>{"shadow"});
    const GraphError& params = compiled.error().errors[1];
    CHECK(params.message ==
          "2 buffers are named 'params' (created by pass 'shadow', created by pass 'main'): find_texture(), errors and "
          "dumps name resources by name, so give each its own (e.g. a suffix per pass or per object)");
    CHECK(params.passes == std::vector<std::string>{"shadow", "main"});
  }

  TEST_CASE("a duplicate name in a frame that otherwise repeats the last one is still refused (names are not part of a reused plan)") {
    RenderGraph graph;
    auto frame = [&](const char* second_name) {
      graph.reset();
      auto out = graph.import_texture("out", imported_desc(), gpu::Access::Undefined);
      TextureHandle t;
      graph.add_pass("first", [&](PassBuilder& b) { t = b.write(b.create_texture("t", color_desc()), TextureUse::ColorAttachment); });
      graph.add_pass(second_name, [&](PassBuilder& b) {
        b.read(t, TextureUse::Sampled);
        out = b.write(out, TextureUse::ColorAttachment);
      });
      graph.mark_output(out);
      return graph.compile(options);
    };
    for (int round = 0; round < 2; ++round) {
      REQUIRE(frame("second"));
      REQUIRE(frame("second"));
      auto bad = frame("first");
      REQUIRE_FALSE(bad);
      CHECK(only_error(bad.error()).kind == GraphErrorKind::DuplicateName);
    }
  }

  TEST_CASE("attachments of one render pass with different sizes") {
    RenderGraph graph;
    graph.add_pass("gbuffer", [&](PassBuilder& b) {
      (void)b.write(b.create_texture("albedo", {.size = RelativeSize{1.0f}}), TextureUse::ColorAttachment);
      (void)b.write(b.create_texture("depth", {.size = RelativeSize{0.5f}, .format = gpu::Format::Depth32Float}),
                    TextureUse::DepthAttachment);
      b.side_effect();
    });
    auto compiled = graph.compile({.output_extent = {1920, 1080, 1}});
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::MismatchedAttachmentSizes);
    CHECK(e.message ==
          "pass 'gbuffer': attachments have different sizes: texture 'albedo' is 1920x1080, texture 'depth' is "
          "960x540");
    CHECK(e.resources == std::vector<std::string>{"albedo", "depth"});
  }

  TEST_CASE("one texture of the wrong size attached by many passes: one error naming it and every pass") {
    RenderGraph graph;
    TextureHandle depth;
    graph.add_pass("clear_depth", [&](PassBuilder& b) {
      depth = b.write(b.create_texture("depth", {.size = RelativeSize{0.5f}, .format = gpu::Format::Depth32Float}),
                      TextureUse::DepthAttachment);
    });
    for (int i = 0; i < 18; ++i) {
      graph.add_pass("draw" + std::to_string(i), [&](PassBuilder& b) {
        (void)b.write(b.create_texture("color" + std::to_string(i), {.size = RelativeSize{1.0f}}),
                      TextureUse::ColorAttachment);
        depth = b.write(depth, TextureUse::DepthAttachment);
        b.side_effect();
      });
    }
    // and an unrelated pass with its own mismatch keeps its own error
    graph.add_pass("other", [&](PassBuilder& b) {
      (void)b.write(b.create_texture("a", {.size = gpu::Extent3D{16, 16, 1}}), TextureUse::ColorAttachment);
      (void)b.write(b.create_texture("b", {.size = gpu::Extent3D{8, 8, 1}}), TextureUse::ColorAttachment);
      b.side_effect();
    });
    auto compiled = graph.compile({.output_extent = {64, 64, 1}});
    REQUIRE_FALSE(compiled);
    REQUIRE_MESSAGE(compiled.error().size() == 2, compiled.error().to_string());
    const GraphError& e = compiled.error().errors[0];
    CHECK(e.kind == GraphErrorKind::MismatchedAttachmentSizes);
    CHECK(contains(e.message, "texture 'depth' is 32x32, but the other attachments of the 18 passes it is attached to "
                              "are 64x64: passes 'draw0', 'draw1', "));
    CHECK(contains(e.message, "'draw17'; give it their size"));
    CHECK(e.passes.size() == 18);
    CHECK(e.resources.front() == "depth");
    CHECK(e.resources.size() == 19);
    CHECK(compiled.error().errors[1].message ==
          "pass 'other': attachments have different sizes: texture 'a' is 16x16, texture 'b' is 8x8");
  }

  TEST_CASE("an output never written") {
    RenderGraph graph;
    auto out = graph.import_texture("final", imported_desc(), gpu::Access::Undefined);
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::OutputNeverWritten);
    CHECK(e.message == "output texture 'final' (version 0) is never written by any pass");
    CHECK(e.resources == std::vector<std::string>{"final"});
  }

  TEST_CASE("an invalid handle") {
    RenderGraph graph;
    graph.add_pass("lost", [&](PassBuilder& b) {
      b.read(TextureHandle{}, TextureUse::Sampled);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::InvalidHandle);
    CHECK(contains(e.message, "pass 'lost'"));
  }

  TEST_CASE("a handle of a version that does not exist") {
    RenderGraph graph;
    TextureHandle t;
    graph.add_pass("a", [&](PassBuilder& b) { t = b.write(b.create_texture("t", color_desc()), TextureUse::StorageWrite); });
    graph.add_pass("b", [&](PassBuilder& b) {
      b.read(TextureHandle{t.index, 7}, TextureUse::Sampled);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::InvalidHandle);
    CHECK(e.message == "pass 'b': uses texture 't' version 7, which does not exist (latest is version 1)");
  }

  TEST_CASE("one pass using one texture two incompatible ways") {
    RenderGraph graph;
    TextureHandle t;
    graph.add_pass("a", [&](PassBuilder& b) { t = b.write(b.create_texture("t", color_desc()), TextureUse::StorageWrite); });
    graph.add_pass("feedback", [&](PassBuilder& b) {
      b.read(t, TextureUse::Sampled);
      (void)b.write(t, TextureUse::ColorAttachment);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::ConflictingUsage);
    CHECK(e.message ==
          "pass 'feedback': uses texture 't' both as sampled and as color-attachment; a pass can use a resource one way "
          "at a time: to read what it writes, copy it to a second resource in an earlier pass (or split the pass in "
          "two); where it uses different mips or layers, declare each with its TextureRange");
  }

  TEST_CASE("a copy within one buffer is one transfer state; within one texture it is still refused (two layouts)") {
    RenderGraph graph;
    BufferHandle buffer;
    TextureHandle texture;
    graph.add_pass("init", [&](PassBuilder& b) {
      buffer = b.write(b.create_buffer("b", {.size = 256}), BufferUse::CopyDst);
      texture = b.write(b.create_texture("t", color_desc()), TextureUse::CopyDst);
    });
    graph.add_pass("within", [&](PassBuilder& b) {
      buffer = b.write(b.read(buffer, BufferUse::CopySrc), BufferUse::CopyDst);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    const auto p = compiled->find_pass("within");
    REQUIRE(p);
    bool to_copy_dst = false;
    for (const PlannedBarrier& barrier : compiled->barriers_before(*p))
      to_copy_dst |= barrier.after == gpu::Access::CopyDst;
    CHECK(to_copy_dst);
    graph.add_pass("texture_within", [&](PassBuilder& b) {
      (void)b.write(b.read(texture, TextureUse::CopySrc), TextureUse::CopyDst);
      b.side_effect();
    });
    auto refused = graph.compile(options);
    REQUIRE_FALSE(refused);
    CHECK(only_error(refused.error()).kind == GraphErrorKind::ConflictingUsage);
  }

  TEST_CASE("a write usage passed to read()") {
    RenderGraph graph;
    TextureHandle t;
    graph.add_pass("a", [&](PassBuilder& b) { t = b.write(b.create_texture("t", color_desc()), TextureUse::StorageWrite); });
    graph.add_pass("b", [&](PassBuilder& b) {
      b.read(t, TextureUse::StorageWrite);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    CHECK(compiled.error().count(GraphErrorKind::ConflictingUsage) == 1);
    CHECK(contains(compiled.error().errors[0].message, "pass 'b': reads texture 't' with usage storage-write"));
  }

  TEST_CASE("relative size without an output extent, and zero sizes") {
    RenderGraph graph;
    graph.add_pass("p", [&](PassBuilder& b) {
      (void)b.write(b.create_texture("rel", {.size = RelativeSize{0.5f}}), TextureUse::StorageWrite);
      (void)b.write(b.create_texture("empty", {.size = gpu::Extent3D{0, 16, 1}}), TextureUse::StorageWrite);
      (void)b.write(b.create_buffer("nothing", {.size = 0}), BufferUse::StorageWrite);
      b.side_effect();
    });
    auto compiled = graph.compile();
    REQUIRE_FALSE(compiled);
    CHECK(compiled.error().count(GraphErrorKind::InvalidDescriptor) == 3);
    CHECK(contains(compiled.error().to_string(),
                   "texture 'rel' has a size relative to the output, but CompileOptions::output_extent is not set"));
    CHECK(contains(compiled.error().to_string(), "pass 'p': creates texture 'empty' with a zero size (0x16)"));
    CHECK(contains(compiled.error().to_string(), "pass 'p': creates buffer 'nothing' with a zero size"));
  }

  TEST_CASE("a declared kind its uses contradict") {
    RenderGraph graph;
    graph.add_pass("not_compute", [&](PassBuilder& b) {
      b.kind(PassKind::Compute);
      (void)b.write(b.create_texture("t", color_desc()), TextureUse::ColorAttachment);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::WrongPassKind);
    CHECK(e.message == "pass 'not_compute' is declared compute but uses texture 't' as color-attachment");
  }

  TEST_CASE("every error is reported at once") {
    RenderGraph graph;
    TextureHandle never_written;
    auto out = graph.import_texture("final", imported_desc(), gpu::Access::Undefined);
    graph.add_pass("make", [&](PassBuilder& b) { never_written = b.create_texture("ghost", color_desc()); });
    graph.add_pass("reader", [&](PassBuilder& b) {
      b.read(never_written, TextureUse::Sampled);
      b.side_effect();
    });
    graph.add_pass("ssao", [&](PassBuilder& b) {
      (void)b.write(b.create_texture("depth", color_desc(64, 64, gpu::Format::Depth32Float)), TextureUse::StorageWrite);
      b.side_effect();
    });
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphErrors& errors = compiled.error();
    CHECK(errors.size() == 3);
    CHECK(errors.count(GraphErrorKind::UnwrittenRead) == 1);
    CHECK(errors.count(GraphErrorKind::UnsupportedUsage) == 1);
    CHECK(errors.count(GraphErrorKind::OutputNeverWritten) == 1);
    const Error error = errors;
    CHECK(error.kind == ErrorKind::Graph);
    CHECK(contains(error.message, "render graph 'frame': 3 errors"));
    CHECK(contains(error.message, "'ghost'"));
    CHECK(contains(error.message, "'depth'"));
    CHECK(contains(error.message, "'final'"));
  }
}

TEST_SUITE("graph culling") {
  TEST_CASE("a chain that reaches no output is culled, and its transients are never allocated") {
    RenderGraph graph;
    auto out = graph.import_texture("out", imported_desc(), gpu::Access::Undefined);
    TextureHandle unused_a, unused_b;
    graph.add_pass("unused_1", [&](PassBuilder& b) {
      unused_a = b.write(b.create_texture("unused_a", color_desc()), TextureUse::ColorAttachment);
    });
    graph.add_pass("unused_2", [&](PassBuilder& b) {
      b.read(unused_a, TextureUse::Sampled);
      unused_b = b.write(b.create_texture("unused_b", color_desc()), TextureUse::ColorAttachment);
    });
    graph.add_pass("main", [&](PassBuilder& b) { out = b.write(out, TextureUse::ColorAttachment); });
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK(compiled->culled("unused_1"));
    CHECK(compiled->culled("unused_2"));
    CHECK_FALSE(compiled->culled("main"));
    CHECK(compiled->order().size() == 1);
    for (TextureHandle h : {unused_a, unused_b}) {
      CHECK_FALSE(compiled->resources()[h.index].used);
      CHECK(compiled->resources()[h.index].heap == invalid_index);
    }
    CHECK(compiled->memory().aliased_bytes == 0);
    CHECK(compiled->memory().unaliased_bytes == 0);
  }

  TEST_CASE("passes feeding an output are kept, even through several versions") {
    RenderGraph graph;
    auto out = graph.import_texture("out", imported_desc(), gpu::Access::Undefined);
    TextureHandle t;
    graph.add_pass("clear", [&](PassBuilder& b) { t = b.write(b.create_texture("t", color_desc()), TextureUse::ColorAttachment); });
    graph.add_pass("draw", [&](PassBuilder& b) { t = b.write(t, TextureUse::ColorAttachment); });
    graph.add_pass("blit", [&](PassBuilder& b) {
      b.read(t, TextureUse::Sampled);
      out = b.write(out, TextureUse::ColorAttachment);
    });
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK(compiled->order().size() == 3);
  }

  TEST_CASE("a side-effect pass is kept") {
    RenderGraph graph;
    graph.add_pass("upload_uniforms", [&](PassBuilder& b) {
      (void)b.write(b.create_buffer("uniforms", {.size = 256}), BufferUse::CopyDst);
      b.side_effect();
    });
    graph.add_pass("forgotten", [&](PassBuilder& b) {
      (void)b.write(b.create_buffer("scratch", {.size = 256}), BufferUse::CopyDst);
    });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK_FALSE(compiled->culled("upload_uniforms"));
    CHECK(compiled->passes()[0].side_effect);
    CHECK(compiled->culled("forgotten"));
  }

  TEST_CASE("a pass writing only an imported buffer and marked side effect is kept") {
    RenderGraph graph;
    auto stats = graph.import_buffer("gpu_stats", gpu::BufferDescriptor{.label = "gpu_stats", .size = 64,
                                                                        .usage = gpu::BufferUsage::Storage},
                                     gpu::Access::Undefined);
    graph.add_pass("count", [&](PassBuilder& b) {
      (void)b.write(stats, BufferUse::StorageWrite);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK_FALSE(compiled->culled("count"));
  }

  TEST_CASE("writing an imported resource keeps a pass: its result outlives the frame") {
    RenderGraph graph;
    auto history = graph.import_texture("history", imported_desc(64, 64, gpu::TextureUsage::Storage),
                                        gpu::Access::Undefined);
    graph.add_pass("accumulate", [&](PassBuilder& b) { (void)b.write(history, TextureUse::StorageWrite); });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK_FALSE(compiled->culled("accumulate"));
  }

  TEST_CASE("an unknown pass name reads as culled") {
    RenderGraph graph;
    graph.add_pass("p", [&](PassBuilder& b) { b.side_effect(); });
    auto compiled = graph.compile(options);
    REQUIRE(compiled);
    CHECK(compiled->culled("fur"));
    CHECK_FALSE(compiled->find_pass("fur"));
  }
}

TEST_SUITE("graph blackboard") {
  TEST_CASE("features find each other's handles by name") {
    RenderGraph graph;
    auto out = graph.import_texture("out", imported_desc(), gpu::Access::Undefined);
    graph.add_pass("depth_prepass", [&](PassBuilder& b) {
      auto depth = b.write(b.create_texture("depth", color_desc(64, 64, gpu::Format::Depth32Float)),
                           TextureUse::DepthAttachment);
      b.blackboard().put("scene_depth", depth);
    });
    graph.add_pass("lighting", [&](PassBuilder& b) {
      auto depth = b.blackboard().get<TextureHandle>("scene_depth");
      REQUIRE(depth);
      b.read(*depth, TextureUse::DepthRead);
      out = b.write(out, TextureUse::ColorAttachment);
    });
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    CHECK(compiled->order().size() == 2);
    CHECK(graph.blackboard().contains("scene_depth"));
  }

  TEST_CASE("a missing key names the key and the asking pass") {
    RenderGraph graph;
    graph.blackboard().put("shadow_map", TextureHandle{0, 0});
    std::string message;
    graph.add_pass("skin_sss", [&](PassBuilder& b) {
      auto depth = b.blackboard().get<TextureHandle>("scene_depth");
      REQUIRE_FALSE(depth);
      CHECK(depth.error().kind == ErrorKind::NotFound);
      message = depth.error().message;
    });
    CHECK(message == "pass 'skin_sss': blackboard has no texture named 'scene_depth' (it holds 'shadow_map')");
    auto outside = graph.blackboard().get<TextureHandle>("environment");
    REQUIRE_FALSE(outside);
    CHECK(outside.error().message == "blackboard has no texture named 'environment' (it holds 'shadow_map')");
  }

  TEST_CASE("a key of the other type is an error, put replaces, find is optional") {
    RenderGraph graph;
    graph.blackboard().put("lights", BufferHandle{3, 1});
    auto wrong = graph.blackboard().get<TextureHandle>("lights");
    REQUIRE_FALSE(wrong);
    CHECK(wrong.error().message == "blackboard entry 'lights' is a buffer, not a texture");
    graph.blackboard().put("lights", BufferHandle{3, 2});
    CHECK(graph.blackboard().get<BufferHandle>("lights").value() == BufferHandle{3, 2});
    CHECK(graph.blackboard().keys() == std::vector<std::string>{"lights"});
    CHECK_FALSE(graph.blackboard().find<BufferHandle>("nope"));
  }
}

TEST_SUITE("graph scheduling and memory") {
  TEST_CASE("independent passes keep declaration order; dependencies come first") {
    RenderGraph graph;
    TextureHandle a, b2;
    graph.add_pass("first", [&](PassBuilder& b) { a = b.write(b.create_texture("a", color_desc()), TextureUse::StorageWrite); });
    graph.add_pass("second", [&](PassBuilder& b) { b2 = b.write(b.create_texture("b", color_desc()), TextureUse::StorageWrite); });
    graph.add_pass("third", [&](PassBuilder& b) {
      b.read(a, TextureUse::Sampled);
      b.read(b2, TextureUse::Sampled);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE(compiled);
    CHECK(std::vector<std::uint32_t>(compiled->order().begin(), compiled->order().end()) ==
          std::vector<std::uint32_t>{0, 1, 2});
    CHECK(compiled->resources()[a.index].first_use == 0);
    CHECK(compiled->resources()[a.index].last_use == 2);
    CHECK(compiled->resources()[b2.index].first_use == 1);
  }

  TEST_CASE("aliasing: a chain of 10 needs less memory and nothing live overlaps") {
    RenderGraph graph;
    auto out = graph.import_texture("out", imported_desc(256, 256), gpu::Access::Undefined);
    TextureHandle previous;
    for (int i = 0; i < 10; ++i) {
      graph.add_pass("step" + std::to_string(i), [&, i](PassBuilder& b) {
        if (i > 0) b.read(previous, TextureUse::Sampled);
        previous = b.write(b.create_texture("t" + std::to_string(i), color_desc(256, 256, gpu::Format::RGBA16Float)),
                           TextureUse::ColorAttachment);
      });
    }
    graph.add_pass("present", [&](PassBuilder& b) {
      b.read(previous, TextureUse::Sampled);
      out = b.write(out, TextureUse::ColorAttachment);
    });
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    const MemoryPlan& memory = compiled->memory();
    CHECK(memory.unaliased_bytes == 10 * 256 * 256 * 8);
    CHECK(memory.aliased_bytes == 2 * 256 * 256 * 8);  // a ping-pong pair
    CHECK(memory.aliased_bytes < memory.unaliased_bytes);
    const auto resources = compiled->resources();
    for (std::size_t x = 0; x < resources.size(); ++x)
      for (std::size_t y = x + 1; y < resources.size(); ++y) {
        const ResourceInfo &p = resources[x], &q = resources[y];
        if (p.heap == invalid_index || q.heap == invalid_index || p.heap != q.heap) continue;
        const bool live_together = p.first_use <= q.last_use && q.first_use <= p.last_use;
        const bool overlap = p.offset < q.offset + q.bytes && q.offset < p.offset + p.bytes;
        CHECK_FALSE_MESSAGE((live_together && overlap), p.name, " and ", q.name, " overlap while both are live");
      }
    // The third texture reuses the first one's memory and waits for it.
    const auto t2 = *compiled->find_resource("t2");
    const auto barriers = compiled->barriers_before(*compiled->find_pass("step2"));
    bool waits_for_t0 = false;
    for (const PlannedBarrier& b : barriers)
      waits_for_t0 = waits_for_t0 || (b.resource == t2 && b.previous_occupant == *compiled->find_resource("t0") &&
                                      b.occupant_before == gpu::Access::ShaderRead);
    CHECK(waits_for_t0);
    CHECK(resources[t2].alias_group != invalid_index);
    CHECK(resources[t2].alias_group == resources[*compiled->find_resource("t0")].alias_group);
  }

  TEST_CASE("without aliasing every transient has its own memory") {
    RenderGraph graph;
    TextureHandle previous;
    for (int i = 0; i < 4; ++i)
      graph.add_pass("step" + std::to_string(i), [&, i](PassBuilder& b) {
        if (i > 0) b.read(previous, TextureUse::Sampled);
        previous = b.write(b.create_texture("t" + std::to_string(i), color_desc()), TextureUse::ColorAttachment);
        if (i == 3) b.side_effect();
      });
    auto compiled = graph.compile({.output_extent = {64, 64, 1}, .aliasing = false});
    REQUIRE(compiled);
    CHECK(compiled->memory().aliased_bytes == compiled->memory().unaliased_bytes);
    for (const ResourceInfo& r : compiled->resources()) CHECK(r.alias_group == invalid_index);
  }

  TEST_CASE("memory requirements can come from a function") {
    RenderGraph graph;
    graph.add_pass("p", [&](PassBuilder& b) {
      (void)b.write(b.create_texture("t", color_desc()), TextureUse::StorageWrite);
      b.side_effect();
    });
    CompileOptions custom = options;
    custom.texture_requirements = [](const gpu::TextureDescriptor&) -> Result<gpu::MemoryRequirements> {
      return gpu::MemoryRequirements{12345, 16, 1};
    };
    auto compiled = graph.compile(custom);
    REQUIRE(compiled);
    CHECK(compiled->resources()[0].bytes == 12345);
    CHECK(compiled->memory().heaps.at(0).type_bits == 1);
  }

  TEST_CASE("resources whose memory types do not intersect never share a heap") {
    RenderGraph graph;
    TextureHandle previous;
    for (int i = 0; i < 4; ++i)
      graph.add_pass("step" + std::to_string(i), [&, i](PassBuilder& b) {
        if (i > 0) b.read(previous, TextureUse::Sampled);
        previous = b.write(b.create_texture(i % 2 ? "odd" + std::to_string(i) : "even" + std::to_string(i),
                                            color_desc(64, 64, i % 2 ? gpu::Format::RGBA8Unorm : gpu::Format::R32Float)),
                           TextureUse::ColorAttachment);
        if (i == 3) b.side_effect();
      });
    CompileOptions custom = options;
    custom.texture_requirements = [](const gpu::TextureDescriptor& d) -> Result<gpu::MemoryRequirements> {
      return gpu::MemoryRequirements{65536, 65536, d.format == gpu::Format::R32Float ? 1u : 2u};
    };
    auto compiled = graph.compile(custom);
    REQUIRE(compiled);
    CHECK(compiled->memory().heaps.size() == 2);
    const auto r = compiled->resources();
    CHECK(r[0].heap != r[1].heap);
    CHECK(r[0].heap == r[2].heap);
    CHECK(r[1].heap == r[3].heap);
  }

  TEST_CASE("barriers: transitions, hazards, no barrier between equal reads, final state") {
    RenderGraph graph;
    auto readback = graph.import_texture("readback", imported_desc(64, 64, gpu::TextureUsage::ColorAttachment |
                                                                              gpu::TextureUsage::CopySrc),
                                         gpu::Access::Undefined);
    TextureHandle t;
    graph.add_pass("fill", [&](PassBuilder& b) { t = b.write(b.create_texture("t", color_desc()), TextureUse::StorageWrite); });
    graph.add_pass("sample1", [&](PassBuilder& b) {
      b.read(t, TextureUse::Sampled);
      b.side_effect();
    });
    graph.add_pass("sample2", [&](PassBuilder& b) {
      b.read(t, TextureUse::Sampled);
      b.side_effect();
    });
    graph.add_pass("draw", [&](PassBuilder& b) {
      b.read(t, TextureUse::Sampled);
      readback = b.write(readback, TextureUse::ColorAttachment);
    });
    graph.mark_output(readback, gpu::Access::CopySrc);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    using A = gpu::Access;
    auto fill = compiled->barriers_before(0);
    REQUIRE(fill.size() == 1);
    CHECK(fill[0].before == A::Undefined);
    CHECK(fill[0].after == A::StorageWrite);
    auto s1 = compiled->barriers_before(1);
    REQUIRE(s1.size() == 1);
    CHECK(s1[0].before == A::StorageWrite);
    CHECK(s1[0].after == A::ShaderRead);
    CHECK(compiled->barriers_before(2).empty());
    auto draw = compiled->barriers_before(3);
    REQUIRE(draw.size() == 1);
    CHECK(draw[0].resource == readback.index);
    CHECK(draw[0].before == A::Undefined);
    CHECK(draw[0].after == A::ColorAttachment);
    auto final_barriers = compiled->final_barriers();
    REQUIRE(final_barriers.size() == 1);
    CHECK(final_barriers[0].before == A::ColorAttachment);
    CHECK(final_barriers[0].after == A::CopySrc);
  }

  TEST_CASE("reads in different states get a barrier so a later write waits for both") {
    RenderGraph graph;
    auto buffer = graph.import_buffer("b", gpu::BufferDescriptor{.label = "b", .size = 256}, gpu::Access::CopyDst);
    graph.add_pass("uniform", [&](PassBuilder& b) {
      b.read(buffer, BufferUse::Uniform);
      b.side_effect();
    });
    graph.add_pass("vertex", [&](PassBuilder& b) {
      b.read(buffer, BufferUse::Vertex);
      b.side_effect();
    });
    graph.add_pass("overwrite", [&](PassBuilder& b) { (void)b.write(buffer, BufferUse::CopyDst); });
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    REQUIRE(compiled->barriers_before(1).size() == 1);
    CHECK(compiled->barriers_before(1)[0].before == gpu::Access::UniformRead);
    CHECK(compiled->barriers_before(1)[0].after == gpu::Access::VertexBuffer);
    REQUIRE(compiled->barriers_before(2).size() == 1);
    CHECK(compiled->barriers_before(2)[0].before == gpu::Access::VertexBuffer);
  }
}

TEST_SUITE("graph introspection") {
  TEST_CASE("golden DOT of a small graph with a culled pass and an aliasing group") {
    RenderGraph graph("golden");
    auto out = graph.import_texture("output", imported_desc(), gpu::Access::Undefined);
    TextureHandle t0, t1, t2;
    graph.add_pass("a", [&](PassBuilder& b) { t0 = b.write(b.create_texture("t0", color_desc()), TextureUse::ColorAttachment); });
    graph.add_pass("b", [&](PassBuilder& b) {
      b.read(t0, TextureUse::Sampled);
      t1 = b.write(b.create_texture("t1", color_desc()), TextureUse::ColorAttachment);
    });
    graph.add_pass("c", [&](PassBuilder& b) {
      b.read(t1, TextureUse::Sampled);
      t2 = b.write(b.create_texture("t2", color_desc()), TextureUse::ColorAttachment);
    });
    graph.add_pass("d", [&](PassBuilder& b) {
      b.read(t2, TextureUse::Sampled);
      out = b.write(out, TextureUse::ColorAttachment);
    });
    graph.add_pass("debug", [&](PassBuilder& b) {
      b.read(t0, TextureUse::Sampled);
      (void)b.write(b.create_texture("debug_view", color_desc()), TextureUse::ColorAttachment);
    });
    graph.mark_output(out);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
    const std::string expected = R"(digraph "golden" {
  rankdir=LR;
  node [fontname="Helvetica", fontsize=10];
  edge [fontname="Helvetica", fontsize=9];
  p0 [shape=box, style=filled, fillcolor="#cfe2f3", label="a\nrender #0"];
  p1 [shape=box, style=filled, fillcolor="#cfe2f3", label="b\nrender #1"];
  p2 [shape=box, style=filled, fillcolor="#cfe2f3", label="c\nrender #2"];
  p3 [shape=box, style=filled, fillcolor="#cfe2f3", label="d\nrender #3"];
  p4 [shape=box, style="filled,dashed", fillcolor="#eeeeee", fontcolor="#888888", label="debug\nrender, culled"];
  r0 [shape=ellipse, style=filled, fillcolor="#fff2cc", label="output\nrgba8unorm 64x64\nimported"];
  r1 [shape=ellipse, style=filled, fillcolor="#a6cee3", label="t0\nrgba8unorm 64x64\nalias group 0"];
  r2 [shape=ellipse, style=filled, fillcolor="#ffffff", label="t1\nrgba8unorm 64x64"];
  r3 [shape=ellipse, style=filled, fillcolor="#a6cee3", label="t2\nrgba8unorm 64x64\nalias group 0"];
  r4 [shape=ellipse, style=filled, fillcolor="#eeeeee", label="debug_view\nrgba8unorm 64x64\nunused"];
  p0 -> r1 [label="color-attachment"];
  r1 -> p1 [label="sampled"];
  p1 -> r2 [label="color-attachment"];
  r2 -> p2 [label="sampled"];
  p2 -> r3 [label="color-attachment"];
  r3 -> p3 [label="sampled"];
  p3 -> r0 [label="color-attachment"];
  r1 -> p4 [label="sampled", style=dashed, color="#888888"];
  p4 -> r4 [label="color-attachment", style=dashed, color="#888888"];
}
)";
    CHECK(compiled->to_dot() == expected);
    const std::string dump = compiled->dump();
    CHECK(contains(dump, "render graph 'golden': 5 passes (1 culled), 5 resources"));
    CHECK(contains(dump, "culled: debug"));
    CHECK(contains(dump, "barrier t2: undefined -> color-attachment (takes over memory of t0, moved shader-read -> storage-read)"));
  }
}

namespace {

// The memory planner's first design, kept as the reference for its fast paths: per heap type,
// walking the order, place each transient at its first use into the smallest free run that
// fits (else at the end of the heap, growing the trailing free run), free it after its last
// use. Returns the offset of every transient (0 for the rest).
std::vector<std::uint64_t> reference_offsets(const CompiledGraph& g, std::size_t* most_free_runs = nullptr) {
  struct Range {
    std::uint64_t begin, end;
  };
  const auto resources = g.resources();
  std::vector<std::uint64_t> offsets(resources.size(), 0);
  const auto positions = std::uint32_t(g.order().size());
  for (ResourceType type : {ResourceType::Texture, ResourceType::Buffer}) {
    const std::uint64_t alignment = type == ResourceType::Texture ? 64 * 1024 : 256;
    std::vector<Range> free;
    std::uint64_t size = 0;
    for (std::uint32_t pos = 0; pos < positions; ++pos) {
      for (std::size_t r = 0; r < resources.size(); ++r) {
        const ResourceInfo& info = resources[r];
        if (info.type != type || info.heap == invalid_index || info.first_use != pos) continue;
        const std::uint64_t bytes = info.bytes;
        std::uint64_t best = ~0ull, best_size = ~0ull;
        for (const Range& f : free) {
          const std::uint64_t at = (f.begin + alignment - 1) / alignment * alignment;
          if (at + bytes <= f.end && f.end - f.begin < best_size) {
            best = at;
            best_size = f.end - f.begin;
          }
        }
        if (best == ~0ull) {
          const bool trailing = !free.empty() && free.back().end == size;
          best = ((trailing ? free.back().begin : size) + alignment - 1) / alignment * alignment;
          if (trailing) free.back().end = best + bytes;
          else free.push_back({size, best + bytes});
          size = best + bytes;
        }
        std::size_t i = 0;
        while (!(free[i].begin <= best && best + bytes <= free[i].end)) ++i;
        const Range whole = free[i];
        free.erase(free.begin() + std::ptrdiff_t(i));
        if (best + bytes < whole.end) free.insert(free.begin() + std::ptrdiff_t(i), Range{best + bytes, whole.end});
        if (whole.begin < best) free.insert(free.begin() + std::ptrdiff_t(i), Range{whole.begin, best});
        offsets[r] = best;
      }
      for (std::size_t r = 0; r < resources.size(); ++r) {
        const ResourceInfo& info = resources[r];
        if (info.type != type || info.heap == invalid_index || info.last_use != pos) continue;
        free.push_back({info.offset, info.offset + info.bytes});
        std::sort(free.begin(), free.end(), [](const Range& a, const Range& b) { return a.begin < b.begin; });
        std::vector<Range> merged;
        for (const Range& f : free) {
          if (!merged.empty() && merged.back().end == f.begin) merged.back().end = f.end;
          else merged.push_back(f);
        }
        free = merged;
        if (most_free_runs) *most_free_runs = std::max(*most_free_runs, free.size());
      }
    }
  }
  return offsets;
}

}  // namespace

TEST_CASE("memory planner: fast paths place a chain in two alternating slots, one alias group each") {
  RenderGraph graph("chain");
  TextureHandle previous;
  for (int i = 0; i < 8; ++i) {
    graph.add_pass("p" + std::to_string(i), [&](PassBuilder& b) {
      if (previous.valid()) b.read(previous, TextureUse::Sampled);
      previous = b.write(b.create_texture("t" + std::to_string(i), color_desc()), TextureUse::ColorAttachment);
    });
  }
  graph.mark_output(previous);
  auto compiled = graph.compile();
  REQUIRE(compiled.has_value());
  const auto resources = compiled->resources();
  const std::uint64_t slot = resources[0].bytes;
  for (std::size_t i = 0; i < 8; ++i) {
    CHECK(resources[i].offset == (i % 2) * slot);
    if (i < 6) CHECK(resources[i].alias_group == std::uint32_t(i % 2));
  }
  CHECK(compiled->memory().aliased_bytes == 2 * slot);
  CHECK(reference_offsets(*compiled) == std::vector<std::uint64_t>(
                                            [&] {
                                              std::vector<std::uint64_t> v;
                                              for (const ResourceInfo& r : resources) v.push_back(r.offset);
                                              return v;
                                            }()));
}

namespace {

// One random graph of `n` passes with textures of several sizes and buffers of many, each
// pass reading up to three earlier textures. Checks every placement against plain best fit,
// overlaps, and every takeover against painting bytes in placement order; returns how
// fragmented it got (the most free runs the reference saw, the most segments of distinct last
// owners at the end).
void check_mixed_graph(std::mt19937& rng, int n, int trial, std::size_t& most_free_runs, std::size_t& segments,
                       bool many_sizes = false) {
  RenderGraph graph("mixed");
  std::vector<TextureHandle> textures;
  std::vector<BufferHandle> buffers;
  for (int i = 0; i < n; ++i) {
    graph.add_pass("p" + std::to_string(i), [&](PassBuilder& b) {
      const int reads = textures.empty() ? 0 : std::uniform_int_distribution<int>(0, 3)(rng);
      for (int k = 0; k < reads; ++k) {
        const auto j = std::uniform_int_distribution<std::size_t>(0, textures.size() - 1)(rng);
        b.read(textures[j], TextureUse::Sampled);
      }
      if (!buffers.empty() && rng() % 2) b.read(buffers[rng() % buffers.size()], BufferUse::Uniform);
      if (rng() % 4 == 0) {
        buffers.push_back(b.write(b.create_buffer("b" + std::to_string(i), {.size = 256u * (1 + rng() % 40)}),
                                  BufferUse::StorageWrite));
      } else {
        // Four sizes, or sixteen (many sizes leave holes that fit little).
        const std::uint32_t side = many_sizes ? 64u * (1 + rng() % 16) : 32u << (rng() % 4);
        const auto t = b.create_texture("t" + std::to_string(i), color_desc(side, side));
        textures.push_back(b.write(t, TextureUse::StorageWrite));
      }
      if (rng() % 5 == 0) b.side_effect();
    });
  }
  if (!textures.empty()) graph.mark_output(textures.back());
  auto compiled = graph.compile();
  REQUIRE(compiled.has_value());
  const auto resources = compiled->resources();
  const auto expected = reference_offsets(*compiled, &most_free_runs);
  for (std::size_t r = 0; r < resources.size(); ++r) {
    if (resources[r].heap == invalid_index) continue;
    CHECK_MESSAGE(resources[r].offset == expected[r], "trial ", trial, ": ", resources[r].name);
    for (std::size_t q = r + 1; q < resources.size(); ++q) {
      const ResourceInfo &a = resources[r], &b = resources[q];
      if (b.heap != a.heap) continue;
      const bool live_together = a.first_use <= b.last_use && b.first_use <= a.last_use;
      const bool overlap = a.offset < b.offset + b.bytes && b.offset < a.offset + a.bytes;
      CHECK_FALSE_MESSAGE((live_together && overlap), a.name, " and ", b.name);
    }
  }
  // Takeovers: painting each resource's bytes in placement order (first use, then index),
  // what a resource takes over is exactly who painted its bytes last, however the planner
  // placed it (appended, an exact single run, best fit, a grown trailing run).
  std::vector<std::uint32_t> placed;
  for (std::uint32_t r = 0; r < resources.size(); ++r)
    if (resources[r].heap != invalid_index) placed.push_back(r);
  std::stable_sort(placed.begin(), placed.end(), [&](std::uint32_t a, std::uint32_t b) {
    return resources[a].first_use < resources[b].first_use;
  });
  std::map<std::uint32_t, std::vector<std::uint32_t>> painted;  // heap -> owner per 256-byte unit
  std::map<std::uint32_t, std::set<std::uint32_t>> taken;       // resource -> previous occupants
  for (const std::uint32_t pos_pass : compiled->order())
    for (const PlannedBarrier& b : compiled->barriers_before(pos_pass))
      if (b.previous_occupant != invalid_index) taken[b.resource].insert(b.previous_occupant);
  for (const std::uint32_t r : placed) {
    const ResourceInfo& info = resources[r];
    std::vector<std::uint32_t>& units = painted[info.heap];
    const std::uint64_t begin = info.offset / 256, end = (info.offset + info.bytes + 255) / 256;
    if (units.size() < end) units.resize(end, invalid_index);
    std::set<std::uint32_t> expected_occupants;
    for (std::uint64_t u = begin; u < end; ++u) {
      if (units[u] != invalid_index) expected_occupants.insert(units[u]);
      units[u] = r;
    }
    CHECK_MESSAGE(taken[r] == expected_occupants, "trial ", trial, ": takeovers of ", info.name);
  }
  for (const auto& [heap, units] : painted) {
    std::size_t runs = units.empty() ? 0 : 1;
    for (std::size_t u = 1; u < units.size(); ++u) runs += units[u] != units[u - 1] ? 1 : 0;
    segments = std::max(segments, runs);
  }
}

}  // namespace

TEST_CASE("memory planner: random graphs of mixed sizes place exactly as plain best fit, without overlaps") {
  std::mt19937 rng(7);
  std::size_t most_free_runs = 0, segments = 0;
  for (int trial = 0; trial < 300; ++trial)
    check_mixed_graph(rng, std::uniform_int_distribution<int>(2, 40)(rng), trial, most_free_runs, segments);
}

TEST_CASE("memory planner: many live transients in a fragmented heap still place exactly as plain best fit") {
  // Over a thousand passes reading any earlier texture, of sixteen sizes: many transients
  // alive and a fragmented heap, with enough free runs and segments that the planner keeps
  // them in search trees (from 32 free runs and 256 segments, frame_plan.cpp), and back in
  // arrays as they shrink.
  std::mt19937 rng(11);
  std::size_t most_free_runs = 0, segments = 0;
  for (int trial = 0; trial < 4; ++trial)
    check_mixed_graph(rng, std::uniform_int_distribution<int>(1500, 2000)(rng), trial, most_free_runs, segments, true);
  MESSAGE("most free runs ", most_free_runs, ", most segments ", segments);
  CHECK(most_free_runs >= 48);
  CHECK(segments >= 280);
}

TEST_SUITE("graph multisampling") {
  TEST_CASE("multisampled attachments of one pass must share a count; the error names the pass and both") {
    RenderGraph graph("frame");
    graph.add_pass("msaa", [](PassBuilder& b) {
      b.write(b.create_texture("color", {.size = RelativeSize{1.0f}, .format = gpu::Format::RGBA16Float, .sample_count = 4}),
              TextureUse::ColorAttachment);
      b.write(b.create_texture("depth", {.size = RelativeSize{1.0f}, .format = gpu::Format::Depth32Float, .sample_count = 2}),
              TextureUse::DepthAttachment);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::SampleCount);
    CHECK(contains(e.message, "pass 'msaa'"));
    CHECK(contains(e.message, "texture 'color' has 4 samples and texture 'depth' has 2"));
    CHECK(e.passes == std::vector<std::string>{"msaa"});
    CHECK(e.resources == std::vector<std::string>{"color", "depth"});
  }

  TEST_CASE("a single-sample attachment beside multisampled ones is their resolve target, and compiles") {
    RenderGraph graph("frame");
    TextureHandle resolved;
    graph.add_pass("resolve", [&](PassBuilder& b) {
      b.write(b.create_texture("color", {.size = RelativeSize{1.0f}, .format = gpu::Format::RGBA16Float, .sample_count = 4}),
              TextureUse::ColorAttachment);
      resolved = b.write(b.create_texture("resolved", {.size = RelativeSize{1.0f}, .format = gpu::Format::RGBA16Float}),
                         TextureUse::ColorAttachment);
    });
    graph.mark_output(resolved);
    auto compiled = graph.compile(options);
    REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  }

  TEST_CASE("sampling or copying a multisampled texture per texel is an error that says to resolve it") {
    RenderGraph graph("frame");
    TextureHandle color;
    graph.add_pass("draw", [&](PassBuilder& b) {
      color = b.write(b.create_texture("scene", {.size = RelativeSize{1.0f}, .format = gpu::Format::RGBA16Float, .sample_count = 4}),
                      TextureUse::ColorAttachment);
    });
    graph.add_pass("tonemap", [&](PassBuilder& b) {
      b.read(color, TextureUse::Sampled);
      b.side_effect();
    });
    auto compiled = graph.compile(options);
    REQUIRE_FALSE(compiled);
    const GraphError& e = only_error(compiled.error());
    CHECK(e.kind == GraphErrorKind::SampleCount);
    CHECK(contains(e.message, "pass 'tonemap': samples texture 'scene' (4 samples)"));
    CHECK(contains(e.message, "resolve it"));
    CHECK(e.passes == std::vector<std::string>{"tonemap"});
  }

  TEST_CASE("bad sample counts are descriptor errors; multisampled memory is estimated per sample") {
    {
      RenderGraph graph("frame");
      graph.add_pass("odd", [](PassBuilder& b) {
        b.write(b.create_texture("three", {.size = RelativeSize{1.0f}, .format = gpu::Format::RGBA8Unorm, .sample_count = 3}),
                TextureUse::ColorAttachment);
        b.write(b.create_texture("mips", {.size = RelativeSize{1.0f}, .format = gpu::Format::RGBA8Unorm,
                                          .mip_level_count = 2, .sample_count = 4}),
                TextureUse::ColorAttachment);
        b.side_effect();
      });
      auto compiled = graph.compile(options);
      REQUIRE_FALSE(compiled);
      CHECK(compiled.error().count(GraphErrorKind::InvalidDescriptor) == 2);
      CHECK(contains(compiled.error().to_string(), "3 samples"));
      CHECK(contains(compiled.error().to_string(), "4 samples and 2 mip levels"));
    }
    std::uint64_t bytes[2] = {};
    for (int i = 0; i < 2; ++i) {
      RenderGraph graph("frame");
      TextureHandle out;
      graph.add_pass("draw", [&](PassBuilder& b) {
        b.write(b.create_texture("color", {.size = gpu::Extent3D{256, 256, 1}, .format = gpu::Format::RGBA8Unorm,
                                           .sample_count = i == 0 ? 1u : 4u}),
                TextureUse::ColorAttachment);
        out = b.write(b.create_texture("out", {.size = gpu::Extent3D{256, 256, 1}, .format = gpu::Format::RGBA8Unorm}),
                      TextureUse::ColorAttachment);
      });
      graph.mark_output(out);
      auto compiled = graph.compile(options);
      REQUIRE_MESSAGE(compiled, compiled.error().to_string());
      bytes[i] = compiled->memory().unaliased_bytes;
    }
    // 256 KiB per sample for 'color', plus 256 KiB for 'out'.
    CHECK(bytes[0] == 2 * 256 * 1024);
    CHECK(bytes[1] == 5 * 256 * 1024);
  }
}
