// The "neural_btf" material's fields, read with scene::JsonReader so every problem names its
// JSON path; quality presets set the knobs (ambient decode, texel filter) the material leaves out.
module;
#include <charconv>
#include <cstdint>
#include <expected>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <glm/glm.hpp>
#include <weft/try.h>
#include <nlohmann/json.hpp>
module weft.pass.neural_btf;

namespace weft::btf {

namespace {
// "synthetic:<weave>:<W>x<H>[:<seed>]" (docs/neural-btf.md); nullopt when `text` is not that.
std::optional<NeuralBtfParams::Synthetic> parse_synthetic_source(std::string_view text) {
  constexpr std::string_view prefix = "synthetic:";
  if (!text.starts_with(prefix)) return std::nullopt;
  text.remove_prefix(prefix.size());
  NeuralBtfParams::Synthetic s;
  const auto colon = text.find(':');
  if (colon == std::string_view::npos) return std::nullopt;
  s.weave = std::string(text.substr(0, colon));
  text.remove_prefix(colon + 1);
  auto number = [&](auto& value, char end) {
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc{} || ptr == text.data()) return false;
    text.remove_prefix(std::size_t(ptr - text.data()));
    if (text.empty()) return true;
    if (text.front() != end) return false;
    text.remove_prefix(1);
    return true;
  };
  if (!number(s.width, 'x') || text.empty() || !number(s.height, ':')) return std::nullopt;
  if (!text.empty() && !number(s.seed, '\0')) return std::nullopt;
  if (!text.empty() || s.width == 0 || s.height == 0 || s.width > 4096 || s.height > 4096) return std::nullopt;
  if (s.weave != "plain" && s.weave != "twill" && s.weave != "knit") return std::nullopt;
  return s;
}
}  // namespace

std::string_view to_string(BtfMode m) { return m == BtfMode::Neural ? "neural" : "reference"; }
std::string_view to_string(TexelFilter f) { return f == TexelFilter::Nearest ? "nearest" : "bilinear"; }
std::string_view to_string(BtfDebugView d) {
  switch (d) {
    case BtfDebugView::None: return "none";
    case BtfDebugView::Texel: return "texel";
    case BtfDebugView::Uv: return "uv";
    case BtfDebugView::Frame: return "frame";
  }
  return "?";
}

std::string_view to_string(BtfDecoder d) { return d == BtfDecoder::Batched ? "batched" : "fragment"; }

NeuralBtfQualityPreset neural_btf_quality_preset(Quality quality) {
  return {.ambient = quality != Quality::Low,
          .filter = quality == Quality::High || quality == Quality::Reference ? TexelFilter::Bilinear : TexelFilter::Nearest};
}

Result<NeuralBtfParams> parse_neural_btf_material(const scene::Material& material, Quality quality) {
  NeuralBtfParams m;
  const NeuralBtfQualityPreset q = neural_btf_quality_preset(quality);
  m.ambient = q.ambient;
  m.filter = q.filter;
  WEFT_TRY_VOID(read_material_fields(material, "neural_btf", [&](scene::JsonReader& r) {
    const std::string mode = r.string("mode", "neural", {"neural", "reference"});
    m.mode = mode == "reference" ? BtfMode::Reference : BtfMode::Neural;
    if (m.mode == BtfMode::Neural) r.require("model");
    m.model = r.path("model");
    if (m.mode == BtfMode::Reference) r.require("btf");
    if (const nlohmann::json* b = r.value("btf"); b && b->is_string() && b->get<std::string>().starts_with("synthetic")) {
      m.btf_synthetic = parse_synthetic_source(b->get<std::string>());
      if (!m.btf_synthetic)
        r.error_at("btf", weft::format("'{}' is not synthetic:<plain|twill|knit>:<W>x<H>[:<seed>] (sides 1..4096)",
                                       b->get<std::string>()));
    } else {
      m.btf = r.path("btf");
    }
    const scene::Range tiling{.min = 0, .max = 1e6, .min_exclusive = true};
    if (const nlohmann::json* s = r.value("uv_scale"); s && s->is_number()) {
      m.uv_scale = vec2(float(r.number("uv_scale", 1.0, tiling)));
    } else {
      m.uv_scale = r.vec2_of("uv_scale", m.uv_scale, tiling);
    }
    m.exposure = float(r.number("exposure", m.exposure, {.min = 0, .max = 1e6}));
    m.tint = r.vec3_of("tint", m.tint, {.min = 0, .max = 1e6});
    m.ambient = r.boolean("ambient", m.ambient);
    m.filter = read_choice_knob(r, *find_knob(passes::neural_btf_feature().knobs, "filter"),
                                std::string(to_string(m.filter))) == "bilinear"
                   ? TexelFilter::Bilinear
                   : TexelFilter::Nearest;
    m.shadow = r.boolean("shadow", m.shadow);
    const std::string debug = r.string("debug_view", "none", {"none", "texel", "uv", "frame"});
    for (BtfDebugView d : {BtfDebugView::None, BtfDebugView::Texel, BtfDebugView::Uv, BtfDebugView::Frame})
      if (to_string(d) == debug) m.debug_view = d;
    m.decoder = r.string("decoder", "batched", {"batched", "fragment"}) == "fragment" ? BtfDecoder::Fragment
                                                                                    : BtfDecoder::Batched;
  }));
  return m;
}

}  // namespace weft::btf
