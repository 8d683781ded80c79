// weft-bench-aa: what each anti-aliasing option buys against what it costs on a scene (issue 32).
// Every option renders the scene at the accuracy size; the reference is the scene without AA
// rendered at --reference-scale times the width and height and box-filtered down (16 ordered
// samples per pixel at the default 4), averaged as light. Errors are RMSE of the 8-bit
// sRGB-encoded images (0..1) over
//   all pixels; edge pixels -- where the reference's samples within the pixel disagree (luma
//   range over the pixel's block > --edge-threshold): geometric edges and texture detail, what
//   AA is for; the fur's and the cloth's pixels -- where the material covers some of the pixel
//   (the scene with only those objects against the scene with none, at the reference size).
// Frame times are the median render() call of --runs rounds at --time-size, every option once
// per round (alternating, so drift hits all alike), each option in its own renderer (its
// pipelines made once) after one warm-up frame; ratios against "none" of the same rounds.
//
//   build/bin/weft-bench-aa [--scene examples/scenes/showcase.json] [--size 480x270]
//                           [--reference-scale 4] [--time-size 1280x720] [--runs 5]
//                           [--accumulate 4,16] [--edge-threshold 0.06] [--move-frames 24]
//                           [--move-step 0.004] [--out DIR] [--no-timing]
//
// A second table follows the camera sliding right --move-step scene units a frame for
// --move-frames frames: none and FXAA at the last frame, TAA over the whole path, each against
// the supersampled reference at the last frame.
//
// --out DIR writes each option's image, its difference to the reference (x4) and side-by-side
// crops of the fur, the cloth and the teapot (reference | options..., 3x nearest) for the docs.
#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include "weft/try.h"
import weft.core;
import weft.gpu;
import weft.image;
import weft.scene;
import weft.renderer;
import weft.pipeline;
import weft.builtin_features;
import weft.bench.device;

using namespace weft;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

struct Options {
  fs::path scene = fs::path(WEFT_SOURCE_DIR) / "examples" / "scenes" / "showcase.json";
  std::uint32_t width = 480, height = 270;
  std::uint32_t scale = 4;
  std::uint32_t time_width = 1280, time_height = 720;
  int runs = 5;
  std::vector<std::uint32_t> accumulate{4, 16};
  double edge_threshold = 0.06;
  fs::path out;
  bool timing = true;
  std::uint32_t move_frames = 24;  // 0: no moving-camera table
  float move_step = 0.004f;        // scene units a frame
};

const char* usage =
    "usage: weft-bench-aa [--scene FILE] [--size WxH] [--reference-scale N] [--time-size WxH] [--runs N]\n"
    "                     [--accumulate N,N,...] [--edge-threshold X] [--move-frames N] [--move-step S]\n"
    "                     [--out DIR] [--no-timing]\n"
    "Renders the scene with each anti-aliasing option (none, FXAA, MSAA 2x where the adapter has it, MSAA 4x with\n"
    "alpha-to-coverage on fur, accumulation of N jittered frames) and prints RMSE against a supersampled reference\n"
    "(all pixels, edge pixels, the fur's and the cloth's pixels) and frame-time medians with ratios to no AA.\n";

std::optional<std::uint32_t> whole(std::string_view text, std::uint32_t lo, std::uint32_t hi) {
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || v < lo || v > hi) return std::nullopt;
  return std::uint32_t(v);
}

std::optional<std::pair<std::uint32_t, std::uint32_t>> size_of(std::string_view text) {
  const auto x = text.find('x');
  if (x == std::string_view::npos) return std::nullopt;
  auto w = whole(text.substr(0, x), 1, 16384), h = whole(text.substr(x + 1), 1, 16384);
  if (!w || !h) return std::nullopt;
  return std::pair{*w, *h};
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// ---- images --------------------------------------------------------------------------------

// Box filter of an RGBA8 image by `scale`, averaged as light (decode, mean, encode).
image::Image8 box_downsample(const image::Image8& hi, std::uint32_t scale) {
  const std::uint32_t w = hi.width / scale, h = hi.height / scale;
  image::Image8 lo = image::Image8::filled(w, h, 4, 255);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x)
      for (std::uint32_t c = 0; c < 3; ++c) {
        double sum = 0.0;
        for (std::uint32_t j = 0; j < scale; ++j)
          for (std::uint32_t i = 0; i < scale; ++i)
            sum += image::srgb_to_linear(float(hi.at(x * scale + i, y * scale + j, c)) / 255.0f);
        const float mean = float(sum / double(scale * scale));
        lo.at(x, y, c) = std::uint8_t(std::lround(std::clamp(image::linear_to_srgb(mean), 0.0f, 1.0f) * 255.0f));
      }
  return lo;
}

float luma(const image::Image8& im, std::uint32_t x, std::uint32_t y) {
  return (0.299f * im.at(x, y, 0) + 0.587f * im.at(x, y, 1) + 0.114f * im.at(x, y, 2)) / 255.0f;
}

// Pixels of the low-resolution image whose block of the high-resolution one spans more than
// `threshold` of luma.
std::vector<bool> edge_mask(const image::Image8& hi, std::uint32_t scale, double threshold) {
  const std::uint32_t w = hi.width / scale, h = hi.height / scale;
  std::vector<bool> mask(std::size_t{w} * h);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      float lo = 1.0f, high = 0.0f;
      for (std::uint32_t j = 0; j < scale; ++j)
        for (std::uint32_t i = 0; i < scale; ++i) {
          const float l = luma(hi, x * scale + i, y * scale + j);
          lo = std::min(lo, l);
          high = std::max(high, l);
        }
      mask[std::size_t{y} * w + x] = high - lo > threshold;
    }
  return mask;
}

// Pixels of the low-resolution image where the two high-resolution images differ anywhere in
// the pixel's block: where the objects that one has and the other lacks cover the pixel.
std::vector<bool> coverage_mask(const image::Image8& with, const image::Image8& without, std::uint32_t scale) {
  const std::uint32_t w = with.width / scale, h = with.height / scale;
  std::vector<bool> mask(std::size_t{w} * h);
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x) {
      bool differs = false;
      for (std::uint32_t j = 0; j < scale && !differs; ++j)
        for (std::uint32_t i = 0; i < scale && !differs; ++i)
          for (std::uint32_t c = 0; c < 3; ++c)
            differs |= std::abs(int(with.at(x * scale + i, y * scale + j, c)) - int(without.at(x * scale + i, y * scale + j, c))) > 2;
      mask[std::size_t{y} * w + x] = differs;
    }
  return mask;
}

// RMSE of the colour channels (0..1) over the pixels the mask keeps (all when empty).
double rmse(const image::Image8& a, const image::Image8& b, const std::vector<bool>& mask) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::uint32_t y = 0; y < a.height; ++y)
    for (std::uint32_t x = 0; x < a.width; ++x) {
      if (!mask.empty() && !mask[std::size_t{y} * a.width + x]) continue;
      for (std::uint32_t c = 0; c < 3; ++c) {
        const double d = (double(a.at(x, y, c)) - double(b.at(x, y, c))) / 255.0;
        sum += d * d;
      }
      ++n;
    }
  return n ? std::sqrt(sum / double(3 * n)) : 0.0;
}

std::size_t count(const std::vector<bool>& mask) { return std::size_t(std::count(mask.begin(), mask.end(), true)); }

struct Box {
  std::uint32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // inclusive-exclusive
};
std::optional<Box> bounds(const std::vector<bool>& mask, std::uint32_t w, std::uint32_t h) {
  Box b{w, h, 0, 0};
  for (std::uint32_t y = 0; y < h; ++y)
    for (std::uint32_t x = 0; x < w; ++x)
      if (mask[std::size_t{y} * w + x]) {
        b.x0 = std::min(b.x0, x), b.y0 = std::min(b.y0, y);
        b.x1 = std::max(b.x1, x + 1), b.y1 = std::max(b.y1, y + 1);
      }
  if (b.x1 <= b.x0) return std::nullopt;
  return b;
}

// The crops of `images` (same size) at `box`, each scaled up `zoom` times, side by side with a
// 2-pixel gap.
image::Image8 strip(const std::vector<const image::Image8*>& images, Box box, std::uint32_t zoom) {
  const std::uint32_t cw = (box.x1 - box.x0) * zoom, ch = (box.y1 - box.y0) * zoom, gap = 2;
  image::Image8 out = image::Image8::filled(std::uint32_t(images.size()) * (cw + gap) - gap, ch, 4, 255);
  for (std::size_t k = 0; k < images.size(); ++k)
    for (std::uint32_t y = 0; y < ch; ++y)
      for (std::uint32_t x = 0; x < cw; ++x)
        for (std::uint32_t c = 0; c < 4; ++c)
          out.at(std::uint32_t(k) * (cw + gap) + x, y, c) = images[k]->at(box.x0 + x / zoom, box.y0 + y / zoom, c);
  return out;
}

image::Image8 difference(const image::Image8& a, const image::Image8& b, float gain) {
  image::Image8 d = image::Image8::filled(a.width, a.height, 4, 255);
  for (std::size_t i = 0; i < std::size_t{a.width} * a.height; ++i)
    for (std::size_t c = 0; c < 3; ++c)
      d.pixels[i * 4 + c] = std::uint8_t(std::min(255.0f, gain * float(std::abs(int(a.pixels[i * 4 + c]) - int(b.pixels[i * 4 + c])))));
  return d;
}

// ---- the options -----------------------------------------------------------------------------

struct Mode {
  std::string name;
  pipeline::Pipeline pipeline;
  std::uint32_t samples = 1;  // frames accumulated (sample_index 0 .. samples - 1)
  const scene::Scene* scene = nullptr;  // the scene with a knob changed; null: the scene as loaded
  std::optional<renderer::Renderer> renderer;
  image::Image8 image;
  std::vector<double> frame_ms;
};

scene::Scene only_objects_of(const scene::Scene& scene, std::string_view material_type) {
  scene::Scene copy = scene;
  std::erase_if(copy.objects, [&](const scene::Object& o) { return copy.materials.at(o.material).type != material_type; });
  return copy;
}

Result<image::Image8> render(renderer::Renderer& r, const scene::Scene& scene, const pipeline::Pipeline& pipeline,
                             std::uint32_t w, std::uint32_t h, std::uint32_t samples) {
  renderer::RenderOptions options{.width = w, .height = h, .timestamps = false};
  options.pipeline = &pipeline;
  image::Image8 last;
  for (std::uint32_t s = 0; s < samples; ++s) {
    options.sample_index = s;
    WEFT_TRY(auto frame, r.render(scene, options));
    last = std::move(frame.image);
  }
  return last;
}

int die(const std::string& what) {
  std::fprintf(stderr, "weft-bench-aa: %s\n", what.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    auto value = [&]() -> std::optional<std::string_view> {
      if (i + 1 >= argc) return std::nullopt;
      return std::string_view(argv[++i]);
    };
    auto bad = [&](std::string_view why) {
      std::fprintf(stderr, "weft-bench-aa: %.*s\n%s", int(why.size()), why.data(), usage);
      return 2;
    };
    if (a == "--help" || a == "-h") {
      std::printf("%s", usage);
      return 0;
    } else if (a == "--scene") {
      auto v = value();
      if (!v || v->empty()) return bad(v ? "--scene was given an empty value" : "--scene needs a file");
      o.scene = std::string(*v);
    } else if (a == "--size" || a == "--time-size") {
      auto v = value();
      auto s = v ? size_of(*v) : std::nullopt;
      if (!s) return bad(weft::format("{} needs WxH (1..16384 each)", a));
      (a == "--size" ? o.width : o.time_width) = s->first;
      (a == "--size" ? o.height : o.time_height) = s->second;
    } else if (a == "--reference-scale") {
      auto v = value();
      auto s = v ? whole(*v, 2, 8) : std::nullopt;
      if (!s) return bad("--reference-scale needs a whole number in 2..8");
      o.scale = *s;
    } else if (a == "--runs") {
      auto v = value();
      auto s = v ? whole(*v, 1, 1000) : std::nullopt;
      if (!s) return bad("--runs needs a whole number in 1..1000");
      o.runs = int(*s);
    } else if (a == "--accumulate") {
      auto v = value();
      if (!v) return bad("--accumulate needs N,N,...");
      o.accumulate.clear();
      std::string_view list = *v;
      while (!list.empty()) {
        const auto comma = list.find(',');
        auto n = whole(list.substr(0, comma), 2, 4096);
        if (!n) return bad("--accumulate needs whole numbers in 2..4096, comma-separated");
        o.accumulate.push_back(*n);
        list = comma == std::string_view::npos ? std::string_view() : list.substr(comma + 1);
      }
    } else if (a == "--edge-threshold") {
      auto v = value();
      double t = 0.0;
      if (!v || std::from_chars(v->data(), v->data() + v->size(), t).ec != std::errc() || !(t > 0.0 && t < 1.0))
        return bad("--edge-threshold needs a number in (0, 1)");
      o.edge_threshold = t;
    } else if (a == "--out") {
      auto v = value();
      if (!v || v->empty()) return bad(v ? "--out was given an empty value" : "--out needs a folder");
      o.out = std::string(*v);
    } else if (a == "--move-frames") {
      auto v = value();
      auto n = v ? whole(*v, 0, 10000) : std::nullopt;
      if (!n) return bad("--move-frames needs a whole number in 0..10000 (0: no moving-camera table)");
      o.move_frames = *n;
    } else if (a == "--move-step") {
      auto v = value();
      double t = 0.0;
      if (!v || std::from_chars(v->data(), v->data() + v->size(), t).ec != std::errc() || !(t > 0.0 && t < 10.0))
        return bad("--move-step needs a number of scene units in (0, 10)");
      o.move_step = float(t);
    } else if (a == "--no-timing") {
      o.timing = false;
    } else {
      return bad(weft::format("unknown argument '{}'", a));
    }
  }
  // The output folder first, so a path that cannot be one is named before any work; and
  // is_regular_file without an error code threw on a symlink loop (terminate; issue 33).
  if (!o.out.empty()) {
    std::error_code made;
    fs::create_directories(o.out, made);
    if (made) return die(weft::format("--out '{}': cannot make the folder: {}", o.out.string(), made.message()));
  }
  std::error_code scene_error;
  if (!fs::is_regular_file(o.scene, scene_error))
    return die(weft::format("no scene at {} (--scene names one; the showcase is examples/scenes/showcase.json)",
                             o.scene.string()));
  if (auto ok = register_builtins(); !ok) return die(ok.error().what());

  auto loaded = scene::load_scene(o.scene);
  if (!loaded) return die(loaded.error().what());
  const scene::Scene& scene = *loaded;
  auto session = bench::open_session("weft-bench-aa");
  if (!session) return die("no Vulkan device: nothing to measure");
  const auto& limits = session->adapter.info().limits;
  std::printf("# weft-bench-aa on %s: %s, %ux%u (reference %ux%u box-filtered, %u samples per pixel)\n\n",
              session->adapter.info().name.c_str(), o.scene.filename().string().c_str(), o.width, o.height,
              o.width * o.scale, o.height * o.scale, o.scale * o.scale);

  const fs::path pipelines = fs::path(WEFT_SOURCE_DIR) / "examples" / "pipelines";
  auto load = [&](const char* file) -> Result<pipeline::Pipeline> {
    const fs::path p = pipelines / file;
    if (!fs::is_regular_file(p)) return fail(ErrorKind::NotFound, "no pipeline at {}", p.string());
    return pipeline::load_pipeline(p);
  };
  auto base = pipeline::default_pipeline();
  auto fxaa = load("fxaa.json");
  auto msaa = load("msaa.json");
  auto accumulate = load("accumulate.json");
  auto taa = load("taa.json");
  for (auto* p : {&base, &fxaa, &msaa, &accumulate, &taa})
    if (!*p) return die(p->error().what());

  std::vector<Mode> modes;
  modes.push_back({.name = "none", .pipeline = *base});
  modes.push_back({.name = "FXAA", .pipeline = *fxaa});
  // The fur's "msaa_hair" knob: coverage (the medium preset's) and per-sample hair tests.
  scene::Scene per_sample_hair = scene;
  for (auto& m : per_sample_hair.materials)
    if (m.type == "shell_fur") m.params["msaa_hair"] = "per_sample";
  for (std::uint32_t count : {2u, 4u, 8u}) {
    if (!(limits.color_sample_counts & count) || !(limits.depth_sample_counts & count)) continue;
    auto p = pipeline::with_options(*msaa, "scene", {{"msaa", count}});
    if (!p) return die(p.error().what());
    modes.push_back({.name = weft::format("MSAA {}x, fur by coverage", count), .pipeline = *p});
    if (session->adapter.info().features.sample_rate_shading)
      modes.push_back({.name = weft::format("MSAA {}x, fur per sample", count), .pipeline = std::move(*p),
                       .scene = &per_sample_hair});
  }
  for (std::uint32_t n : o.accumulate) {
    auto p = pipeline::with_options(*accumulate, "accumulate", {{"frames", n}});
    if (!p) return die(p.error().what());
    modes.push_back({.name = weft::format("accumulation, {} frames", n), .pipeline = std::move(*p), .samples = n});
  }
  modes.push_back({.name = "TAA, 16 frames of a still view", .pipeline = *taa, .samples = 16});
  for (auto& m : modes) {
    auto r = renderer::Renderer::create(session->device);
    if (!r) return die(r.error().what());
    m.renderer.emplace(std::move(*r));
  }

  // ---- accuracy ----
  const std::uint32_t rw = o.width * o.scale, rh = o.height * o.scale;
  const auto t0 = Clock::now();
  std::fprintf(stderr, "rendering the reference at %ux%u ...\n", rw, rh);
  auto hi = render(*modes[0].renderer, scene, modes[0].pipeline, rw, rh, 1);
  if (!hi) return die(hi.error().what());
  const image::Image8 reference = box_downsample(*hi, o.scale);
  const std::vector<bool> edges = edge_mask(*hi, o.scale, o.edge_threshold);
  struct Group {
    std::string name, material;
    std::vector<bool> mask;
  };
  // Registered material type names (scene files may use aliases: "fur", "btf", "ssdf").
  std::vector<Group> groups{{"fur", "shell_fur", {}}, {"cloth", "neural_btf", {}}, {"teapot", "ssdf_lighting", {}}};
  {
    scene::Scene empty = scene;
    empty.objects.clear();
    auto nothing = render(*modes[0].renderer, empty, modes[0].pipeline, rw, rh, 1);
    if (!nothing) return die(nothing.error().what());
    for (auto& g : groups) {
      scene::Scene only = only_objects_of(scene, g.material);
      if (g.name == "teapot") {
        // Its outline only: in a standard material, so no SSDF is baked for a scene of one object.
        std::erase_if(only.objects, [](const scene::Object& ob) { return ob.name != "teapot"; });
        only.materials.push_back(scene::Material{.name = "mask"});
        for (auto& ob : only.objects) ob.material = std::uint32_t(only.materials.size() - 1);
      }
      if (only.objects.empty()) continue;
      auto with = render(*modes[0].renderer, only, modes[0].pipeline, rw, rh, 1);
      if (!with) return die(with.error().what());
      g.mask = coverage_mask(*with, *nothing, o.scale);
    }
  }
  for (auto& m : modes) {
    std::fprintf(stderr, "rendering %s ...\n", m.name.c_str());
    auto im = render(*m.renderer, m.scene ? *m.scene : scene, m.pipeline, o.width, o.height, m.samples);
    if (!im) return die(weft::format("{}: {}", m.name, im.error().what()));
    m.image = std::move(*im);
  }
  std::printf("## Error against the reference (RMSE of 8-bit sRGB, 0..1; ratio to no AA)\n\n");
  std::printf("Edge pixels: %zu of %u (reference luma range within the pixel > %.2f).", count(edges), o.width * o.height,
              o.edge_threshold);
  for (const auto& g : groups)
    if (!g.mask.empty()) std::printf(" %s pixels: %zu.", g.name.c_str(), count(g.mask));
  std::printf("\n\n| option | all pixels | edge pixels |");
  for (const auto& g : groups)
    if (!g.mask.empty()) std::printf(" %s pixels |", g.name.c_str());
  std::printf("\n|:--|--:|--:|");
  for (const auto& g : groups)
    if (!g.mask.empty()) std::printf("--:|");
  std::printf("\n");
  const double none_all = rmse(modes[0].image, reference, {}), none_edges = rmse(modes[0].image, reference, edges);
  for (const auto& m : modes) {
    const double all = rmse(m.image, reference, {}), e = rmse(m.image, reference, edges);
    std::printf("| %s | %.4f (%.2fx) | %.4f (%.2fx) |", m.name.c_str(), all, all / none_all, e, e / none_edges);
    for (const auto& g : groups) {
      if (g.mask.empty()) continue;
      const double none_g = rmse(modes[0].image, reference, g.mask), v = rmse(m.image, reference, g.mask);
      std::printf(" %.4f (%.2fx) |", v, v / none_g);
    }
    std::printf("\n");
  }
  std::printf("\n(accuracy: %.1f s)\n\n", std::chrono::duration<double>(Clock::now() - t0).count());

  if (!o.out.empty()) {
    std::error_code ec;
    fs::create_directories(o.out, ec);
    auto save = [&](const std::string& file, const image::Image8& im) {
      if (auto ok = image::save_png(o.out / file, im); !ok) std::fprintf(stderr, "weft-bench-aa: %s\n", ok.error().what().c_str());
    };
    auto slug = [](std::string s) {
      std::string out;
      for (char c : s)
        if (std::isalnum(static_cast<unsigned char>(c))) out += char(std::tolower(static_cast<unsigned char>(c)));
        else if (!out.empty() && out.back() != '_') out += '_';
      while (!out.empty() && out.back() == '_') out.pop_back();
      return out;
    };
    save("reference.png", reference);
    std::vector<const image::Image8*> all{&reference};
    std::vector<image::Image8> diffs;
    diffs.reserve(modes.size());
    for (const auto& m : modes) {
      save(slug(m.name) + ".png", m.image);
      diffs.push_back(difference(m.image, reference, 4.0f));
      save(slug(m.name) + "_diff_x4.png", diffs.back());
      all.push_back(&m.image);
    }
    std::vector<const image::Image8*> diff_strip{&reference};
    for (const auto& d : diffs) diff_strip.push_back(&d);
    for (const auto& g : groups) {
      if (g.mask.empty()) continue;
      auto box = bounds(g.mask, o.width, o.height);
      if (!box) continue;
      // At most 96 pixels a side, centred on the object.
      const std::uint32_t cx = (box->x0 + box->x1) / 2, cy = (box->y0 + box->y1) / 2, half = 48;
      Box b{cx > half ? cx - half : 0, cy > half ? cy - half : 0, std::min(o.width, cx + half), std::min(o.height, cy + half)};
      save("crop_" + g.name + ".png", strip(all, b, 3));
      save("crop_" + g.name + "_diff_x4.png", strip(diff_strip, b, 3));
    }
    std::printf("images in %s (crops: reference, then the options in the table's order)\n\n", o.out.string().c_str());
  }

  // ---- a moving camera: the options that work frame by frame, at the path's last frame ----
  if (o.move_frames > 0) {
    const vec3 right = glm::normalize(glm::cross(scene.camera.target - scene.camera.position, scene.camera.up));
    auto at = [&](std::uint32_t frame) {
      scene::Scene moved = scene;
      const vec3 offset = right * (o.move_step * float(frame));
      moved.camera.position += offset;
      moved.camera.target += offset;
      return moved;
    };
    const scene::Scene last = at(o.move_frames - 1);
    auto hi_last = render(*modes[0].renderer, last, modes[0].pipeline, rw, rh, 1);
    if (!hi_last) return die(hi_last.error().what());
    const image::Image8 reference_last = box_downsample(*hi_last, o.scale);
    const std::vector<bool> edges_last = edge_mask(*hi_last, o.scale, o.edge_threshold);
    struct Moving {
      std::string name;
      const pipeline::Pipeline* pipeline;
      bool temporal;
    };
    const std::vector<Moving> moving{{"none", &modes[0].pipeline, false}, {"FXAA", &modes[1].pipeline, false},
                                     {"TAA", &*taa, true}};
    std::printf("## A moving camera: %u frames sliding %.4f scene units a frame to the right (error at the last)\n\n"
                "| option | all pixels | edge pixels |\n|:--|--:|--:|\n",
                o.move_frames, double(o.move_step));
    double none_all = 0, none_edges = 0;
    for (const auto& m : moving) {
      auto r = renderer::Renderer::create(session->device);
      if (!r) return die(r.error().what());
      renderer::RenderOptions options{.width = o.width, .height = o.height, .timestamps = false};
      options.pipeline = m.pipeline;
      image::Image8 image;
      for (std::uint32_t f = m.temporal ? 0 : o.move_frames - 1; f < o.move_frames; ++f) {
        options.sample_index = m.temporal ? f : 0;
        auto frame = r->render(at(f), options);
        if (!frame) return die(frame.error().what());
        image = std::move(frame->image);
      }
      const double all = rmse(image, reference_last, {}), e = rmse(image, reference_last, edges_last);
      if (m.name == "none") none_all = all, none_edges = e;
      std::printf("| %s | %.4f (%.2fx) | %.4f (%.2fx) |\n", m.name.c_str(), all, all / none_all, e, e / none_edges);
      if (!o.out.empty()) (void)image::save_png(o.out / ("moving_" + m.name + ".png"), image);
    }
    std::printf("\n");
  }

  // ---- cost ----
  if (o.timing) {
    std::fprintf(stderr, "timing at %ux%u, %d rounds ...\n", o.time_width, o.time_height, o.runs);
    renderer::RenderOptions options{.width = o.time_width, .height = o.time_height, .timestamps = false};
    for (auto& m : modes) {  // warm-up: pipelines, transients and caches at this size
      options.pipeline = &m.pipeline;
      options.sample_index = 0;
      if (auto f = m.renderer->render(m.scene ? *m.scene : scene, options); !f) return die(f.error().what());
    }
    for (int round = 0; round < o.runs; ++round)
      for (auto& m : modes) {
        options.pipeline = &m.pipeline;
        // An accumulating option in its steady state: a later sample, which reads the history.
        options.sample_index = m.samples > 1 ? std::uint32_t(round + 1) : 0;
        const auto f0 = Clock::now();
        auto f = m.renderer->render(m.scene ? *m.scene : scene, options);
        if (!f) return die(f.error().what());
        m.frame_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - f0).count());
      }
    std::printf("## Frame time at %ux%u (median of %d alternating rounds, the whole render() call: prepare, "
                "graph, execute, readback)\n\n| option | ms | ratio to none | each round, ms |\n|:--|--:|--:|:--|\n",
                o.time_width, o.time_height, o.runs);
    const double none_ms = median(modes[0].frame_ms);
    for (const auto& m : modes) {
      std::string rounds;
      for (double ms : m.frame_ms) rounds += weft::format("{}{:.0f}", rounds.empty() ? "" : " / ", ms);
      std::printf("| %s | %.1f | %.2fx | %s |\n", m.name.c_str(), median(m.frame_ms), median(m.frame_ms) / none_ms,
                  rounds.c_str());
    }
    std::printf("\nAccumulation's row is one frame of it; its image costs that times its frame count.\n");
  }
  return 0;
}
