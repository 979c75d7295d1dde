// The HTML report (audit::report_html): names escaped everywhere, +inf and NaN PSNR in the figures and tables,
// one view, many views, many candidates, the page from a JSON file equal to the page from memory, its images
// decoded back to the audit's pixels, JSON that is not an audit's refused, and the netpbm reader. Results made
// by hand where an edge case needs values no render gives; a real audit of guitar where one does.
#include <doctest/doctest.h>
#include <zlib.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "audit_test_util.h"
#include "rgs/audit/audit.h"
#include "rgs/audit/audit_report.h"
#include "rgs/audit/report_html.h"
#include "rgs/format/file_io.h"
#include "rgs/runtime/camera.h"

namespace {

using namespace rgs;

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

/// The <svg> element of data-plot `kind` (empty when there is none).
std::string plot(const std::string& html, const std::string& kind) {
  const size_t begin = html.find("<svg class='rgs-plot' data-plot='" + kind + "'");
  return begin == std::string::npos ? std::string() : html.substr(begin, html.find("</svg>", begin) + 6 - begin);
}

/// The data-points of every series group of `kind` in `svg`, in order.
std::vector<int> series_points(const std::string& svg, const std::string& kind) {
  std::vector<int> points;
  const std::regex series("<g class='series' data-kind='" + kind + "' data-label='[^']*' data-points='([0-9]+)'>");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), series); it != std::sregex_iterator(); ++it) {
    points.push_back(std::stoi((*it)[1]));
  }
  return points;
}

/// An 8-bit image whose pixels vary with x, y and `seed`.
audit::Image8 pattern(uint32_t width, uint32_t height, uint32_t channels, uint32_t seed) {
  audit::Image8 image{width, height, channels, {}};
  for (uint32_t i = 0; i < width * height * channels; ++i) image.pixels.push_back(uint8_t((i * 37 + seed * 11) % 256));
  return image;
}

/// A candidate's summary from its views, as run_audit computes it.
audit::Summary summarize(const std::vector<audit::ViewMetrics>& views) {
  audit::Summary s;
  s.psnr_min_db = s.ssim_min = s.foreground_psnr_min_db = INFINITY;
  size_t foreground = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    const audit::ViewMetrics& m = views[v];
    s.psnr_mean_db += m.psnr_db / double(views.size());
    s.ssim_mean += m.ssim / double(views.size());
    if (m.psnr_db < s.psnr_min_db) s.psnr_min_db = m.psnr_db, s.worst_view = v;
    s.ssim_min = std::min(s.ssim_min, m.ssim);
    s.max_abs_diff = std::max(s.max_abs_diff, m.max_abs_diff);
    if (!std::isnan(m.foreground_psnr_db)) {
      s.foreground_psnr_mean_db += m.foreground_psnr_db, ++foreground;
      s.foreground_psnr_min_db = std::min(s.foreground_psnr_min_db, m.foreground_psnr_db);
    }
  }
  s.foreground_psnr_mean_db = foreground ? s.foreground_psnr_mean_db / double(foreground) : NAN;
  if (foreground == 0) s.foreground_psnr_min_db = NAN;
  return s;
}

/// An audit of `views` views and `candidates` candidates made by hand: candidate i reads about 60 - 3i dB on the
/// whole frame and 12 dB less on the foreground, each with one worst view of 12x8 images.
audit::AuditResult made_result(size_t views, size_t candidates) {
  audit::AuditResult r;
  r.device = "made by hand";
  r.source = {"/scenes/source.ply", "source", "ply", 6'000'000, 90'000, 0, {}, 0, {}, 0.1};
  for (size_t v = 0; v < views; ++v) r.views.push_back({"view_" + std::to_string(v), 160, 90});
  for (size_t i = 0; i < candidates; ++i) {
    audit::CandidateResult c;
    c.scene = {"/scenes/c" + std::to_string(i) + ".rgs", "cand " + std::to_string(i), "rgs",
               3'000'000 - 150'000 * i, 90'000, 0,
               {{"means", "none", 1'080'000, 1'080'000}, {"sh", "zstd", 500'000 - 20'000 * i, 810'000}}, 1'000, {},
               0.05};
    c.attributes_note = "no per-attribute errors: made by hand";
    for (size_t v = 0; v < views; ++v) {
      audit::ViewMetrics m;
      m.psnr_db = 60.0 - 3.0 * double(i) + std::sin(double(v));
      m.foreground_psnr_db = m.psnr_db - 12.0;
      m.foreground_fraction = 0.06;
      m.ssim = 0.9995 - 0.0002 * double(i) - 0.0001 * std::cos(double(v));
      m.max_abs_diff = 0.01f * float(i + 1);
      c.views.push_back(m);
    }
    c.summary = summarize(c.views);
    audit::ViewImages w;
    w.view = c.summary.worst_view;
    w.psnr_db = c.views[w.view].psnr_db;
    w.source = pattern(12, 8, 3, uint32_t(i));
    w.candidate = pattern(12, 8, 3, uint32_t(i + 1));
    w.difference = pattern(12, 8, 1, uint32_t(i + 2));
    w.heat_scale = c.heat_scale = 0.004f;
    c.worst.push_back(w);
    r.candidates.push_back(c);
  }
  return r;
}

std::string html_of(const audit::AuditResult& r, const audit::ReportOptions& options = {}) {
  auto html = audit::report_html(r, options);
  REQUIRE_MESSAGE(html.ok(), html.status().to_string());
  return *html;
}

/// True when a coordinate of the page's figures is "nan" or "inf" (computed from a missing value).
bool has_non_finite_coordinate(const std::string& html) {
  return std::regex_search(
      html, std::regex(" (x|y|cx|cy|width|height|d|transform|viewBox)='[^']*(nan|inf)", std::regex::icase));
}

/// The pixels of a PNG written by report_html: 8-bit grey or RGB, not interlaced, any of the five filters.
audit::Image8 decode_png(const std::string& data_uri) {
  const std::string prefix = "data:image/png;base64,";
  REQUIRE(data_uri.rfind(prefix, 0) == 0);
  std::string png;
  uint32_t bits = 0, n = 0;
  for (char ch : data_uri.substr(prefix.size())) {
    const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    if (ch == '=') break;
    bits = bits << 6 | uint32_t(alphabet.find(ch)), n += 6;
    if (n >= 8) png.push_back(char((bits >> (n -= 8)) & 0xFF));
  }
  REQUIRE(png.substr(0, 8) == "\x89PNG\r\n\x1a\n");
  auto u32 = [&](size_t at) { return uint32_t(uint8_t(png[at])) << 24 | uint32_t(uint8_t(png[at + 1])) << 16 |
                                     uint32_t(uint8_t(png[at + 2])) << 8 | uint32_t(uint8_t(png[at + 3])); };
  audit::Image8 image;
  std::string idat;
  for (size_t at = 8; at + 12 <= png.size(); at += 12 + u32(at)) {
    const std::string type = png.substr(at + 4, 4);
    if (type == "IHDR") {
      image.width = u32(at + 8), image.height = u32(at + 12);
      image.channels = png[at + 17] == 2 ? 3 : 1;
    }
    if (type == "IDAT") idat += png.substr(at + 8, u32(at));
  }
  const size_t stride = size_t(image.width) * image.channels;
  std::vector<uint8_t> rows((stride + 1) * image.height);
  uLongf size = uLongf(rows.size());
  REQUIRE(uncompress(rows.data(), &size, reinterpret_cast<const Bytef*>(idat.data()), uLong(idat.size())) == Z_OK);
  REQUIRE(size == rows.size());
  for (uint32_t y = 0; y < image.height; ++y) {
    const uint8_t filter = rows[y * (stride + 1)];
    REQUIRE(filter <= 4);
    for (size_t i = 0; i < stride; ++i) {
      const size_t at = y * stride + i, bpp = image.channels;
      const int a = i >= bpp ? image.pixels[at - bpp] : 0, b = y ? image.pixels[at - stride] : 0;
      const int c = y && i >= bpp ? image.pixels[at - stride - bpp] : 0, p = a + b - c;
      const int paeth = std::abs(p - a) <= std::abs(p - b) && std::abs(p - a) <= std::abs(p - c) ? a
                        : std::abs(p - b) <= std::abs(p - c)                                 ? b
                                                                                              : c;
      const int predicted = filter == 0 ? 0 : filter == 1 ? a : filter == 2 ? b : filter == 3 ? (a + b) / 2 : paeth;
      image.pixels.push_back(uint8_t(rows[y * (stride + 1) + 1 + i] + predicted));
    }
  }
  return image;
}

/// The src of every <img> of class `cls`, in order.
std::vector<std::string> image_sources(const std::string& html, const std::string& cls) {
  std::vector<std::string> sources;
  const std::regex img("<img class='" + cls + "'[^>]* src='([^']*)'");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), img); it != std::sregex_iterator(); ++it) {
    sources.push_back((*it)[1]);
  }
  return sources;
}

TEST_CASE("report: names with markup, quotes and ampersands are escaped in the page and its figures") {
  audit::AuditResult r = made_result(3, 2);
  const std::string label = "<script>alert(\"x&y\")</script> 'q'";
  const std::string escaped = "&lt;script&gt;alert(&quot;x&amp;y&quot;)&lt;/script&gt; &#39;q&#39;";
  r.candidates[1].scene.label = label;
  r.candidates[1].scene.path = "/scenes/a&b<c>.rgs";
  r.views[1].name = "v<1>&\"";
  r.source.path = "/scenes/<source>&.ply";
  const std::string html = html_of(r, {"0.1", "rgs-audit '<x>'", std::nullopt, 40.0, 1.0, ""});
  CHECK(count(html, "<script") == 1);  // the page's own
  CHECK(html.find(label) == std::string::npos);
  CHECK(html.find("<c>") == std::string::npos);
  CHECK(html.find("<source>") == std::string::npos);
  CHECK(html.find("v<1>") == std::string::npos);
  CHECK(html.find("data-label='" + escaped + "'") != std::string::npos);  // the verdict's line
  CHECK(count(plot(html, "views"), escaped) >= 3);   // legend texts and the series' groups
  CHECK(plot(html, "views").find("v&lt;1&gt;&amp;&quot;") != std::string::npos);  // its x tick
  CHECK(plot(html, "sizes").find("data-label='" + escaped + "'") != std::string::npos);
  CHECK(plot(html, "size_quality").find(escaped) != std::string::npos);
  CHECK(html.find("/scenes/&lt;source&gt;&amp;.ply") != std::string::npos);
  CHECK(html.find("rgs-audit &#39;&lt;x&gt;&#39;") != std::string::npos);  // the command
}

TEST_CASE("report: +inf and NaN PSNR values are drawn as such, never as coordinates") {
  audit::AuditResult r = made_result(4, 2);
  for (audit::ViewMetrics& m : r.candidates[0].views) m.psnr_db = m.foreground_psnr_db = INFINITY;  // identical
  r.candidates[1].views[2].foreground_psnr_db = NAN;  // a view without foreground
  r.candidates[1].views[2].foreground_fraction = 0;
  for (auto& c : r.candidates) c.summary = summarize(c.views);
  const std::string html = html_of(r);
  const std::string views = plot(html, "views");
  CHECK_FALSE(has_non_finite_coordinate(html));
  // The identical candidate: every view an open triangle at the top edge, and the legend says what they are.
  CHECK(series_points(views, "whole_frame") == std::vector<int>{4, 4});
  CHECK(series_points(views, "foreground") == std::vector<int>{4, 3});  // the view without foreground left out
  CHECK(count(views, "class='pt inf'") == 8);
  CHECK(views.find("identical images (PSNR inf)") != std::string::npos);
  CHECK(views.find("cand 0, view_1: inf dB") != std::string::npos);  // tooltip
  // Near-lossless and identical candidates sit at the size/quality plot's top edge with their value written.
  CHECK(plot(html, "size_quality").find("cand 0 (inf dB)") != std::string::npos);
  CHECK(html.find("data-psnr-mean='inf'") != std::string::npos);
  CHECK(html.find("<td>inf</td><td>inf</td>") != std::string::npos);        // the per-view table
  CHECK(html.find("<td>\xE2\x80\x93</td><td>") != std::string::npos);       // no foreground: a dash
}

TEST_CASE("report: one view") {
  const audit::AuditResult r = made_result(1, 1);
  const std::string html = html_of(r);
  const std::string views = plot(html, "views");
  CHECK_FALSE(has_non_finite_coordinate(html));
  CHECK(plot(html, "size_quality").empty());  // one candidate: no size/quality chart
  CHECK(series_points(views, "whole_frame") == std::vector<int>{1});
  CHECK(series_points(views, "foreground") == std::vector<int>{1});
  CHECK(series_points(views, "ssim") == std::vector<int>{1});
  CHECK(views.find(">view_0</text>") != std::string::npos);
  CHECK(count(plot(html, "sizes"), "<g class='bar-row'") == 2);
  CHECK(count(html, "<img class='view heatmap'") == 1);
  CHECK(count(html, "class='colorbar'") == 1);
}

TEST_CASE("report: many views are lines without markers or view names, every view in the table") {
  const audit::AuditResult r = made_result(200, 2);
  const std::string html = html_of(r);
  const std::string views = plot(html, "views");
  CHECK_FALSE(has_non_finite_coordinate(html));
  CHECK(series_points(views, "whole_frame") == std::vector<int>{0, 0});
  CHECK(count(views, "class='pt") == 0);
  CHECK(views.find(">view_17</text>") == std::string::npos);
  // Each series is one path through its 200 points.
  const std::regex path("<g class='series' data-kind='ssim'[^>]*><path d='M([^']*)'");
  std::smatch m;
  REQUIRE(std::regex_search(views, m, path));
  CHECK(count(m[1], "L") == 199);
  CHECK(count(html, "<tr><td>view_") == 200);
}

TEST_CASE("report: many candidates, SERIES@POINT labels drawn as one curve") {
  audit::AuditResult r = made_result(5, 12);
  for (size_t i = 8; i < 12; ++i) r.candidates[i].scene.label = "archive@" + std::to_string(i);
  const std::string html = html_of(r);
  const std::string views = plot(html, "views"), quality = plot(html, "size_quality");
  CHECK_FALSE(has_non_finite_coordinate(html));
  CHECK(series_points(views, "whole_frame") == std::vector<int>(12, 5));
  CHECK(series_points(views, "foreground") == std::vector<int>(12, 5));
  CHECK(series_points(views, "ssim") == std::vector<int>(12, 5));
  CHECK(count(plot(html, "sizes"), "<g class='bar-row'") == 13);
  CHECK(series_points(quality, "candidate") == std::vector<int>(8, 1));
  CHECK(series_points(quality, "curve_mean") == std::vector<int>{4});
  CHECK(quality.find("archive: worst view") != std::string::npos);
  CHECK(quality.find("rate-distortion curves (labels SERIES@POINT)") != std::string::npos);
  CHECK(count(html, "<li class='verdict-cand'") == 12);
  CHECK(count(html, "<section class='cand'>") == 12);
  CHECK(count(html, "<img class='view heatmap'") == 12);
  // Twelve colour bars, each with its own gradient.
  for (size_t i = 0; i < 12; ++i) CHECK(count(html, "id='rgs-heat-" + std::to_string(i) + "'") == 1);
}

TEST_CASE("report: the page from the JSON file and its images is the page from memory, its images the audit's pixels") {
  const audit::AuditResult r = made_result(3, 2);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "rgs_test_report_html";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  audit::ReportOptions options;
  options.image_dir = "r_files/";
  options.min_psnr_db = 45.0;
  REQUIRE(audit::write_report_images(r, (dir / "r_files").string()).ok());
  const std::string text = audit::audit_json(r, options);
  REQUIRE(format::write_file_atomic((dir / "r.json").string(), text.data(), text.size()).ok());
  auto from_file = audit::report_html_from_file((dir / "r.json").string());
  REQUIRE_MESSAGE(from_file.ok(), from_file.status().to_string());
  const std::string html = html_of(r, options);
  CHECK(*from_file == html);
  CHECK(html_of(r) == html_of(r));  // deterministic
  CHECK(html.find("gate --min-psnr 45 dB") != std::string::npos);
  CHECK(count(plot(html, "views"), "class='hline'") == 2);  // the threshold and the gate

  // Source, candidate and heatmap of each worst view: the audit's pixels, the heatmap through inferno.
  const auto sources = image_sources(html, "view under"), candidates = image_sources(html, "view over");
  const auto heatmaps = image_sources(html, "view heatmap");
  REQUIRE(sources.size() == 2);
  REQUIRE(heatmaps.size() == 2);
  for (size_t i = 0; i < 2; ++i) {
    const audit::ViewImages& w = r.candidates[i].worst[0];
    CHECK(decode_png(sources[i]).pixels == w.source.pixels);
    CHECK(decode_png(candidates[i]).pixels == w.candidate.pixels);
    const audit::Image8 heat = decode_png(heatmaps[i]);
    REQUIRE(heat.channels == 3);
    REQUIRE(heat.pixels.size() == w.difference.pixels.size() * 3);
    for (size_t p = 0; p < w.difference.pixels.size(); ++p) {
      const uint8_t level = w.difference.pixels[p];
      if (level == 0) CHECK(heat.pixels[3 * p + 2] == 4);  // inferno's black is (0, 0, 4)
      if (level == 255) CHECK(heat.pixels[3 * p + 1] == 255);  // its top is (252, 255, 164)
      if (p > 0 && level > w.difference.pixels[p - 1] + 40) {  // brighter level, brighter red
        CHECK(heat.pixels[3 * p] > heat.pixels[3 * (p - 1)]);
      }
    }
  }

  // A missing image file is an error naming it.
  std::filesystem::remove(dir / "r_files" / "c1_v0_diff.pgm");
  auto missing = audit::report_html_from_file((dir / "r.json").string());
  CHECK(missing.status().code() == StatusCode::kIoError);
  CHECK(missing.status().message().find("c1_v0_diff.pgm") != std::string::npos);
  std::filesystem::remove_all(dir);
}

TEST_CASE("report: JSON that is not an rgs-audit JSON of this schema is refused") {
  const auto no_image = [](const std::string& name) -> Result<audit::Image8> {
    return Status(StatusCode::kIoError, name + ": no image");
  };
  const std::string good = audit::audit_json(made_result(2, 1), {});
  REQUIRE(audit::report_html(good, no_image).ok());  // no image_dir: the worst views name no images
  nlohmann::json old = nlohmann::json::parse(good);
  old["schema_version"] = 3;
  nlohmann::json truncated = nlohmann::json::parse(good);
  truncated["candidates"][0].erase("ssim");
  for (const std::string& text : {std::string("{}"), std::string("[1, 2"), old.dump(), truncated.dump()}) {
    auto html = audit::report_html(text, no_image);
    CHECK(html.status().code() == StatusCode::kInvalidArgument);
  }
  CHECK(audit::report_html(old.dump(), no_image).status().message().find("schema version 4") != std::string::npos);
  CHECK(audit::report_html(truncated.dump(), no_image).status().message().find("ssim") != std::string::npos);
}

TEST_CASE("read_netpbm reads what write_netpbm writes and refuses damaged files") {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "rgs_test_report_netpbm";
  std::filesystem::create_directories(dir);
  for (uint32_t channels : {1u, 3u}) {
    const audit::Image8 image = pattern(7, 5, channels, channels);
    const std::string path = (dir / ("image" + std::to_string(channels))).string();
    REQUIRE(audit::write_netpbm(path, image).ok());
    auto back = audit::read_netpbm(path);
    REQUIRE_MESSAGE(back.ok(), back.status().to_string());
    CHECK(back->width == 7);
    CHECK(back->height == 5);
    CHECK(back->channels == channels);
    CHECK(back->pixels == image.pixels);
  }
  const auto write = [&](const std::string& name, const std::string& bytes) {
    const std::string path = (dir / name).string();
    REQUIRE(format::write_file_atomic(path, bytes.data(), bytes.size()).ok());
    return path;
  };
  auto commented = audit::read_netpbm(write("commented.pgm", "P5\n# a comment\n2 1\n255\n\x01\x02"));
  REQUIRE(commented.ok());
  CHECK(commented->pixels == std::vector<uint8_t>{1, 2});
  CHECK(audit::read_netpbm(write("short.ppm", "P6\n2 2\n255\n\x01\x02\x03")).status().code() ==
        StatusCode::kCorruptData);
  CHECK(audit::read_netpbm(write("deep.pgm", "P5\n1 1\n65535\n\x01\x02")).status().code() ==
        StatusCode::kCorruptData);
  CHECK(audit::read_netpbm(write("text.ppm", "P3\n1 1\n255\n1 2 3\n")).status().code() == StatusCode::kCorruptData);
  CHECK(audit::read_netpbm((dir / "missing.ppm").string()).status().code() == StatusCode::kIoError);
  std::filesystem::remove_all(dir);
}

TEST_CASE("report of a real audit: guitar against itself and its conversion") {
  const audit::AuditScene source = test::audit_scene(test::repo_path("samples/guitar.ply"));
  std::vector<audit::AuditScene> candidates;
  candidates.push_back(test::audit_scene(test::repo_path("samples/guitar.ply")));
  candidates.push_back(test::converted_scene(source, "rgs_test_report_html_guitar.rgs"));
  auto cameras = runtime::orbit_cameras(source.bounds, 3, 160, 90);
  REQUIRE(cameras.ok());
  audit::AuditOptions options;
  options.worst_views = 2;
  auto result = audit::run_audit(source, candidates, *cameras, options);
  REQUIRE_MESSAGE(result.ok(), result.status().to_string());
  const std::string html = html_of(*result);
  const std::string views = plot(html, "views");
  CHECK_FALSE(has_non_finite_coordinate(html));
  CHECK(series_points(views, "whole_frame") == std::vector<int>{3, 3});
  CHECK(count(views, "class='pt inf'") == 6);  // the identical candidate, whole frame and foreground
  CHECK(count(html, "<img class='view heatmap'") == 4);
  CHECK(count(html, "class='colorbar'") == 2);
  // The renders as the page holds them are the audit's pixels (rows of every PNG filter type).
  const auto sources = image_sources(html, "view under");
  REQUIRE(sources.size() == 4);
  for (size_t k = 0; k < 4; ++k) {
    CHECK(decode_png(sources[k]).pixels == result->candidates[k / 2].worst[k % 2].source.pixels);
  }
  // The identical candidate's heatmaps are inferno's black; the conversion's are not.
  const auto heatmaps = image_sources(html, "view heatmap");
  REQUIRE(heatmaps.size() == 4);
  for (size_t k = 0; k < 4; ++k) {
    const audit::Image8 heat = decode_png(heatmaps[k]);
    const bool black = std::all_of(heat.pixels.begin(), heat.pixels.end(), [](uint8_t p) { return p <= 4; });
    CHECK(black == (k < 2));
  }
}

}  // namespace
