// The viewer protocol's client messages (view/PROTOCOL.md): valid views parse to what they say; malformed, oversize,
// non-finite, non-orthonormal, too large and otherwise out-of-range messages are refused with the key named.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "rgs/api/camera.h"
#include "rgs/view/protocol.h"

namespace {

using namespace rgs;
using nlohmann::json;

json valid_view() {
  return json::parse(R"({"type":"view","seq":17,
    "camera":{"position":[0.5,-1,4],"rotation":[[1,0,0],[0,0.8,-0.6],[0,0.6,0.8]],"fx":1111.5,"fy":1100,
              "width":1920,"height":1080},
    "preset":"paper","background":[0.25,0.5,1],"encoding":"webp","quality":70,"compare":"off","diff_scale":16})");
}

Result<view::ClientMessage> parse(const json& message, const view::ProtocolLimits& limits = {}) {
  return view::parse_client_message(message.dump(), limits);
}

// The refusal of `message` names `needle`.
void check_refused(const std::string& text, const std::string& needle, const view::ProtocolLimits& limits = {},
                   StatusCode code = StatusCode::kInvalidArgument) {
  CAPTURE(text);
  auto parsed = view::parse_client_message(text, limits);
  REQUIRE_FALSE(parsed.ok());
  CHECK(parsed.status().code() == code);
  CHECK_MESSAGE(parsed.status().message().find(needle) != std::string::npos, parsed.status().message());
}

void check_refused_json(const json& message, const std::string& needle, const view::ProtocolLimits& limits = {}) {
  check_refused(message.dump(), needle, limits);
}

}  // namespace

TEST_CASE("protocol: a valid view parses to its values, and writes back to the same view") {
  auto parsed = parse(valid_view());
  REQUIRE(parsed.ok());
  REQUIRE(parsed->type == view::ClientMessage::Type::kView);
  const view::ViewRequest& v = parsed->view;
  CHECK(v.seq == 17);
  CHECK(v.camera.position[2] == 4.0);
  CHECK(v.camera.rotation_c2w[5] == -0.6);
  CHECK(v.camera.fx == 1111.5);
  CHECK(v.camera.width == 1920);
  CHECK(v.camera.height == 1080);
  CHECK(v.preset == api::Preset::kPaper);
  CHECK(v.background[1] == 0.5f);
  CHECK(v.encoding == view::Encoding::kWebp);
  CHECK(v.quality == 70);
  CHECK(v.compare == view::CompareMode::kOff);
  CHECK(v.diff_scale == 16.f);

  auto again = view::parse_client_message(view::view_message_json(v), {});
  REQUIRE(again.ok());
  CHECK(again->view.camera.rotation_c2w == v.camera.rotation_c2w);
  CHECK(again->view.camera.position == v.camera.position);
  CHECK(again->view.preset == v.preset);
  CHECK(again->view.encoding == v.encoding);

  // The camera is the INRIA convention: camera_from_request gives R = c2wᵀ and t = −R·position.
  auto camera = view::camera_from_request(v.camera);
  REQUIRE(camera.ok());
  CHECK(camera->rotation[1] == doctest::Approx(0.0));
  CHECK(camera->rotation[5] == doctest::Approx(0.6));  // R[1][2] = c2w[2][1]
  const auto back = view::inria_from_camera(*camera);
  for (int i = 0; i < 3; ++i) CHECK(back.position[i] == doctest::Approx(v.camera.position[i]).epsilon(1e-6));

  // Defaults: preset from the limits, jpeg 85, compare off.
  json minimal = valid_view();
  for (const char* key : {"preset", "background", "encoding", "quality", "compare", "diff_scale"}) minimal.erase(key);
  view::ProtocolLimits limits;
  limits.default_preset = api::Preset::kFaithful;
  auto defaults = parse(minimal, limits);
  REQUIRE(defaults.ok());
  CHECK(defaults->view.preset == api::Preset::kFaithful);
  CHECK(defaults->view.encoding == view::Encoding::kJpeg);
  CHECK(defaults->view.quality == 85);
  CHECK(defaults->view.compare == view::CompareMode::kOff);

  auto ping = view::parse_client_message(R"({"type":"ping"})", {});
  REQUIRE(ping.ok());
  CHECK(ping->type == view::ClientMessage::Type::kPing);
}

TEST_CASE("protocol: malformed, oversize and deeply nested messages are refused") {
  check_refused("", "not valid JSON");
  check_refused("{\"type\":\"view\"", "not valid JSON");
  check_refused("[1,2,3]", "not a JSON object");
  check_refused(R"({"type":"render"})", "unknown type");
  check_refused(R"({"seq":1})", "missing \"type\"");
  check_refused(R"({"type":7})", "\"type\" is not a string");
  // NaN and Infinity are not JSON.
  check_refused(R"({"type":"view","seq":1,"camera":{"position":[NaN,0,0]}})", "not valid JSON");
  // Over the size limit, whatever it holds.
  std::string big = valid_view().dump();
  big.insert(big.size() - 1, ",\"pad\":\"" + std::string(70 * 1024, 'x') + "\"");
  check_refused(big, "exceeds the limit of 65536", {}, StatusCode::kLimitExceeded);
  std::string nested = R"({"type":"view","x":)" + std::string(100, '[') + std::string(100, ']') + "}";
  check_refused(nested, "deeper than 8", {}, StatusCode::kLimitExceeded);
  // Brackets inside strings do not count.
  json quoted = valid_view();
  quoted["note"] = std::string(100, '[');
  CHECK(parse(quoted).ok());
}

TEST_CASE("protocol: non-finite, non-orthonormal and out-of-range camera values are refused") {
  json v = valid_view();
  json m;
  // An overflowing literal: refused by the parser, or read as infinity and refused as not finite.
  {
    auto overflow = view::parse_client_message(
        R"({"type":"view","seq":1,"camera":{"position":[0,0,1e999],"rotation":[[1,0,0],[0,1,0],[0,0,1]],)"
        R"("fx":100,"fy":100,"width":64,"height":64}})",
        {});
    REQUIRE_FALSE(overflow.ok());
    CHECK(overflow.status().code() == StatusCode::kInvalidArgument);
  }
  m = v, m["camera"]["position"] = {0, 0};
  check_refused_json(m, "camera.position");
  m = v, m["camera"]["position"] = {0, 0, 2e9};
  check_refused_json(m, "outside ±1e9");
  m = v, m["camera"]["position"] = {0, "1", 0};
  check_refused_json(m, "camera.position");
  m = v, m["camera"]["rotation"] = {{1, 0, 0}, {0, 1, 0}, {0, 0.1, 1}};
  check_refused_json(m, "camera");
  m = v, m["camera"]["rotation"] = {{1, 0, 0}, {0, 1, 0}, {0, 0, -1}};  // a reflection, det −1
  check_refused_json(m, "camera");
  m = v, m["camera"]["rotation"] = {{2, 0, 0}, {0, 2, 0}, {0, 0, 2}};
  check_refused_json(m, "camera");
  m = v, m["camera"]["rotation"] = {{1, 0, 0}, {0, 1, 0}};
  check_refused_json(m, "camera.rotation");
  m = v, m["camera"]["fx"] = 0;
  check_refused_json(m, "fx");
  m = v, m["camera"]["fy"] = -5;
  check_refused_json(m, "fy");
  m = v, m["camera"]["fx"] = 2e6;
  check_refused_json(m, "(0, 1e6]");
  m = v, m["camera"]["width"] = 7681;
  check_refused_json(m, "\"width\" must be an integer in 1..7680");
  m = v, m["camera"]["height"] = 4321;
  check_refused_json(m, "\"height\" must be an integer in 1..4320");
  m = v, m["camera"]["width"] = 0;
  check_refused_json(m, "width");
  m = v, m["camera"]["width"] = 640.5;
  check_refused_json(m, "width");
  m = v, m["camera"]["width"] = 1920.0;  // a JSON integer, as in a cameras.json
  check_refused_json(m, "\"width\" must be an integer in 1..7680");
  m = v, m["camera"]["height"] = "1080";
  check_refused_json(m, "height");
  m = v, m["camera"].erase("fy");
  check_refused_json(m, "missing \"fy\"");
  m = v, m.erase("camera");
  check_refused_json(m, "missing \"camera\"");
  m = v, m["camera"] = 3;
  check_refused_json(m, "\"camera\" is not an object");
  // The largest frame is allowed; a server with a lower limit refuses it.
  m = v, m["camera"]["width"] = 7680, m["camera"]["height"] = 4320;
  CHECK(parse(m).ok());
  view::ProtocolLimits small;
  small.max_width = 1920;
  small.max_height = 1080;
  m["camera"]["fx"] = 1000;
  check_refused_json(m, "1..1920", small);
}

TEST_CASE("protocol: other fields out of range or of the wrong type are refused") {
  const json v = valid_view();
  json m;
  m = v, m["seq"] = -1;
  check_refused_json(m, "seq");
  m = v, m["seq"] = 9007199254740992.0;
  check_refused_json(m, "seq");
  m = v, m["seq"] = 1.5;
  check_refused_json(m, "seq");
  m = v, m.erase("seq");
  check_refused_json(m, "missing \"seq\"");
  m = v, m["preset"] = "quick";
  check_refused_json(m, "preset");
  m = v, m["background"] = {0, 0, 1.5};
  check_refused_json(m, "background");
  m = v, m["background"] = {0, 0};
  check_refused_json(m, "background");
  m = v, m["encoding"] = "png";
  check_refused_json(m, "encoding");
  m = v, m["quality"] = 0;
  check_refused_json(m, "quality");
  m = v, m["quality"] = 101;
  check_refused_json(m, "quality");
  m = v, m["quality"] = "high";
  check_refused_json(m, "quality");
  m = v, m["compare"] = "side";
  check_refused_json(m, "compare");
  m = v, m["diff_scale"] = 0.5;
  check_refused_json(m, "diff_scale");
  // The bandwidth budget: a finite number in [0, 100000] Mbit/s; still: a boolean.
  for (const json& bad : {json(-1), json(100001), json(1e300), json("50"), json::array()}) {  // null: none
    m = v, m["max_mbps"] = bad;
    check_refused_json(m, "max_mbps");
  }
  // Numbers JSON cannot hold (an overflow to infinity, NaN) are not JSON.
  for (const char* bad : {"1e400", "-1e400", "NaN", "Infinity"}) {
    check_refused(R"({"type":"view","seq":1,"camera":)" + v["camera"].dump() + ",\"max_mbps\":" + bad + "}",
                  "not valid JSON");
  }
  for (const json& bad : {json(1), json("true"), json(nullptr)}) {
    m = v, m["still"] = bad;
    check_refused_json(m, "still");
  }
  m = v, m["max_mbps"] = 12.5, m["still"] = true;
  auto budgeted = parse(m);
  REQUIRE(budgeted.ok());
  CHECK(budgeted->view.max_mbps == 12.5);
  CHECK(budgeted->view.still);
  auto written = view::parse_client_message(view::view_message_json(budgeted->view), {});
  REQUIRE(written.ok());
  CHECK(written->view.max_mbps == 12.5);
  CHECK(written->view.still);
  CHECK_FALSE(parse(v)->view.still);
  CHECK(parse(v)->view.max_mbps == 0);
  // Compare modes need a second scene; a preset the server does not offer is refused.
  m = v, m["compare"] = "split";
  check_refused_json(m, "second scene");
  view::ProtocolLimits two;
  two.compare_available = true;
  CHECK(parse(m, two).ok());
  view::ProtocolLimits fastest_only;
  fastest_only.presets = {api::Preset::kFastest};
  check_refused_json(v, "not offered", fastest_only);
  // Unknown keys are ignored.
  m = v, m["future"] = {{"a", 1}};
  CHECK(parse(m).ok());
}

TEST_CASE("the viewer's cameras.json reader (api::read_inria_cameras): numbers as written, hostile files refused") {
  const auto path = std::filesystem::temp_directory_path() / "rgs_test_view_cameras.json";
  const auto write = [&](const std::string& text) { std::ofstream(path) << text; };
  write(R"([{"id":0,"img_name":"a","width":640,"height":360,"position":[0.1,0.2,-3.3],
             "rotation":[[1,0,0],[0,1,0],[0,0,1]],"fx":500.25,"fy":500.5},
            {"id":1,"width":320,"height":180,"position":[1,2,3],
             "rotation":[[0,0,1],[0,1,0],[-1,0,0]],"fx":250,"fy":250}])");
  auto cameras = api::read_inria_cameras(path.string());
  REQUIRE(cameras.ok());
  REQUIRE(cameras->size() == 2);
  CHECK((*cameras)[0].name == "a");
  CHECK((*cameras)[0].camera.position[2] == -3.3);
  CHECK((*cameras)[0].camera.fx == 500.25);
  CHECK((*cameras)[1].name == "camera_1");
  CHECK((*cameras)[1].camera.rotation_c2w[2] == 1.0);
  // What the renderers' reader refuses the viewer refuses too, with the same code: a rotation that is not one,
  // sizes that are not integers, an empty array, nesting deeper than a cameras.json has.
  const auto refused = [&](const std::string& text, StatusCode code, const std::string& needle) {
    write(text);
    auto bad = api::read_inria_cameras(path.string());
    REQUIRE_FALSE(bad.ok());
    CHECK(bad.status().code() == code);
    CHECK_MESSAGE(bad.status().message().find(needle) != std::string::npos, bad.status().message());
  };
  const std::string camera = R"({"width":640,"height":360,"position":[0,0,0],"rotation":[[1,0,0],[0,1,0],[0,0,1]],
                                 "fx":100,"fy":100})";
  auto with = [&](const std::string& from, const std::string& to) {
    std::string text = camera;
    text.replace(text.find(from), from.size(), to);
    return "[" + camera + "," + text + "]";
  };
  refused(with("[0,0,1]]", "[0,0,2]]"), StatusCode::kCorruptData, "camera 1");
  refused(with("\"width\":640", "\"width\":640.0"), StatusCode::kCorruptData,
          "\"width\" must be an integer in 1..32768");
  refused(with("\"fx\":100", "\"fx\":1e7"), StatusCode::kCorruptData, "focal lengths");
  refused(with("\"position\":[0,0,0]", "\"position\":[0,0,1e10]"), StatusCode::kCorruptData, "outside");
  refused("[]", StatusCode::kCorruptData, "empty");
  refused("[" + camera + "," + std::string(100000, '[') + std::string(100000, ']') + "]", StatusCode::kLimitExceeded,
          "nested deeper than 8 levels");
  std::filesystem::remove(path);
  CHECK(api::read_inria_cameras(path.string()).status().code() == StatusCode::kIoError);
}
