// weft-bench-btf-data: the neural BTF's data side at the paper's size (100 x 100 texels x
// 81 x 81 directions, 751 MB of float RGB): synthetic generation (all threads against one
// thread, measured in the same run), the .btfraw cache, preprocessing, and PCA + k-means
// clustering for k = 500, 1000, 2000 with the error of replacing each texel by its
// cluster's median / medoid ABRDF (plain and with the per-texel mean-luminance scale).
// Writes texel images of the synthetic fabrics with --images DIR. Numbers: docs/neural-btf.md.
//
//   weft-bench-btf-data [--size 100] [--runs 3] [--clusters 500,1000,2000] [--images DIR]
//                       [--pca-sample N] [--cache FILE] [--load FILE] [--no-single-thread]
// --load takes the BTF from a file (a .btfraw written by --cache) instead of generating it.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>
#include <thread>
#include <vector>
#include <glm/glm.hpp>
#include <weft/args.h>
import weft.core;
import weft.image;
import weft.btf;

using namespace weft;
using namespace weft::btf;

namespace {

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
double median(std::vector<double> v) {
  std::ranges::sort(v);
  return v.empty() ? 0.0 : (v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]));
}
template <class T>
T check(Result<T> r, std::string_view what) {
  if (!r) {
    std::fprintf(stderr, "%s: %s\n", std::string(what).c_str(), r.error().what().c_str());
    std::exit(1);
  }
  return std::move(*r);
}
void check_ok(const Result<void>& r, std::string_view what) {
  if (!r) {
    std::fprintf(stderr, "%s: %s\n", std::string(what).c_str(), r.error().what().c_str());
    std::exit(1);
  }
}

// Images side by side with a 2-pixel dark gap, each scaled by `exposure`.
image::Image row_of(const std::vector<image::Image>& images) {
  std::uint32_t w = 0, h = 0;
  for (const auto& i : images) w += i.width + 2, h = std::max(h, i.height);
  auto out = image::Image::filled(w - 2, h, 3, 0.02f);
  std::uint32_t x0 = 0;
  for (const auto& i : images) {
    for (std::uint32_t y = 0; y < i.height; ++y)
      for (std::uint32_t x = 0; x < i.width; ++x)
        for (std::uint32_t c = 0; c < 3; ++c) out.at(x0 + x, y, c) = i.at(x, y, c);
    x0 += i.width + 2;
  }
  return out;
}

// RMSE (over every sample, normalised by the global max like the paper's targets) of
// replacing each texel by a representative ABRDF, optionally scaled per texel by the ratio
// of mean luminances (the paper's suggested blotch fix).
double representative_rmse(const Btf& btf, const Clustering& c, bool medoid, bool scale, float max) {
  const std::size_t n = btf.abrdf_floats();
  const auto lum = mean_luminance(btf);
  std::vector<float> rep_lum(c.count());
  for (std::size_t k = 0; k < c.count(); ++k) {
    double sum = 0.0;
    const float* r = medoid ? btf.abrdf(c.medoids[k]).data() : c.medians.data() + k * n;
    for (std::size_t s = 0; s < n / 3; ++s) sum += 0.2126 * r[s * 3] + 0.7152 * r[s * 3 + 1] + 0.0722 * r[s * 3 + 2];
    rep_lum[k] = static_cast<float>(sum / double(n / 3));
  }
  double sum = 0.0;
  for (std::size_t t = 0; t < btf.texels(); ++t) {
    const std::uint32_t k = c.ids[t];
    const float* r = medoid ? btf.abrdf(c.medoids[k]).data() : c.medians.data() + k * n;
    const float f = scale && rep_lum[k] > 0.0f ? lum[t] / rep_lum[k] : 1.0f;
    const auto a = btf.abrdf(t);
    for (std::size_t d = 0; d < n; ++d) {
      const double e = (double(a[d]) - double(r[d]) * f) / max;
      sum += e * e;
    }
  }
  return std::sqrt(sum / double(btf.rgb.size()));
}

}  // namespace

int main(int argc, char** argv) {
  std::uint32_t size = 100, runs = 3;
  std::vector<std::uint32_t> ks{500, 1000, 2000};
  std::filesystem::path images, cache, load;
  bool single_thread = true;
  std::uint32_t pca_sample = ClusterOptions{}.pca_sample_texels;
  const char* usage = "usage: weft-bench-btf-data [--size N] [--runs R] [--clusters a,b,c] [--pca-sample N] [--images DIR] "
                      "[--cache FILE] [--load FILE] [--no-single-thread]\n";
  // A bad value is named before any work (issue 33: std::stoul's exception ended the program).
  const auto bad = [&](const std::string& why) {
    std::fprintf(stderr, "weft-bench-btf-data: %s\n%s", why.c_str(), usage);
    return 2;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    if (a == "-h" || a == "--help") {
      std::printf("%s", usage);
      return 0;
    }
    if (a == "--no-single-thread") {
      single_thread = false;
      continue;
    }
    if (a != "--size" && a != "--runs" && a != "--images" && a != "--cache" && a != "--load" && a != "--pca-sample" &&
        a != "--clusters")
      return bad("unknown argument '" + std::string(a) + "'");
    if (i + 1 >= argc) return bad(std::string(a) + " needs a value");
    const std::string_view v = argv[++i];
    const auto n = weft::args::whole(v, 1, 1'000'000);
    if (a == "--images") images = std::string(v);
    else if (a == "--cache") cache = std::string(v);
    else if (a == "--load") load = std::string(v);
    else if (a == "--clusters") {
      const auto list = weft::args::whole_list(v, 1, 1'000'000);
      if (!list) return bad("--clusters '" + std::string(v) + "': expected whole numbers 1..1000000, comma-separated");
      ks.assign(list->begin(), list->end());
    } else if (!n || (a == "--size" && *n > 65536) || (a == "--runs" && *n > 1000)) {
      return bad(std::string(a) + " '" + std::string(v) + "': expected a whole number within 1.." +
                 (a == "--size" ? "65536" : a == "--runs" ? "1000" : "1000000"));
    } else if (a == "--size") size = std::uint32_t(*n);
    else if (a == "--runs") runs = std::uint32_t(*n);
    else pca_sample = std::uint32_t(*n);
  }
  log::set_level("warn");
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  std::printf("weft-bench-btf-data: %u x %u texels x 81 x 81 directions, %u hardware threads, %u runs\n", size, size, cores, runs);

  // ---- images of the three weaves (small, reduced directions: quick) ------------------
  if (!images.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(images, ec);
    if (ec) return bad("--images '" + images.string() + "': cannot make the folder: " + ec.message());
    const auto dirs = ubo2003_directions();
    // (light, view) index pairs: overhead light & view; light 60° from the side; grazing 75°
    // light opposite a 45° view; a mirror pair at 45°.
    struct Pair { std::size_t l, v; const char* name; };
    const Pair pairs[] = {{0, 0, "l0_v0"}, {1 + 6 + 12, 0, "l60_v0"}, {1 + 6 + 12 + 18 + 20 + 12, 1 + 6 + 12, "l75_v45"},
                          {1 + 6 + 12 + 18 + 10, 1 + 6 + 12 + 18, "l45_v45_mirror"}};
    for (Weave weave : {Weave::Twill, Weave::Plain, Weave::Knit}) {
      SyntheticOptions o;
      o.width = o.height = 160;
      o.weave = weave;
      std::vector<Direction> ls, vs;
      for (auto p : pairs) ls.push_back(dirs[p.l]), vs.push_back(dirs[p.v]);
      o.lights = ls, o.views = vs;
      if (weave == Weave::Knit) o.warp_color = vec3(0.45f, 0.07f, 0.06f);
      const Btf b = check(synthetic_btf(o), "synthetic images");
      std::vector<image::Image> row;
      for (std::size_t i = 0; i < std::size(pairs); ++i) row.push_back(texel_image(b, i, i));
      const auto file = images / ("synthetic_" + std::string(to_string(weave)) + ".png");
      check_ok(image::save_image(file, row_of(row), 2.5f), "saving image");
      std::printf("wrote %s (light/view pairs: overhead, light 60 deg, light 75 deg + view 45 deg, mirror 45 deg)\n",
                  file.string().c_str());
    }
  }

  // ---- generation -----------------------------------------------------------------------
  Btf btf;
  if (!load.empty()) {
    const double t0 = now_s();
    btf = check(load_btf(load), "load_btf");
    std::printf("loaded %s: %u x %u texels x %zu x %zu directions in %.2f s\n", load.string().c_str(), btf.width,
                btf.height, btf.lights.size(), btf.views.size(), now_s() - t0);
  } else {
    SyntheticOptions o;
    o.width = o.height = size;
    std::vector<double> gen;
    for (std::uint32_t r = 0; r < runs; ++r) {
      const double t0 = now_s();
      btf = check(synthetic_btf(o), "synthetic");
      gen.push_back(now_s() - t0);
    }
    const double mb = double(btf.rgb.size() * sizeof(float)) / (1024.0 * 1024.0);
    std::printf("synthetic twill %u x %u x 81 x 81 (%.0f MB): median %.2f s over %u runs (%u threads), %.1f M samples/s\n",
                size, size, mb, median(gen), runs, cores, double(btf.rgb.size() / 3) / median(gen) / 1e6);
    if (single_thread) {
      o.threads = 1;
      const double t0 = now_s();
      const Btf one = check(synthetic_btf(o), "synthetic (1 thread)");
      const double t1 = now_s() - t0;
      std::printf("  1 thread: %.2f s (speed-up %.2fx), identical: %s\n", t1, t1 / median(gen), one.rgb == btf.rgb ? "yes" : "NO");
    }
  }
  const double mb = double(btf.rgb.size() * sizeof(float)) / (1024.0 * 1024.0);
  float max = 0.0f;
  for (float v : btf.rgb) max = std::max(max, v);
  const auto lum = mean_luminance(btf);
  std::printf("  samples: max %.3f, mean texel luminance %.4f .. %.4f\n", max, *std::ranges::min_element(lum),
              *std::ranges::max_element(lum));

  // ---- cache ------------------------------------------------------------------------------
  if (!cache.empty()) {
    double t0 = now_s();
    check_ok(save_btf(btf, cache), "save_btf");
    const double save = now_s() - t0;
    t0 = now_s();
    const Btf back = check(load_btf(cache), "load_btf");
    const double load_s = now_s() - t0;
    std::printf(".btfraw: save %.2f s, load (checksum + validate) %.2f s, %.0f MB, identical: %s\n", save, load_s,
                double(std::filesystem::file_size(cache)) / (1024.0 * 1024.0), back.rgb == btf.rgb ? "yes" : "NO");
  }

  // ---- preprocessing ------------------------------------------------------------------------
  {
    std::vector<double> times;
    for (std::uint32_t r = 0; r < runs; ++r) {
      const double t0 = now_s();
      const Preprocessed p = preprocess(btf);
      times.push_back(now_s() - t0);
    }
    std::printf("preprocess (inputs + targets, 2 x %.0f MB): median %.2f s\n", mb, median(times));
  }

  // ---- clustering ---------------------------------------------------------------------------
  std::printf("PCA fitted on %u sampled texels (0 = all)\n", pca_sample);
  std::printf("| k | clusters | PCA energy (16 comp.) | iterations | time (s) | RMSE median | RMSE medoid | RMSE median x lum |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (std::uint32_t k : ks) {
    ClusterOptions co;
    co.clusters = k;
    co.pca_sample_texels = pca_sample;
    std::vector<double> times;
    Clustering c;
    for (std::uint32_t r = 0; r < std::min(runs, 2u); ++r) {
      const double t0 = now_s();
      c = check(cluster_abrdfs(btf, co), "clustering");
      times.push_back(now_s() - t0);
    }
    std::printf("| %u | %u | %.3f | %zu | %.2f | %.4f | %.4f | %.4f |\n", k, c.count(), c.pca_energy, c.iterations,
                median(times), representative_rmse(btf, c, false, false, max), representative_rmse(btf, c, true, false, max),
                representative_rmse(btf, c, false, true, max));
    std::fflush(stdout);
  }
  return 0;
}
