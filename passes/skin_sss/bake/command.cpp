// `weft bake skin-lut -o lut.exr|png [--size N] [--range penner|adaptive|full] ...`: the
// pre-integrated skin LUT (docs/skin.md) to a file. The feature's descriptor offers it to
// `weft bake` (FeatureDescriptor::bakes).
module;
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <expected>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>
#include <CLI/CLI.hpp>
module weft.pass.skin_sss;
import weft.core;

namespace weft::passes::detail {

// The pre-integrated skin LUT (docs/skin.md): RGB diffuse D(N·L, 1/r), A Beckmann.
std::function<int()> add_skin_lut_bake(CLI::App& command) {
  struct Args {
    std::string output;
    std::uint32_t size = 256, width = 0, height = 0, samples = 256, threads = 0;
    std::string range = "adaptive", convention = "default", normalization, quadrature = "per-gaussian";
    double variance_scale = 0.0, max_curvature = 1.0;
    bool alpha = false;
  };
  auto a = std::make_shared<Args>();
  auto* sub = &command;
  sub->add_option("-o,--output", a->output, "Output: .exr (linear RGBA float, the data) or .png (sRGB picture)")->required();
  sub->add_option("--size", a->size, "Texels per side (2..4096)")->capture_default_str();
  sub->add_option("--width", a->width, "N·L texels (default: --size)");
  sub->add_option("--height", a->height, "Curvature texels (default: --size)");
  sub->add_option("--range", a->range, "Integration range: penner (±π/2), adaptive (±π(r+1)/2r, the thesis), full (±π)")
      ->capture_default_str();
  sub->add_option("--convention", a->convention,
                  "Profile normalisation preset: default (ring, v×1.414), thesis (planar, v×1), penner (ring, v×1.414)")
      ->capture_default_str();
  sub->add_option("--normalization", a->normalization, "Override: ring (1/√(2πv)) or planar (1/(2πv))");
  sub->add_option("--variance-scale", a->variance_scale, "Override: multiply every variance by this");
  sub->add_option("--max-curvature", a->max_curvature, "1/r of the last row, in 1/mm (0, 10]")->capture_default_str();
  sub->add_option("--samples", a->samples, "Ring quadrature samples (per Gaussian)")->capture_default_str();
  sub->add_option("--quadrature", a->quadrature, "per-gaussian or uniform")->capture_default_str();
  sub->add_option("--threads", a->threads, "Threads (0: all)")->capture_default_str()->check(CLI::Range(0u, 1024u));
  sub->add_flag("--alpha", a->alpha, "PNG: keep the Beckmann alpha channel (EXR always has it)");
  return [a] {
            skin::LutParams p;
            p.width = a->width ? a->width : a->size;
            p.height = a->height ? a->height : a->size;
            auto range = skin::integration_range_from_string(a->range);
            if (!range) return bake_failed("skin-lut", range.error());
            p.range = *range;
            if (a->convention == "thesis") p.convention = skin::thesis_convention;
            else if (a->convention == "penner") p.convention = skin::penner_convention;
            else if (a->convention != "default")
              return bake_failed("skin-lut", Error{ErrorKind::InvalidArgument,
                                                   weft::format("unknown --convention '{}' (default, thesis, penner)", a->convention)});
            if (a->normalization == "ring") p.convention.normalization = skin::Normalization::Ring;
            else if (a->normalization == "planar") p.convention.normalization = skin::Normalization::Planar;
            else if (!a->normalization.empty())
              return bake_failed("skin-lut", Error{ErrorKind::InvalidArgument,
                                                   weft::format("unknown --normalization '{}' (ring, planar)", a->normalization)});
            if (a->variance_scale != 0.0) p.convention.variance_scale = a->variance_scale;
            if (a->quadrature == "uniform") p.quadrature = skin::Quadrature::Uniform;
            else if (a->quadrature != "per-gaussian")
              return bake_failed("skin-lut", Error{ErrorKind::InvalidArgument,
                                                   weft::format("unknown --quadrature '{}' (per-gaussian, uniform)", a->quadrature)});
            p.max_curvature = a->max_curvature;
            p.samples = a->samples;
            p.threads = a->threads;
            const auto t0 = std::chrono::steady_clock::now();
            auto lut = skin::generate_lut(p);
            if (!lut) return bake_failed("skin-lut", lut.error());
            const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
            if (auto ok = skin::save_lut(a->output, *lut, a->alpha); !ok) return bake_failed("skin-lut", ok.error());
            std::printf("wrote %s: skin LUT %s, hash %s, generated in %.1f ms\n", a->output.c_str(), p.describe().c_str(),
                        hex64(lut->hash).c_str(), ms);
            std::printf("layout: x = N·L from -1 to 1, y (top to bottom) = 1/r from 0 to %g per mm; alpha: "
                        "min(0.5 P(N·H, m)^0.1, 1) over x = N·H in [0, 1], y = m in [0, 1]\n",
                        p.max_curvature);
            return 0;
          };
}

}  // namespace weft::passes::detail
