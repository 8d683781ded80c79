// The Pareto front and the three reports of a sweep: CSV (every number), markdown (a table
// for docs and terminals) and SVG (the curve).
module;
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <span>
#include <string>
#include <string_view>
#include <vector>
#include <nlohmann/json.hpp>
module weft.tradeoff;
import weft.core;
import weft.feature;

namespace weft::tradeoff {

std::vector<std::size_t> pareto_front(std::span<const Point> points) {
  auto usable = [](const Point& p) { return std::isfinite(p.cost) && std::isfinite(p.error); };
  std::vector<std::size_t> front;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!usable(points[i])) continue;
    bool dominated = false;
    for (std::size_t j = 0; j < points.size() && !dominated; ++j) {
      if (j == i || !usable(points[j])) continue;
      const auto &a = points[j], &b = points[i];
      dominated = a.cost <= b.cost && a.error <= b.error && (a.cost < b.cost || a.error < b.error);
    }
    if (!dominated) front.push_back(i);
  }
  std::sort(front.begin(), front.end(), [&](std::size_t a, std::size_t b) {
    return points[a].cost != points[b].cost ? points[a].cost < points[b].cost : points[a].error < points[b].error;
  });
  return front;
}

void mark_pareto(std::span<Row> rows, CostAxis axis) {
  std::vector<Point> points;
  for (const auto& r : rows) points.push_back({r.cost(axis), r.error.rmse});
  for (auto& r : rows) r.pareto = false;
  for (auto i : pareto_front(points)) rows[i].pareto = true;
}

std::string csv_field(std::string_view field) {
  if (field.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(field);
  std::string out = "\"";
  for (char c : field) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

namespace {
std::string number(double v, int digits = 4) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (std::isnan(v)) return "nan";
  return weft::format("{:.{}f}", v, digits);
}

std::string preset_name(const Row& r) { return r.setting.preset ? std::string(to_string(*r.setting.preset)) : ""; }

std::vector<std::size_t> by_cost(std::span<const Row> rows, CostAxis axis) {
  std::vector<std::size_t> order(rows.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](auto a, auto b) {
    return rows[a].cost(axis) != rows[b].cost(axis) ? rows[a].cost(axis) < rows[b].cost(axis) : a < b;
  });
  return order;
}
}  // namespace

bool has_ratios(std::span<const Row> rows) {
  return std::any_of(rows.begin(), rows.end(), [](const Row& r) { return !std::isnan(r.cost_ratio); });
}

std::string csv(std::span<const Row> rows, const ReportInfo& info) {
  const bool ratios = has_ratios(rows);
  std::string out =
      "feature,setting,group,quality,preset,reference,values,frame_ms,gpu_ms,feature_gpu_ms,process_cpu_ms,wall_ms,"
      "cold_frame_ms,rmse_linear,relative_rmse,psnr_db,ssim,max_diff,pixels,pareto";
  out += ratios ? ",cost_ratio,node\n" : "\n";
  for (const auto& r : rows) {
    const auto& s = r.setting;
    const std::array<std::string, 20> fields = {
        info.feature, s.label, s.group, std::string(to_string(s.quality)), preset_name(r),
        s.is_reference ? "1" : "0", s.values.dump(), number(r.frame_ms, 3), number(r.gpu_ms, 3),
        number(r.feature_gpu_ms, 3), number(r.process_cpu_ms, 3), number(r.wall_ms, 3), number(r.cold_frame_ms, 3),
        number(r.error.rmse, 6), number(r.error.relative_rmse, 5), number(r.error.psnr_db, 2),
        number(r.error.ssim, 5), number(r.error.max_diff, 5), std::to_string(r.error.pixels), r.pareto ? "1" : "0"};
    for (std::size_t i = 0; i < fields.size(); ++i) out += (i ? "," : "") + csv_field(fields[i]);
    if (ratios) out += "," + number(r.cost_ratio, 4) + "," + csv_field(r.node);
    out += "\n";
  }
  return out;
}

std::string markdown(std::span<const Row> rows, const ReportInfo& info) {
  std::string out = weft::format("### {}: {} at {}x{}\n\n", info.feature, info.scene, info.width, info.height);
  out += weft::format("`{}`  \n{}. Cost: {}. Frame ms: {}, median of {} frames after the first; GPU ms: "
                      "timestamps; cold: the first frame's wall time with empty caches. Error: linear RGB against "
                      "the reference over {}.\n\n",
                      info.command, info.device, to_string(info.cost), info.frame_clock, info.frames, info.mask_note);
  const bool ratios = has_ratios(rows);
  out += "| setting | frame ms | GPU ms | cold frame ms | RMSE (linear) | relative RMSE | PSNR dB | SSIM | max diff | Pareto |";
  out += ratios ? " cost ratio |\n" : "\n";
  out += "|---|---:|---:|---:|---:|---:|---:|---:|---:|:---:|";
  out += ratios ? "---:|\n" : "\n";
  for (auto i : by_cost(rows, info.cost)) {
    const auto& r = rows[i];
    std::string label = r.setting.label;
    if (r.setting.is_reference || r.setting.preset) label = "**" + label + "**";
    out += weft::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", label, number(r.frame_ms, 1),
                        number(r.gpu_ms, 1), number(r.cold_frame_ms, 0), number(r.error.rmse, 5),
                        weft::format("{:.1f} %", 100.0 * r.error.relative_rmse),
                        number(r.error.psnr_db, 1), number(r.error.ssim, 4), number(r.error.max_diff, 3),
                        r.pareto ? "●" : "");
    if (ratios) {
      out.pop_back();
      out += weft::format(" {} |\n", number(r.cost_ratio, 3));
    }
  }
  return out;
}

std::string xml_escape(std::string_view text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

namespace {
// A log axis over [lo, hi] (both > 0), padded so points do not sit on the frame.
struct LogAxis {
  double lo = 1, hi = 10;
  double from = 0, to = 1;  // pixels
  static LogAxis fit(std::vector<double> values, double from, double to) {
    LogAxis a;
    a.from = from, a.to = to;
    std::erase_if(values, [](double v) { return !(v > 0.0) || !std::isfinite(v); });
    if (values.empty()) return a;
    a.lo = *std::min_element(values.begin(), values.end());
    a.hi = *std::max_element(values.begin(), values.end());
    if (a.hi < a.lo * 1.5) {
      const double mid = std::sqrt(a.lo * a.hi);
      a.lo = mid / 1.5, a.hi = mid * 1.5;
    }
    a.lo /= 1.25, a.hi *= 1.25;
    return a;
  }
  [[nodiscard]] double at(double v) const {
    return from + (to - from) * (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo));
  }
  // 1, 2, 5 per decade when the axis spans less than three decades, else decades.
  [[nodiscard]] std::vector<double> ticks() const {
    std::vector<double> t;
    const bool fine = hi / lo < 1000.0;
    for (double d = std::pow(10.0, std::floor(std::log10(lo))); d <= hi; d *= 10.0)
      for (double m : fine ? std::vector<double>{1, 2, 5} : std::vector<double>{1})
        if (d * m >= lo && d * m <= hi) t.push_back(d * m);
    return t;
  }
};

std::string tick_text(double v) {
  if (v >= 1.0) return weft::format("{:g}", v);
  return weft::format("{:.{}g}", v, 1);
}

constexpr std::array<const char*, 8> palette = {"#1f77b4", "#2ca02c", "#9467bd", "#8c564b",
                                               "#e377c2", "#17becf", "#bcbd22", "#7f7f7f"};
}  // namespace

std::string svg(std::span<const Row> rows, const ReportInfo& info) {
  constexpr double width = 760, height = 500, left = 80, right = 200, top = 50, bottom = 60;
  std::vector<double> costs, errors;
  for (const auto& r : rows) {
    costs.push_back(r.cost(info.cost));
    if (!r.setting.is_reference) errors.push_back(r.error.rmse);
  }
  const LogAxis x = LogAxis::fit(costs, left, width - right);
  const LogAxis y = LogAxis::fit(errors, height - bottom, top);
  std::map<std::string, std::string> colour_of;  // group -> colour
  for (const auto& r : rows)
    if (!r.setting.preset && !r.setting.is_reference && !colour_of.contains(r.setting.group))
      colour_of[r.setting.group] = palette[colour_of.size() % palette.size()];

  std::string s = weft::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" viewBox=\"0 0 {} {}\" "
      "font-family=\"sans-serif\" font-size=\"11\">\n"
      "<rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"white\"/>\n",
      width, height, width, height, width, height);
  s += weft::format("<text x=\"{}\" y=\"22\" font-size=\"14\" font-weight=\"bold\">{}</text>\n", left,
                    xml_escape(weft::format("{}: error against cost ({}, {}x{})", info.feature, info.scene, info.width,
                                            info.height)));
  s += weft::format("<text x=\"{}\" y=\"38\" fill=\"#555\">{}</text>\n", left, xml_escape(info.device));
  // Frame, grid and ticks.
  s += weft::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#333\"/>\n", left, top,
                    width - right - left, height - bottom - top);
  for (double t : x.ticks()) {
    const double px = x.at(t);
    s += weft::format("<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"#ddd\"/>\n", px, top, height - bottom);
    s += weft::format("<text x=\"{:.1f}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", px, height - bottom + 15, tick_text(t));
  }
  for (double t : y.ticks()) {
    const double py = y.at(t);
    s += weft::format("<line x1=\"{1}\" y1=\"{0:.1f}\" x2=\"{2}\" y2=\"{0:.1f}\" stroke=\"#ddd\"/>\n", py, left, width - right);
    s += weft::format("<text x=\"{}\" y=\"{:.1f}\" text-anchor=\"end\">{}</text>\n", left - 5, py + 4, tick_text(t));
  }
  s += weft::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", (left + width - right) / 2, height - 20,
                    xml_escape(info.cost == CostAxis::Frame ? "frame time, ms (" + info.frame_clock + ", median; log)"
                                                            : std::string("cold first frame incl. bakes, wall ms (log)")));
  s += weft::format("<text x=\"20\" y=\"{0}\" text-anchor=\"middle\" transform=\"rotate(-90 20 {0})\">RMSE against the "
                    "reference, linear (log)</text>\n",
                    (top + height - bottom) / 2);
  // The reference: error 0, so a vertical line at its cost.
  for (const auto& r : rows)
    if (r.setting.is_reference && r.cost(info.cost) > 0.0) {
      const double px = x.at(r.cost(info.cost));
      s += weft::format("<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"#d62728\" "
                        "stroke-dasharray=\"5,4\"/>\n",
                        px, top, height - bottom);
      s += weft::format("<text x=\"{:.1f}\" y=\"{}\" fill=\"#d62728\" text-anchor=\"end\">reference ({})</text>\n",
                        px - 4, top + 12, xml_escape(r.setting.label == "reference" ? "error 0" : r.setting.label));
    }
  // The Pareto front (without the reference, which has no place on a log error axis).
  std::string front;
  for (auto i : by_cost(rows, info.cost)) {
    const auto& r = rows[i];
    if (!r.pareto || r.setting.is_reference || !(r.error.rmse > 0.0)) continue;
    front += weft::format("{}{:.1f},{:.1f}", front.empty() ? "" : " ", x.at(r.cost(info.cost)), y.at(r.error.rmse));
  }
  if (!front.empty())
    s += weft::format("<polyline points=\"{}\" fill=\"none\" stroke=\"#d62728\" stroke-width=\"1.5\"/>\n", front);
  // Points: sweeps as circles coloured by knob, presets as black squares; front points ringed
  // and labelled, above and below in turn so neighbours do not overwrite each other.
  int labelled = 0;
  for (auto i : by_cost(rows, info.cost)) {
    const auto& r = rows[i];
    if (r.setting.is_reference || !(r.error.rmse > 0.0) || !(r.cost(info.cost) > 0.0)) continue;
    const double px = x.at(r.cost(info.cost)), py = y.at(r.error.rmse);
    if (r.setting.preset) {
      s += weft::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"9\" height=\"9\" fill=\"black\"/>\n", px - 4.5, py - 4.5);
      s += weft::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-weight=\"bold\">{}</text>\n", px + 7, py + 14,
                        xml_escape(to_string(*r.setting.preset)));
    } else {
      s += weft::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"3.5\" fill=\"{}\"/>\n", px, py, colour_of[r.setting.group]);
    }
    if (r.pareto) {
      s += weft::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"7\" fill=\"none\" stroke=\"#d62728\"/>\n", px, py);
      if (!r.setting.preset)
        s += weft::format("<text x=\"{:.1f}\" y=\"{:.1f}\" fill=\"#d62728\">{}</text>\n", px + 8,
                          labelled++ % 2 ? py + 16 : py - 8, xml_escape(r.setting.label));
    }
  }
  // Legend.
  double ly = top + 10;
  const double lx = width - right + 15;
  s += weft::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"9\" height=\"9\" fill=\"black\"/>\n", lx - 4.5, ly - 4.5);
  s += weft::format("<text x=\"{}\" y=\"{:.1f}\">quality preset</text>\n", lx + 10, ly + 4);
  ly += 18;
  s += weft::format("<circle cx=\"{}\" cy=\"{:.1f}\" r=\"7\" fill=\"none\" stroke=\"#d62728\"/>\n", lx, ly);
  s += weft::format("<text x=\"{}\" y=\"{:.1f}\">Pareto front</text>\n", lx + 10, ly + 4);
  for (const auto& [group, colour] : colour_of) {
    ly += 18;
    s += weft::format("<circle cx=\"{}\" cy=\"{:.1f}\" r=\"3.5\" fill=\"{}\"/>\n", lx, ly, colour);
    s += weft::format("<text x=\"{}\" y=\"{:.1f}\">{}</text>\n", lx + 10, ly + 4, xml_escape(group));
  }
  s += "</svg>\n";
  return s;
}

}  // namespace weft::tradeoff
