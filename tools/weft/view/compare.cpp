// Compare with reference: the selected feature's reference setting (the one `weft tradeoff`
// measures against) rendered at the current camera on the render thread, RMSE and PSNR of
// the current image against it, and a false-colour difference overlay.
module;
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <expected>
#include <memory>
#include <string>
#include <utility>
#include <nlohmann/json.hpp>
module weft.viewer;
import weft.core;
import weft.image;
import weft.scene;

namespace weft::viewer::detail {

std::shared_ptr<const scene::Scene> with_values(const scene::Scene& source, const std::string& type,
                                                const nlohmann::json& values) {
  auto copy = std::make_shared<scene::Scene>(source);
  for (auto& material : copy->materials) {
    if (material_type_name(material) != type) continue;
    for (const auto& [field, value] : values.items()) {
      nlohmann::json* at = &material.params;  // "lut.size" descends, as the knob tables name fields
      std::string rest = field;
      for (auto dot = rest.find('.'); dot != std::string::npos; dot = rest.find('.')) {
        at = &(*at)[rest.substr(0, dot)];
        rest.erase(0, dot + 1);
      }
      (*at)[rest] = value;
    }
  }
  return copy;
}

namespace {
image::Image to_float_rgb(const image::Image8& in) {
  auto out = image::Image::filled(in.width, in.height, 3);
  for (std::size_t i = 0; i < std::size_t(in.width) * in.height; ++i)
    for (std::uint32_t c = 0; c < 3; ++c) out.pixels[i * 3 + c] = float(in.pixels[i * in.channels + c]) / 255.0f;
  return out;
}
}  // namespace

Result<ComparisonMetrics> compare_images(const image::Image8& current, const image::Image8& reference) {
  const auto a = to_float_rgb(current), b = to_float_rgb(reference);
  auto rmse = image::rmse(a, b);
  if (!rmse) return std::unexpected(rmse.error());
  auto psnr = image::psnr(a, b);
  if (!psnr) return std::unexpected(psnr.error());
  // False colour of the largest channel difference: black (equal) through blue, red and
  // yellow to white at `full_scale` (a tenth of the range: differences worth seeing are small).
  constexpr float full_scale = 0.1f;
  ComparisonMetrics m{*rmse, *psnr, image::Image8::filled(current.width, current.height, 4, 255)};
  for (std::size_t i = 0; i < std::size_t(current.width) * current.height; ++i) {
    float d = 0.0f;
    for (std::uint32_t c = 0; c < 3; ++c) d = std::max(d, std::abs(a.pixels[i * 3 + c] - b.pixels[i * 3 + c]));
    const float t = std::clamp(d / full_scale, 0.0f, 1.0f);
    const float r = std::clamp(3.0f * t - 1.0f, 0.0f, 1.0f), g = std::clamp(3.0f * t - 2.0f, 0.0f, 1.0f);
    const float bl = t < 1.0f / 3.0f ? 3.0f * t : std::clamp(2.0f - 3.0f * t, 0.0f, 1.0f) + g;
    m.overlay.pixels[i * 4 + 0] = std::uint8_t(std::lround(255.0f * r));
    m.overlay.pixels[i * 4 + 1] = std::uint8_t(std::lround(255.0f * g));
    m.overlay.pixels[i * 4 + 2] = std::uint8_t(std::lround(255.0f * std::min(bl, 1.0f)));
  }
  return m;
}

}  // namespace weft::viewer::detail
