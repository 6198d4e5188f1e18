#include "eval/report.h"

#include "afterimage/version.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "io/io.h"

namespace afterimage {

namespace {

std::string html_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '&':
        o += "&amp;";
        break;
      case '"':
        o += "&quot;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

std::string format_value(double v) {
  if (std::isinf(v)) return v > 0 ? "&infin;" : "-&infin;";
  if (std::isnan(v)) return "&ndash;";
  if (std::abs(v) >= 100) return fmt::format("{:.1f}", v);
  if (std::abs(v) >= 1) return fmt::format("{:.3f}", v);
  return fmt::format("{:.4f}", v);
}

// Distinct colors for plot series (colorblind-friendly Okabe-Ito palette).
const char* series_color(size_t i) {
  static const char* c[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00",
                            "#56B4E9", "#F0E442", "#000000", "#999999"};
  return c[i % 9];
}

std::string image_tag(const ImageF& img, int display_width) {
  return fmt::format(
      "<img style=\"image-rendering:pixelated;width:{}px\" src=\"data:image/png;base64,{}\"/>",
      display_width, base64_encode(io::encode_png(img)));
}

}  // namespace

const std::vector<MetricColumn>& report_columns() {
  static const std::vector<MetricColumn> cols = {
      {"psnr", "PSNR (dB)", true},     {"ssim", "SSIM", true},
      {"flip", "FLIP", false},         {"temporal_error", "temporal error", false},
      {"ghosting", "ghosting", false}, {"sharpness", "sharpness (1 = as sharp as ref)", true, 1.0},
  };
  return cols;
}

bool MetricColumn::better(double a, double b) const {
  if (!std::isnan(target)) return std::abs(a - target) < std::abs(b - target);
  return higher_is_better ? a > b : a < b;
}

std::string base64_encode(const std::vector<unsigned char>& b) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string o;
  o.reserve((b.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < b.size(); i += 3) {
    unsigned v = (b[i] << 16) | (b[i + 1] << 8) | b[i + 2];
    o += t[v >> 18];
    o += t[(v >> 12) & 63];
    o += t[(v >> 6) & 63];
    o += t[v & 63];
  }
  if (i + 1 == b.size()) {
    unsigned v = b[i] << 16;
    o += t[v >> 18];
    o += t[(v >> 12) & 63];
    o += "==";
  } else if (i + 2 == b.size()) {
    unsigned v = (b[i] << 16) | (b[i + 1] << 8);
    o += t[v >> 18];
    o += t[(v >> 12) & 63];
    o += t[(v >> 6) & 63];
    o += '=';
  }
  return o;
}

std::string svg_line_plot(const std::string& title,
                          const std::vector<std::pair<std::string, std::vector<double>>>& series,
                          const std::string& x_label, int first_x) {
  const double W = 520, H = 260, L = 56, R = 150, T = 24, B = 36;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  size_t n = 0;
  for (const auto& [name, v] : series)
    for (double x : v)
      if (std::isfinite(x)) lo = std::min(lo, x), hi = std::max(hi, x), n = std::max(n, v.size());
  std::string s = fmt::format(
      "<svg class=\"plot\" xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" "
      "viewBox=\"0 0 {} {}\"><text x=\"{}\" y=\"16\" font-size=\"13\" "
      "font-weight=\"bold\">{}</text>",
      W, H, W, H, L, html_escape(title));
  if (!std::isfinite(lo) || n < 1) return s + "<text x=\"60\" y=\"120\">no data</text></svg>";
  if (hi - lo < 1e-12) hi = lo + 1e-6, lo -= 1e-6;
  const double pw = W - L - R, ph = H - T - B;
  auto px = [&](size_t i) { return L + (n > 1 ? pw * double(i) / double(n - 1) : pw / 2); };
  auto py = [&](double v) { return T + ph * (1.0 - (v - lo) / (hi - lo)); };
  s += fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#888\"/>", L, T,
      pw, ph);
  for (int k = 0; k <= 4; ++k) {
    double v = lo + (hi - lo) * k / 4.0;
    s += fmt::format("<text x=\"{}\" y=\"{:.1f}\" font-size=\"10\" text-anchor=\"end\">{}</text>",
                     L - 4, py(v) + 3, fmt::format("{:.4g}", v));
  }
  s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"10\">{}</text>", L, H - B + 14, first_x);
  s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"10\" text-anchor=\"end\">{}</text>", L + pw,
                   H - B + 14, first_x + int(n) - 1);
  s += fmt::format("<text x=\"{}\" y=\"{}\" font-size=\"11\" text-anchor=\"middle\">{}</text>",
                   L + pw / 2, H - 6, html_escape(x_label));
  for (size_t k = 0; k < series.size(); ++k) {
    const auto& [name, v] = series[k];
    std::string pts;
    for (size_t i = 0; i < v.size(); ++i)
      if (std::isfinite(v[i])) pts += fmt::format("{:.1f},{:.1f} ", px(i), py(v[i]));
    s += fmt::format("<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\" points=\"{}\"/>",
                     series_color(k), pts);
    s += fmt::format(
        "<rect x=\"{}\" y=\"{}\" width=\"10\" height=\"10\" fill=\"{}\"/><text x=\"{}\" y=\"{}\" "
        "font-size=\"11\">{}</text>",
        W - R + 8, T + 14 * k, series_color(k), W - R + 22, T + 14 * k + 9, html_escape(name));
  }
  return s + "</svg>";
}

std::string render_report_html(const ReportData& data) {
  std::string h;
  h += "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>" +
       html_escape(data.title) + "</title><style>";
  h += "body{font-family:system-ui,sans-serif;margin:24px;color:#222}"
       "table.results{border-collapse:collapse;margin:8px 0 16px}"
       "table.results td,table.results th{border:1px solid #bbb;padding:4px 8px;text-align:right}"
       "table.results td:first-child,table.results th:first-child{text-align:left}"
       "td.best{font-weight:bold;background:#e6f4ea}"
       "figure{display:inline-block;margin:4px;vertical-align:top}"
       "figcaption{font-size:12px;text-align:center}"
       ".figrow{margin:8px 0}.plots svg{margin:4px}"
       "pre{background:#f4f4f4;padding:8px;white-space:pre-wrap}";
  h += "</style></head><body>";
  h += "<h1>" + html_escape(data.title) + "</h1>";
  for (const auto& n : data.notes) h += "<p>" + html_escape(n) + "</p>";

  for (const auto& sc : data.scenes) {
    h += "<section class=\"scene\"><h2>Scene: " + html_escape(sc.name) + "</h2>";
    if (!sc.description.empty()) h += "<p>" + html_escape(sc.description) + "</p>";
    // Results table: rows = methods, columns = metrics and ms/frame; best per column in bold.
    h += "<table class=\"results\"><tr><th>method</th>";
    for (const auto& c : report_columns())
      h += "<th>" + html_escape(c.header) +
           (!std::isnan(c.target) ? "" : (c.higher_is_better ? " &uarr;" : " &darr;")) + "</th>";
    h += "<th>ms/frame</th></tr>";
    for (const auto& m : sc.methods) {
      h += "<tr><td>" + html_escape(m.label) + "</td>";
      for (const auto& c : report_columns()) {
        auto it = m.aggregate.find(c.key);
        double v = it == m.aggregate.end() ? std::nan("") : it->second;
        bool best = std::isfinite(v) || std::isinf(v);
        for (const auto& o : sc.methods) {
          auto jt = o.aggregate.find(c.key);
          if (jt == o.aggregate.end() || std::isnan(jt->second)) continue;
          if (c.better(jt->second, v)) best = false;
        }
        h += std::string("<td") + (best && sc.methods.size() > 1 ? " class=\"best\"" : "") + ">" +
             format_value(v) + "</td>";
      }
      h += "<td>" + (m.ms_per_frame >= 0 ? fmt::format("{:.2f}", m.ms_per_frame) : "&ndash;") +
           "</td></tr>";
    }
    h += "</table>";
    // Per-frame plots, one per metric, all methods overlaid.
    h += "<div class=\"plots\">";
    std::vector<std::string> keys;
    for (const auto& m : sc.methods)
      for (const auto& [k, v] : m.per_frame)
        if (std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
    for (const auto& k : keys) {
      std::vector<std::pair<std::string, std::vector<double>>> series;
      for (const auto& m : sc.methods) {
        auto it = m.per_frame.find(k);
        if (it != m.per_frame.end()) series.push_back({m.label, it->second});
      }
      h += svg_line_plot(k + " per frame", series);
    }
    std::vector<std::pair<std::string, std::vector<double>>> ghost;
    for (const auto& m : sc.methods)
      if (!m.ghosting.empty()) ghost.push_back({m.label, m.ghosting});
    if (!ghost.empty())
      h += svg_line_plot("ghosting: error k frames after disocclusion (k = 1..8)", ghost,
                         "k (frames since disocclusion)", 1);
    h += "</div>";
    for (const auto& f : sc.figures) {
      h += "<div class=\"figrow\"><h3>" + html_escape(f.title) + "</h3>";
      for (const auto& p : f.panels) {
        int dw = std::clamp(p.image.width() * 4, 96, 256);
        h += "<figure>" + image_tag(p.image, dw) + "<figcaption>" + html_escape(p.caption) +
             "</figcaption></figure>";
      }
      h += "</div>";
    }
    h += "</section>";
  }
  h += "<h2>Commands</h2><pre>";
  h += html_escape(std::string("afterimage ") + AFTERIMAGE_VERSION_STRING) + "\n";
  for (const auto& c : data.commands) h += html_escape(c) + "\n";
  for (const auto& sc : data.scenes)
    for (const auto& m : sc.methods)
      if (!m.command.empty()) h += html_escape(sc.name + " / " + m.label + ": " + m.command) + "\n";
  h += "</pre></body></html>\n";
  return h;
}

}  // namespace afterimage
