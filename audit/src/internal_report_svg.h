// The report's figures as inline SVG written by the audit: line and point plots on stacked panels, horizontal
// stacked bars and a colour bar, and the text helpers the report's HTML (and the audit's notes) share with them.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace rgs::audit::detail {

/// `text` with & < > " ' as character references: safe in HTML and SVG text and in quoted attributes.
std::string escape_html(std::string_view text);
/// printf-style formatting of one number (e.g. "%.2f", "%g", "%.3e"), with a decimal point whatever the locale.
std::string format_number(const char* format, double value);

/// A colour of matplotlib's default cycle ("tab10"), i modulo 10.
const char* cycle_colour(size_t i);

/// One series of a panel: a line through its points and/or a marker at each.
struct PlotSeries {
  std::string label;   ///< legend text; empty: not in the legend
  std::string kind;    ///< data-kind of the series' group (what the test and a reader look up)
  std::string colour;  ///< CSS colour
  std::string dash;    ///< SVG stroke-dasharray; empty: solid
  bool line = true;    ///< joins consecutive finite points (a non-finite y breaks the line)
  char marker = 0;     ///< 0 none, 'o' circle, 's' square, '^' triangle
  std::vector<double> x, y;  ///< equal lengths; +inf y is drawn as an open triangle at the top edge
  std::vector<double> y_low;  ///< empty, or per point the bottom of a bar drawn down from y
  std::vector<std::string> notes;  ///< empty, or per point a text written beside it
  std::vector<std::string> tips;   ///< empty, or per point its tooltip
  bool in_legend = true;           ///< false: the label only names the series' group (data-label)
};

/// A horizontal line across a panel (the threshold, the gate).
struct PlotLine {
  double y = 0;
  std::string colour, dash, label;
};

/// One panel: axes, series and horizontal lines.
struct PlotPanel {
  std::string kind;  ///< data-panel of the panel's group
  std::string title, x_label, y_label;
  double x_lo = 0, x_hi = 1, y_lo = 0, y_hi = 1;
  bool x_log = false;
  /// Labelled x ticks (drawn rotated); empty: numeric ticks chosen from the range. Only the bottom panel of a
  /// figure draws x tick labels and the x label.
  std::vector<std::pair<double, std::string>> x_ticks;
  std::vector<PlotSeries> series;
  std::vector<PlotLine> lines;
};

/// Panels stacked top to bottom, `width` x `panel_height` pixels each, sharing their x axis, with one legend
/// under them (every labelled series and line, first occurrence of a label only).
/// @param kind  data-plot of the <svg> element.
std::string svg_plot(const std::string& kind, const std::vector<PlotPanel>& panels, double width,
                     double panel_height);

/// One horizontal bar of stacked segments.
struct BarRow {
  std::string label;
  std::vector<std::pair<size_t, double>> segments;  ///< (key index, length), drawn left to right
};

/// Horizontal stacked bars, one row per BarRow, top to bottom; `keys` are (label, colour) of the legend.
std::string svg_bars(const std::string& kind, const std::string& title, const std::string& x_label,
                     const std::vector<BarRow>& rows, const std::vector<std::pair<std::string, std::string>>& keys,
                     double width);

/// A horizontal colour bar of inferno from 0 to `scale`, with an arrow when `largest` exceeds it, ticks and
/// `label` under it. `id` makes its gradient's id unique in the page.
std::string svg_colour_bar(double scale, double largest, const std::string& label, const std::string& id);

}  // namespace rgs::audit::detail
