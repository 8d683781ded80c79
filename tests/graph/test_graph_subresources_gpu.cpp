// Subresources on lavapipe (or a GPU) under validation + synchronization validation: a mip
// chain rendered inside one texture (each pass samples one mip and renders the next), checked
// against a CPU box filter, then its memory taken over while its mips are in two states; the
// six faces of a cube rendered by six passes and read back face by face.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <utility>
#include <vector>
#include "graph_test_util.hpp"
import weft.core;
import weft.gpu;
import weft.graph;
import weft.test.gpu;

using namespace weft;
using weft::test::expect_no_validation_messages;

namespace {

gpu::Device& device() { return weft::test::gpu().device; }

using graph_test::fullscreen_vs;

// Each texel of the target: the mean of the 2 x 2 texels of the (one-mip) source view.
constexpr const char* downsample_fs = R"(#version 460
layout(location = 0) out vec4 color;
layout(set = 0, binding = 0) uniform sampler2D src;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy) * 2;
  color = 0.25 * (texelFetch(src, p, 0) + texelFetch(src, p + ivec2(1, 0), 0) + texelFetch(src, p + ivec2(0, 1), 0) +
                  texelFetch(src, p + ivec2(1, 1), 0));
})";

// A host-written buffer holding `bytes` (a texture's mip 0 to upload).
gpu::Buffer staging_buffer(const std::vector<std::uint8_t>& bytes) {
  auto staging = device().create_buffer({.label = "level0", .size = bytes.size(),
                                         .usage = gpu::BufferUsage::MapWrite | gpu::BufferUsage::CopySrc});
  REQUIRE(staging);
  std::memcpy(staging->mapped()->data(), bytes.data(), bytes.size());
  return std::move(*staging);
}

// A pass creating a square RGBA8 texture of `mips` mips and copying `source` into mip 0 --
// only mip 0 is declared, so the other mips are parts the next passes write.
TextureHandle add_upload(RenderGraph& graph, BufferHandle source, std::string_view name, std::uint32_t size,
                         std::uint32_t mips) {
  struct Upload {
    TextureHandle texture;
  };
  auto& upload = graph.add_pass<Upload>(
      "upload",
      [&](PassBuilder& b, Upload& d) {
        b.read(source, BufferUse::CopySrc);
        d.texture = b.write(b.create_texture(name, {.size = gpu::Extent3D{size, size, 1}, .mip_level_count = mips}),
                            TextureUse::CopyDst, TextureRange::mip(0));
      },
      [source](const PassResources& res, const Upload& d, PassContext& ctx) {
        ctx.encoder().copy_buffer_to_texture(res.buffer(source), 0, res.texture(d.texture), 0);
      });
  return upload.texture;
}

}  // namespace

TEST_CASE("a mip chain rendered inside one texture, each pass sampling the mip above (sync validation), then its memory taken over") {
  constexpr std::uint32_t size = 32, mips = 6;
  auto vs = device().create_shader_module({.label = "fullscreen", .stage = gpu::ShaderStage::Vertex, .glsl = fullscreen_vs});
  auto fs = device().create_shader_module({.label = "downsample", .stage = gpu::ShaderStage::Fragment, .glsl = downsample_fs});
  REQUIRE(vs);
  REQUIRE_MESSAGE(fs, (fs ? "" : fs.error().message));
  auto bgl = device().create_bind_group_layout(
      {.label = "downsample-bgl", .entries = {{0, gpu::BindingType::TextureSampler, gpu::ShaderStage::Fragment}}});
  REQUIRE(bgl);
  auto layout = device().create_pipeline_layout({.label = "downsample-layout", .bind_group_layouts = {&*bgl}});
  REQUIRE(layout);
  auto pipeline = device().create_render_pipeline({.label = "downsample", .layout = &*layout, .vertex = &*vs,
                                                   .fragment = &*fs, .color_targets = {{gpu::Format::RGBA8Unorm}}});
  REQUIRE(pipeline);
  auto sampler = device().create_sampler({.label = "nearest", .mag_filter = gpu::FilterMode::Nearest,
                                          .min_filter = gpu::FilterMode::Nearest});
  REQUIRE(sampler);

  // Mip 0: a pattern with detail at every scale.
  std::vector<std::uint8_t> level0(size * size * 4);
  for (std::uint32_t y = 0; y < size; ++y)
    for (std::uint32_t x = 0; x < size; ++x) {
      std::uint8_t* px = &level0[(y * size + x) * 4];
      px[0] = std::uint8_t(x * 8);
      px[1] = std::uint8_t(y * 8);
      px[2] = std::uint8_t(((x ^ y) & 1) * 255);
      px[3] = std::uint8_t(((x / 4 + y / 4) & 1) * 200 + 20);
    }
  const gpu::Buffer staging = staging_buffer(level0);
  std::vector<std::uint64_t> offsets(mips + 1, 0);
  for (std::uint32_t m = 0; m < mips; ++m) offsets[m + 1] = offsets[m] + std::uint64_t(size >> m) * (size >> m) * 4;
  auto readback = device().create_buffer({.label = "mips", .size = offsets[mips] + size * size * 4,
                                          .usage = gpu::BufferUsage::MapRead | gpu::BufferUsage::CopyDst});
  REQUIRE(readback);

  RenderGraph graph("mip chain");
  struct Step {
    TextureHandle chain;
    std::uint32_t mip = 0;
  };
  auto source = graph.import_buffer("level0", &staging, gpu::Access::HostWrite);
  auto out = graph.import_buffer("mips", &*readback, gpu::Access::Undefined);
  TextureHandle chain = add_upload(graph, source, "chain", size, mips);
  for (std::uint32_t m = 1; m < mips; ++m) {
    auto& step = graph.add_pass<Step>(
        "mip " + std::to_string(m),
        [&, m](PassBuilder& b, Step& d) {
          d.mip = m;
          d.chain = b.read(chain, TextureUse::Sampled, TextureRange::mip(m - 1));
          d.chain = b.write(d.chain, TextureUse::ColorAttachment, TextureRange::mip(m));
        },
        [&](const PassResources& res, const Step& d, PassContext& ctx) {
          const gpu::TextureView& above = res.view(d.chain, TextureRange::mip(d.mip - 1));
          const gpu::TextureView& target = res.view(d.chain, TextureRange::mip(d.mip));
          CHECK(above.base_mip() == d.mip - 1);
          CHECK(target.mip_count() == 1);
          CHECK(res.extent(d.chain, d.mip).width == size >> d.mip);
          auto group = ctx.device().create_bind_group(
              {.label = "downsample-group", .layout = &*bgl, .entries = {gpu::bind(0, above, &*sampler)}});
          REQUIRE(group);
          auto pass = ctx.encoder().begin_render_pass(
              {.label = "downsample", .color_attachments = {{.view = &target, .load = gpu::LoadOp::DontCare}}});
          pass.set_pipeline(*pipeline);
          pass.set_bind_group(0, ctx.keep(std::move(*group)));
          pass.draw(3);
          pass.end();
        });
    chain = step.chain;
  }
  // Mips 1 and on are copied back; mip 0 stays as the first step left it (sampled), so the
  // texture's mips are in two states when its memory is taken over below.
  struct Copy {
    TextureHandle chain;
    BufferHandle out;
  };
  auto& copy = graph.add_pass<Copy>(
      "read back",
      [&](PassBuilder& b, Copy& d) {
        d.chain = b.read(chain, TextureUse::CopySrc, TextureRange::mips(1, TextureRange::remaining));
        d.out = b.write(out, BufferUse::CopyDst);
      },
      [&](const PassResources& res, const Copy& d, PassContext& ctx) {
        for (std::uint32_t m = 1; m < mips; ++m)
          ctx.encoder().copy_texture_to_buffer(res.texture(d.chain), res.buffer(d.out), offsets[m], m);
      });
  // A texture made after the chain's last use: it takes the chain's memory over.
  struct After {
    TextureHandle other;
    BufferHandle out;
  };
  auto& after = graph.add_pass<After>(
      "after",
      [&](PassBuilder& b, After& d) {
        b.read(source, BufferUse::CopySrc);
        d.other = b.write(b.create_texture("other", {.size = gpu::Extent3D{size, size, 1}}), TextureUse::CopyDst);
      },
      [&](const PassResources& res, const After& d, PassContext& ctx) {
        ctx.encoder().copy_buffer_to_texture(res.buffer(source), 0, res.texture(d.other), 0);
      });
  auto& copy_other = graph.add_pass<Copy>(
      "read back other",
      [&](PassBuilder& b, Copy& d) {
        d.chain = b.read(after.other, TextureUse::CopySrc);
        d.out = b.write(copy.out, BufferUse::CopyDst);
      },
      [&](const PassResources& res, const Copy& d, PassContext& ctx) {
        ctx.encoder().copy_texture_to_buffer(res.texture(d.chain), res.buffer(d.out), offsets[mips], 0);
      });
  graph.mark_output(copy_other.out, gpu::Access::HostRead);

  auto compiled = graph.compile({.device = &device()});
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  auto stats = compiled->execute(device());
  REQUIRE_MESSAGE(stats, stats.error().message);
  // Run twice: the views of the mips are kept with the textures, the states come back.
  REQUIRE(compiled->execute(device()));
  expect_no_validation_messages();

  const auto resources = compiled->resources();
  const auto c = compiled->find_resource("chain"), o = compiled->find_resource("other");
  REQUIRE(c);
  REQUIRE(o);
  CHECK_MESSAGE(resources[*c].alias_group == resources[*o].alias_group, compiled->dump());
  // The takeover moves the chain's mips block by block: mip 0 from shader-read, the rest
  // from copy-src.
  const auto after_pass = compiled->find_pass("after");
  REQUIRE(after_pass);
  int blocks = 0;
  for (const PlannedBarrier& b : compiled->barriers_before(*after_pass))
    if (b.previous_occupant == *c) {
      ++blocks;
      CHECK(b.occupant_before == (b.range.base_mip == 0 ? gpu::Access::ShaderRead : gpu::Access::CopySrc));
    }
  CHECK_MESSAGE(blocks == 2, compiled->dump());

  // Each mip against the box filter of the one above, computed on the CPU the way the shader
  // does (unorm8 in, the mean in float, rounded to unorm8).
  auto bytes = readback->mapped();
  REQUIRE(bytes);
  const auto* data = reinterpret_cast<const std::uint8_t*>(bytes->data());
  std::vector<std::uint8_t> above = level0;
  int worst = 0;
  for (std::uint32_t m = 1; m < mips; ++m) {
    const std::uint32_t w = size >> m, wa = size >> (m - 1);
    std::vector<std::uint8_t> expected(w * w * 4);
    for (std::uint32_t y = 0; y < w; ++y)
      for (std::uint32_t x = 0; x < w; ++x)
        for (std::uint32_t ch = 0; ch < 4; ++ch) {
          auto at = [&](std::uint32_t xx, std::uint32_t yy) { return float(above[(yy * wa + xx) * 4 + ch]); };
          const float mean = 0.25f * (at(2 * x, 2 * y) + at(2 * x + 1, 2 * y) + at(2 * x, 2 * y + 1) + at(2 * x + 1, 2 * y + 1));
          expected[(y * w + x) * 4 + ch] = std::uint8_t(mean + 0.5f);
        }
    for (std::size_t i = 0; i < expected.size(); ++i)
      worst = std::max(worst, std::abs(int(data[offsets[m] + i]) - int(expected[i])));
    above.assign(data + offsets[m], data + offsets[m] + w * w * 4);  // the GPU's mip feeds the next
  }
  CHECK(worst <= 1);
  CHECK(std::memcmp(data + offsets[mips], level0.data(), level0.size()) == 0);  // the texture that took over
}

TEST_CASE("six passes render the six faces of one cube; a copy reads every face back (sync validation)") {
  constexpr std::uint32_t size = 8;
  auto readback = device().create_buffer({.label = "faces", .size = 6 * size * size * 4,
                                          .usage = gpu::BufferUsage::MapRead | gpu::BufferUsage::CopyDst});
  REQUIRE(readback);
  RenderGraph graph("cube");
  struct Face {
    TextureHandle cube;
    std::uint32_t face = 0;
  };
  TextureHandle cube;
  for (std::uint32_t face = 0; face < 6; ++face) {
    auto& pass = graph.add_pass<Face>(
        "face " + std::to_string(face),
        [&, face](PassBuilder& b, Face& d) {
          d.face = face;
          if (face == 0)
            cube = b.create_texture("cube", {.size = gpu::Extent3D{size, size, 6}, .dimension = gpu::TextureDimension::Cube});
          d.cube = b.write(cube, TextureUse::ColorAttachment, TextureRange::layer(face));
        },
        [](const PassResources& res, const Face& d, PassContext& ctx) {
          const gpu::TextureView& view = res.view(d.cube, TextureRange::layer(d.face));
          CHECK(view.layer_count() == 1);
          CHECK(view.base_layer() == d.face);
          const float f = float(d.face);
          auto pass = ctx.encoder().begin_render_pass(
              {.label = "face", .color_attachments = {{.view = &view, .clear_color = {f / 8.0f, 1.0f - f / 8.0f, 0.5f, 1.0f}}}});
          pass.end();
        });
    cube = pass.cube;
  }
  struct Copy {
    TextureHandle cube;
    BufferHandle out;
  };
  auto out = graph.import_buffer("faces", &*readback, gpu::Access::Undefined);
  auto& copy = graph.add_pass<Copy>(
      "read back",
      [&](PassBuilder& b, Copy& d) {
        d.cube = b.read(cube, TextureUse::CopySrc);
        d.out = b.write(out, BufferUse::CopyDst);
      },
      [](const PassResources& res, const Copy& d, PassContext& ctx) {
        ctx.encoder().copy_texture_to_buffer(res.texture(d.cube), res.buffer(d.out), 0, 0);
      });
  graph.mark_output(copy.out, gpu::Access::HostRead);
  auto compiled = graph.compile({.device = &device()});
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  REQUIRE(compiled->execute(device()));
  expect_no_validation_messages();
  auto bytes = readback->mapped();
  REQUIRE(bytes);
  const auto* data = reinterpret_cast<const std::uint8_t*>(bytes->data());
  int wrong = 0;
  for (std::uint32_t face = 0; face < 6; ++face) {
    const std::uint8_t expected[4] = {std::uint8_t(face * 255 / 8.0f + 0.5f), std::uint8_t((1.0f - face / 8.0f) * 255 + 0.5f),
                                      128, 255};
    for (std::uint32_t i = 0; i < size * size; ++i) {
      const std::uint8_t* px = data + (face * size * size + i) * 4;
      for (int ch = 0; ch < 4; ++ch) wrong += std::abs(int(px[ch]) - int(expected[ch])) > 1 ? 1 : 0;
    }
  }
  CHECK(wrong == 0);
}

TEST_CASE("a view of a range the texture does not have fails execute, naming pass, range and texture") {
  RenderGraph graph("bad view");
  struct Data {
    TextureHandle t;
  };
  std::string seen;
  auto& pass = graph.add_pass<Data>(
      "asks",
      [&](PassBuilder& b, Data& d) {
        d.t = b.write(b.create_texture("two mips", {.size = gpu::Extent3D{8, 8, 1}, .mip_level_count = 2}),
                      TextureUse::ColorAttachment, TextureRange::mip(1));
        b.side_effect();
      },
      [](const PassResources& res, const Data& d, PassContext& ctx) {
        (void)res.view(d.t, TextureRange::mip(2));
        auto p = ctx.encoder().begin_render_pass({.label = "clear", .color_attachments = {{.view = &res.view(d.t, TextureRange::mip(1))}}});
        p.end();
      });
  (void)pass;
  auto compiled = graph.compile({.device = &device()});
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  auto result = compiled->execute(device());
  REQUIRE_FALSE(result);
  CHECK_MESSAGE(graph_test::contains(result.error().message, "pass 'asks': execute asks for a view of mip 2 of texture 'two mips'"),
                result.error().message);
  expect_no_validation_messages();
}

TEST_CASE("a mip chain blitted inside one texture: each pass copies one mip into the next (sync validation)") {
  constexpr std::uint32_t size = 16, mips = 5;
  std::vector<std::uint8_t> level0(size * size * 4);
  for (std::uint32_t i = 0; i < size * size; ++i)
    for (std::uint32_t ch = 0; ch < 4; ++ch) level0[i * 4 + ch] = std::uint8_t((i % size) * 12 + ch * 8);
  const gpu::Buffer staging = staging_buffer(level0);
  auto readback = device().create_buffer(
      {.label = "last mip", .size = 4, .usage = gpu::BufferUsage::MapRead | gpu::BufferUsage::CopyDst});
  REQUIRE(readback);
  RenderGraph graph("blit chain");
  struct Data {
    TextureHandle t;
    BufferHandle out;
    std::uint32_t mip = 0;
  };
  auto source = graph.import_buffer("level0", &staging, gpu::Access::HostWrite);
  TextureHandle t = add_upload(graph, source, "t", size, mips);
  for (std::uint32_t m = 1; m < mips; ++m) {
    auto& step = graph.add_pass<Data>(
        "blit " + std::to_string(m),
        [&, m](PassBuilder& b, Data& d) {
          d.mip = m;
          d.t = b.read(t, TextureUse::CopySrc, TextureRange::mip(m - 1));
          d.t = b.write(d.t, TextureUse::CopyDst, TextureRange::mip(m));
        },
        [](const PassResources& res, const Data& d, PassContext& ctx) {
          const gpu::Texture& tex = res.texture(d.t);
          ctx.encoder().blit_texture(tex, d.mip - 1, tex, d.mip, gpu::FilterMode::Linear);
        });
    t = step.t;
  }
  auto out = graph.import_buffer("last mip", &*readback, gpu::Access::Undefined);
  auto& copy = graph.add_pass<Data>(
      "read back",
      [&](PassBuilder& b, Data& d) {
        d.t = b.read(t, TextureUse::CopySrc, TextureRange::mip(mips - 1));
        d.out = b.write(out, BufferUse::CopyDst);
      },
      [](const PassResources& res, const Data& d, PassContext& ctx) {
        ctx.encoder().copy_texture_to_buffer(res.texture(d.t), res.buffer(d.out), 0, mips - 1);
      });
  graph.mark_output(copy.out, gpu::Access::HostRead);
  auto compiled = graph.compile({.device = &device()});
  REQUIRE_MESSAGE(compiled, compiled.error().to_string());
  REQUIRE(compiled->execute(device()));
  expect_no_validation_messages();
  // The last mip (1 x 1) is the mean of the whole image: each column x has value x*12 + ch*8.
  auto bytes = readback->mapped();
  REQUIRE(bytes);
  const auto* px = reinterpret_cast<const std::uint8_t*>(bytes->data());
  for (std::uint32_t ch = 0; ch < 4; ++ch) {
    const float mean = 7.5f * 12.0f + float(ch) * 8.0f;
    CHECK(std::abs(float(px[ch]) - mean) <= 3.0f);
  }
}
