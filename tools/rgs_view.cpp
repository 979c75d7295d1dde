// rgs-view: serves an interactive viewer page for one scene, or two to compare (view/, docs/VIEWER.md).
//   rgs-view scene.rgs                                   http://127.0.0.1:8080/ (GPU when there is one)
//   rgs-view a.rgs b.rgs --cameras cameras.json          split view, PSNR, difference heatmap
//   rgs-view big_lod.rgs --splat-budget 2000000 --memory-budget 2GiB --host 0.0.0.0 --port 9000
// Prints the URL (with its token when the host is not loopback) and serves until SIGINT or SIGTERM (exit 0).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>
#include <vector>

#include "cli_common.h"
#include "rgs/api/scene.h"
#include "rgs/api/camera.h"
#include "rgs/config.h"
#include "rgs/view/server.h"

namespace {

using namespace rgs;

constexpr const char* kTool = "rgs-view";

struct Options {
  std::string scene, scene2;
  tools::RenderOptions render;  ///< --backend, --device, --preset (the page's first), budgets, --cpu-threads
  std::string cameras;
  view::ServerOptions server;
  bool quiet = false;
};

int run(const Options& opt) {
  const tools::RenderOptions& render = opt.render;
  auto device = api::parse_device(render.backend);
  if (!device.ok()) return tools::report_usage_error(kTool, device.status());
  std::string why;
  if (render.backend == "auto" && *device == api::Device::kCpu && !opt.quiet) {
    api::cuda_available(&why);
    tools::report_note(kTool, "no CUDA device (" + why + "): the CPU reference renders, at 640x360 by default");
  }
  const api::LoadOptions load = tools::load_options(render, *device);
  std::vector<api::Scene> scenes;
  for (const std::string& path : {opt.scene, opt.scene2}) {
    if (path.empty()) continue;
    if (const Status input = tools::check_input_file(path); !input.ok()) return tools::report_error(kTool, input);
    auto scene = view::load_view_scene(path, load);
    if (!scene.ok()) return tools::report_error(kTool, scene.status());
    tools::report_notes(kTool, scene->info().notes, opt.quiet);
    scenes.push_back(std::move(*scene));
  }
  view::ServerOptions server = opt.server;
  auto preset = api::parse_preset(render.preset);
  if (!preset.ok()) return tools::report_usage_error(kTool, preset.status());
  server.preset = *preset;
  server.cuda_device = render.device;
  server.gpu_scratch_budget = render.scratch_budget;
  server.cpu_threads = render.cpu_threads;
  // Without --cameras, those a trainer wrote beside the scene (api::find_scene_cameras).
  auto cameras_path = opt.cameras.empty() ? api::find_scene_cameras(opt.scene) : Result<std::string>(opt.cameras);
  if (!cameras_path.ok()) return tools::report_error(kTool, cameras_path.status());
  if (!cameras_path->empty()) {
    if (const Status input = tools::check_input_file(*cameras_path); !input.ok()) return tools::report_error(kTool, input);
    auto cameras = api::read_inria_cameras(*cameras_path);
    if (!cameras.ok()) return tools::report_error(kTool, cameras.status());
    server.cameras = std::move(*cameras);
    if (opt.cameras.empty() && !opt.quiet) {
      tools::report_note(kTool, "cameras: " + *cameras_path + " (found beside the scene; --cameras names others)");
    }
  }
  auto started = view::Server::start(std::move(scenes), server);
  if (!started.ok()) return tools::report_error(kTool, started.status());
  auto info = api::query_device(*device, render.device);
  std::printf("%s: serving %s%s%s on %s (%s)\n", kTool, tools::escape_text(opt.scene).c_str(),
              opt.scene2.empty() ? "" : " vs ", tools::escape_text(opt.scene2).c_str(), api::device_name(*device),
              info.ok() ? tools::escape_text(info->name).c_str() : "?");
  std::printf("%s\n", started->url().c_str());
  if (!opt.quiet) std::printf("%s: frames %s\n", kTool, tools::escape_text(started->jpeg_encoder()).c_str());
  if (!started->token().empty() && !opt.quiet) {
    std::fprintf(stderr, "%s: the URL's token is required by every request (host %s is not loopback)\n", kTool,
                 tools::escape_text(opt.server.host).c_str());
  }
  if (const Status flushed = tools::flush_standard_streams(); !flushed.ok()) {
    return tools::report_error(kTool, flushed);
  }
  const int signal_number = tools::wait_for_termination_signal();
  started->stop();
  if (!opt.quiet) {
    std::fprintf(stderr, "%s: stopped (signal %d)\n", kTool, signal_number);
  }
  return tools::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  // Before any thread: the server's threads inherit the mask, and the main thread takes the signal (sigwait).
  tools::block_termination_signals();
  Options opt;
  CLI::App app{std::string("Serve an interactive viewer of a scene (or of two, compared: split view, PSNR, "
                           "difference heatmap) to a web browser: orbit and fly, the scene's cameras, presets, "
                           "frame statistics, screenshots and camera paths (docs/VIEWER.md). Frames are rendered "
                           "here through the front door and sent as JPEG or WebP. This build: CUDA ") +
                   (RGS_HAS_CUDA ? "yes." : "no (the CPU reference renders)."),
               kTool};
  app.add_option("scene", opt.scene, "Scene in any format, " + tools::scene_formats_help())->required();
  app.add_option("scene2", opt.scene2, "Second scene: compare it with the first (same cameras)");
  app.add_option("--cameras", opt.cameras, "INRIA cameras.json whose cameras the page can jump to (default: the one a "
                 "trainer wrote beside the scene, as rgs-audit finds it)");
  tools::add_render_options(app, opt.render,
                            tools::kBackendOption | tools::kPresetOption | tools::kScratchBudgetOption |
                                tools::kLodOptions,
                            "--cpu-threads");
  app.add_option("--host", opt.server.host,
                 "Address to listen on; anything but 127.0.0.1, ::1 or localhost requires the printed URL's token")
      ->capture_default_str();
  app.add_option("--port", opt.server.port, "TCP port (0: any free port)")->capture_default_str();
  app.add_option("--token", opt.server.token,
                 "Token every request must carry (?token=...; at least " + std::to_string(view::kMinTokenLength) +
                     " letters, digits, - and _); default: random (32 hex digits) when the host is not loopback, "
                     "none otherwise. With a token, any Host name reaches the server")
      ->check(CLI::Validator(
          [](std::string& token) {
            return token.size() >= view::kMinTokenLength
                       ? std::string()
                       : "a token needs at least " + std::to_string(view::kMinTokenLength) + " characters, not " +
                             std::to_string(token.size());
          },
          ""));
  app.add_option("--max-clients", opt.server.max_clients, "Most browser connections at once")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_option("--idle-timeout", opt.server.idle_timeout_s,
                 "Seconds without a message after which a browser connection is closed, freeing its slot (the "
                 "page pings every 20 s)")
      ->check(CLI::Range(0.05, 86400.0))
      ->capture_default_str();
  app.add_option("--frame-memory", opt.server.frame_memory,
                 "Host memory all clients' frames share (e.g. 2GiB, at least 16MiB): buffers, encoders and "
                 "encoded frames waiting to be sent; a client that does not read waits, a frame needing more "
                 "fails")
      ->transform(CLI::AsSizeValue(false))
      ->check(CLI::Validator(
          [](std::string& bytes) {
            const bool enough = std::stoull(bytes) >= (uint64_t(16) << 20);
            return enough ? std::string() : "at least 16MiB, not " + bytes + " bytes";
          },
          ""))
      ->capture_default_str();
  app.add_option("--max-mbps", opt.server.max_mbps,
                 "Bandwidth budget of each browser, Mbit/s (0: none; the page may set a lower one): while the "
                 "camera moves, frames are encoded at a lower JPEG/WebP quality and rendered smaller to keep "
                 "within it; the view it stops at comes at full quality")
      ->check(tools::finite_number_in(0, view::kMaxMbps))
      ->capture_default_str();
  app.add_flag_callback("--cpu-jpeg", [&opt] { opt.server.gpu_jpeg = false; },
                        "GPU backend: encode JPEG frames on the CPU even where nvJPEG is found");
  app.add_flag("-q,--quiet", opt.quiet, "Print only the URL line and errors");
  tools::add_scene_read_options(app);
  if (auto code = tools::parse_command_line(app, argc, argv, kTool)) return tools::finish(kTool, *code);
  return tools::finish(kTool, run(opt));
}
