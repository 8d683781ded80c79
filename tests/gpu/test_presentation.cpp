// weft.gpu's presentation pieces that need no window: a headless instance refuses surfaces
// with a message naming the switch, blit_texture scales and swaps RGBA to BGRA as a window
// texture needs, set_scissor_rect clips draws (clamped to the attachment), and a texture
// moves to Access::Present and back without a validation message.
#include <doctest/doctest.h>
#include <array>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>
import weft.core;
import weft.gpu;
import weft.test.gpu;

using namespace weft;

TEST_CASE("a headless instance (the default) makes no surface and says which switch enables it") {
  auto instance = gpu::Instance::create({.application_name = "weft-test-headless"});
  REQUIRE(instance);
  CHECK_FALSE(instance->presentation_enabled());
  auto surface = instance->create_surface({.x11_display = reinterpret_cast<void*>(1), .x11_window = 1});
  REQUIRE_FALSE(surface);
  CHECK(surface.error().message ==
        "create_surface needs an instance made with InstanceDescriptor::presentation = true");
}

TEST_CASE("blit_texture scales RGBA onto BGRA, nearest: each source texel becomes a 2x2 block, channels swapped") {
  auto& device = test::gpu().device;
  auto src = device.create_texture({.label = "blit src", .size = {2, 2, 1}, .format = gpu::Format::RGBA8Unorm,
                                    .usage = gpu::TextureUsage::CopySrc | gpu::TextureUsage::CopyDst});
  auto dst = device.create_texture({.label = "blit dst", .size = {4, 4, 1}, .format = gpu::Format::BGRA8Unorm,
                                    .usage = gpu::TextureUsage::CopySrc | gpu::TextureUsage::CopyDst});
  REQUIRE(src);
  REQUIRE(dst);
  const std::array<std::uint8_t, 16> texels = {10, 20, 30, 255, 40, 50, 60, 255, 70, 80, 90, 255, 100, 110, 120, 255};
  REQUIRE(device.queue().write_texture(*src, std::as_bytes(std::span(texels)), 0, gpu::Access::CopySrc));
  auto encoder = device.create_command_encoder("blit");
  REQUIRE(encoder);
  encoder->transition(*dst, gpu::Access::CopyDst);
  encoder->blit_texture(*src, *dst, gpu::FilterMode::Nearest);
  auto commands = encoder->finish();
  REQUIRE(commands);
  REQUIRE(device.queue().submit(std::move(*commands)));
  auto bytes = device.queue().read_texture(*dst);
  REQUIRE(bytes);
  const auto* out = reinterpret_cast<const std::uint8_t*>(bytes->data());
  for (std::uint32_t y = 0; y < 4; ++y)
    for (std::uint32_t x = 0; x < 4; ++x) {
      const std::uint8_t* want = &texels[((y / 2) * 2 + x / 2) * 4];
      const std::uint8_t* got = &out[(y * 4 + x) * 4];
      CHECK(got[0] == want[2]);  // B
      CHECK(got[1] == want[1]);  // G
      CHECK(got[2] == want[0]);  // R
    }
  test::expect_no_validation_messages();
}

TEST_CASE("blit_texture with a missing usage is an error naming the texture") {
  auto& device = test::gpu().device;
  auto src = device.create_texture({.label = "no copy-src", .size = {2, 2, 1}, .format = gpu::Format::RGBA8Unorm,
                                    .usage = gpu::TextureUsage::Sampled});
  auto dst = device.create_texture({.label = "blit dst 2", .size = {2, 2, 1}, .format = gpu::Format::RGBA8Unorm,
                                    .usage = gpu::TextureUsage::CopyDst});
  REQUIRE(src);
  REQUIRE(dst);
  auto encoder = device.create_command_encoder("bad blit");
  REQUIRE(encoder);
  encoder->blit_texture(*src, *dst);
  auto commands = encoder->finish();
  REQUIRE_FALSE(commands);
  CHECK(commands.error().message == "blit source 'no copy-src' lacks copy-src usage (has sampled)");
}

TEST_CASE("set_scissor_rect clips a clear-colour draw; rectangles past the edge are clamped") {
  auto& device = test::gpu().device;
  auto target = device.create_texture({.label = "scissored", .size = {8, 8, 1}, .format = gpu::Format::RGBA8Unorm,
                                       .usage = gpu::TextureUsage::ColorAttachment | gpu::TextureUsage::CopySrc});
  REQUIRE(target);
  auto vs = device.create_shader_module({.label = "full.vert", .stage = gpu::ShaderStage::Vertex, .glsl = R"(#version 450
void main() { vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2); gl_Position = vec4(p * 2.0 - 1.0, 0, 1); })"});
  auto fs = device.create_shader_module({.label = "white.frag", .stage = gpu::ShaderStage::Fragment, .glsl = R"(#version 450
layout(location = 0) out vec4 color; void main() { color = vec4(1); })"});
  REQUIRE(vs);
  REQUIRE(fs);
  auto layout = device.create_pipeline_layout({.label = "scissor"});
  REQUIRE(layout);
  auto pipeline = device.create_render_pipeline({.label = "scissor", .layout = &*layout, .vertex = &*vs, .fragment = &*fs,
                                                 .color_targets = {{gpu::Format::RGBA8Unorm}}});
  REQUIRE(pipeline);
  auto encoder = device.create_command_encoder("scissor");
  REQUIRE(encoder);
  encoder->transition(*target, gpu::Access::ColorAttachment);
  {
    auto pass = encoder->begin_render_pass({.label = "scissor", .color_attachments = {{.view = &target->view()}}});
    pass.set_pipeline(*pipeline);
    pass.set_scissor_rect(1, 2, 3, 2);    // x 1..3, y 2..3
    pass.draw(3);
    pass.set_scissor_rect(6, -4, 10, 5);  // clamped to x 6..7, y 0
    pass.draw(3);
    pass.end();
  }
  // Present and back: the layout a window needs, then a copy reads it.
  encoder->transition(*target, gpu::Access::Present);
  encoder->transition(*target, gpu::Access::CopySrc);
  auto commands = encoder->finish();
  REQUIRE(commands);
  REQUIRE(device.queue().submit(std::move(*commands)));
  auto bytes = device.queue().read_texture(*target);
  REQUIRE(bytes);
  const auto* out = reinterpret_cast<const std::uint8_t*>(bytes->data());
  for (std::uint32_t y = 0; y < 8; ++y)
    for (std::uint32_t x = 0; x < 8; ++x) {
      const bool inside = (x >= 1 && x < 4 && y >= 2 && y < 4) || (x >= 6 && y == 0);
      CHECK_MESSAGE(out[(y * 8 + x) * 4] == (inside ? 255 : 0), "texel " << x << "," << y);
    }
  test::expect_no_validation_messages();
}
