// An rgs::view server on 127.0.0.1 (port 0, CPU backend, samples/guitar.ply) answering Beast HTTP and WebSocket
// clients: the embedded page and nothing else, the token rule, the connection limit, protocol violations closing
// only the offending client, frames whose lossless image is the front door's 8-bit render of the same camera,
// the compare mode's images and PSNR, and a clean stop; on a GPU, frames equal to the front door's GPU render and
// JPEG frames encoded on the GPU within JPEG's tolerance of the CPU encoder's.
#include <atomic>
#include <cmath>
#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include <doctest/doctest.h>
#include <webp/decode.h>

#include "rgs/api/convert.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/parallel/fork_join.h"
#include "rgs/view/image_codec.h"
#include "rgs/view/server.h"
#include "test_data.h"
#include "view_server_client.h"
#include "view_test_util.h"

namespace {

using namespace rgs;
using namespace rgs::test;

// The 8-bit RGB of a kRgba8 image (its alpha dropped), copied to the host.
std::vector<uint8_t> host_rgb(const api::Image& image) {
  const size_t pixels = size_t(image.width()) * image.height();
  std::vector<uint8_t> rgba(pixels * 4), rgb(pixels * 3);
  REQUIRE(image.copy_to_host(rgba.data(), nullptr).ok());
  for (size_t p = 0; p < pixels; ++p) {
    for (int c = 0; c < 3; ++c) rgb[p * 3 + c] = rgba[p * 4 + c];
  }
  return rgb;
}

// The front door's 8-bit RGB of `scene` from the protocol camera `camera` (as rgs-render writes it).
std::vector<uint8_t> reference_rgb(const api::Scene& scene, const json& camera) {
  view::ViewRequest request;
  auto parsed = view::parse_client_message(view_json(camera, 0, "lossless").dump(), {});
  REQUIRE(parsed.ok());
  auto cam = view::camera_from_request(parsed->view.camera);
  REQUIRE(cam.ok());
  auto renderer = api::Renderer::create(api::Device::kCpu);
  REQUIRE(renderer.ok());
  api::RenderSettings settings;
  settings.background = {0.2f, 0.1f, 0.0f};
  auto image = renderer->render_image(scene, *cam, settings, api::PixelFormat::kRgba8);
  REQUIRE(image.ok());
  return host_rgb(*image);
}

}  // namespace

TEST_CASE("server: serves the embedded page and nothing else") {
  view::Server server = start({guitar()});
  CHECK(server.url() == "http://127.0.0.1:" + std::to_string(server.port()) + "/");
  CHECK(server.token().empty());
  const Reply page = http_request(server.port(), "/");
  CHECK(page.status == 200);
  CHECK(page.content_type == "text/html; charset=utf-8");
  CHECK(page.body.find("<html") != std::string::npos);
  CHECK(http_request(server.port(), "/index.html").body == page.body);
  CHECK(http_request(server.port(), "/", http::verb::head).status == 200);
  for (const char* path : {"/../etc/passwd", "/..%2f..%2fetc/passwd", "/CMakeLists.txt", "/view/web/index.html",
                           "/index.html/", "//index.html", "/web/app.js", "/favicon.ico", "/etc/passwd"}) {
    CAPTURE(path);
    const Reply reply = http_request(server.port(), path);
    CHECK(reply.status == 404);
    CHECK(reply.body.find("root:") == std::string::npos);
  }
  CHECK(http_request(server.port(), "/", http::verb::post).status == 405);
  CHECK(http_request(server.port(), "/ws").status == 400);  // not an upgrade
  // The page works without internet: the page and what it loads name no other host (no CDN, no web font).
  for (const char* path : {"/", "/app.js", "/style.css"}) {
    CAPTURE(path);
    const Reply reply = http_request(server.port(), path);
    CHECK(reply.status == 200);
    CHECK(reply.body.find("://") == std::string::npos);
    CHECK(reply.body.find("@import") == std::string::npos);
  }
  server.stop();
  server.stop();  // idempotent
}

TEST_CASE("server: with a token, requests and upgrades without it get 403") {
  view::ServerOptions options;
  options.token = "secret-token_0001";
  view::Server server = start({guitar()}, options);
  CHECK(server.url() == "http://127.0.0.1:" + std::to_string(server.port()) + "/?token=secret-token_0001");
  CHECK(http_request(server.port(), "/").status == 403);
  CHECK(http_request(server.port(), "/?token=secret-token_0002").status == 403);
  CHECK(http_request(server.port(), "/?token=secret-token_000").status == 403);
  CHECK(http_request(server.port(), "/CMakeLists.txt").status == 403);
  CHECK(http_request(server.port(), "/?token=secret-token_0001").status == 200);
  CHECK(http_request(server.port(), "/app.js?x=1&token=secret-token_0001").status ==
        (http_request(server.port(), "/app.js?token=secret-token_0001").status));
  CHECK(http_request(server.port(), "/ws", http::verb::get, true).status == 403);
  CHECK(http_request(server.port(), "/ws?token=nope", http::verb::get, true).status == 403);
  CHECK(http_request(server.port(), "/ws?token=secret-token_0001", http::verb::get, true).status == 101);
  WsClient client;
  REQUIRE(client.connect(server.port(), "/ws?token=secret-token_0001") == 101);
  CHECK(client.read_json()["type"] == "hello");

  // A host other than loopback gets a random token of 32 hex digits.
  view::ServerOptions any;
  any.host = "0.0.0.0";
  view::Server open = start({guitar()}, any);
  CHECK(open.token().size() == 32);
  CHECK(open.token().find_first_not_of("0123456789abcdef") == std::string::npos);
  CHECK(open.url().find("?token=" + open.token()) != std::string::npos);
  CHECK(http_request(open.port(), "/").status == 403);
  CHECK(http_request(open.port(), "/?token=" + open.token()).status == 200);
  view::Server other = start({guitar()}, any);
  CHECK(other.token() != open.token());

  view::ServerOptions bad;
  bad.token = "a b";
  CHECK(view::Server::start({guitar()}, bad).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("server: a lossless frame is the front door's 8-bit render of the same camera") {
  view::Server server = start({guitar()});
  WsClient client;
  REQUIRE(client.connect(server.port(), "/ws") == 101);
  const json hello = client.read_json();
  CHECK(hello["type"] == "hello");
  CHECK(hello["version"] == view::kProtocolVersion);
  CHECK(hello["backend"] == "cpu");
  CHECK(hello["compare"] == false);
  CHECK(hello["default_width"] == 640);
  CHECK(hello["scenes"][0]["gaussians"] == guitar().info().gaussians);
  CHECK(hello["scenes"][0]["path_basename"] == "guitar.ply");
  CHECK(hello["presets"] == json({"fastest", "faithful", "paper"}));
  CHECK(hello["max_width"] == 7680);
  CHECK(hello["encoder"] == view::jpeg_encoder_name(std::min(parallel::available_cpus(), 8u)));

  const json camera = small_camera(hello, 200, 120);
  client.send(view_json(camera, 41, "lossless").dump());
  const Frame frame = read_frame(client);
  CHECK(frame.header["type"] == "frame");
  CHECK(frame.header["seq"] == 41);
  CHECK(frame.header["width"] == 200);
  CHECK(frame.header["height"] == 120);
  REQUIRE(frame.images.size() == 1);
  CHECK(frame.header["images"][0]["role"] == "a");
  CHECK(frame.header["images"][0]["encoding"] == "webp-lossless");
  CHECK(frame.header["stats"]["splats"] == guitar().info().gaussians);
  CHECK(frame.header["stats"]["pairs"].get<uint64_t>() > 0);
  CHECK(frame.header["stats"]["preprocess_ms"].is_null());  // CPU: no GPU stage times
  CHECK(frame.header["psnr"].is_null());
  int w = 0, h = 0;
  const std::vector<uint8_t> rgb = decode_webp(frame.images[0], &w, &h);
  CHECK(w == 200);
  CHECK(h == 120);
  CHECK(rgb == reference_rgb(guitar(), camera));

  // JPEG at the same camera: a JPEG of that size.
  client.send(view_json(camera, 42, "jpeg").dump());
  const Frame jpeg = read_frame(client);
  CHECK(jpeg.header["seq"] == 42);
  CHECK(jpeg.header["images"][0]["encoding"] == "jpeg");
  CHECK(jpeg.images[0][0] == 0xFF);

  client.send(R"({"type":"ping"})");
  CHECK(client.read_json()["type"] == "pong");
}

TEST_CASE("server: a protocol violation closes that client only, with an error and close code 1008") {
  view::Server server = start({guitar()});
  WsClient good, bad, binary, huge;
  for (WsClient* c : {&good, &bad, &binary, &huge}) {
    REQUIRE(c->connect(server.port(), "/ws") == 101);
    REQUIRE(c->read_json()["type"] == "hello");
  }
  bad.send(R"({"type":"view","seq":1,"camera":{"position":[0,0,0],"rotation":[[1,0,0],[0,1,0],[0,0,3]],)"
           R"("fx":100,"fy":100,"width":64,"height":64}})");
  const json error = bad.read_json();
  CHECK(error["type"] == "error");
  CHECK(error["fatal"] == true);
  CHECK(error["code"] == "bad_message");
  std::string rest;
  CHECK_FALSE(bad.read(&rest));
  CHECK(bad.ws.reason().code == websocket::close_code::policy_error);
  const auto& reason = bad.ws.reason().reason;  // the close frame says why too
  CHECK(std::string(reason.data(), reason.size()).find("rotation") != std::string::npos);


  binary.ws.binary(true);
  binary.ws.write(net::buffer(std::string("\x01\x02")));
  CHECK(binary.read_json()["code"] == "binary");
  CHECK_FALSE(binary.read(&rest));

  huge.send(std::string(70 * 1024, ' '));
  CHECK_FALSE(huge.read(&rest));
  CHECK(huge.ws.reason().code == websocket::close_code::too_big);

  // The others go on.
  std::string hello_text;
  WsClient probe;
  REQUIRE(probe.connect(server.port(), "/ws") == 101);
  const json hello = probe.read_json();
  good.send(view_json(small_camera(hello, 64, 36), 5, "webp").dump());
  CHECK(read_frame(good).header["seq"] == 5);
}

TEST_CASE("server: the ninth client is refused with busy and close code 1013, a freed slot is taken again") {
  view::ServerOptions options;
  CHECK(options.max_clients == 8);
  view::Server server = start({guitar()}, options);
  std::vector<std::unique_ptr<WsClient>> clients;
  for (int i = 0; i < 8; ++i) {
    clients.push_back(std::make_unique<WsClient>());
    REQUIRE(clients.back()->connect(server.port(), "/ws") == 101);
    REQUIRE(clients.back()->read_json()["type"] == "hello");
  }
  CHECK(server.clients() == 8);
  WsClient ninth;
  REQUIRE(ninth.connect(server.port(), "/ws") == 101);
  const json busy = ninth.read_json();
  CHECK(busy["type"] == "error");
  CHECK(busy["code"] == "busy");
  std::string rest;
  CHECK_FALSE(ninth.read(&rest));
  CHECK(ninth.ws.reason().code == websocket::close_code::try_again_later);
  CHECK(server.clients() == 8);

  clients.front()->ws.close(websocket::close_code::normal);
  clients.erase(clients.begin());
  for (int i = 0; i < 200 && server.clients() > 7; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  CHECK(server.clients() == 7);
  WsClient again;
  REQUIRE(again.connect(server.port(), "/ws") == 101);
  CHECK(again.read_json()["type"] == "hello");
}

TEST_CASE("server: the latest view wins, stale views are dropped, not queued") {
  view::Server server = start({guitar()});
  WsClient client;
  REQUIRE(client.connect(server.port(), "/ws") == 101);
  const json camera = small_camera(client.read_json(), 320, 180);
  const uint64_t kViews = 30;
  for (uint64_t seq = 0; seq < kViews; ++seq) client.send(view_json(camera, seq, "lossless").dump());
  std::vector<uint64_t> seqs;
  while (seqs.empty() || seqs.back() != kViews - 1) seqs.push_back(read_frame(client).header["seq"].get<uint64_t>());
  MESSAGE(kViews << " views sent at once gave " << seqs.size() << " frames");
  CHECK(seqs.size() < kViews / 2);
  for (size_t i = 1; i < seqs.size(); ++i) CHECK(seqs[i] > seqs[i - 1]);
}

TEST_CASE("server: a client that never reads does not stall another, and stop() closes both with 1001") {
  view::Server server = start({guitar()});
  WsClient stuck, live;
  REQUIRE(stuck.connect(server.port(), "/ws") == 101);
  REQUIRE(live.connect(server.port(), "/ws") == 101);
  const json hello = stuck.read_json();
  live.read_json();
  for (uint64_t seq = 0; seq < 40; ++seq) stuck.send(view_json(small_camera(hello, 320, 180), seq, "lossless").dump());
  for (uint64_t seq = 100; seq < 103; ++seq) {
    live.send(view_json(small_camera(hello, 96, 54), seq, "jpeg").dump());
    CHECK(read_frame(live).header["seq"] == seq);
  }
  const auto begin = std::chrono::steady_clock::now();
  server.stop();
  CHECK(std::chrono::steady_clock::now() - begin < std::chrono::seconds(5));
  CHECK(server.clients() == 0);
  std::string rest;
  while (live.read(&rest)) {
  }
  CHECK(live.ws.reason().code == websocket::close_code::going_away);
  CHECK_THROWS(http_request(server.port(), "/"));  // nothing listens any more
}

TEST_CASE("server: compare mode sends a and b, or the heatmap, with the PSNR of the two 8-bit images") {
  // a: the sample's float values; b: the sample converted to .rgs (quantized): close to a but not equal.
  const auto rgs_path = std::filesystem::temp_directory_path() / "rgs_test_view_guitar.rgs";
  REQUIRE(api::convert(test::repo_path("samples/guitar.ply"), rgs_path.string()).ok());
  const api::Scene a = cpu_scene(test::repo_path("samples/guitar.ply"), false);
  const api::Scene b = cpu_scene(rgs_path.string());
  view::Server server = start({a, b});
  WsClient client;
  REQUIRE(client.connect(server.port(), "/ws") == 101);
  const json hello = client.read_json();
  CHECK(hello["compare"] == true);
  REQUIRE(hello["scenes"].size() == 2);
  CHECK(hello["scenes"][1]["name"] == "b");
  const json camera = small_camera(hello, 160, 90);

  client.send(view_json(camera, 1, "lossless", "split").dump());
  const Frame split = read_frame(client);
  REQUIRE(split.images.size() == 2);
  CHECK(split.header["images"][0]["role"] == "a");
  CHECK(split.header["images"][1]["role"] == "b");
  int w = 0, h = 0;
  const std::vector<uint8_t> a_rgb = decode_webp(split.images[0], &w, &h);
  const std::vector<uint8_t> b_rgb = decode_webp(split.images[1], &w, &h);
  CHECK(a_rgb == reference_rgb(a, camera));
  CHECK(b_rgb == reference_rgb(b, camera));
  REQUIRE(a_rgb != b_rgb);
  const view::ImageDifference expected = view::compare_rgb(a_rgb.data(), b_rgb.data(), 160, 90, 32, nullptr);
  REQUIRE(split.header["psnr"].is_number());
  CHECK(split.header["psnr"].get<double>() == doctest::Approx(*expected.psnr_db));
  CHECK(split.header["psnr"].get<double>() > 25.0);
  CHECK(split.header["diff_max"] == expected.max_abs);

  client.send(view_json(camera, 2, "lossless", "diff").dump());
  const Frame diff = read_frame(client);
  REQUIRE(diff.images.size() == 1);
  CHECK(diff.header["images"][0]["role"] == "diff");
  CHECK(diff.header["diff_scale"] == 32.0);
  std::vector<uint8_t> heat;
  view::compare_rgb(a_rgb.data(), b_rgb.data(), 160, 90, 32, &heat);
  CHECK(decode_webp(diff.images[0], &w, &h) == heat);
  std::filesystem::remove(rgs_path);
}

TEST_CASE("server GPU: frames carry stage times and GPU memory, and equal the front door's GPU 8-bit render") {
  std::string why;
  if (!api::cuda_available(&why)) {
    MESSAGE("skipped: no CUDA device (" << why << ")");
    return;
  }
  api::LoadOptions gpu;
  gpu.device = api::Device::kCuda;
  auto scene = view::load_view_scene(test::repo_path("samples/guitar.ply"), gpu);
  REQUIRE(scene.ok());
  view::Server server = start({*scene});
  WsClient client;
  REQUIRE(client.connect(server.port(), "/ws") == 101);
  const json hello = client.read_json();
  CHECK(hello["backend"] == "cuda");
  CHECK(hello["default_width"] == 1920);
  CHECK(hello["presets"] == json({"fastest", "faithful", "paper"}));
  const json camera = small_camera(hello, 640, 360);
  for (const char* preset : {"fastest", "faithful"}) {
    CAPTURE(preset);
    json message = view_json(camera, 9, "lossless");
    message["preset"] = preset;
    client.send(message.dump());
    const Frame frame = read_frame(client);
    const json& stats = frame.header["stats"];
    CHECK(stats["preprocess_ms"].get<double>() > 0);
    CHECK(stats["total_gpu_ms"].get<double>() > 0);
    CHECK(stats["gpu_memory_total_bytes"].get<uint64_t>() > stats["gpu_memory_used_bytes"].get<uint64_t>());
    CHECK(stats["gpu_memory_used_bytes"].get<uint64_t>() >= scene->info().memory_bytes);
    int w = 0, h = 0;
    const std::vector<uint8_t> rgb = decode_webp(frame.images[0], &w, &h);
    // The reference: the same camera through the front door on the GPU.
    auto parsed = view::parse_client_message(message.dump(), {});
    REQUIRE(parsed.ok());
    auto cam = view::camera_from_request(parsed->view.camera);
    REQUIRE(cam.ok());
    auto renderer = api::Renderer::create(api::Device::kCuda);
    REQUIRE(renderer.ok());
    api::RenderSettings settings;
    settings.preset = *api::parse_preset(preset);
    settings.background = {0.2f, 0.1f, 0.0f};
    auto image = renderer->render_image(*scene, *cam, settings, api::PixelFormat::kRgba8);
    REQUIRE(image.ok());
    CHECK(rgb == host_rgb(*image));
  }
}

TEST_CASE("server GPU: JPEG frames encoded with nvJPEG decode within JPEG's tolerance of the CPU encoder's") {
  std::string why;
  if (!api::cuda_available(&why)) {
    MESSAGE("skipped: no CUDA device (" << why << ")");
    return;
  }
  auto encoder = api::GpuJpegEncoder::create();
  if (!encoder.ok()) {
    MESSAGE("skipped: " << encoder.status().message());
    return;
  }
  api::LoadOptions gpu;
  gpu.device = api::Device::kCuda;
  auto scene = view::load_view_scene(test::repo_path("samples/guitar.ply"), gpu);
  REQUIRE(scene.ok());
  auto renderer = api::Renderer::create(api::Device::kCuda);
  REQUIRE(renderer.ok());
  api::RenderSettings settings;
  settings.background = {0.2f, 0.1f, 0.0f};
  // The server's frames: the hello names nvJPEG, and a frame is the GPU encoding of the front door's render.
  view::Server server = start({*scene});
  WsClient client;
  REQUIRE(client.connect(server.port(), "/ws") == 101);
  const json hello = client.read_json();
  CHECK(hello["encoder"].get<std::string>().find("nvJPEG") != std::string::npos);
  // Odd sizes (partial MCUs), 4:2:0 below quality 90 and 4:4:4 from it.
  for (const auto& [w, h, quality] : {std::tuple{640u, 360u, 85}, std::tuple{637u, 359u, 60}, std::tuple{641u, 353u, 95}}) {
    CAPTURE(w);
    CAPTURE(quality);
    const json camera = small_camera(hello, w, h);
    json message = view_json(camera, 5, "jpeg");
    message["quality"] = quality;
    client.send(message.dump());
    const Frame frame = read_frame(client);
    REQUIRE(frame.images.size() == 1);
    auto parsed = view::parse_client_message(message.dump(), {});
    REQUIRE(parsed.ok());
    auto cam = view::camera_from_request(parsed->view.camera);
    REQUIRE(cam.ok());
    auto image = renderer->render_image(*scene, *cam, settings, api::PixelFormat::kRgba8);
    REQUIRE(image.ok());
    const std::vector<uint8_t> rgb = host_rgb(*image);
    std::vector<uint8_t> on_gpu;
    REQUIRE(encoder->encode(*image, quality, view::jpeg_subsamples_chroma(quality), &on_gpu).ok());
    CHECK(frame.images[0] == on_gpu);  // the server's frame is this encoding
    auto on_cpu = view::encode_rgb(rgb.data(), w, h, view::Encoding::kJpeg, quality, 3);
    REQUIRE(on_cpu.ok());
    const std::vector<uint8_t> gpu_rgb = decode_jpeg(on_gpu, w, h), cpu_rgb = decode_jpeg(*on_cpu, w, h);
    // Each against the render, and the two decodings against each other: the encoders differ only in their
    // colour conversion's and DCT's rounding and their chroma filters.
    const view::ImageDifference gpu_error = view::compare_rgb(gpu_rgb.data(), rgb.data(), w, h, 1.f, nullptr, 3);
    const view::ImageDifference cpu_error = view::compare_rgb(cpu_rgb.data(), rgb.data(), w, h, 1.f, nullptr, 3);
    const view::ImageDifference between = view::compare_rgb(gpu_rgb.data(), cpu_rgb.data(), w, h, 1.f, nullptr, 3);
    REQUIRE(gpu_error.psnr_db);
    REQUIRE(cpu_error.psnr_db);
    MESSAGE("quality " << quality << ": GPU " << *gpu_error.psnr_db << " dB, CPU " << *cpu_error.psnr_db
                       << " dB against the render; " << on_gpu.size() << " and " << on_cpu->size() << " bytes");
    CHECK(std::abs(*gpu_error.psnr_db - *cpu_error.psnr_db) < 1.0);
    CHECK(between.psnr_db.value_or(99.0) > 38.0);
    CHECK(double(on_gpu.size()) < 1.3 * double(on_cpu->size()));
  }
  // What the encoder refuses: a CPU image, a quality out of range.
  api::LoadOptions cpu;
  cpu.device = api::Device::kCpu;
  auto host_scene = view::load_view_scene(test::repo_path("samples/guitar.ply"), cpu);
  REQUIRE(host_scene.ok());
  auto parsed = view::parse_client_message(view_json(small_camera(hello, 64, 48), 6, "jpeg").dump(), {});
  REQUIRE(parsed.ok());
  auto cam = view::camera_from_request(parsed->view.camera);
  REQUIRE(cam.ok());
  auto cpu_renderer = api::Renderer::create(api::Device::kCpu);
  REQUIRE(cpu_renderer.ok());
  auto cpu_image = cpu_renderer->render_image(*host_scene, *cam, settings, api::PixelFormat::kRgba8);
  REQUIRE(cpu_image.ok());
  std::vector<uint8_t> out;
  CHECK(encoder->encode(*cpu_image, 80, true, &out).code() == StatusCode::kInvalidArgument);
  auto gpu_image = renderer->render_image(*scene, *cam, settings, api::PixelFormat::kRgba8);
  REQUIRE(gpu_image.ok());
  CHECK(encoder->encode(*gpu_image, 0, true, &out).code() == StatusCode::kInvalidArgument);
  CHECK(encoder->encode(*gpu_image, 101, true, &out).code() == StatusCode::kInvalidArgument);
}
