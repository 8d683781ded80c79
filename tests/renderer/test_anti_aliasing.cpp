// Anti-aliasing through the renderer, on lavapipe under validation, against a supersampled
// reference: a black square turned 20 degrees on a white sky (aces off: the clamp), whose
// edges stair-step without AA. The reference is the same frame at 4x the width and height,
// box-filtered as light. MSAA, FXAA and accumulation must each bring the edge pixels nearer
// to it and leave the flat pixels alone; accumulation starts afresh where it must.
#include <doctest/doctest.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>
#include <glm/glm.hpp>
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.test.gpu;
#include "renderer_support.h"

using namespace weft;

namespace {
using weft::test::load;
using weft::test::shared_renderer;

const char* edge_scene = R"({
  "version": 1,
  "output": {"width": 64, "height": 64},
  "camera": {"position": [0, 3, 0], "target": [0, 0, 0], "up": [0, 0, -1], "fov": 40},
  "environment": {"color": [1, 1, 1]},
  "meshes": {"square": {"primitive": "plane", "size": 1.1}},
  "materials": {"black": {"type": "standard", "base_color": [0, 0, 0], "roughness": 1, "metallic": 0}},
  "objects": [{"name": "square", "mesh": "square", "material": "black",
               "transform": {"rotation_degrees": [0, 20, 0]}}]
})";

pipeline::Pipeline parse(const std::string& text) {
  auto p = pipeline::parse_pipeline(text, "test pipeline");
  REQUIRE_MESSAGE(p, (p ? "" : p.error().message));
  return std::move(*p);
}

// The default frame without the shadow map, `scene_options` on the scene colour, `tail` the
// passes after the tone map ("fxaa", "accumulate") in order.
pipeline::Pipeline frame_with(const std::string& scene_options, const std::vector<std::string>& tail,
                              const std::string& tail_options = "{}") {
  std::string passes = R"("scene": {"type": "scene_color", "options": )" + scene_options +
                       R"(}, "background": {"type": "background"}, "tonemap": {"type": "tonemap"})";
  std::string connections = R"("scene.color -> background.color", "scene.depth -> background.depth",
                                "background.color -> tonemap.color")";
  std::string last = "tonemap";
  for (const auto& t : tail) {
    passes += ", \"" + t + "\": {\"type\": \"" + t + "\", \"options\": " + (t == "accumulate" ? tail_options : "{}") + "}";
    connections += ", \"" + last + ".color -> " + t + ".color\"";
    last = t;
  }
  return parse("{\"passes\": {" + passes + "}, \"connections\": [" + connections + "], \"outputs\": [\"" + last +
               ".color\"]}");
}

image::Image8 render(const scene::Scene& s, const pipeline::Pipeline& p, std::uint32_t w, std::uint32_t h,
                     std::uint32_t sample = 0) {
  renderer::RenderOptions o{.width = w, .height = h, .aces = false, .sample_index = sample};
  o.pipeline = &p;
  auto f = shared_renderer().render(s, o);
  REQUIRE_MESSAGE(f, (f ? "" : f.error().message));
  return std::move(f->image);
}

image::Image8 accumulate(const scene::Scene& s, const pipeline::Pipeline& p, std::uint32_t w, std::uint32_t h,
                         std::uint32_t samples) {
  image::Image8 last;
  for (std::uint32_t i = 0; i < samples; ++i) last = render(s, p, w, h, i);
  return last;
}

// Red channel as light (0..1).
double light(const image::Image8& im, std::uint32_t x, std::uint32_t y) {
  return image::srgb_to_linear(float(weft::test::channel(im, x, y)) / 255.0f);
}

std::vector<double> box_filtered(const image::Image8& hi, std::uint32_t scale) {
  const std::uint32_t w = hi.width / scale, h = hi.height / scale;
  std::vector<double> out(std::size_t{w} * h);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      double sum = 0;
      for (std::uint32_t j = 0; j < scale; ++j)
        for (std::uint32_t i = 0; i < scale; ++i) sum += light(hi, x * scale + i, y * scale + j);
      out[std::size_t{y} * w + x] = sum / double(scale * scale);
    }
  return out;
}

struct Errors {
  double edges = 0;   // RMSE as light over the pixels the edge crosses
  int flat_changed = 0;  // pixels away from the edge that differ from the frame without AA by more than 1
};
Errors errors(const image::Image8& im, const image::Image8& plain, const std::vector<double>& reference) {
  double sum = 0;
  int n = 0, changed = 0;
  for (std::uint32_t y = 1; y + 1 < im.height; ++y)
    for (std::uint32_t x = 1; x + 1 < im.width; ++x) {
      const double r = reference[std::size_t{y} * im.width + x];
      bool flat = true;  // the pixel and its neighbours entirely inside or outside in the reference
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const double v = reference[std::size_t(int(y) + dy) * im.width + std::size_t(int(x) + dx)];
          flat &= v < 0.002 || v > 0.998;
        }
      if (r > 0.02 && r < 0.98) {
        const double d = light(im, x, y) - r;
        sum += d * d;
        ++n;
      }
      if (flat && std::abs(weft::test::channel(im, x, y) - weft::test::channel(plain, x, y)) > 1) ++changed;
    }
  REQUIRE(n > 40);  // the edges of the square cross that many pixels
  return {std::sqrt(sum / n), changed};
}
}  // namespace

TEST_CASE("MSAA 4x, FXAA and accumulation bring a diagonal edge towards the supersampled reference and leave flat pixels alone") {
  const auto s = load(edge_scene);
  const std::uint32_t size = 64, scale = 4;
  const auto plain_pipeline = frame_with("{}", {});
  const auto reference = box_filtered(render(s, plain_pipeline, size * scale, size * scale), scale);
  const auto plain = render(s, plain_pipeline, size, size);
  const Errors none = errors(plain, plain, reference);
  CHECK(none.edges > 0.05);  // stair steps: edge pixels are nearly all or nothing

  const auto msaa = render(s, frame_with(R"({"msaa": 4})", {}), size, size);
  const Errors m = errors(msaa, plain, reference);
  CHECK(m.edges < 0.5 * none.edges);
  CHECK(m.flat_changed == 0);

  const auto fxaa = render(s, frame_with("{}", {"fxaa"}), size, size);
  const Errors f = errors(fxaa, plain, reference);
  CHECK(f.edges < 0.9 * none.edges);
  CHECK(f.flat_changed == 0);

  const auto accumulated = accumulate(s, frame_with("{}", {"accumulate"}, R"({"frames": 16})"), size, size, 16);
  const Errors a = errors(accumulated, plain, reference);
  CHECK(a.edges < 0.4 * none.edges);
  CHECK(a.flat_changed == 0);
  MESSAGE("edge RMSE (light): none " << none.edges << ", MSAA 4x " << m.edges << ", FXAA " << f.edges
                                     << ", accumulation of 16 " << a.edges);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("accumulation: sample 0 is the frame without it; a skipped sample, a resize or frames = 1 start afresh") {
  const auto s = load(edge_scene);
  const auto plain_pipeline = frame_with("{}", {});
  const auto acc = frame_with("{}", {"accumulate"}, R"({"frames": 64})");
  auto max_difference = [](const image::Image8& a, const image::Image8& b) {
    REQUIRE(a.pixels.size() == b.pixels.size());
    int d = 0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i) d = std::max(d, std::abs(int(a.pixels[i]) - int(b.pixels[i])));
    return d;
  };
  // The plain frames first: a renderer keeps the passes of the pipeline it last rendered, so
  // rendering another pipeline in between would drop the accumulate pass and its history.
  const auto plain_0 = render(s, plain_pipeline, 48, 48, 0);
  const auto jittered = render(s, plain_pipeline, 48, 48, 5);  // sample 5 alone
  const auto plain_3 = render(s, plain_pipeline, 48, 48, 3);
  const auto small_4 = render(s, plain_pipeline, 40, 40, 4), small_5 = render(s, plain_pipeline, 40, 40, 5);
  // A jittered sample moves the edges.
  CHECK(max_difference(jittered, plain_0) > 100);
  // Sample 0: the history is the frame (through half floats and back: within one code value).
  CHECK(max_difference(render(s, acc, 48, 48, 0), plain_0) <= 1);
  // Samples 1..3, then sample 5 (4 was skipped: a frame failed or the caller restarted): the
  // history starts again from sample 5 alone.
  for (std::uint32_t i = 1; i < 4; ++i) (void)render(s, acc, 48, 48, i);
  CHECK(max_difference(render(s, acc, 48, 48, 5), jittered) <= 1);
  // A resize mid-accumulation (samples 0..3 at 48x48, sample 4 at 40x40): sample 4 alone...
  for (std::uint32_t i = 0; i < 4; ++i) (void)render(s, acc, 48, 48, i);
  CHECK(max_difference(render(s, acc, 40, 40, 4), small_4) <= 1);
  // ...and the accumulation goes on from there at the new size: sample 5 is the mean of 4 and 5.
  const auto mean_45 = render(s, acc, 40, 40, 5);
  CHECK(max_difference(mean_45, small_5) > 1);
  int between = 0, pixels = 0;
  for (std::size_t i = 0; i < mean_45.pixels.size(); i += 4, ++pixels) {
    const int lo = std::min(small_4.pixels[i], small_5.pixels[i]), hi = std::max(small_4.pixels[i], small_5.pixels[i]);
    between += mean_45.pixels[i] >= lo - 1 && mean_45.pixels[i] <= hi + 1;
  }
  CHECK(between == pixels);
  // frames = 1: every sample is the jittered frame alone (no history).
  const auto one = frame_with("{}", {"accumulate"}, R"({"frames": 1})");
  for (std::uint32_t i = 0; i < 3; ++i) (void)render(s, one, 48, 48, i);
  CHECK(max_difference(render(s, one, 48, 48, 3), plain_3) <= 1);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("accumulation on a 1x1 frame converges to the pixel's covered fraction; MSAA renders a 1x1 frame too") {
  // The square's corner region seen through one pixel: every sample is black or white, the
  // mean is the fraction of the pixel the square covers -- the reference's one pixel.
  const auto s = load(edge_scene);
  const auto plain_pipeline = frame_with("{}", {});
  const auto reference = box_filtered(render(s, plain_pipeline, 64, 64), 64);  // 4096 samples of one pixel
  REQUIRE(reference.size() == 1);
  const auto acc = accumulate(s, frame_with("{}", {"accumulate"}, R"({"frames": 256})"), 1, 1, 64);
  REQUIRE(acc.width == 1);
  CHECK(light(acc, 0, 0) == doctest::Approx(reference[0]).epsilon(0.08));
  const auto msaa = render(s, frame_with(R"({"msaa": 4})", {}), 1, 1);
  REQUIRE(msaa.width == 1);
  weft::test::expect_no_validation_messages();
}

TEST_CASE("MSAA at the adapter's largest count weft allows renders; a count the adapter lacks is refused naming it") {
  const auto s = load(edge_scene);
  const auto& limits = weft::test::gpu().adapter.info().limits;
  const std::uint32_t best = gpu::max_sample_count(limits.color_sample_counts & limits.depth_sample_counts);
  MESSAGE("adapter sample counts: " << gpu::sample_counts_text(limits.color_sample_counts));
  if (best <= 64) {
    const auto top = render(s, frame_with("{\"msaa\": " + std::to_string(std::min(best, 64u)) + "}", {}), 32, 32);
    CHECK(top.width == 32);
  }
  for (std::uint32_t count : {2u, 8u, 16u, 32u, 64u}) {
    if (limits.color_sample_counts & count) continue;
    renderer::RenderOptions o{.width = 16, .height = 16};
    const auto p = frame_with("{\"msaa\": " + std::to_string(count) + "}", {});
    o.pipeline = &p;
    auto f = shared_renderer().render(s, o);
    REQUIRE(!f);
    CHECK(f.error().message.find(std::to_string(count)) != std::string::npos);
    CHECK(f.error().message.find("scene") != std::string::npos);
    break;
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("MSAA on fur: testing the hair per sample comes nearer the supersampled fur than alpha to coverage") {
  const char* source = std::getenv("WEFT_SOURCE_DIR");
  REQUIRE(source);
  auto loaded = scene::load_scene(std::filesystem::path(source) / "examples/fur/scenes/fur_spot.json");
  REQUIRE_MESSAGE(loaded, (loaded ? "" : loaded.error().message));
  if (!weft::test::gpu().adapter.info().features.sample_rate_shading) {
    MESSAGE("the adapter cannot shade per sample: only coverage is there to test");
    return;
  }
  auto with_hair = [&](const char* mode) {
    scene::Scene s = *loaded;
    for (auto& m : s.materials)
      if (m.type == "shell_fur") m.params["msaa_hair"] = mode;
    return s;
  };
  const std::uint32_t w = 96, h = 72, scale = 4;
  const auto plain = frame_with("{}", {}), msaa = frame_with(R"({"msaa": 4})", {});
  const auto reference = box_filtered(render(*loaded, plain, w * scale, h * scale), scale);
  const auto none = render(*loaded, plain, w, h);
  const auto coverage = render(with_hair("coverage"), msaa, w, h);
  const auto per_sample = render(with_hair("per_sample"), msaa, w, h);
  // RMSE as light over the pixels where the reference is not the frame without AA: the fur's
  // fringe and hair, where aliasing is.
  auto error = [&](const image::Image8& im) {
    double sum = 0;
    int n = 0;
    for (std::uint32_t y = 0; y < h; ++y)
      for (std::uint32_t x = 0; x < w; ++x) {
        const double r = reference[std::size_t{y} * w + x];
        if (std::abs(light(none, x, y) - r) < 0.02) continue;
        const double d = light(im, x, y) - r;
        sum += d * d;
        ++n;
      }
    REQUIRE(n > 100);
    return std::sqrt(sum / n);
  };
  const double e_none = error(none), e_coverage = error(coverage), e_sample = error(per_sample);
  MESSAGE("fur RMSE (light) against 16 samples: none " << e_none << ", MSAA coverage " << e_coverage << ", per sample "
                                                       << e_sample);
  CHECK(e_coverage < e_none);
  CHECK(e_sample < 0.9 * e_coverage);
  weft::test::expect_no_validation_messages();
}


TEST_CASE("TAA: a still view converges towards the supersampled one; a moving camera keeps its edges smooth, no ghosts; a resize starts again") {
  auto s = load(edge_scene);
  const std::uint32_t size = 64, scale = 4;
  const auto plain = frame_with("{}", {});
  auto taa_pipeline = [&](const std::string& options) {
    return parse(R"({"passes": {"scene": {"type": "scene_color"}, "background": {"type": "background"},
                  "tonemap": {"type": "tonemap"}, "taa": {"type": "taa", "options": )" + options + R"(}},
      "connections": ["scene.color -> background.color", "scene.depth -> background.depth",
                      "background.color -> tonemap.color", "tonemap.color -> taa.color", "scene.depth -> taa.depth"],
      "outputs": ["taa.color"]})");
  };
  // Still: 16 jittered frames.
  {
    const auto taa = taa_pipeline("{}");
    const auto reference = box_filtered(render(s, plain, size * scale, size * scale), scale);
    const auto none = render(s, plain, size, size);
    const Errors e_none = errors(none, none, reference);
    image::Image8 last;
    for (std::uint32_t i = 0; i < 16; ++i) last = render(s, taa, size, size, i);
    const Errors e_taa = errors(last, none, reference);
    MESSAGE("still view, edge RMSE (light): none " << e_none.edges << ", TAA after 16 frames " << e_taa.edges);
    CHECK(e_taa.edges < 0.6 * e_none.edges);
    CHECK(e_taa.flat_changed == 0);
  }
  // Moving: the camera slides a third of a pixel a frame for 24 frames.
  {
    const auto taa = taa_pipeline("{}");
    image::Image8 last;
    scene::Scene moving = s;
    const float step = 0.01f;  // scene units a frame: about 0.3 pixels at this view
    for (std::uint32_t i = 0; i < 24; ++i) {
      moving.camera.position = s.camera.position + vec3(step * float(i), 0.0f, 0.0f);
      moving.camera.target = s.camera.target + vec3(step * float(i), 0.0f, 0.0f);
      last = render(moving, taa, size, size, i + 1);
    }
    const auto reference = box_filtered(render(moving, plain, size * scale, size * scale), scale);
    const auto none = render(moving, plain, size, size);
    const Errors e_none = errors(none, none, reference);
    const Errors e_taa = errors(last, none, reference);
    MESSAGE("moving camera, edge RMSE (light): none " << e_none.edges << ", TAA " << e_taa.edges);
    CHECK(e_taa.edges < 0.75 * e_none.edges);
    CHECK(e_taa.flat_changed == 0);  // no ghost of the square where it was
  }
  // A resize: the first frame at the new size is that frame alone.
  {
    const auto taa = taa_pipeline("{}");
    for (std::uint32_t i = 0; i < 4; ++i) (void)render(s, taa, 48, 48, i);
    const auto resized = render(s, taa, 40, 40, 4);
    const auto alone = render(s, plain, 40, 40, 4);
    int worst = 0;
    for (std::size_t i = 0; i < alone.pixels.size(); ++i) worst = std::max(worst, std::abs(int(resized.pixels[i]) - int(alone.pixels[i])));
    CHECK(worst <= 1);
  }
  weft::test::expect_no_validation_messages();
}

TEST_CASE("TAA's reprojection: unjittered frames and a whole-pixel camera move bring the history onto the current frame") {
  auto s = load(edge_scene);
  const auto taa = parse(R"({"passes": {"scene": {"type": "scene_color"}, "background": {"type": "background"},
                  "tonemap": {"type": "tonemap"}, "taa": {"type": "taa", "options": {"blend": 0.5, "clamp": false}}},
      "connections": ["scene.color -> background.color", "scene.depth -> background.depth",
                      "background.color -> tonemap.color", "tonemap.color -> taa.color", "scene.depth -> taa.depth"],
      "outputs": ["taa.color"]})");
  const auto plain = frame_with("{}", {});
  const float pixel = 2.0f * 3.0f * std::tan(glm::radians(20.0f)) / 64.0f;  // scene units a pixel at the square
  auto moved_by = [&](int k) {
    scene::Scene moved = s;
    moved.camera.position = s.camera.position + vec3(pixel * float(k), 0.0f, 0.0f);
    moved.camera.target = s.camera.target + vec3(pixel * float(k), 0.0f, 0.0f);
    return moved;
  };
  // The plain frames first: a renderer keeps only the last pipeline's pass instances (and the
  // TAA pass's history with them).
  std::vector<image::Image8> current;
  for (int k = 0; k <= 3; ++k) current.push_back(render(moved_by(k), plain, 64, 64, 0));
  (void)render(moved_by(0), taa, 64, 64, 0);
  for (int k = 1; k <= 3; ++k) {
    const auto out = render(moved_by(k), taa, 64, 64, 0);
    int worst = 0, x_worst = 0, y_worst = 0;
    for (std::uint32_t y = 2; y < 62; ++y)
      for (std::uint32_t x = 2; x < 62; ++x) {
        const int d = std::abs(weft::test::channel(out, x, y) - weft::test::channel(current[k], x, y));
        if (d > worst) worst = d, x_worst = int(x), y_worst = int(y);
      }
    CAPTURE(k);
    CAPTURE(x_worst);
    CAPTURE(y_worst);
    CHECK(worst <= 2);
  }
  weft::test::expect_no_validation_messages();
}
