// The fur feature through the renderer: a scene with a "fur" material gets exactly one extra
// pass between forward and background, caches its assets across frames, generates UVs for
// meshes without them (with a warning), and reports material errors at their JSON paths.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <expected>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <unistd.h>
import weft.core;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.pass.shell_fur;
import weft.test.gpu;

using namespace weft;

namespace {

std::filesystem::path work_dir() {
  static const auto dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("weft-fur-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    REQUIRE(image::save_png(d / "photo.png", fur::synthesize_fur_photo({.width = 64, .height = 64})));
    // A quad without texture coordinates.
    std::ofstream(d / "no_uvs.obj") << "v -0.5 0 -0.5\nv 0.5 0 -0.5\nv 0.5 0 0.5\nv -0.5 0 0.5\nvn 0 1 0\n"
                                       "f 1//1 3//1 2//1\nf 1//1 4//1 3//1\n";
    return d;
  }();
  return dir;
}

std::filesystem::path shared_data() {
  const char* env = std::getenv("WEFT_SHARED_DATA");
  return env ? std::filesystem::path(env) : std::filesystem::path("/work/shared/data");
}

std::string fur_scene(const std::string& material, const std::string& mesh = R"({"primitive": "plane", "size": 1.2, "subdivisions": 4})") {
  return R"({
    "version": 1, "output": {"width": 64, "height": 64},
    "camera": {"position": [0, 1.4, 1.4], "target": [0, 0, 0], "fov": 45},
    "lights": [{"type": "directional", "direction": [0.3, -1, -0.4], "intensity": 3}],
    "environment": {"color": [0.15, 0.15, 0.2]},
    "meshes": {"rug": )" + mesh + R"(},
    "materials": {"fur": )" + material + R"(},
    "objects": [{"name": "rug", "mesh": "rug", "material": "fur"}]
  })";
}

Result<scene::Scene> load(const std::string& json) {
  auto desc = scene::parse_scene(json, work_dir());
  if (!desc) return std::unexpected(desc.error());
  return scene::load_scene(*desc);
}

renderer::Renderer& shared_renderer() {
  static auto r = renderer::Renderer::create(weft::test::gpu().device);
  REQUIRE(r);
  return *r;
}

double mean_luma(const image::Image8& img, std::uint32_t x0, std::uint32_t y0, std::uint32_t x1, std::uint32_t y1,
                 double* variance = nullptr) {
  double sum = 0.0, sum2 = 0.0, n = 0.0;
  for (std::uint32_t y = y0; y < y1; ++y)
    for (std::uint32_t x = x0; x < x1; ++x) {
      const double v = img.at(x, y, 1);
      sum += v;
      sum2 += v * v;
      n += 1.0;
    }
  if (variance) *variance = sum2 / n - (sum / n) * (sum / n);
  return sum / n;
}

bool contains(const std::vector<std::string>& lines, std::string_view text) {
  return std::any_of(lines.begin(), lines.end(), [&](const std::string& l) { return l.find(text) != std::string::npos; });
}

}  // namespace

TEST_CASE("a fur scene adds one pass, shell_fur, between forward and background, and draws textured fur") {
  auto s = load(fur_scene(R"({"type": "fur", "photo": "photo.png", "layers": 8, "thickness": 0.06})"));
  REQUIRE_MESSAGE(s, (s ? "" : s.error().what()));
  auto report = shared_renderer().describe(*s);
  REQUIRE_MESSAGE(report, (report ? "" : report.error().what()));
  CHECK(report->passes == std::vector<std::string>{"shadow_map", "forward", "shell_fur", "background", "tonemap"});
  auto frame = shared_renderer().render(*s);
  REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().what()));
  double variance = 0.0;
  const double centre = mean_luma(frame->image, 24, 24, 40, 40, &variance);
  const double corner = mean_luma(frame->image, 0, 0, 4, 4);
  CHECK(std::abs(centre - corner) > 10.0);  // fur, not sky
  CHECK(variance > 20.0);         // the photo's strands, not a flat colour
  weft::test::expect_no_validation_messages();
}

TEST_CASE("a second frame of a fur scene creates, uploads and compiles nothing new and draws the same image") {
  auto s = load(fur_scene(R"({"type": "fur", "photo": "photo.png", "layers": 8, "thickness": 0.06})"));
  REQUIRE(s);
  auto& r = shared_renderer();
  auto first = r.render(*s);
  REQUIRE(first);
  const auto before = r.cache_stats();
  auto second = r.render(*s);
  REQUIRE(second);
  CHECK(r.cache_stats().pass_creations == before.pass_creations);
  CHECK(r.cache_stats().mesh_uploads == before.mesh_uploads);
  CHECK(first->image.pixels == second->image.pixels);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("a mesh without UVs gets generated UVs and a warning; \"uv_mapping\": \"mesh\" is a clear error") {
  auto s = load(fur_scene(R"({"type": "fur", "photo": "photo.png", "layers": 8, "thickness": 0.05})", R"({"path": "no_uvs.obj"})"));
  REQUIRE_MESSAGE(s, (s ? "" : s.error().what()));
  auto frame = shared_renderer().render(*s);
  REQUIRE_MESSAGE(frame, (frame ? "" : frame.error().what()));
  CHECK(contains(frame->warnings, "has no UVs"));
  double variance = 0.0;
  mean_luma(frame->image, 24, 24, 40, 40, &variance);
  CHECK(variance > 20.0);
  auto strict = load(fur_scene(R"({"type": "fur", "photo": "photo.png", "uv_mapping": "mesh"})", R"({"path": "no_uvs.obj"})"));
  REQUIRE(strict);
  auto refused = shared_renderer().render(*strict);
  REQUIRE(!refused);
  CHECK(refused.error().message.find("no UVs") != std::string::npos);
  CHECK(refused.error().message.find("rug") != std::string::npos);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("fur material errors name their JSON path; a missing photo names the file") {
  auto s = load(fur_scene(R"({"type": "fur", "photo": "photo.png", "layers": 0, "lighting": "phong"})"));
  REQUIRE(s);
  auto frame = shared_renderer().render(*s);
  REQUIRE(!frame);
  CHECK(frame.error().message.find("$.materials.fur.layers") != std::string::npos);
  CHECK(frame.error().message.find("$.materials.fur.lighting") != std::string::npos);
  auto missing = load(fur_scene(R"({"type": "fur", "photo": "nowhere.jpg"})"));
  REQUIRE(missing);
  auto refused = shared_renderer().render(*missing);
  REQUIRE(!refused);
  CHECK(refused.error().message.find("nowhere.jpg") != std::string::npos);
}

TEST_CASE("real fur photos (when ../shared/data is present): render on a sphere; patches are flagged") {
  const auto cream = shared_data() / "fur" / "cream_long.jpg";
  const auto patches = shared_data() / "fur" / "black_white_patches.jpg";
  if (!std::filesystem::exists(cream) || !std::filesystem::exists(patches)) {
    MESSAGE("skipped: the real fur photos are not at " << (shared_data() / "fur").string() << " (set WEFT_SHARED_DATA)");
    return;
  }
  const std::string sphere = R"({"primitive": "sphere", "radius": 0.5, "segments": 48})";
  auto a = load(fur_scene(R"({"type": "fur", "photo": ")" + cream.string() + R"(", "layers": 8})", sphere));
  auto b = load(fur_scene(R"({"type": "fur", "photo": ")" + patches.string() + R"(", "layers": 8})", sphere));
  REQUIRE(a);
  REQUIRE(b);
  auto fa = shared_renderer().render(*a);
  auto fb = shared_renderer().render(*b);
  REQUIRE_MESSAGE(fa, (fa ? "" : fa.error().what()));
  REQUIRE_MESSAGE(fb, (fb ? "" : fb.error().what()));
  CHECK(!contains(fa->warnings, "two-coloured"));
  CHECK(contains(fb->warnings, "two-coloured"));
  CHECK(mean_luma(fa->image, 24, 24, 40, 40) > mean_luma(fa->image, 0, 0, 4, 4) + 10.0);
  weft::test::expect_no_validation_messages();
}
