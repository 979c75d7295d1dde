#include "internal_report_svg.h"

#include <algorithm>
#include <cmath>
#include <clocale>
#include <cstdio>

#include "internal_report_image.h"

namespace rgs::audit::detail {

namespace {

// Text is measured by an estimate of the average advance of a 12 px sans-serif face: the layout only has to
// leave room, not to fit tightly.
constexpr double kCharWidth = 7.0;
constexpr double kLegendRow = 18.0;
constexpr size_t kMaxTickChars = 24;

std::string px(double v) { return format_number("%.1f", v); }

/// Characters of UTF-8 `text` (continuation bytes not counted).
size_t text_chars(const std::string& text) {
  return size_t(std::count_if(text.begin(), text.end(), [](char c) { return (uint8_t(c) & 0xC0) != 0x80; }));
}

double text_width(const std::string& text) { return double(text_chars(text)) * kCharWidth; }

/// `text` cut to `max_chars` characters with an ellipsis.
std::string shorten(const std::string& text, size_t max_chars) {
  if (text_chars(text) <= max_chars) return text;
  size_t chars = 0, end = 0;
  for (; end < text.size(); ++end) {
    if ((uint8_t(text[end]) & 0xC0) != 0x80 && ++chars > max_chars - 1) break;
  }
  return text.substr(0, end) + "\xE2\x80\xA6";
}

std::string svg_open(const std::string& kind, double width, double height) {
  return "<svg class='rgs-plot' data-plot='" + escape_html(kind) + "' xmlns='http://www.w3.org/2000/svg' width='" +
         px(width) + "' height='" + px(height) + "' viewBox='0 0 " + px(width) + " " + px(height) +
         "' font-family='system-ui,sans-serif' font-size='12' role='img'>";
}

std::string text_at(double x, double y, const std::string& text, const char* anchor = "start",
                    const std::string& extra = "") {
  return "<text x='" + px(x) + "' y='" + px(y) + "' text-anchor='" + anchor + "'" + extra + ">" + escape_html(text) +
         "</text>";
}

/// Ticks at 1, 2 or 5 times a power of ten inside [lo, hi], about `target` of them, with their labels.
std::vector<std::pair<double, std::string>> nice_ticks(double lo, double hi, int target) {
  std::vector<std::pair<double, std::string>> ticks;
  if (!(hi > lo) || !std::isfinite(hi - lo)) return ticks;
  const double raw = (hi - lo) / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / magnitude;
  const double step = magnitude * (f < 1.5 ? 1 : f < 3 ? 2 : f < 7 ? 5 : 10);
  const int decimals = std::max(0, -int(std::floor(std::log10(step) + 1e-9)));
  for (double k = std::ceil(lo / step - 1e-9); k * step <= hi + step * 1e-9; k += 1) {
    const double v = k * step;
    ticks.emplace_back(v, format_number(("%." + std::to_string(decimals) + "f").c_str(), v == 0 ? 0.0 : v));
  }
  return ticks;
}

/// Decades inside [lo, hi] (lo > 0), with 2 and 5 times each when the range spans fewer than three.
std::vector<std::pair<double, std::string>> log_ticks(double lo, double hi) {
  std::vector<std::pair<double, std::string>> ticks;
  const bool fine = std::log10(hi / lo) < 3;
  for (int e = int(std::floor(std::log10(lo))); e <= int(std::ceil(std::log10(hi))); ++e) {
    for (double m : {1.0, 2.0, 5.0}) {
      const double v = m * std::pow(10.0, e);
      if ((m == 1.0 || fine) && v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) {
        ticks.emplace_back(v, format_number("%g", v));
      }
    }
  }
  return ticks;
}

/// Pixel box of a panel and its mapping from data.
struct Box {
  double left, top, width, height;
  const PlotPanel* panel;
  double x(double v) const {
    const PlotPanel& p = *panel;
    const double t = p.x_log ? std::log10(v / p.x_lo) / std::log10(p.x_hi / p.x_lo) : (v - p.x_lo) / (p.x_hi - p.x_lo);
    return left + t * width;
  }
  double y(double v) const { return top + (panel->y_hi - v) / (panel->y_hi - panel->y_lo) * height; }
};

struct LegendEntry {
  std::string label, colour, dash;
  char marker = 0;
  bool line = true, patch = false;
};

/// A marker at (x, y): class "pt" for a data point ("pt inf" for +inf drawn at the top), "key" in the legend.
std::string marker_svg(char marker, double x, double y, const std::string& colour, const std::string& tip,
                       bool open = false, bool key = false) {
  const std::string paint = open ? "fill='white' stroke='" + colour + "' stroke-width='1.5'" : "fill='" + colour + "'";
  const std::string title = tip.empty() ? "" : "<title>" + escape_html(tip) + "</title>";
  const std::string cls = key ? "key" : open ? "pt inf" : "pt";
  if (marker == 's') {
    return "<rect class='" + cls + "' x='" + px(x - 3) + "' y='" + px(y - 3) + "' width='6' height='6' " + paint +
           ">" + title + "</rect>";
  }
  if (marker == '^') {
    return "<path class='" + cls + "' d='M" + px(x) + " " + px(y - 4) + "L" + px(x + 4.5) + " " + px(y + 3.5) + "L" +
           px(x - 4.5) + " " + px(y + 3.5) + "Z' " + paint + ">" + title + "</path>";
  }
  return "<circle class='" + cls + "' cx='" + px(x) + "' cy='" + px(y) + "' r='3' " + paint + ">" + title +
         "</circle>";
}

std::string stroke(const std::string& colour, const std::string& dash, double width = 1.5) {
  return "fill='none' stroke='" + colour + "' stroke-width='" + px(width) + "'" +
         (dash.empty() ? "" : " stroke-dasharray='" + dash + "'");
}

/// A series in `box`; sets *inf_drawn when a +inf value was drawn at the top edge.
std::string series_svg(const Box& box, const PlotSeries& s, bool* inf_drawn) {
  std::string path, marks, notes;
  size_t points = 0;
  bool open = false;  // a line segment is under way
  for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
    const double v = s.y[i];
    const std::string tip = i < s.tips.size() ? s.tips[i] : "";
    if (!std::isfinite(v)) {
      open = false;
      if (v > 0 && s.marker) {
        marks += marker_svg('^', box.x(s.x[i]), box.top, s.colour, tip, true);
        *inf_drawn = true;
        ++points;
      }
      continue;
    }
    const double x = box.x(s.x[i]), y = box.y(v);
    if (s.line) path += (open ? "L" : "M") + px(x) + " " + px(y);
    open = true;
    if (i < s.y_low.size() && std::isfinite(s.y_low[i])) {
      const double low = box.y(s.y_low[i]);
      marks += "<path d='M" + px(x) + " " + px(y) + "V" + px(low) + "M" + px(x - 4) + " " + px(low) + "H" +
               px(x + 4) + "' " + stroke(s.colour, "") + "/>";
    }
    if (s.marker) {
      marks += marker_svg(s.marker, x, y, s.colour, tip);
      ++points;
    }
    if (i < s.notes.size() && !s.notes[i].empty()) {
      const bool right = x > box.left + 0.75 * box.width;
      notes += text_at(x + (right ? -7 : 7), y - 6, s.notes[i], right ? "end" : "start", " font-size='11'");
    }
  }
  return "<g class='series' data-kind='" + escape_html(s.kind) + "' data-label='" + escape_html(s.label) +
         "' data-points='" + std::to_string(points) + "'>" +
         (path.empty() ? "" : "<path d='" + path + "' " + stroke(s.colour, s.dash) + "/>") + marks + notes + "</g>";
}

/// Frame, grid, ticks and labels of `box`; x tick labels only when `x_labels`.
std::string axes_svg(const Box& box, bool x_labels, double x_label_y) {
  const PlotPanel& p = *box.panel;
  std::string out = "<rect x='" + px(box.left) + "' y='" + px(box.top) + "' width='" + px(box.width) + "' height='" +
                    px(box.height) + "' fill='white' stroke='#444'/>";
  for (const auto& [v, label] : nice_ticks(p.y_lo, p.y_hi, 6)) {
    const double y = box.y(v);
    out += "<path d='M" + px(box.left) + " " + px(y) + "H" + px(box.left + box.width) + "' stroke='#ddd'/>";
    out += text_at(box.left - 6, y + 4, label, "end");
  }
  const bool named = !p.x_ticks.empty();
  const auto ticks = named ? p.x_ticks : p.x_log ? log_ticks(p.x_lo, p.x_hi) : nice_ticks(p.x_lo, p.x_hi, 8);
  for (const auto& [v, label] : ticks) {
    const double x = box.x(v), bottom = box.top + box.height;
    out += "<path d='M" + px(x) + " " + px(box.top) + "V" + px(bottom) + "' stroke='#eee'/>";
    if (!x_labels) continue;
    out += "<path d='M" + px(x) + " " + px(bottom) + "V" + px(bottom + 4) + "' stroke='#444'/>";
    if (named) {
      out += text_at(x + 4, bottom + 12, shorten(label, kMaxTickChars), "end",
                     " font-size='11' transform='rotate(-60 " + px(x + 4) + " " + px(bottom + 12) + ")'");
    } else {
      out += text_at(x, bottom + 16, label, "middle");
    }
  }
  if (x_labels && !p.x_label.empty()) out += text_at(box.left + box.width / 2, x_label_y, p.x_label, "middle");
  if (!p.y_label.empty()) {
    const double cy = box.top + box.height / 2;
    out += text_at(16, cy, p.y_label, "middle", " transform='rotate(-90 16 " + px(cy) + ")'");
  }
  if (!p.title.empty()) out += text_at(box.left + box.width / 2, box.top - 9, p.title, "middle", " font-size='14'");
  return out;
}

/// The legend's entries laid out in rows from (left, top) within `width`; returns the SVG, sets *height.
std::string legend_svg(const std::vector<LegendEntry>& entries, double left, double top, double width,
                       double* height) {
  std::string out = "<g class='legend'>";
  double x = left, y = top;
  for (const LegendEntry& e : entries) {
    const double w = 44 + text_width(e.label);
    if (x > left && x + w > left + width) {
      x = left;
      y += kLegendRow;
    }
    const double mid = y + kLegendRow / 2;
    if (e.patch) {
      out += "<rect x='" + px(x + 4) + "' y='" + px(mid - 5) + "' width='22' height='10' fill='" + e.colour + "'/>";
    } else if (e.line) {
      out += "<path d='M" + px(x) + " " + px(mid) + "H" + px(x + 30) + "' " + stroke(e.colour, e.dash) + "/>";
    }
    if (e.marker) out += marker_svg(e.marker, x + 15, mid, e.colour, "", e.marker == '^' && !e.line, true);
    out += text_at(x + 36, mid + 4, e.label);
    x += w;
  }
  *height = entries.empty() ? 0 : y + kLegendRow - top;
  return out + "</g>";
}

}  // namespace

std::string escape_html(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string format_number(const char* format, double value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, value);
  std::string text = buf;
  // A program that set LC_NUMERIC would get "12,5": SVG coordinates and the page's numbers take a point.
  const char point = *std::localeconv()->decimal_point;
  if (point != '.') std::replace(text.begin(), text.end(), point, '.');
  return text;
}

const char* cycle_colour(size_t i) {
  static const char* kTab10[10] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                   "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  return kTab10[i % 10];
}

std::string svg_plot(const std::string& kind, const std::vector<PlotPanel>& panels, double width,
                     double panel_height) {
  size_t tick_chars = 4, x_tick_chars = 0;
  for (const PlotPanel& p : panels) {
    for (const auto& t : nice_ticks(p.y_lo, p.y_hi, 6)) tick_chars = std::max(tick_chars, t.second.size());
  }
  for (const auto& t : panels.back().x_ticks) {
    x_tick_chars = std::max(x_tick_chars, text_chars(shorten(t.second, kMaxTickChars)));
  }
  const double left = 30 + double(tick_chars) * kCharWidth, plot_width = width - left - 16;
  std::string body;
  std::vector<LegendEntry> legend, line_legend;  // the series' entries, then the lines'
  auto add_legend = [](std::vector<LegendEntry>& entries, const LegendEntry& e) {
    if (e.label.empty()) return;
    for (const LegendEntry& have : entries) {
      if (have.label == e.label) return;
    }
    entries.push_back(e);
  };
  bool inf_drawn = false;
  double top = 0;
  for (size_t k = 0; k < panels.size(); ++k) {
    const PlotPanel& p = panels[k];
    const bool last = k + 1 == panels.size();
    top += p.title.empty() ? 12 : 30;
    const Box box{left, top, plot_width, panel_height, &p};
    const double x_tick_room = p.x_ticks.empty() ? 22 : 16 + double(x_tick_chars) * 0.87 * kCharWidth * 0.92;
    body += "<g class='panel' data-panel='" + escape_html(p.kind) + "'>" +
            axes_svg(box, last, top + panel_height + x_tick_room + 14);
    for (const PlotLine& l : p.lines) {
      const double y = box.y(l.y);
      body += "<path class='hline' d='M" + px(left) + " " + px(y) + "H" + px(left + plot_width) + "' " +
              stroke(l.colour, l.dash, 1.2) + "/>";
      add_legend(line_legend, {l.label, l.colour, l.dash, 0, true, false});
    }
    for (const PlotSeries& s : p.series) {
      body += series_svg(box, s, &inf_drawn);
      if (s.in_legend) add_legend(legend, {s.label, s.colour, s.dash, s.marker, s.line, false});
    }
    body += "</g>";
    top += panel_height + (last ? x_tick_room + (p.x_label.empty() ? 4 : 24) : 0);
  }
  legend.insert(legend.end(), line_legend.begin(), line_legend.end());
  if (inf_drawn) add_legend(legend, {"at the top: identical images (PSNR inf)", "#555", "", '^', false, false});
  double legend_height = 0;
  body += legend_svg(legend, left, top + 4, plot_width, &legend_height);
  return svg_open(kind, width, top + legend_height + 10) + body + "</svg>";
}

std::string svg_bars(const std::string& kind, const std::string& title, const std::string& x_label,
                     const std::vector<BarRow>& rows, const std::vector<std::pair<std::string, std::string>>& keys,
                     double width) {
  constexpr double kRow = 30, kBar = 20;
  double label_width = 40, x_hi = 0;
  for (const BarRow& r : rows) {
    label_width = std::max(label_width, text_width(shorten(r.label, 32)));
    double total = 0;
    for (const auto& seg : r.segments) total += std::max(seg.second, 0.0);
    x_hi = std::max(x_hi, total);
  }
  PlotPanel axes;
  axes.title = title;
  axes.x_label = x_label;
  axes.x_hi = x_hi > 0 ? x_hi * 1.04 : 1;
  const double left = label_width + 16, top = 30, height = kRow * double(rows.size()) + 8;
  const Box box{left, top, width - left - 16, height, &axes};  // its x mapping only: rows are placed by index
  std::string body = "<rect x='" + px(left) + "' y='" + px(top) + "' width='" + px(box.width) + "' height='" +
                     px(height) + "' fill='white' stroke='#444'/>";
  for (const auto& [v, label] : nice_ticks(axes.x_lo, axes.x_hi, 8)) {
    const double x = box.x(v);
    body += "<path d='M" + px(x) + " " + px(top) + "V" + px(top + height + 4) + "' stroke='#ddd'/>" +
            text_at(x, top + height + 18, label, "middle");
  }
  body += text_at(left + box.width / 2, top + height + 38, x_label, "middle") +
          text_at(left + box.width / 2, top - 9, title, "middle", " font-size='14'");
  std::vector<bool> used(keys.size(), false);
  for (size_t r = 0; r < rows.size(); ++r) {
    const double y = top + 4 + kRow * double(r) + (kRow - kBar) / 2;
    body += "<g class='bar-row' data-label='" + escape_html(rows[r].label) + "'>" +
            text_at(left - 8, y + kBar / 2 + 4, shorten(rows[r].label, 32), "end");
    double at = 0;
    for (const auto& [key, value] : rows[r].segments) {
      if (!(value > 0) || key >= keys.size()) continue;
      used[key] = true;
      body += "<rect class='bar' data-key='" + escape_html(keys[key].first) + "' x='" + px(box.x(at)) + "' y='" +
              px(y) + "' width='" + px(box.x(at + value) - box.x(at)) + "' height='" + px(kBar) + "' fill='" +
              keys[key].second + "'><title>" + escape_html(rows[r].label + ", " + keys[key].first + ": " +
                                                           format_number("%.3f", value)) +
              "</title></rect>";
      at += value;
    }
    body += "</g>";
  }
  std::vector<LegendEntry> legend;
  for (size_t k = 0; k < keys.size(); ++k) {
    if (used[k]) legend.push_back({keys[k].first, keys[k].second, "", 0, false, true});
  }
  double legend_height = 0;
  body += legend_svg(legend, left, top + height + 48, box.width, &legend_height);
  return svg_open(kind, width, top + height + 56 + legend_height) + body + "</svg>";
}

std::string svg_colour_bar(double scale, double largest, const std::string& label, const std::string& id) {
  constexpr double kLeft = 24, kWidth = 420, kHeight = 22, kArrow = 18;
  const bool extend = largest > scale;
  std::string out = svg_open("colour-bar", kLeft + kWidth + kArrow + 24, 74) + "<defs><linearGradient id='" +
                    escape_html(id) + "'>";
  for (int k = 0; k <= 16; ++k) {
    const auto rgb = inferno(uint8_t(std::min(255, k * 16)));
    char colour[8];
    std::snprintf(colour, sizeof colour, "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
    out += "<stop offset='" + format_number("%.4f", std::min(255, k * 16) / 255.0) + "' stop-color='" + colour + "'/>";
  }
  out += "</linearGradient></defs><rect x='" + px(kLeft) + "' y='4' width='" + px(kWidth) + "' height='" +
         px(kHeight) + "' fill='url(#" + escape_html(id) + ")' stroke='#444'/>";
  if (extend) {
    const auto top = inferno(255);
    char colour[8];
    std::snprintf(colour, sizeof colour, "#%02x%02x%02x", top[0], top[1], top[2]);
    out += "<path d='M" + px(kLeft + kWidth) + " 4L" + px(kLeft + kWidth + kArrow) + " " + px(4 + kHeight / 2) + "L" +
           px(kLeft + kWidth) + " " + px(4 + kHeight) + "Z' fill='" + colour + "' stroke='#444'/>";
  }
  for (const auto& [v, text] : nice_ticks(0, scale, 7)) {
    const double x = kLeft + v / scale * kWidth;
    out += "<path d='M" + px(x) + " " + px(4 + kHeight) + "V" + px(8 + kHeight) + "' stroke='#444'/>" +
           text_at(x, 20 + kHeight, text, "middle", " font-size='10'");
  }
  return out + text_at(kLeft + kWidth / 2, 40 + kHeight, label, "middle", " font-size='11'") + "</svg>";
}

}  // namespace rgs::audit::detail
