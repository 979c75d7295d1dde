#include "rgs/audit/report_html.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>

#include "report_assets.h"
#include "internal_report_image.h"
#include "internal_report_svg.h"
#include "rgs/format/file_io.h"

namespace rgs::audit {

namespace {

using detail::escape_html;
using detail::format_number;
using nlohmann::json;

// The PSNR axes span at least this many dB (threshold included), so that a fraction of a dB between views does
// not fill the plot.
constexpr double kMinPsnrSpanDb = 10.0;
// The size-against-quality plot stops here: higher means (lossless files, PSNR limited by float arithmetic) are
// drawn at this edge with their value written, so that they do not flatten the lossy candidates.
constexpr double kSizeQualityTopDb = 100.0;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kDash = "\xE2\x80\x93";  // en dash: no value

std::string esc(const json& v) { return escape_html(v.is_string() ? v.get<std::string>() : v.dump()); }
std::string fixed(double v, int digits) { return format_number(("%." + std::to_string(digits) + "f").c_str(), v); }
std::string fixed(const json& v, int digits) { return fixed(v.get<double>(), digits); }
std::string general(double v) { return format_number("%g", v); }
std::string sci(const json& v) { return format_number("%.3e", v.get<double>()); }
std::string group(const json& v) { return rgs::group_digits(v.get<long long>()); }

/// A dB value of the JSON: a number, "inf" / "-inf", or null (NaN: no value).
double number(const json& v) {
  if (v.is_string()) {
    const std::string s = v.get<std::string>();
    if (s == "inf" || s == "-inf") return s == "inf" ? INFINITY : -INFINITY;
  }
  return v.is_null() ? kNan : v.get<double>();
}

detail::PlotSeries series(std::string label, const char* kind, const char* colour, const char* dash, bool line,
                          char marker) {
  detail::PlotSeries s;
  s.label = std::move(label), s.kind = kind, s.colour = colour, s.dash = dash, s.line = line, s.marker = marker;
  return s;
}

/// The cells of a table row: "<td>a</td><td>b</td>..." (`tag` "th": a header row's).
std::string cells(std::initializer_list<std::string> texts, const char* tag = "td") {
  std::string out;
  for (const std::string& text : texts) out += std::string("<") + tag + ">" + text + "</" + tag + ">";
  return out;
}

/// A member that may be missing or null: null then.
const json& member(const json& j, const char* key) {
  static const json kNull;
  const auto it = j.find(key);
  return it == j.end() ? kNull : *it;
}

/// The report's text of a dB value: "inf" as written, a dash for none, else two decimals.
std::string num(const json& v, int digits = 2) {
  if (v.is_string()) return escape_html(v.get<std::string>());
  return v.is_null() ? kDash : fixed(v, digits);
}

std::string metric_words(const json& doc) {
  return member(member(doc, "verdict"), "metric") == "foreground" ? "foreground" : "whole frame";
}

/// The verdict's threshold and the --min-psnr gate as horizontal lines.
std::vector<detail::PlotLine> threshold_lines(const json& doc) {
  std::vector<detail::PlotLine> lines;
  const std::string what = metric_words(doc);
  if (const json& v = member(doc, "verdict"); !v.is_null()) {
    const double t = v.at("threshold_db").get<double>();
    lines.push_back({t, "crimson", "", "threshold " + general(t) + " dB (mean, " + what + ")"});
  }
  if (const json& g = member(doc, "gate"); !g.is_null()) {
    const double m = g.at("min_psnr_db").get<double>();
    lines.push_back({m, "crimson", "1.5,3", "--min-psnr " + general(m) + " dB (each view, " + what + ")"});
  }
  return lines;
}

/// y limits (dB) holding every finite value and every line, at least kMinPsnrSpanDb wide, 5% padding.
void psnr_limits(const std::vector<double>& values, const std::vector<detail::PlotLine>& lines,
                 detail::PlotPanel* panel) {
  double lo = INFINITY, hi = -INFINITY;
  for (double v : values) {
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  }
  for (const auto& l : lines) lo = std::min(lo, l.y), hi = std::max(hi, l.y);
  if (!(hi >= lo)) lo = 0, hi = kMinPsnrSpanDb;
  if (hi - lo < kMinPsnrSpanDb) {
    const double mid = (lo + hi) / 2;
    lo = mid - kMinPsnrSpanDb / 2, hi = mid + kMinPsnrSpanDb / 2;
  }
  const double pad = 0.05 * (hi - lo);
  panel->y_lo = lo - pad, panel->y_hi = hi + pad;
  panel->lines = lines;
}

std::string plot_views(const json& doc) {
  const json& views = doc.at("views");
  const size_t n = views.size();
  const char marker = n <= 40 ? 'o' : 0;
  detail::PlotPanel psnr, ssim;
  psnr.kind = "psnr", ssim.kind = "ssim";
  psnr.title = "Per-view quality against the source render";
  psnr.y_label = "PSNR (dB)", ssim.y_label = "SSIM", ssim.x_label = "view";
  const double pad = std::max(0.5, 0.03 * double(n));
  psnr.x_lo = ssim.x_lo = -pad, psnr.x_hi = ssim.x_hi = double(n) - 1 + pad;
  if (n <= 30) {  // both panels, so that their grids match; the bottom one writes the names
    for (size_t k = 0; k < n; ++k) ssim.x_ticks.emplace_back(double(k), views[k].at("name").get<std::string>());
    psnr.x_ticks = ssim.x_ticks;
  }
  std::vector<double> shown;
  double ssim_low = 1.0;
  const json& cands = doc.at("candidates");
  for (size_t i = 0; i < cands.size(); ++i) {
    const json& c = cands[i];
    const std::string label = c.at("label").get<std::string>();
    const char* colour = detail::cycle_colour(i);
    detail::PlotSeries whole = series(label + " (whole frame)", "whole_frame", colour, "", true, marker);
    detail::PlotSeries fg = series(label + " (foreground)", "foreground", colour, "6,3", true, marker);
    detail::PlotSeries s = series(label, "ssim", colour, "", true, marker);
    s.in_legend = false;
    bool any_fg = false;
    for (size_t k = 0; k < c.at("views").size() && k < n; ++k) {
      const json& v = c.at("views")[k];
      const std::string view = views[k].at("name").get<std::string>();
      whole.x.push_back(double(k)), fg.x.push_back(double(k)), s.x.push_back(double(k));
      whole.y.push_back(number(v.at("psnr_db")));
      whole.tips.push_back(label + ", " + view + ": " + num(v.at("psnr_db")) + " dB");
      fg.y.push_back(number(member(v, "foreground_psnr_db")));
      fg.tips.push_back(label + ", " + view + ": foreground " + num(member(v, "foreground_psnr_db")) + " dB");
      any_fg = any_fg || !std::isnan(fg.y.back());  // +inf too: an identical foreground
      s.y.push_back(v.at("ssim").get<double>());
      s.tips.push_back(label + ", " + view + ": SSIM " + fixed(s.y.back(), 5));
      ssim_low = std::min(ssim_low, s.y.back());
    }
    shown.insert(shown.end(), whole.y.begin(), whole.y.end());
    psnr.series.push_back(std::move(whole));
    if (any_fg) {
      shown.insert(shown.end(), fg.y.begin(), fg.y.end());
      psnr.series.push_back(std::move(fg));
    }
    ssim.series.push_back(std::move(s));
  }
  psnr_limits(shown, threshold_lines(doc), &psnr);
  ssim.y_lo = std::min(ssim_low, 0.99) - 0.0005, ssim.y_hi = 1.0005;  // at least 0.01 wide, 1 at the top
  return detail::svg_plot("views", {psnr, ssim}, 1000, 220);
}

std::string plot_sizes(const json& doc) {
  static const std::vector<std::string> kOrder = {"means", "rotations", "scales", "opacities",
                                                  "sh", "metadata", "provenance"};
  const json& cands = doc.at("candidates");
  std::vector<std::string> names;
  for (const json& c : cands) {
    for (const json& s : c.at("sections")) {
      const std::string name = s.at("name").get<std::string>();
      if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    }
  }
  const auto rank = [&](const std::string& name) {
    return size_t(std::find(kOrder.begin(), kOrder.end(), name) - kOrder.begin());
  };
  std::stable_sort(names.begin(), names.end(), [&](const std::string& a, const std::string& b) {
    return rank(a) != rank(b) ? rank(a) < rank(b) : rank(a) == kOrder.size() && a < b;
  });
  std::vector<std::pair<std::string, std::string>> keys = {{"whole file", "#999999"}};
  for (size_t k = 0; k < names.size(); ++k) keys.emplace_back(names[k], detail::cycle_colour(k));
  keys.emplace_back("rest of file", "#cccccc");
  std::vector<detail::BarRow> rows = {{"source", {{0, doc.at("source").at("bytes_per_gaussian").get<double>()}}}};
  for (const json& c : cands) {
    detail::BarRow row{c.at("label").get<std::string>(), {}};
    double rest = c.at("bytes_per_gaussian").get<double>();
    for (size_t k = 0; k < names.size(); ++k) {
      for (const json& s : c.at("sections")) {
        if (s.at("name") != names[k]) continue;
        row.segments.emplace_back(k + 1, s.at("bytes_per_gaussian").get<double>());
        rest -= row.segments.back().second;
      }
    }
    row.segments.emplace_back(keys.size() - 1, rest);
    rows.push_back(std::move(row));
  }
  return detail::svg_bars("sizes", "Size per Gaussian, by section", "bytes per Gaussian", rows, keys, 1000);
}

/// "archive@40" -> "archive": candidates labelled SERIES@POINT are drawn as one rate-distortion curve.
std::string curve_name(const std::string& label) {
  const size_t at = label.find('@');
  return at == std::string::npos ? std::string() : label.substr(0, at);
}

std::string plot_size_quality(const json& doc) {
  detail::PlotPanel panel;
  panel.kind = "size_quality";
  panel.x_label = "bytes per Gaussian";
  panel.y_label = "PSNR (dB): mean, bar down to the worst view";
  std::vector<double> shown, sizes;
  std::map<std::string, std::vector<std::array<double, 3>>> curves;  // (bytes per Gaussian, mean, worst view)
  const json& cands = doc.at("candidates");
  for (size_t i = 0; i < cands.size(); ++i) {
    const json& c = cands[i];
    const std::string label = c.at("label").get<std::string>();
    const double mean = number(c.at("psnr_db").at("mean")), low = number(c.at("psnr_db").at("min"));
    const double bytes = c.at("bytes_per_gaussian").get<double>();
    if (std::isnan(mean) || mean == -INFINITY || !(bytes > 0)) continue;
    sizes.push_back(bytes);
    shown.push_back(std::min(mean, kSizeQualityTopDb));
    shown.push_back(std::min(low, kSizeQualityTopDb));
    if (const std::string name = curve_name(label); !name.empty()) {
      curves[name].push_back({bytes, mean, low});
      continue;
    }
    detail::PlotSeries point = series(label, "candidate", detail::cycle_colour(i), "", false, 'o');
    point.x = {bytes}, point.y = {mean};
    point.in_legend = false;
    point.tips = {label + ": " + num(c.at("psnr_db").at("mean")) + " dB mean, worst view " +
                  num(c.at("psnr_db").at("min")) + " dB"};
    if (mean > kSizeQualityTopDb) {  // near-lossless: drawn at the top edge, its value written
      point.marker = '^';
      point.y = {kSizeQualityTopDb};
      point.notes = {label + " (" + (std::isinf(mean) ? std::string("inf") : fixed(mean, 0)) + " dB)"};
    } else {
      point.y_low = {low};
      point.notes = {label};
    }
    panel.series.push_back(std::move(point));
  }
  size_t k = cands.size();
  for (auto& [name, points] : curves) {
    std::sort(points.begin(), points.end());
    const char* colour = detail::cycle_colour(k++);
    detail::PlotSeries mean = series(name + ": mean", "curve_mean", colour, "", true, 's');
    detail::PlotSeries worst = series(name + ": worst view", "curve_worst", colour, "1.5,3", true, 0);
    for (const auto& p : points) {
      mean.x.push_back(p[0]), mean.y.push_back(std::min(p[1], kSizeQualityTopDb));
      mean.tips.push_back(name + " at " + fixed(p[0], 2) + " B/Gaussian: " + fixed(p[1], 2) + " dB mean");
      worst.x.push_back(p[0]), worst.y.push_back(std::min(p[2], kSizeQualityTopDb));
    }
    panel.series.push_back(std::move(mean));
    panel.series.push_back(std::move(worst));
  }
  psnr_limits(shown, threshold_lines(doc), &panel);
  const double lo = sizes.empty() ? 1 : *std::min_element(sizes.begin(), sizes.end());
  const double hi = sizes.empty() ? 2 : *std::max_element(sizes.begin(), sizes.end());
  panel.x_log = hi > 8 * lo;
  if (panel.x_log) {
    panel.x_lo = lo / std::pow(hi / lo, 0.06), panel.x_hi = hi * std::pow(hi / lo, 0.06);
  } else {
    const double pad = hi > lo ? 0.06 * (hi - lo) : 0.1 * hi;
    panel.x_lo = std::max(0.0, lo - pad), panel.x_hi = hi + pad;
  }
  panel.title = "Size against quality" +
                std::string(curves.empty() ? "" : ": rate-distortion curves (labels SERIES@POINT) and points");
  return detail::svg_plot("size_quality", {panel}, 760, 300);
}

std::string verdict_html(const json& doc) {
  const json& v = member(doc, "verdict");
  if (v.is_null()) {
    return "<div id='verdict' class='verdict'><b>No verdict</b>: this JSON was written before rgs-audit had one "
           "(run the audit again).</div>";
  }
  const double t = v.at("threshold_db").get<double>();
  const json& cands = doc.at("candidates");
  const std::string metric = member(v, "metric").is_string() ? v.at("metric").get<std::string>() : "whole_frame";
  const std::string what = metric_words(doc);
  const bool all = v.at("passed").get<bool>();
  size_t passed = 0;
  std::string items;
  for (const json& c : cands) {
    const json& cv = c.at("verdict");
    const bool ok = cv.at("passed").get<bool>();
    passed += ok;
    const json& saved = member(cv, "bytes_saved");
    std::string size = "no file size";
    if (!saved.is_null()) {
      const long long s = saved.get<long long>();
      const double fraction = 100 * cv.at("bytes_saved_fraction").get<double>();
      size = (s >= 0 ? "saves " : "adds ") + rgs::group_digits(s >= 0 ? s : -s) + " bytes (" +
             fixed(s >= 0 ? fraction : -fraction, 0) + "% of the source)";
    }
    const json& wv = cv.at("worst_view");
    const json& lost_why = member(cv, "content_lost");
    const std::string lost = lost_why.is_null() ? "" : "lost its content (" + esc(lost_why) + "); ";
    const json& mean = cv.at("psnr_mean_db");
    const bool at_least = mean == "inf" || (mean.is_number() && mean.get<double>() >= t);
    const std::string beside =
        metric == "foreground" ? " (whole frame " + num(cv.at("whole_frame_psnr_mean_db")) + " dB)" : "";
    const std::string cls = ok ? "gate-pass" : "gate-fail";
    items += "<li class='verdict-cand' data-label='" + esc(c.at("label")) + "' data-passed='" +
             (ok ? "true" : "false") + "' data-metric='" + escape_html(metric) + "' data-psnr-mean='" +
             num(cv.at("psnr_mean_db")) + "' data-worst-view='" + esc(wv.at("name")) + "' data-worst-psnr='" +
             num(wv.at("psnr_db")) + "'><b class='" + cls + "'>" + (ok ? "PASS" : "FAIL") + "</b> " +
             esc(c.at("label")) + ": " + lost + "mean " + what + " PSNR " + num(cv.at("psnr_mean_db")) + " dB " +
             (at_least ? "&ge; " : "&lt; ") + general(t) + " dB" + beside + "; worst view " + esc(wv.at("name")) + " " +
             num(wv.at("psnr_db")) + " dB; " + size + "</li>";
  }
  const std::string why = metric == "foreground" ? " The foreground PSNR decides: the black background raises the "
                                                   "whole-frame PSNR (below)."
                                                 : "";
  return "<div id='verdict' class='verdict' data-passed='" + std::string(all ? "true" : "false") +
         "' data-threshold='" + general(t) + "' data-metric='" + escape_html(metric) + "'><b class='" +
         (all ? "gate-pass" : "gate-fail") + "'>" + (all ? "PASS" : "FAIL") + "</b>: " + std::to_string(passed) +
         " of " + std::to_string(cands.size()) + " candidate(s) have a mean " + what +
         " PSNR over the views of at least " + general(t) + " dB (rgs-audit --threshold)." + why + "<ul>" + items +
         "</ul></div>";
}

/// Why the whole-frame PSNR is inflated by the black background, with this audit's numbers.
std::string background_note(const json& doc) {
  const json& cands = doc.at("candidates");
  if (cands.empty()) return "";
  double sum = 0, low = INFINITY;
  size_t n = 0;
  for (const json& v : cands[0].at("views")) {
    if (!v.contains("foreground_fraction")) continue;
    const double f = v.at("foreground_fraction").get<double>();
    sum += f, low = std::min(low, f), ++n;
  }
  if (n == 0 || low >= 1.0) return "";
  const double f = sum / double(n);
  const std::string extra = f > 0 ? fixed(10 * std::log10(1 / f), 1) : "inf";
  return "<p class='note'>The renders have a black background, equal in both images, and the scene covers " +
         fixed(100 * f, 0) + "% of the frame on average: the background's zero errors dilute the whole-frame MSE, "
         "raising its PSNR by 10&middot;log10(1/" + fixed(f, 2) + ") = " + extra + " dB for the same error on the "
         "scene, so the foreground PSNR (over the pixels where the source render's alpha or colour is not "
         "background) is the one to compare between scenes.</p>";
}

std::string stats_row(const std::string& name, const json& s, const std::string& unit) {
  return "<tr>" + cells({escape_html(name), sci(s.at("max")), sci(s.at("rms")), escape_html(unit)}) + "</tr>";
}

/// The per-attribute errors of a candidate and how its Gaussians were paired, or why there are none.
std::string errors_html(const json& c) {
  const json& e = member(c, "errors");
  if (e.is_null()) {
    const json& note = member(c, "errors_note");
    return "<p>" + (note.is_string() ? esc(note) : std::string("no per-attribute errors")) + "</p>";
  }
  std::string out = "<table><tr><th>attribute error</th><th>max</th><th>rms</th><th>unit</th></tr>" +
                    stats_row("position", e.at("position_scene_units"), "scene units") +
                    stats_row("rotation", e.at("rotation_deg"), "degrees");
  if (e.contains("scale_of_largest_axis")) {  // reports before it existed show the per-axis relative error
    out += stats_row("scale", e.at("scale_of_largest_axis"), "of the Gaussian's largest axis");
  } else {
    out += stats_row("scale", e.at("scale_relative"), "relative");
  }
  out += stats_row("opacity", e.at("opacity"), "absolute");
  for (const json& d : e.at("sh")) {
    out += stats_row("SH degree " + d.at("degree").dump(), d.at("error"), "absolute");
    for (const json& ch : d.at("channels")) {
      const std::string note = ch.contains("scale") ? "scale " + sci(ch.at("scale")) + ", " +
                                                          group(ch.at("clipped")) + " clipped"
                                                    : "";
      out += stats_row("  " + ch.at("channel").get<std::string>(), ch.at("error"), note);
    }
  }
  out += "</table>";
  const json& pairing = member(e, "pairing");  // reports before it existed paired index by index
  std::string text = "Gaussians paired index by index (the source's Gaussians in its order)";
  if (!pairing.is_null() && pairing.at("method") == "content") {
    text = "Gaussians paired by content: each with a source Gaussian within " +
           sci(pairing.at("position_tolerance_scene_units")) + " scene units";
  }
  if (!pairing.is_null() && pairing.at("source_gaussians_unpaired").get<long long>() != 0) {
    text += "; " + group(pairing.at("source_gaussians_unpaired")) + " source Gaussians not in the candidate";
  }
  return out + "<p>" + escape_html(text) + ".</p>";
}

/// Source and candidate stacked; the slider moves the split (source left, candidate right), flip swaps
/// between all source and all candidate. Driven by audit/report/report.js.
std::string compare_widget(const std::string& source_uri, const std::string& candidate_uri, const json& label) {
  return "<figure class='compare' data-split='50'><div class='stack'><img class='view under' alt='source' src='" +
         source_uri + "'><img class='view over' alt='" + esc(label) + "' src='" + candidate_uri +
         "' style='clip-path: inset(0 0 0 50%)'><div class='divider' style='left: 50%'></div></div>"
         "<div class='controls'><input type='range' class='slider' min='0' max='100' value='50' "
         "aria-label='split between source and " + esc(label) + "'><button type='button' class='flip'>flip</button>"
         "</div><figcaption>left of the line: source, right: " + esc(label) + " (drag, or flip)</figcaption></figure>";
}

/// A candidate's colour bar and worst views, each as the compare widget beside its heatmap.
Result<std::string> worst_views_html(const json& doc, size_t index, const json& c,
                                     const ReportImageReader& read_image) {
  const json& worst = c.at("worst_views");
  if (worst.empty()) return std::string();
  std::string out = "<h3>Worst views: source against candidate, and the difference</h3>";
  const json& scale_json = member(c, "heat_scale");
  const bool any_diff = std::any_of(worst.begin(), worst.end(), [](const json& w) { return w.contains("diff_image"); });
  const double largest = c.at("max_abs_diff").get<double>();
  if (!scale_json.is_null() && any_diff) {
    const double scale = scale_json.get<double>();
    const double pct = doc.value("heat_scale_percentile", 99.0);
    const std::string top =
        scale > 0 ? "the top of the colour bar is " + fixed(scale, 4) + ", the " + general(pct) +
                        "th percentile of the non-zero |d| of these heatmaps; larger |d|, up to the largest, " +
                        fixed(largest, 4) + ", take the top colour"
                  : "this candidate does not differ from the source here, so its heatmaps are black";
    out += "<p class='note'>Heatmaps of " + esc(c.at("label")) + " on its own scale: black is no difference; " + top +
           ". Compare candidates by the numbers, not by brightness.</p><div class='colorbar' data-heat-scale='" +
           scale_json.dump() + "' data-max-abs-diff='" + c.at("max_abs_diff").dump() + "'>" +
           detail::svg_colour_bar(scale > 0 ? scale : 1.0, largest,
                                  "|d|, max over R, G, B (clamped values); largest " + fixed(largest, 4),
                                  "rgs-heat-" + std::to_string(index)) +
           "</div>";
  }
  std::map<std::string, const json*> per_view;
  for (const json& v : c.at("views")) per_view[v.at("name").get<std::string>()] = &v;
  for (const json& w : worst) {
    if (!w.contains("source_image")) continue;
    std::string uri[3];
    const char* keys[3] = {"source_image", "candidate_image", "diff_image"};
    for (int k = 0; k < 3; ++k) {
      const std::string name = w.at(keys[k]).get<std::string>();
      RGS_ASSIGN_OR_RETURN(const Image8 image, read_image(name));
      RGS_ASSIGN_OR_RETURN(uri[k], detail::png_data_uri(image, k == 2));
    }
    const auto view = per_view.find(w.at("name").get<std::string>());
    RGS_RETURN_ERROR_IF(view == per_view.end(), StatusCode::kInvalidArgument,
                        "worst view " + w.at("name").dump() + " is not among the candidate's views");
    const json& v = *view->second;
    const double scale = w.at("heat_scale").get<double>(), view_max = v.at("max_abs_diff").get<double>();
    const std::string cap = "|d| max over RGB: largest here " + fixed(view_max, 4) + "; colour bar above: 0 to " +
                            fixed(scale, 4) + (view_max > scale ? " and more" : "");
    const std::string fg =
        v.contains("foreground_psnr_db") ? ", foreground " + num(v.at("foreground_psnr_db")) + " dB" : "";
    out += "<div class='worst'><p><b>" + esc(w.at("name")) + "</b>: PSNR " + num(w.at("psnr_db")) + " dB" + fg +
           "</p><div class='row'>" + compare_widget(uri[0], uri[1], c.at("label")) +
           "<figure><img class='view heatmap' data-heat-scale='" + w.at("heat_scale").dump() + "' data-max-abs-diff='" +
           v.at("max_abs_diff").dump() + "' alt='difference' src='" + uri[2] + "'><figcaption>" + escape_html(cap) +
           "</figcaption></figure></div></div>";
  }
  return out;
}

Result<std::string> candidate_section(const json& doc, size_t index, const json& c,
                                      const ReportImageReader& read_image) {
  std::string out = "<section class='cand'><h2>" + esc(c.at("label")) + " <small>" + esc(c.at("path")) + " (" +
                    esc(c.at("format")) + ")</small></h2>";
  const json& fg = member(c, "foreground_psnr_db");
  const std::string fg_text = fg.is_null() ? "" : "foreground PSNR mean " + num(member(fg, "mean")) + " dB, min " +
                                                      num(member(fg, "min")) + " dB; ";
  const json& reference = member(c, "reference");
  if (!reference.is_null()) out += "<p class='reference'>Compared with " + esc(reference.at("description")) + ".</p>";
  out += "<p>" + group(c.at("bytes")) + " bytes, " + fixed(c.at("bytes_per_gaussian"), 2) + " B/Gaussian, ratio " +
         fixed(c.value("ratio", 0.0), 2) + "x to the source; PSNR mean " + num(c.at("psnr_db").at("mean")) +
         " dB, min " + num(c.at("psnr_db").at("min")) + " dB; " + fg_text + "worst view " + esc(c.at("worst_view")) + "; " +
         "SSIM mean " + fixed(c.at("ssim").at("mean"), 5) + ", min " + fixed(c.at("ssim").at("min"), 5) +
         "; max |d| " + fixed(c.at("max_abs_diff"), 4) + ".</p><div class='cols'>";
  if (!c.at("sections").empty()) {
    out += "<table><tr>" + cells({"section", "codec", "bytes", "B/Gaussian"}, "th") + "</tr>";
    for (const json& s : c.at("sections")) {
      out += "<tr>" + cells({esc(s.at("name")), esc(s.at("codec")), group(s.at("bytes")),
                             fixed(s.at("bytes_per_gaussian"), 3)}) + "</tr>";
    }
    const long long overhead = c.value("header_table_padding_bytes", 0LL);
    const double gaussians = double(std::max(c.at("gaussians").get<long long>(), 1LL));
    out += "<tr>" + cells({"header, table, padding", "", rgs::group_digits(overhead),
                           fixed(double(overhead) / gaussians, 3)}) + "</tr></table>";
  }
  out += errors_html(c) + "</div>";
  RGS_ASSIGN_OR_RETURN(const std::string worst, worst_views_html(doc, index, c, read_image));
  return out + worst + "</section>";
}

std::string views_table(const json& doc) {
  const json& cands = doc.at("candidates");
  std::string head, rows;
  for (const json& c : cands) head += cells({esc(c.at("label")) + " PSNR", "PSNR fg", "SSIM", "max |d|"}, "th");
  const json& views = doc.at("views");
  for (size_t k = 0; k < views.size(); ++k) {
    const std::string size = views[k].at("width").dump() + "x" + views[k].at("height").dump();
    rows += "<tr>" + cells({esc(views[k].at("name")), size});
    for (const json& c : cands) {
      const json& v = c.at("views").at(k);
      rows += cells({num(v.at("psnr_db")), num(member(v, "foreground_psnr_db")), fixed(v.at("ssim"), 5),
                     fixed(v.at("max_abs_diff"), 4)});
    }
    rows += "</tr>";
  }
  return "<details><summary>Per-view table (" + std::to_string(views.size()) + " views)</summary><table><tr>" +
         cells({"view", "size"}, "th") + head + "</tr>" + rows + "</table></details>";
}

/// The heading, the source's line and the summary table with its notes.
std::string summary_html(const json& doc) {
  const json& src = doc.at("source");
  const json& cands = doc.at("candidates");
  const json& first = doc.at("views").at(0);
  std::string gate_html;
  if (const json& gate = member(doc, "gate"); !gate.is_null()) {
    const bool passed = gate.at("passed").get<bool>();
    gate_html = "; gate --min-psnr " + general(gate.at("min_psnr_db").get<double>()) + " dB: <b class='" +
                (passed ? "gate-pass'>passed" : "gate-fail'>FAILED") + "</b>";
  }
  const std::string backend = doc.at("backend").get<std::string>();
  std::string out = "<h1>rgs-audit: " + esc(src.at("path")) + "</h1><p>Source: " + esc(src.at("format")) + ", " +
                    group(src.at("gaussians")) + " Gaussians (SH degree " + src.at("sh_degree").dump() + "), " +
                    group(src.at("bytes")) + " bytes (" + fixed(src.at("bytes_per_gaussian"), 1) +
                    " B/Gaussian). " + std::to_string(doc.at("views").size()) + " views (" + first.at("width").dump() +
                    "x" + first.at("height").dump() + " first), " + std::to_string(cands.size()) +
                    " candidate(s); backend <b>" + escape_html(backend) + "</b> (" + esc(doc.at("device")) + "), " +
                    esc(doc.at("renderer")) + "; " + fixed(doc.at("time_seconds").at("total"), 1) +
                    " s" + gate_html + ". rgs-audit " + esc(doc.value("tool_version", "")) + ".</p><table><tr>" +
                    cells({"candidate", "format", "bytes", "B/Gaussian", "ratio", "PSNR mean", "PSNR min",
                           "PSNR fg mean", "PSNR fg min", "SSIM mean", "SSIM min", "max |d|", "load s", "render s"},
                          "th") +
                    "</tr>";
  for (const json& c : cands) {
    const json& fg = member(c, "foreground_psnr_db");
    const double load = c.value("load_seconds", 0.0);
    out += "<tr>" +
           cells({esc(c.at("label")), esc(c.at("format")), group(c.at("bytes")), fixed(c.at("bytes_per_gaussian"), 2),
                  fixed(c.value("ratio", 0.0), 2) + "x", num(c.at("psnr_db").at("mean")),
                  num(c.at("psnr_db").at("min")), num(member(fg, "mean")), num(member(fg, "min")),
                  fixed(c.at("ssim").at("mean"), 5), fixed(c.at("ssim").at("min"), 5), fixed(c.at("max_abs_diff"), 4),
                  load != 0 ? fixed(load, 2) : kDash,
                  c.contains("render_seconds") ? fixed(c.at("render_seconds"), 2) : kDash}) +
           "</tr>";
  }
  return out + "</table><p class='note'>PSNR fg: over the foreground. load s: reading and decoding the file (source " +
         fixed(src.value("load_seconds", 0.0), 2) + " s). render s: the candidate's renders, summed over the views (" +
         escape_html(backend) + " backend" + (backend == "cuda" ? ", until the device finished each" : "") +
         ").</p>" + background_note(doc);
}

/// The text of the embedded file `path` (audit/report/, the generated report_assets.h).
std::string asset_text(const char* path) {
  const detail::Asset* asset = detail::find_asset(path);
  assert(asset != nullptr);  // audit/CMakeLists.txt embeds every file the page names
  return std::string(reinterpret_cast<const char*>(asset->data), asset->size);
}

Result<std::string> page(const json& doc, const ReportImageReader& read_image) {
  RGS_RETURN_ERROR_IF(doc.value("schema", "") != kAuditSchemaName ||
                          doc.value("schema_version", 0) != kAuditSchemaVersion,
                      StatusCode::kInvalidArgument,
                      std::string("not an rgs-audit JSON of schema version ") + std::to_string(kAuditSchemaVersion));
  RGS_RETURN_ERROR_IF(doc.at("views").empty() || doc.at("candidates").empty(), StatusCode::kInvalidArgument,
                      "an rgs-audit JSON without views or candidates");
  const json& src = doc.at("source");
  const json& cands = doc.at("candidates");
  std::string out = "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'><title>rgs-audit: " +
                    esc(src.at("label")) + " " +
                    escape_html(std::filesystem::path(src.at("path").get<std::string>()).filename().string()) +
                    "</title><style>\n" + asset_text("/report.css") + "</style><script>\n" + asset_text("/report.js") +
                    "</script></head><body>\n" +
                    verdict_html(doc) + "\n" + summary_html(doc) + "\n";
  if (cands.size() > 1) out += "<div class='plot'>" + plot_size_quality(doc) + "</div>\n";
  out += "<div class='plot'>" + plot_views(doc) + "</div>\n" + views_table(doc) + "\n<div class='plot'>" +
         plot_sizes(doc) + "</div>\n";
  const bool any_diff = std::any_of(cands.begin(), cands.end(), [](const json& c) {
    const json& w = c.at("worst_views");
    return std::any_of(w.begin(), w.end(), [](const json& v) { return v.contains("diff_image"); });
  });
  if (any_diff) {
    out += "<h2>Differences</h2><p class='note'>Each candidate's heatmaps are on its own scale, under its own colour "
           "bar, so that every candidate's structure shows (one shared scale topped by one candidate's brightest "
           "pixel leaves the others black); the largest |d| is written beside each. Heatmaps reduced for the page "
           "keep the largest |d| of each block.</p>\n";
  }
  for (size_t i = 0; i < cands.size(); ++i) {
    RGS_ASSIGN_OR_RETURN(const std::string section, candidate_section(doc, i, cands[i], read_image));
    out += section + "\n";
  }
  const json& metrics = doc.at("metrics");
  return out + "<p><small>PSNR: " + esc(metrics.at("psnr")) + ". SSIM: " + esc(metrics.at("ssim")) + ". max |d|: " +
         esc(metrics.at("max_abs_diff")) + ". Command: <code>" + esc(doc.value("command", "")) +
         "</code></small></p></body></html>\n";
}

}  // namespace

Result<std::string> report_html(const std::string& json_text, const ReportImageReader& read_image) {
  try {
    const json doc = json::parse(json_text);
    return page(doc, read_image);
  } catch (const json::exception& e) {
    return Status(StatusCode::kInvalidArgument, std::string("not a complete rgs-audit JSON: ") + e.what());
  }
}

Result<std::string> report_html(const AuditResult& result, const ReportOptions& options) {
  ReportOptions named = options;
  if (named.image_dir.empty()) named.image_dir = "images/";  // any folder: the names only pair JSON and images
  std::map<std::string, const Image8*> images;
  for (const auto& [path, image] : report_images(result, named.image_dir)) images[path] = image;
  return report_html(audit_json(result, named), [&](const std::string& name) -> Result<Image8> {
    const auto it = images.find(name);
    RGS_RETURN_ERROR_IF(it == images.end(), StatusCode::kInvalidArgument, name + ": not an image of this audit");
    return *it->second;
  });
}

Result<std::string> report_html_from_file(const std::string& json_path) {
  RGS_ASSIGN_OR_RETURN(const auto file, format::MappedFile::open(json_path));
  const std::string text(reinterpret_cast<const char*>(file->data()), file->size());
  const std::filesystem::path base = std::filesystem::path(json_path).parent_path();
  auto html = report_html(text, [&](const std::string& name) { return read_netpbm((base / name).string()); });
  if (html.ok()) return html;
  Status st = html.status();
  return st.prepend(json_path);
}

}  // namespace rgs::audit
