// Helpers of the renderer suites: a scene from JSON text, the one renderer of the test run,
// a channel of an 8-bit frame. Include after <doctest/doctest.h>, <filesystem>, <string> and
// the imports of weft.core, weft.image, weft.scene, weft.renderer and weft.test.gpu.
#pragma once

namespace weft::test {

inline scene::Scene load(const std::string& json, const std::filesystem::path& base = std::filesystem::temp_directory_path()) {
  auto desc = scene::parse_scene(json, base);
  REQUIRE_MESSAGE(desc, (desc ? "" : desc.error().message));
  auto s = scene::load_scene(*desc);
  REQUIRE_MESSAGE(s, (s ? "" : s.error().message));
  return std::move(*s);
}

inline renderer::Renderer& shared_renderer() {
  static auto r = renderer::Renderer::create(weft::test::gpu().device);
  REQUIRE(r);
  return *r;
}

inline int channel(const image::Image8& img, std::uint32_t x, std::uint32_t y, int c = 0) {
  return img.pixels[(std::size_t(y) * img.width + x) * img.channels + c];
}

}  // namespace weft::test
