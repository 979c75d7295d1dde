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
  std::string backend = "auto";
  int device = 0;
  std::string preset = "fastest";
  std::string cameras;
  api::LodSettings lod;
  bool no_lod = false;
  uint64_t scratch_budget = 0;
  view::ServerOptions server;
  bool quiet = false;
};

int run(const Options& opt) {
  auto device = api::parse_device(opt.backend);
  if (!device.ok()) return tools::report_usage_error(kTool, device.status());
  std::string why;
  if (opt.backend == "auto" && *device == api::Device::kCpu && !opt.quiet) {
    api::cuda_available(&why);
    tools::report_note(kTool, "no CUDA device (" + why + "): the CPU reference renders, at 640x360 by default");
  }
  api::LoadOptions load;
  load.device = *device;
  load.cuda_device = opt.device;
  load.read_options = tools::scene_read_options();
  load.lod = opt.lod;
  load.lod.enabled = !opt.no_lod;
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
  auto preset = api::parse_preset(opt.preset);
  if (!preset.ok()) return tools::report_usage_error(kTool, preset.status());
  server.preset = *preset;
  server.cuda_device = opt.device;
  server.gpu_scratch_budget = opt.scratch_budget;
  if (!opt.cameras.empty()) {
    if (const Status input = tools::check_input_file(opt.cameras); !input.ok()) return tools::report_error(kTool, input);
    auto cameras = api::read_inria_cameras(opt.cameras);
    if (!cameras.ok()) return tools::report_error(kTool, cameras.status());
    server.cameras = std::move(*cameras);
  }
  auto started = view::Server::start(std::move(scenes), server);
  if (!started.ok()) return tools::report_error(kTool, started.status());
  auto info = api::query_device(*device, opt.device);
  std::printf("%s: serving %s%s%s on %s (%s)\n", kTool, tools::escape_text(opt.scene).c_str(),
              opt.scene2.empty() ? "" : " vs ", tools::escape_text(opt.scene2).c_str(), api::device_name(*device),
              info.ok() ? tools::escape_text(info->name).c_str() : "?");
  std::printf("%s\n", started->url().c_str());
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
  app.add_option("--backend", opt.backend, "auto (cuda when a device answers, else cpu), cuda or cpu")
      ->check(CLI::IsMember({"auto", "cuda", "cpu"}))
      ->capture_default_str();
  app.add_option("--device", opt.device, "CUDA device ordinal")->check(CLI::Range(0, 1023))->capture_default_str();
  app.add_option("--preset", opt.preset, "Preset the page starts with: fastest, faithful or paper")
      ->check(CLI::IsMember({"fastest", "faithful", "paper"}))
      ->capture_default_str();
  app.add_option("--cameras", opt.cameras, "INRIA cameras.json whose cameras the page can jump to");
  const std::string lod_help = "Level-of-detail .rgs (docs/LOD.md): ";
  auto* splat_budget = app.add_option("--splat-budget", opt.lod.splat_budget,
                                      lod_help + "most Gaussians a frame draws (0: no limit)")
                           ->capture_default_str();
  auto* memory_budget =
      app.add_option("--memory-budget", opt.lod.memory_budget,
                     lod_help + "GPU memory for the level pool, frame arrays and upload buffer (e.g. 2GiB; 0: every "
                                "level)")
          ->transform(CLI::AsSizeValue(false))
          ->capture_default_str();
  auto* pixel_error = app.add_option("--pixel-error", opt.lod.pixel_error,
                                     lod_help + "largest projected error of a drawn level, in pixels")
                          ->check(CLI::Range(0.0f, 1000.0f))
                          ->capture_default_str();
  app.add_flag("--no-lod", opt.no_lod, lod_help + "render the full detail, no budgets")
      ->excludes(splat_budget)
      ->excludes(memory_budget)
      ->excludes(pixel_error);
  app.add_option("--scratch-budget", opt.scratch_budget,
                 "GPU: bound on each client's renderer scratch memory (e.g. 1GiB; 0: none)")
      ->transform(CLI::AsSizeValue(false))
      ->capture_default_str();
  app.add_option("--host", opt.server.host,
                 "Address to listen on; anything but 127.0.0.1, ::1 or localhost requires the printed URL's token")
      ->capture_default_str();
  app.add_option("--port", opt.server.port, "TCP port (0: any free port)")->capture_default_str();
  app.add_option("--token", opt.server.token,
                 "Token every request must carry (?token=...; letters, digits, - and _); default: random when the "
                 "host is not loopback, none otherwise");
  app.add_option("--max-clients", opt.server.max_clients, "Most browser connections at once")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app.add_option("--cpu-threads", opt.server.cpu_threads, "CPU backend: threads per frame (0: all)")
      ->capture_default_str();
  app.add_flag("-q,--quiet", opt.quiet, "Print only the URL line and errors");
  app.set_version_flag("--version", tools::version_line(kTool));
  tools::add_scene_read_options(app);
  if (auto code = tools::parse_command_line(app, argc, argv, kTool)) return tools::finish(kTool, *code);
  return tools::finish(kTool, run(opt));
}
