// rgs-view-bench: a benchmark client for rgs-view. It connects to a running server's WebSocket (view/PROTOCOL.md)
// like the page does, sends a scripted camera path (a fly-through of a cameras.json, an orbit or a path around
// the scene of the server's hello) paced by the frames it gets back, with --in-flight views outstanding, and
// reports sustained frames per second, camera-to-frame latency (send of a view → arrival of its frame), bytes
// per frame and the medians of the server's own per-frame statistics.
//
//   rgs-view-bench http://127.0.0.1:8080/ --cameras cameras.json --fly 600 --width 1920 --height 1080
//   rgs-view-bench "http://host:8080/?token=..." --orbit 120 --encoding webp --in-flight 2 --json out.json
//   rgs-view-bench URL --cameras c.json --fly 600 --shape-mbps 50 --shape-rtt-ms 20 --max-mbps 50 --psnr-every 10
//
// --shape-mbps puts a TCP relay on 127.0.0.1 between the bench and the server that shapes the connection like a
// link of that rate and round trip (shaping_proxy.h); --max-mbps sends the views with that bandwidth budget
// (view/PROTOCOL.md "Bandwidth budget"); --psnr-every K decodes every K-th measured frame and compares it with the
// lossless frame of the same view, asked for after the flight on a direct connection (upscaled bilinearly to full
// size first when the budget rendered it smaller, as the page draws it).
//
// The cameras are built by the front door (api::make_cameras, as rgs-render builds them) and sent in the INRIA
// form (view::inria_from_camera: rotation c2w = Rᵀ, position = −Rᵀ·t). The URL's token is used, never printed.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <map>
#include <numeric>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <sys/socket.h>
#include <turbojpeg.h>
#include <webp/decode.h>

#include <CLI/CLI.hpp>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>

#include "cli_common.h"
#include "rgs/api/camera.h"
#include "rgs/view/image_codec.h"
#include "rgs/view/protocol.h"
#include "shaping_proxy.h"

namespace {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;
using rgs::Result;
using rgs::Status;
using rgs::StatusCode;
namespace api = rgs::api;
namespace tools = rgs::tools;
namespace view = rgs::view;

constexpr const char* kTool = "rgs-view-bench";

struct Options {
  std::string url;
  api::CameraChoice cameras;
  std::string encoding = "jpeg";
  int quality = 85;
  std::string preset;  // empty: the server's
  std::string background = "0,0,0";
  uint32_t in_flight = 1;
  uint32_t warmup = 3;
  double timeout_s = 60;
  double shape_mbps = 0, shape_rtt_ms = 0, max_mbps = 0;
  uint32_t psnr_every = 0;
  std::string json_path;
  bool quiet = false;
};

/// host, port and the WebSocket target ("/ws?token=...") of a URL as rgs-view prints it (http://host:port/?token=T)
/// or of its WebSocket (ws://host:port/ws?token=T).
struct Endpoint {
  std::string host, port, target;
  std::string shown;  ///< the URL without its token, for reports
};

Result<Endpoint> parse_url(const std::string& url) {
  std::string rest;
  for (const char* scheme : {"http://", "ws://"}) {
    if (url.rfind(scheme, 0) == 0) rest = url.substr(std::char_traits<char>::length(scheme));
  }
  if (rest.empty()) {
    return Status(StatusCode::kInvalidArgument,
                  "the URL must start with http:// or ws:// (https/wss are not supported)");
  }
  const size_t slash = rest.find_first_of("/?");
  const std::string authority = rest.substr(0, slash);
  const std::string path_query = slash == std::string::npos ? "/" : rest.substr(slash);
  Endpoint e;
  if (!authority.empty() && authority[0] == '[') {  // [v6]:port
    const size_t close = authority.find(']');
    if (close == std::string::npos) return Status(StatusCode::kInvalidArgument, "bad IPv6 address in the URL");
    e.host = authority.substr(1, close - 1);
    e.port = close + 1 < authority.size() && authority[close + 1] == ':' ? authority.substr(close + 2) : "80";
  } else {
    const size_t colon = authority.rfind(':');
    e.host = authority.substr(0, colon);
    e.port = colon == std::string::npos ? "80" : authority.substr(colon + 1);
  }
  if (e.host.empty() || e.port.empty() || e.port.find_first_not_of("0123456789") != std::string::npos) {
    return Status(StatusCode::kInvalidArgument, "cannot read host and port from the URL");
  }
  std::string token;
  const size_t q = path_query.find('?');
  if (q != std::string::npos) {
    const std::string query = path_query.substr(q + 1);
    size_t at = 0;
    while (at <= query.size()) {
      const size_t amp = std::min(query.find('&', at), query.size());
      const std::string pair = query.substr(at, amp - at);
      if (pair.rfind("token=", 0) == 0) token = pair.substr(6);
      at = amp + 1;
    }
  }
  if (token.find_first_not_of("0123456789abcdefABCDEF-_") != std::string::npos) {
    return Status(StatusCode::kInvalidArgument, "the URL's token has characters a token cannot have");
  }
  e.target = "/ws" + (token.empty() ? std::string() : "?token=" + token);
  e.shown = "ws://" + authority + "/ws" + (token.empty() ? "" : "?token=...");
  return e;
}

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Nearest-rank percentile (p in (0, 100]).
double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t rank = static_cast<size_t>(std::ceil(p / 100.0 * static_cast<double>(v.size())));
  return v[std::min(v.size(), std::max<size_t>(rank, 1)) - 1];
}

json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

/// Closes the socket when nothing arrives for `timeout`: a blocking read then fails instead of hanging.
class Watchdog {
 public:
  Watchdog(int fd, std::chrono::duration<double> timeout) : fd_(fd), timeout_(timeout) {
    thread_ = std::thread([this] { run(); });
  }
  ~Watchdog() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  void progress() {
    std::lock_guard<std::mutex> lock(mutex_);
    last_ = Clock::now();
  }
  bool fired() const { return fired_; }

 private:
  void run() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!done_) {
      const auto deadline = last_ + std::chrono::duration_cast<Clock::duration>(timeout_);
      if (Clock::now() >= deadline) {
        fired_ = true;
        ::shutdown(fd_, SHUT_RDWR);
        return;
      }
      cv_.wait_until(lock, deadline);
    }
  }
  int fd_;
  std::chrono::duration<double> timeout_;
  std::mutex mutex_;
  std::condition_variable cv_;
  Clock::time_point last_ = Clock::now();
  bool done_ = false;
  std::atomic<bool> fired_{false};
  std::thread thread_;
};

/// The statistics keys of a frame header whose medians are reported.
const char* const kStatKeys[] = {"preprocess_ms", "sort_ms",    "render_ms",          "total_gpu_ms",
                                 "render_call_ms", "readback_ms", "encode_ms",          "pairs",
                                 "splats",         "gpu_memory_used_bytes", "lod_bytes_streamed",
                                 "lod_bytes_resident"};

/// kIoError saying `what`; when the watchdog closed the socket, also that nothing came for `timeout_s`.
Status io_error(const Watchdog& watchdog, const std::string& what, double timeout_s) {
  return Status(StatusCode::kIoError, watchdog.fired() ? what + ": nothing from the server for " +
                                                             std::to_string(timeout_s) + " s"
                                                       : what);
}

/// Opens the WebSocket of `endpoint` on `ws` (TCP without Nagle's delay, messages up to 1 GiB); through
/// 127.0.0.1:`relay_port` when one is given (the shaping proxy), still naming the server in its Host header.
Status open_websocket(websocket::stream<tcp::socket>& ws, net::io_context& ioc, const Endpoint& endpoint,
                      uint16_t relay_port = 0) {
  try {
    tcp::resolver resolver{ioc};
    const auto addresses = relay_port ? resolver.resolve("127.0.0.1", std::to_string(relay_port))
                                      : resolver.resolve(endpoint.host, endpoint.port);
    net::connect(ws.next_layer(), addresses.begin(), addresses.end());
    ws.next_layer().set_option(tcp::no_delay(true));
    ws.set_option(websocket::stream_base::decorator(
        [](websocket::request_type& req) { req.set(beast::http::field::user_agent, "rgs-view-bench"); }));
    ws.read_message_max(1ull << 30);
    ws.handshake(endpoint.host + ":" + endpoint.port, endpoint.target);
  } catch (const std::exception& e) {
    return Status(StatusCode::kIoError, "cannot connect to " + endpoint.shown + ": " + e.what());
  }
  return Status();
}

/// The server's first message, a hello with at least one scene (view/PROTOCOL.md).
Result<json> read_hello(websocket::stream<tcp::socket>& ws, beast::flat_buffer& buffer, Watchdog& watchdog,
                        double timeout_s) {
  json hello;
  try {
    ws.read(buffer);
    watchdog.progress();
    hello = json::parse(beast::buffers_to_string(buffer.data()));
    buffer.consume(buffer.size());
  } catch (const std::exception& e) {
    return io_error(watchdog, std::string("no hello from the server: ") + e.what(), timeout_s);
  }
  if (!hello.is_object() || hello.value("type", "") != "hello" || !hello.contains("scenes") ||
      !hello["scenes"].is_array() || hello["scenes"].empty()) {
    return io_error(watchdog, "the server's first message is not a hello with scenes", timeout_s);
  }
  return hello;
}

/// The cameras of `choice`: the front door's, around the hello's `scene` (its content's frame sphere) for an orbit
/// or a path.
Result<std::vector<api::Camera>> scene_cameras(const api::CameraChoice& choice, const json& scene) {
  rgs::format::SceneBounds sphere;
  const json& c = scene["center"];
  for (int i = 0; i < 3; ++i) sphere.sphere_center[i] = c.is_array() && c.size() == 3 ? c[i].get<float>() : 0.f;
  sphere.sphere_radius = scene.value("radius", 1.0f);
  return api::make_cameras(choice, api::ContentFrame::of_sphere(sphere));
}

/// What the measured loop saw: every frame counted, and the measurements of those after the warm-up.
struct Measurements {
  size_t frames = 0, refine_frames = 0, failed = 0, dropped = 0;
  std::vector<double> latency_ms, bytes, frame_arrival_s;  ///< per measured frame
  std::map<std::string, std::vector<double>> stats;        ///< kStatKeys of the measured frames' headers
  std::vector<double> quality, scale;                      ///< the headers' (the bandwidth budget's choice)
  double total_s = 0;                                      ///< from the first view sent to the last frame
  /// Every psnr_every-th measured frame's image (seq → its encoding and bytes), for the PSNR pass.
  std::map<uint64_t, std::pair<std::string, std::string>> kept;
};

/// Sends the views (view k + 1 is messages[k]) paced by the frames that come back, `opt.in_flight` views
/// outstanding, measures the frames after the first `opt.warmup`, and closes the connection.
Result<Measurements> measure(websocket::stream<tcp::socket>& ws, beast::flat_buffer& buffer, Watchdog& watchdog,
                             const std::vector<std::string>& messages, const Options& opt) {
  const auto fail = [&](const std::string& what) { return io_error(watchdog, what, opt.timeout_s); };
  const size_t count = messages.size();
  // Send views paced by frames: `in_flight` views outstanding. A frame of seq s answers every view up to s
  // (the server may replace a pending view by a newer one: those never get a frame and count as dropped).
  std::vector<Clock::time_point> sent_at(count + 1);
  std::vector<bool> answered(count + 1, false);
  size_t next = 1, highest_answered = 0;
  Measurements m;
  Clock::time_point start, measured_from;
  bool measuring = false;
  const auto send_next = [&]() {
    sent_at[next] = Clock::now();
    ws.text(true);
    ws.write(net::buffer(messages[next - 1]));
    ++next;
  };
  try {
    start = Clock::now();
    while (next <= count && next - 1 - highest_answered < opt.in_flight) send_next();
    while (highest_answered < count) {
      ws.read(buffer);
      watchdog.progress();
      const auto arrival = Clock::now();
      const std::string data = beast::buffers_to_string(buffer.data());
      buffer.consume(buffer.size());
      if (ws.got_text()) {
        const json msg = json::parse(data, nullptr, false);
        if (msg.is_object() && msg.value("type", "") == "error") {
          if (msg.value("fatal", true)) return fail("server error: " + msg.value("message", data));
          // a frame failed to render: the oldest view outstanding
          ++m.failed;
          if (highest_answered < next - 1) answered[++highest_answered] = true;
          while (next <= count && next - 1 - highest_answered < opt.in_flight) send_next();
        }
        continue;
      }
      if (data.size() < 4) return fail("a binary message shorter than its header length");
      const uint32_t n = uint32_t(uint8_t(data[0])) | uint32_t(uint8_t(data[1])) << 8 |
                         uint32_t(uint8_t(data[2])) << 16 | uint32_t(uint8_t(data[3])) << 24;
      if (n > data.size() - 4) return fail("a frame header longer than its message");
      const json header = json::parse(data.substr(4, n), nullptr, false);
      if (!header.is_object() || header.value("type", "") != "frame" || !header.contains("seq")) {
        return fail("a binary message that is no frame");
      }
      const uint64_t seq = header["seq"].get<uint64_t>();
      if (seq == 0 || seq > next - 1) return fail("a frame of seq " + std::to_string(seq) + ", never sent");
      if (header.value("refine", false)) {
        ++m.refine_frames;
        continue;
      }
      if (answered[seq]) continue;
      for (uint64_t s = highest_answered + 1; s < seq; ++s) {
        if (!answered[s]) ++m.dropped;
        answered[s] = true;
      }
      answered[seq] = true;
      highest_answered = std::max<size_t>(highest_answered, seq);
      ++m.frames;
      if (!measuring && m.frames > opt.warmup) {
        measuring = true;
        measured_from = sent_at[seq];
      }
      if (m.frames > opt.warmup) {
        m.latency_ms.push_back(std::chrono::duration<double, std::milli>(arrival - sent_at[seq]).count());
        m.bytes.push_back(double(data.size()));
        m.frame_arrival_s.push_back(std::chrono::duration<double>(arrival - measured_from).count());
        if (header.value("quality", json()).is_number()) m.quality.push_back(header["quality"].get<double>());
        m.scale.push_back(header.value("scale", 1.0));
        const json images = header.value("images", json::array());
        const size_t image_bytes = images.empty() ? 0 : images[0].value("bytes", size_t(0));
        if (opt.psnr_every && m.latency_ms.size() % opt.psnr_every == 0 && image_bytes <= data.size() - 4 - n) {
          m.kept[seq] = {images[0].value("encoding", ""), data.substr(4 + n, image_bytes)};
        }
        if (header.contains("stats") && header["stats"].is_object()) {
          for (const char* key : kStatKeys) {
            const auto it = header["stats"].find(key);
            if (it != header["stats"].end() && it->is_number()) m.stats[key].push_back(it->get<double>());
          }
        }
      }
      while (next <= count && next - 1 - highest_answered < opt.in_flight) send_next();
    }
  } catch (const std::exception& e) {
    return fail(std::string("connection lost: ") + e.what());
  }
  m.total_s = std::chrono::duration<double>(Clock::now() - start).count();
  try {
    ws.close(websocket::close_code::normal);
  } catch (const std::exception&) {
    // the server went first; the measurements are complete
  }
  return m;
}

/// 8-bit RGB [h, w, 3] of a frame's image (`encoding` as in the frame header: jpeg, webp, webp-lossless).
Result<std::vector<uint8_t>> decode_rgb(const std::string& encoding, const std::string& bytes, int* w, int* h) {
  const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
  if (encoding == "jpeg") {
    tjhandle d = tjInitDecompress();
    int subsampling = 0, colorspace = 0;
    std::vector<uint8_t> rgb;
    bool ok = d && tjDecompressHeader3(d, data, bytes.size(), w, h, &subsampling, &colorspace) == 0;
    if (ok) {
      rgb.resize(size_t(*w) * *h * 3);
      ok = tjDecompress2(d, data, bytes.size(), rgb.data(), *w, *w * 3, *h, TJPF_RGB, 0) == 0;
    }
    if (d) tjDestroy(d);
    if (!ok) return Status(StatusCode::kCorruptData, "a JPEG frame does not decode");
    return rgb;
  }
  uint8_t* rgb = WebPDecodeRGB(data, bytes.size(), w, h);
  if (!rgb) return Status(StatusCode::kCorruptData, "a WebP frame does not decode");
  std::vector<uint8_t> out(rgb, rgb + size_t(*w) * *h * 3);
  WebPFree(rgb);
  return out;
}

/// `rgb` [sh, sw, 3] resized to [dh, dw, 3], bilinear with pixel centres aligned (as a canvas draws it scaled).
std::vector<uint8_t> resize_rgb(const std::vector<uint8_t>& rgb, int sw, int sh, int dw, int dh) {
  std::vector<uint8_t> out(size_t(dw) * dh * 3);
  for (int y = 0; y < dh; ++y) {
    const double fy = std::clamp((y + 0.5) * sh / dh - 0.5, 0.0, double(sh - 1));
    const int y0 = int(fy), y1 = std::min(y0 + 1, sh - 1);
    for (int x = 0; x < dw; ++x) {
      const double fx = std::clamp((x + 0.5) * sw / dw - 0.5, 0.0, double(sw - 1));
      const int x0 = int(fx), x1 = std::min(x0 + 1, sw - 1);
      const double ax = fx - x0, ay = fy - y0;
      for (int c = 0; c < 3; ++c) {
        const auto at = [&](int xx, int yy) { return double(rgb[(size_t(yy) * sw + xx) * 3 + c]); };
        const double v = (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x1, y0)) +
                         ay * ((1 - ax) * at(x0, y1) + ax * at(x1, y1));
        out[(size_t(y) * dw + x) * 3 + c] = uint8_t(std::lround(v));
      }
    }
  }
  return out;
}

/// PSNR (dB) of each kept frame against the lossless frame of its view, asked for on a direct connection to the
/// server (no shaping, no budget); identical images are left out (infinite PSNR).
Result<std::vector<double>> psnr_against_lossless(const Endpoint& endpoint, const Options& opt,
                                                  const std::vector<view::ViewRequest>& requests,
                                                  const Measurements& m) {
  net::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  RGS_RETURN_IF_ERROR(open_websocket(ws, ioc, endpoint));
  Watchdog watchdog(ws.next_layer().native_handle(), std::chrono::duration<double>(opt.timeout_s));
  beast::flat_buffer buffer;
  RGS_RETURN_IF_ERROR(read_hello(ws, buffer, watchdog, opt.timeout_s).status());
  std::vector<double> psnr;
  try {
    for (const auto& [seq, image] : m.kept) {
      view::ViewRequest lossless = requests[seq - 1];
      lossless.encoding = view::Encoding::kLossless;
      lossless.still = true;
      lossless.max_mbps = 0;
      ws.text(true);
      ws.write(net::buffer(view::view_message_json(lossless)));
      std::string data;
      do {  // the frame (text messages: pongs, errors)
        buffer.consume(buffer.size());
        ws.read(buffer);
        watchdog.progress();
        data = beast::buffers_to_string(buffer.data());
      } while (ws.got_text());
      if (data.size() < 4) return io_error(watchdog, "a binary message shorter than its header length", opt.timeout_s);
      const uint32_t n = uint32_t(uint8_t(data[0])) | uint32_t(uint8_t(data[1])) << 8 |
                         uint32_t(uint8_t(data[2])) << 16 | uint32_t(uint8_t(data[3])) << 24;
      if (n > data.size() - 4) return io_error(watchdog, "a frame header longer than its message", opt.timeout_s);
      int fw = 0, fh = 0, w = 0, h = 0;
      RGS_ASSIGN_OR_RETURN(auto full, decode_rgb("webp-lossless", data.substr(4 + n), &fw, &fh));
      RGS_ASSIGN_OR_RETURN(auto got, decode_rgb(image.first, image.second, &w, &h));
      if (w != fw || h != fh) got = resize_rgb(got, w, h, fw, fh);
      const view::ImageDifference d = view::compare_rgb(got.data(), full.data(), uint32_t(fw), uint32_t(fh), 32,
                                                        nullptr, 3);
      if (d.psnr_db) psnr.push_back(*d.psnr_db);
    }
    ws.close(websocket::close_code::normal);
  } catch (const std::exception& e) {
    return io_error(watchdog, std::string("the lossless frames: ") + e.what(), opt.timeout_s);
  }
  return psnr;
}

/// Prints the report of `m` for the `count` views at width x height, and writes it as JSON when asked. Returns
/// the exit code: an I/O error when no frame arrived or the JSON cannot be written.
int summarize(const Options& opt, const Endpoint& endpoint, const json& hello, const std::string& preset_name,
              size_t count, uint32_t width, uint32_t height, const Measurements& m, const std::vector<double>& psnr) {
  const json& scene = hello["scenes"][0];
  const size_t measured = m.latency_ms.size();
  const double span = m.frame_arrival_s.empty() ? 0 : m.frame_arrival_s.back();
  // frames measured over the time from sending the first measured view to the last frame's arrival
  const double fps = span > 0 ? double(measured) / span : NAN;
  double mean_bytes = NAN;
  if (!m.bytes.empty()) {
    double sum = 0;
    for (double b : m.bytes) sum += b;
    mean_bytes = sum / double(m.bytes.size());
  }
  // bits of the measured frames over the span they arrived in (as frames/s)
  const double mbps = span > 0 ? mean_bytes * double(measured) * 8 / span / 1e6 : NAN;
  json report = {
      {"tool", kTool},
      {"benchmark", true},
      {"url", endpoint.shown},
      {"backend", hello.value("backend", "")},
      {"device", hello.value("device", "")},
      {"encoder", hello.value("encoder", "")},
      {"scene", scene.value("path_basename", "")},
      {"gaussians", scene.value("gaussians", 0)},
      {"cameras", opt.cameras.cameras_path},
      {"fly", opt.cameras.fly},
      {"views", count},
      {"width", width},
      {"height", height},
      {"preset", preset_name},
      {"encoding", opt.encoding},
      {"quality", opt.quality},
      {"in_flight", opt.in_flight},
      {"warmup_frames", std::min<size_t>(opt.warmup, m.frames)},
      {"frames", m.frames},
      {"measured_frames", measured},
      {"refine_frames", m.refine_frames},
      {"dropped_views", m.dropped},
      {"failed_views", m.failed},
      {"seconds", m.total_s},
      {"frames_per_second", number_or_null(fps)},
      {"latency_ms",
       {{"median", number_or_null(median(m.latency_ms))},
        {"p95", number_or_null(percentile(m.latency_ms, 95))},
        {"max",
         number_or_null(m.latency_ms.empty() ? NAN : *std::max_element(m.latency_ms.begin(), m.latency_ms.end()))}}},
      {"bytes_per_frame", {{"median", number_or_null(median(m.bytes))}, {"mean", number_or_null(mean_bytes)}}},
      {"shaping", opt.shape_mbps > 0 ? json{{"mbps", opt.shape_mbps}, {"rtt_ms", opt.shape_rtt_ms}} : json(nullptr)},
      {"max_mbps", opt.max_mbps > 0 ? json(opt.max_mbps) : json(nullptr)},
      {"mbps", number_or_null(mbps)},
      {"quality_median", number_or_null(median(m.quality))},
      {"scale_median", number_or_null(median(m.scale))},
      {"psnr_db",
       {{"views", psnr.size()},
        {"mean", number_or_null(psnr.empty() ? NAN
                                              : std::accumulate(psnr.begin(), psnr.end(), 0.0) / double(psnr.size()))},
        {"min", number_or_null(psnr.empty() ? NAN : *std::min_element(psnr.begin(), psnr.end()))}}},
  };
  json server = json::object();
  for (const char* key : kStatKeys) {
    const auto it = m.stats.find(key);
    server[key] = it == m.stats.end() ? json(nullptr) : number_or_null(median(it->second));
  }
  report["server_median"] = server;

  const auto ms = [](const json& v) { return v.is_number() ? v.get<double>() : NAN; };
  std::printf("%s: %s (%s, %s)\n", kTool, tools::escape_text(report["scene"].get<std::string>()).c_str(),
              tools::escape_text(report["backend"].get<std::string>()).c_str(),
              tools::escape_text(report["device"].get<std::string>()).c_str());
  std::printf("  views            %zu at %ux%u, %s q%d, preset %s, %u in flight\n", count, width, height,
              opt.encoding.c_str(), opt.quality, preset_name.c_str(), opt.in_flight);
  std::printf("  frames           %zu (%zu measured after %u warm-up), %zu dropped, %zu failed, %zu refinements\n",
              m.frames, measured, opt.warmup, m.dropped, m.failed, m.refine_frames);
  std::printf("  frames/s         %.2f sustained\n", fps);
  std::printf("  latency          median %.2f ms, p95 %.2f ms, max %.2f ms (view sent -> its frame received)\n",
              ms(report["latency_ms"]["median"]), ms(report["latency_ms"]["p95"]), ms(report["latency_ms"]["max"]));
  std::printf("  bytes/frame      median %.0f, mean %.0f; %.2f Mbit/s\n", ms(report["bytes_per_frame"]["median"]),
              ms(report["bytes_per_frame"]["mean"]), mbps);
  if (opt.shape_mbps > 0 || opt.max_mbps > 0 || opt.psnr_every > 0) {
    std::printf("  budget           link %s, budget %s: quality median %.0f, scale median %.2f; PSNR vs lossless "
                "mean %.2f dB, min %.2f dB over %zu views\n",
                opt.shape_mbps > 0
                    ? (number(opt.shape_mbps) + " Mbit/s, " + number(opt.shape_rtt_ms) + " ms round trip").c_str()
                    : "loopback",
                opt.max_mbps > 0 ? (number(opt.max_mbps) + " Mbit/s").c_str() : "none",
                ms(report["quality_median"]), ms(report["scale_median"]), ms(report["psnr_db"]["mean"]),
                ms(report["psnr_db"]["min"]), psnr.size());
  }
  std::printf("  server medians  ");
  for (const char* key : kStatKeys) {
    if (server[key].is_number()) std::printf(" %s %.6g", key, server[key].get<double>());
  }
  std::printf("\n");
  if (!opt.json_path.empty()) {
    std::ofstream out(opt.json_path);
    out << report.dump(2) << "\n";
    out.close();
    if (!out) {
      return tools::report_error(kTool, Status(StatusCode::kIoError, "cannot write " + opt.json_path));
    }
  }
  if (m.frames == 0) return tools::report_error(kTool, Status(StatusCode::kIoError, "no frame arrived"));
  return tools::kExitOk;
}

/// The benchmark: connect, read the hello, make the views, send them paced by their frames, report.
int run(const Options& opt) {
  auto endpoint = parse_url(opt.url);
  if (!endpoint.ok()) return tools::report_usage_error(kTool, endpoint.status());
  auto background = tools::parse_background(opt.background);
  for (size_t c = 0; background.ok() && c < 3; ++c) {
    if (!((*background)[c] >= 0.f && (*background)[c] <= 1.f)) {
      background = Status(StatusCode::kInvalidArgument, "--background: '" + opt.background + "' is not in [0, 1]");
    }
  }
  if (!background.ok()) return tools::report_usage_error(kTool, background.status());
  view::Encoding encoding = view::Encoding::kJpeg;
  if (opt.encoding == "webp") encoding = view::Encoding::kWebp;
  if (opt.encoding == "lossless") encoding = view::Encoding::kLossless;

  std::unique_ptr<rgs::lab::ShapingProxy> proxy;
  if (opt.shape_mbps > 0) {
    auto started = rgs::lab::ShapingProxy::start(endpoint->host, endpoint->port, opt.shape_mbps, opt.shape_rtt_ms);
    if (!started.ok()) return tools::report_error(kTool, started.status());
    proxy = std::move(*started);
  }
  net::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  if (Status opened = open_websocket(ws, ioc, *endpoint, proxy ? proxy->port() : 0); !opened.ok()) {
    return tools::report_error(kTool, opened);
  }
  Watchdog watchdog(ws.next_layer().native_handle(), std::chrono::duration<double>(opt.timeout_s));
  beast::flat_buffer buffer;
  auto hello = read_hello(ws, buffer, watchdog, opt.timeout_s);
  if (!hello.ok()) return tools::report_error(kTool, hello.status());
  const json& scene = (*hello)["scenes"][0];
  std::string preset_name = opt.preset.empty() ? hello->value("preset", std::string("fastest")) : opt.preset;
  auto preset = api::parse_preset(preset_name);
  if (!preset.ok()) return tools::report_usage_error(kTool, preset.status());

  auto cameras = scene_cameras(opt.cameras, scene);
  if (!cameras.ok()) return tools::report_error(kTool, cameras.status());
  if (cameras->empty()) return tools::report_error(kTool, Status(StatusCode::kInvalidArgument, "no cameras"));
  const size_t count = cameras->size();
  std::vector<std::string> messages;
  std::vector<view::ViewRequest> requests(count);
  for (size_t i = 0; i < count; ++i) {
    view::ViewRequest& req = requests[i];
    req.seq = i + 1;
    req.camera = view::inria_from_camera((*cameras)[i]);
    req.preset = *preset;
    req.background = *background;
    req.encoding = encoding;
    req.quality = opt.quality;
    req.max_mbps = opt.max_mbps;  // a flight: moving views (still false)
    messages.push_back(view::view_message_json(req));
  }
  const uint32_t width = (*cameras)[0].width, height = (*cameras)[0].height;
  if (!opt.quiet) {
    std::fprintf(stderr, "%s: %s: %s on %s (%s), %zu views %ux%u, %s, %u in flight\n", kTool,
                 endpoint->shown.c_str(), tools::escape_text(scene.value("path_basename", std::string("?"))).c_str(),
                 tools::escape_text(hello->value("backend", std::string("?"))).c_str(),
                 tools::escape_text(hello->value("device", std::string("?"))).c_str(), count, width, height,
                 opt.encoding.c_str(), opt.in_flight);
  }

  auto measured = measure(ws, buffer, watchdog, messages, opt);
  if (!measured.ok()) return tools::report_error(kTool, measured.status());
  proxy.reset();
  std::vector<double> psnr;
  if (!measured->kept.empty()) {
    auto compared = psnr_against_lossless(*endpoint, opt, requests, *measured);
    if (!compared.ok()) return tools::report_error(kTool, compared.status());
    psnr = std::move(*compared);
  }
  return summarize(opt, *endpoint, *hello, preset_name, count, width, height, *measured, psnr);
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{
      "Benchmark client for rgs-view: connects to a running server's WebSocket like its page, sends a scripted "
      "camera path paced by the returned frames (--in-flight views outstanding) and reports sustained frames "
      "per second, camera-to-frame latency (view sent -> its frame received: median, p95, max), bytes per frame "
      "and the medians of the server's per-frame statistics. It measures the server, the network and the "
      "encoder together; it is a benchmark, not a test of the images.",
      kTool};
  app.add_option("url", opt.url, "The server's URL as rgs-view prints it (http://host:port/?token=...) or its "
                                 "WebSocket (ws://host:port/ws?token=...)")
      ->required();
  tools::add_camera_options(app, opt.cameras, "INRIA cameras.json (its cameras, or a fly-through with --fly)",
                            "Use at most N cameras of the file, or N views of an orbit or path",
                            "Orbit of N views around the bounding sphere of the server's first scene");
  app.add_option("--width", opt.cameras.width, "Image width (field of view kept; height follows the aspect ratio "
                                               "if not given); orbit/path default 1920x1080")
      ->check(CLI::Range(1, 7680));
  app.add_option("--height", opt.cameras.height, "Image height")->check(CLI::Range(1, 4320));
  app.add_option("--encoding", opt.encoding, "Frame encoding: jpeg, webp or lossless")
      ->check(CLI::IsMember({"jpeg", "webp", "lossless"}))
      ->capture_default_str();
  app.add_option("--quality", opt.quality, "JPEG/WebP quality")->check(CLI::Range(1, 100))->capture_default_str();
  app.add_option("--preset", opt.preset, "fastest, faithful or paper (default: the server's)")
      ->check(CLI::IsMember({"fastest", "faithful", "paper"}));
  app.add_option("--background", opt.background, "Background r,g,b in [0, 1]")->capture_default_str();
  app.add_option("--in-flight", opt.in_flight, "Views outstanding at once (1: send the next view when the last "
                                               "frame arrived; 2: one rendering while one is sent)")
      ->check(CLI::Range(1, 8))
      ->capture_default_str();
  app.add_option("--warmup", opt.warmup, "Frames left out of the statistics at the start")->capture_default_str();
  app.add_option("--timeout", opt.timeout_s, "Give up when nothing arrives for this many seconds")
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
  app.add_option("--shape-mbps", opt.shape_mbps, "Connect through a relay on 127.0.0.1 that shapes both directions "
                                                 "like a link of this many Mbit/s (0: direct)")
      ->check(tools::finite_number_in(0, 1e6));
  app.add_option("--shape-rtt-ms", opt.shape_rtt_ms, "The shaped link's round trip, ms (half each way)")
      ->check(tools::finite_number_in(0, 1e5));
  app.add_option("--max-mbps", opt.max_mbps, "Send the views with this bandwidth budget, Mbit/s (0: none)")
      ->check(tools::finite_number_in(0, view::kMaxMbps));
  app.add_option("--psnr-every", opt.psnr_every, "PSNR of every K-th measured frame against the lossless frame of "
                                                 "its view (0: none)")
      ->capture_default_str();
  app.add_option("--json", opt.json_path, "Also write the report as JSON here");
  app.add_flag("-q,--quiet", opt.quiet, "No progress line on stderr");
  const auto check = [&]() -> std::string {
    if (opt.cameras.cameras_path.empty() && opt.cameras.orbit == 0 && opt.cameras.path == 0) {
      return "one of --cameras, --orbit or --path is required";
    }
    return {};
  };
  if (auto code = tools::parse_command_line(app, argc, argv, kTool, check)) return *code;
  return tools::finish(kTool, run(opt));
}
