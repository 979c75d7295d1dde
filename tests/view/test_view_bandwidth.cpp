// The bandwidth budget (view/PROTOCOL.md "Bandwidth budget"): the control law (view/src/internal_bandwidth.h) fed
// simulated frames and times, and a server on the CPU backend whose moving frames shrink under a tiny budget while
// a still view comes back at full size and quality.
#include <cmath>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "internal_bandwidth.h"
#include "view_server_client.h"

namespace {

using namespace rgs;
using namespace rgs::test;
using view::detail::RateChoice;
using view::detail::RateControl;

view::ViewRequest moving_view(uint32_t width, uint32_t height, int quality) {
  view::ViewRequest v;
  v.camera.width = width;
  v.camera.height = height;
  v.camera.fx = v.camera.fy = 1000;
  v.quality = quality;
  return v;
}

/// A client looping over a link: each frame takes `fixed_s` (round trip, render, decode) plus its bytes at
/// `link_mbps`; a frame's size is `bytes_per_unit` · rendered pixels^0.8 · jpeg_size_factor(q) · 1.25 (the law's
/// model assumes pixels^1: the law must cope with a codec unlike its model).
struct Loop {
  Loop(double mbps_, double link_mbps_, double fixed_s_, double bytes_per_unit_)
      : mbps(mbps_), link_mbps(link_mbps_), fixed_s(fixed_s_), bytes_per_unit(bytes_per_unit_) {}
  double mbps, link_mbps, fixed_s, bytes_per_unit;
  RateControl control;
  double now_s = 0, last_bytes = 0;
  std::vector<double> bytes, seconds;
  std::vector<RateChoice> choices;

  void run(const view::ViewRequest& view, int frames, bool still = false) {
    for (int i = 0; i < frames; ++i) {
      const RateChoice choice = control.choose(mbps, view, still);
      choices.push_back(choice);
      const view::ViewRequest rendered = view::detail::apply_rate(view, choice);
      const double pixels = double(rendered.camera.width) * rendered.camera.height;
      const double b = bytes_per_unit * std::pow(pixels, 0.8) * 1.25 * RateControl::jpeg_size_factor(choice.quality);
      // handed over once its loop is done and the budget's pacing allows
      double ready_s = now_s + fixed_s + last_bytes * 8 / (link_mbps * 1e6);
      ready_s += control.wait_s(ready_s);
      control.record(uint64_t(b), uint64_t(pixels), choice.quality, true, choice.limited ? mbps : 0, ready_s);
      seconds.push_back(ready_s - now_s);
      bytes.push_back(last_bytes);  // the bytes sent in that interval: the previous frame's
      now_s = ready_s;
      last_bytes = b;
    }
  }
  // Bytes/s and frames/s over the last `n` frames.
  double bytes_per_s(size_t n) const { return sum(bytes, n) / sum(seconds, n); }
  double fps(size_t n) const { return double(n) / sum(seconds, n); }
  static double sum(const std::vector<double>& v, size_t n) {
    double s = 0;
    for (size_t i = v.size() - n; i < v.size(); ++i) s += v[i];
    return s;
  }
};

}  // namespace

TEST_CASE("bandwidth: the budget is the smaller of the server's and the view's, 0 being none") {
  CHECK(view::detail::effective_mbps(0, 0) == 0);
  CHECK(view::detail::effective_mbps(50, 0) == 50);
  CHECK(view::detail::effective_mbps(0, 20) == 20);
  CHECK(view::detail::effective_mbps(50, 20) == 20);
  CHECK(view::detail::effective_mbps(20, 50) == 20);
}

TEST_CASE("bandwidth: a scaled view keeps its field of view, and the size model grows with quality") {
  const view::ViewRequest v = moving_view(1920, 1080, 85);
  const view::ViewRequest s = view::detail::apply_rate(v, {40, 0.75});
  CHECK(s.camera.width == 1440);
  CHECK(s.camera.height == 810);
  CHECK(s.camera.fx == doctest::Approx(750));
  CHECK(s.camera.fy == doctest::Approx(750));
  CHECK(s.quality == 40);
  const view::ViewRequest tiny = view::detail::apply_rate(moving_view(1, 1, 85), {30, 0.5});
  CHECK(tiny.camera.width == 1);
  CHECK(tiny.camera.height == 1);
  for (int q = 2; q <= 100; ++q) CHECK(RateControl::jpeg_size_factor(q) >= RateControl::jpeg_size_factor(q - 1));
  for (int q = 2; q <= 98; ++q) CHECK(RateControl::jpeg_size_factor(q) > RateControl::jpeg_size_factor(q - 1));
  CHECK(RateControl::jpeg_size_factor(85) == doctest::Approx(1 / std::sqrt(30.0)));
}

TEST_CASE("bandwidth: no budget, a still view, a lossless frame: the view's quality at full size") {
  RateControl control;
  view::ViewRequest v = moving_view(1920, 1080, 85);
  for (int i = 0; i < 20; ++i) {
    const RateChoice c = control.choose(0, v, false);
    CHECK(c.quality == 85);
    CHECK(c.scale == 1.0);
    control.record(2000000, 1920 * 1080, 85, true, 0, i * 0.01);
  }
  // Frames far over a 1 Mbit/s budget: moving views shrink, a still one does not.
  CHECK(control.choose(1, v, false).scale < 1.0);
  const RateChoice still = control.choose(1, v, true);
  CHECK(still.quality == 85);
  CHECK(still.scale == 1.0);
  v.encoding = view::Encoding::kLossless;
  CHECK(control.choose(1, v, false).scale == 1.0);
  // The first frame, before any size is known, is the view's.
  RateControl fresh;
  CHECK(fresh.choose(1, moving_view(1920, 1080, 85), false).quality == 85);
}

TEST_CASE("bandwidth: over a 50 Mbit/s link with a 24 ms loop, moving 1080p frames hold 30 frames/s") {
  // 260 KB at 1080p q85 full size (taebak's median JPEG frame).
  Loop loop{50, 50, 0.024, 0};
  loop.bytes_per_unit = 260000 / (std::pow(1920.0 * 1080, 0.8) * 1.25 * RateControl::jpeg_size_factor(85));
  const view::ViewRequest v = moving_view(1920, 1080, 85);
  loop.run(v, 1);
  CHECK(loop.last_bytes == doctest::Approx(260000).epsilon(1e-3));
  loop.run(v, 120);
  for (const RateChoice& c : loop.choices) {  // never out of bounds
    CHECK(c.quality >= RateControl::kMinQuality);
    CHECK(c.quality <= 85);
    CHECK((c.scale == 1.0 || c.scale == 0.75 || c.scale == 0.5));
  }
  CHECK(loop.choices[5].quality < 85);  // lowered at once
  CHECK(loop.fps(60) >= 29);
  CHECK(loop.bytes_per_s(60) <= 50e6 / 8);
  MESSAGE("held: " << loop.fps(60) << " frames/s, " << loop.bytes_per_s(60) * 8 / 1e6 << " Mbit/s, q"
                   << loop.choices.back().quality << " at scale " << loop.choices.back().scale);
  // The camera stops: full size and quality, even though that frame alone is over a moving frame's share.
  loop.run(v, 1, true);
  CHECK(loop.choices.back().quality == 85);
  CHECK(loop.choices.back().scale == 1.0);
}

TEST_CASE("bandwidth: a fast client on a fast link is paced to the budget, and a generous one changes nothing") {
  Loop loop{20, 1000, 0.004, 0};
  loop.bytes_per_unit = 260000 / (std::pow(1920.0 * 1080, 0.8) * 1.25 * RateControl::jpeg_size_factor(85));
  const view::ViewRequest v = moving_view(1920, 1080, 85);
  loop.run(v, 200);
  // Even the smallest frames at the client's 200 frames/s would be over: they are paced, and the law settles at
  // 30 frames/s with the quality that fits.
  CHECK(loop.bytes_per_s(100) <= 20e6 / 8 * 1.01);
  CHECK(loop.fps(100) >= 29);
  MESSAGE("paced: " << loop.fps(100) << " frames/s, " << loop.bytes_per_s(100) * 8 / 1e6 << " Mbit/s, q"
                    << loop.choices.back().quality << " at scale " << loop.choices.back().scale);
  Loop generous{1000, 1000, 0.004, loop.bytes_per_unit};
  generous.run(v, 100);
  for (const RateChoice& c : generous.choices) {
    CHECK(c.quality == 85);
    CHECK(c.scale == 1.0);
  }
  // A quality below the floor is never raised; pauses between frames are not frame intervals.
  Loop low{0.1, 1000, 0.004, loop.bytes_per_unit};
  low.run(moving_view(1920, 1080, 20), 30);
  for (const RateChoice& c : low.choices) CHECK(c.quality <= 20);
  CHECK(low.choices.back().scale == 0.5);
}

TEST_CASE("bandwidth: a server's moving frames shrink under a tiny budget, and a still view comes at full size") {
  view::ServerOptions options;
  options.max_mbps = 0.05;
  view::Server server = start({guitar()}, options);
  WsClient client;
  REQUIRE(client.connect(server.port(), "/ws") == 101);
  const json hello = client.read_json();
  CHECK(hello["max_mbps"] == 0.05);
  const json camera = small_camera(hello, 320, 180);
  json moving = view_json(camera, 1, "jpeg");
  moving["quality"] = 85;
  moving["still"] = false;
  std::vector<size_t> sizes;
  for (uint64_t seq = 1; seq <= 4; ++seq) {
    moving["seq"] = seq;
    client.send(moving.dump());
    const Frame frame = read_frame(client);
    CHECK(frame.header["seq"] == seq);
    CHECK(frame.header["max_mbps"] == 0.05);
    sizes.push_back(frame.images[0].size());
    if (seq == 1) {  // nothing known yet: the view's
      CHECK(frame.header["width"] == 320);
      CHECK(frame.header["quality"] == 85);
    } else {  // far over 6250 bytes/s: the smallest
      CHECK(frame.header["width"] == 160);
      CHECK(frame.header["height"] == 90);
      CHECK(frame.header["scale"] == 0.5);
      CHECK(frame.header["quality"] == RateControl::kMinQuality);
    }
  }
  CHECK(sizes.back() * 2 < sizes.front());
  json still = moving;
  still["seq"] = 5;
  still["still"] = true;
  client.send(still.dump());
  const Frame full = read_frame(client);
  CHECK(full.header["width"] == 320);
  CHECK(full.header["height"] == 180);
  CHECK(full.header["quality"] == 85);
  CHECK(full.header["scale"] == 1.0);

  // The view's own budget applies when the server has none; frames without a budget say null.
  view::Server open = start({guitar()});
  WsClient other;
  REQUIRE(other.connect(open.port(), "/ws") == 101);
  CHECK(other.read_json()["max_mbps"] == 0);
  json own = moving;
  for (uint64_t seq = 1; seq <= 2; ++seq) {
    own["seq"] = seq;
    own["max_mbps"] = 0.05;
    other.send(own.dump());
    CHECK(read_frame(other).header["width"] == (seq == 1 ? 320 : 160));
  }
  own["seq"] = 3;
  own.erase("max_mbps");
  other.send(own.dump());
  const Frame unbudgeted = read_frame(other);
  CHECK(unbudgeted.header["width"] == 320);
  CHECK(unbudgeted.header["max_mbps"].is_null());
  // The header's null sent back is no budget either, not a protocol violation.
  own["seq"] = 4;
  own["max_mbps"] = nullptr;
  other.send(own.dump());
  const Frame echoed = read_frame(other);
  CHECK(echoed.header["width"] == 320);
  CHECK(echoed.header["max_mbps"].is_null());

  // A bad budget is a protocol violation: error, then close (1008).
  own["seq"] = 5;
  own["max_mbps"] = -3;
  other.send(own.dump());
  const json error = other.read_json();
  CHECK(error["code"] == "bad_message");
  CHECK(error["fatal"] == true);
  CHECK(error["message"].get<std::string>().find("max_mbps") != std::string::npos);
}
