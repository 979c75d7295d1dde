// Helpers shared by the command-line tools: error reporting, terminal-safe text, standard streams, command-line
// parsing, input and output declaration, interrupt cleanup and number formatting; and the scene-reading options of
// every tool that reads scenes (--max-gaussians, --max-decompression-ratio, --spz-frame), the camera options and the
// rendering options (--backend, --device, --preset, budgets), each defined once so that their names, defaults and
// help text agree across tools (format/SPEC.md §5.5, converter/INTEROP.md).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rgs/format/output_transaction.h"
#include "rgs/api/camera.h"
#include "rgs/api/convert.h"
#include "rgs/api/scene.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "rgs/format/status.h"

namespace CLI {
class App;
class Validator;
}  // namespace CLI

namespace rgs::tools {

/// Exit codes of every tool: 0 success, 1 the operation failed (message on stderr), 2 usage error; an
/// interrupt exits 128 + the signal number (130 SIGINT, 143 SIGTERM, 129 SIGHUP).
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitUsage = 2;

/// Makes bytes from files, paths and arguments safe to print: control characters (C0, DEL, C1), bidirectional
/// overrides and bytes that are not UTF-8 become "\xNN" or "\uNNNN"; other UTF-8 text is kept. A NUL no
/// longer cuts the text short and escape sequences never reach the terminal.
std::string escape_text(std::string_view text);

/// Prints "<tool>: error: <message> [kCode]" (escaped) to stderr and returns kExitFailure. Here and in the other
/// report functions, a library's hint that names an API setting names the option instead ("spz frame as-stored":
/// "--spz-frame as-stored"; "use device cpu": "use --backend cpu"; "LoadOptions::lod.enabled = false": "--no-lod").
int report_error(const char* tool, const Status& status);

/// Prints "<tool>: error: <message> [kCode]" (escaped) and a --help hint to stderr; returns kExitUsage.
int report_usage_error(const char* tool, const Status& status);

/// Prints "<tool>: <note>" (escaped) to stderr.
void report_note(const char* tool, const std::string& note);

/// Prints each of `notes` as "<tool>: <note>" (escaped) on stderr, unless `quiet`.
void report_notes(const char* tool, const std::vector<std::string>& notes, bool quiet = false);

/// The long option of `app` nearest to the unknown argument `arg` ("--filtr-nan", "--scael=2") by edit distance,
/// when at most a third of `arg`'s name differs ("--filter-nan", "--scale"); "" otherwise, and for an argument
/// that does not start with '-'.
std::string nearest_option(const CLI::App& app, const std::string& arg);

/// Adds --version (the tool, its version and the commit CMake was configured from), parses the command line into
/// `app`'s bindings, then runs `check`, which returns a usage error's message
/// (empty: the command line is fine). @return std::nullopt to go on; else the exit code to return at once
/// (after finish()): --help and --version print through the app and give kExitOk, a parse or `check` error
/// prints "<tool>: error: <what>" and a --help hint to stderr and gives kExitUsage; an unknown option's error also
/// names the nearest_option().
std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv, const char* tool,
                                      const std::function<std::string()>& check = {});

/// Flushes stdout and stderr. @return kIoError when a write to either failed (a full disk, a closed pipe),
/// so that a tool never exits 0 with its report lost.
Status flush_standard_streams();

/// A tool's last step: flush_standard_streams(), and kExitFailure instead of kExitOk when that failed (the
/// message goes to stderr if stderr still works). A non-zero `code` is returned as is.
int finish(const char* tool, int code);

/// Installs handlers for SIGINT, SIGTERM and SIGHUP that remove this run's temporaries
/// (format::remove_pending_temporaries) and exit with 128 + the signal number. A signal the parent set to
/// be ignored (nohup, background jobs) stays ignored.
void install_interrupt_cleanup();

/// For servers (rgs-view) that shut down cleanly instead: blocks SIGINT, SIGTERM and SIGHUP in the calling thread,
/// so that every thread started after it inherits the mask and none is interrupted by them. Call it first in
/// main, before any thread starts; then wait_for_termination_signal(). Signals the parent set to be ignored stay
/// ignored.
void block_termination_signals();

/// Waits until SIGINT, SIGTERM or SIGHUP arrives (blocked by block_termination_signals()) and returns its number.
int wait_for_termination_signal();

/// Checks, without blocking, that `path` is a regular file that can be opened for reading: a FIFO, device,
/// socket or directory is refused at once instead of hanging the tool or being misread.
/// @return kIoError naming `path` and what it is ("no such file", "is a directory", "is a FIFO ...").
Status check_input_file(const std::string& path);

/// Checks `path` with check_input_file (for a `scene`, a directory holding a lod-meta.json or meta.json is
/// accepted too: a streamed or plain SOG folder, which converter::read_scene reads through that file) and
/// declares it as an input of `outputs`, so that no output of the run replaces it; for a scene, also every
/// file it names (converter::list_scene_files: a SOG's images, a streamed SOG's chunks, a .gltf's buffers).
/// @return kExitOk; else the error is printed and the exit code returned: kExitFailure for a path that cannot
/// be read, kExitUsage for one that format::OutputTransaction::add_input refuses.
int declare_input(const char* tool, format::OutputTransaction& outputs, const std::string& path, bool scene = false);

/// declare_input for every scene of `scenes` and for the file `cameras_path` unless it is empty.
int declare_inputs(const char* tool, format::OutputTransaction& outputs, const std::vector<std::string>& scenes,
                   const std::string& cameras_path);

/// Declares `path` as an output of `outputs`. @return kExitOk; else the error is printed and the exit code
/// returned: kExitUsage for an alias of an input or another output or a device (kInvalidArgument),
/// kExitFailure for an existing directory or an OS error.
int declare_output(const char* tool, format::OutputTransaction& outputs, const std::string& path);

/// A run's last steps: flushes stdout and stderr, so that its report has been written before the files
/// appear (a failed report leaves none), then commits `outputs` and, unless `quiet`, says in one note which
/// existing files it replaced. @return kExitOk, or kExitFailure with the error printed.
int commit_outputs(const char* tool, format::OutputTransaction& outputs, bool quiet = false);

/// Reads standard input (the tools' "-" input) as a stream, never more than its content proves: a .rgs up to
/// the file_size of its header (more bytes: kCorruptData; above ReadLimits::max_file_bytes: kLimitExceeded),
/// a PLY up to what its header's elements can hold (converter::ply_stream_bytes; a vertex count above
/// --max-gaussians: kLimitExceeded from the header), anything else only its first bytes, for the reader to name.
/// With `convert` (a conversion's options), never more than api::max_whole_input_bytes allows its format under
/// the conversion's memory limit either: one byte more ends the reading with kLimitExceeded ("standard input:
/// more than N bytes, ... the memory limit of M bytes (--memory-limit) ..."), whatever the header declares.
/// The buffer grows with the bytes received (by an eighth at a time), never to what a header declares.
/// @return kIoError with the OS cause.
Result<std::vector<uint8_t>> read_standard_input(const api::ConvertOptions* convert = nullptr);

/// Parses a --background value "r,g,b": three finite numbers (linear RGB) separated by commas.
/// @return kInvalidArgument quoting the text or the part that is not a number.
Result<std::array<float, 3>> parse_background(const std::string& text);

/// `names` usable as file names, all different: in name i, '/', '\\' and control characters replaced by '_';
/// "view_<i>" (three digits) if empty, "view_<i>" for "." and ".."; "_<i>" appended when an earlier name is the
/// same. rgs-render's views and rgs-audit --save-renders' folders and views are named so.
std::vector<std::string> file_safe_names(const std::vector<std::string>& names);
/// Fixed-point with `digits` decimals ("%.*f").
std::string fixed(double value, int digits);
/// Scientific with 3 significant decimals ("1.234e-05"), or "0" for zero.
std::string sci(double value);

/// Seconds since `start`.
double seconds_since(std::chrono::steady_clock::time_point start);

/// How this process reads scenes: converter::SceneReadOptions' defaults until the command line changes them
/// (add_scene_read_options). Every tool's scene loading passes it to the library's loaders.
converter::SceneReadOptions& scene_read_options();

/// Adds `--max-gaussians N`, `--max-decompression-ratio R` (defaults as in SPEC §5.5), `--antialiased` and
/// `--spz-frame rub|as-stored|FILE=rub|FILE=as-stored`, repeatable (converter::SpzFrame for all SPZ files or one;
/// tools that read only .rgs leave it out) to `app`, bound to scene_read_options(); shown in --help.
void add_scene_read_options(CLI::App& app, bool with_spz_frame = true);

/// Adds --cameras, --every, --limit, --fly, --orbit and --path to `app`, bound to `choice`
/// (api::CameraChoice, built by api::make_cameras): --every and --fly need --cameras; --cameras, --orbit and
/// --path exclude each other, and --fly excludes --orbit and --path. --fly N flies N views through the file's
/// cameras (after --every and --limit, which then count key cameras). `cameras_help`, `limit_help` and
/// `orbit_help` describe --cameras, --limit and --orbit.
void add_camera_options(CLI::App& app, api::CameraChoice& choice, const std::string& cameras_help,
                        const std::string& limit_help, const std::string& orbit_help);

/// The rendering options of the tools that render scenes (rgs-render, rgs-view, rgs-audit, the lab's rgs-bench),
/// declared once by add_render_options so that their names, checks, defaults and help agree across tools.
struct RenderOptions {
  /// --backend auto|cuda|cpu (api::parse_device); each tool sets its default before add_render_options.
  std::string backend = "auto";
  /// --device: CUDA device ordinal.
  int device = 0;
  /// --preset fastest|faithful|paper (api::parse_preset).
  std::string preset = "fastest";
  /// --scratch-budget: api::RenderSettings::gpu_scratch_budget (bytes; 0: none).
  uint64_t scratch_budget = 0;
  /// --splat-budget, --memory-budget, --pixel-error, --stream-bytes; --no-lod clears `enabled`: api::LoadOptions::lod.
  api::LodSettings lod;
  /// --cpu-threads (rgs-audit: --threads): CPU backend threads per frame, 0: all cores.
  unsigned cpu_threads = 0;
};

/// The groups of RenderOptions a tool offers (add_render_options), or-ed together; --device always comes.
enum RenderOptionGroup : unsigned {
  kBackendOption = 1u << 0,        ///< --backend
  kPresetOption = 1u << 1,         ///< --preset
  kScratchBudgetOption = 1u << 2,  ///< --scratch-budget
  /// --splat-budget, --memory-budget, --pixel-error, --stream-bytes, and --no-lod, which excludes the four
  kLodOptions = 1u << 3,
};

/// Adds --device and the groups `offered` names to `app`, bound to `options`, shown in --help with their defaults;
/// with `cpu_threads_name` ("--cpu-threads"; rgs-audit keeps "--threads"), also the CPU thread count under it.
void add_render_options(CLI::App& app, RenderOptions& options, unsigned offered,
                        const std::string& cpu_threads_name = "");

/// api::LoadOptions for scenes rendered on `device` with `options`: its CUDA ordinal and level-of-detail settings,
/// and scene_read_options().
api::LoadOptions load_options(const RenderOptions& options, api::Device device);

/// format::ReadOptions with scene_read_options()' limits, checksums verified: for opening a .rgs directly.
format::ReadOptions read_options();

/// Parses a whole number written in decimal digits alone (no sign, exponent, fraction or spaces) in [min, max]:
/// "-1" or "2^64" must not wrap round to a huge value, "5e21" not saturate to the largest.
/// @return kInvalidArgument naming `text` and the range.
Result<uint64_t> parse_whole_number(const std::string& text, uint64_t min, uint64_t max);
/// A CLI11 check (`description` shown in --help) that passes a value when check(value) is ok and else fails with
/// its message.
CLI::Validator status_check(std::function<Status(const std::string&)> check, const std::string& description);
/// A CLI11 check that the option's value is a whole number parse_whole_number() accepts in [min, max].
CLI::Validator whole_number_in(uint64_t min, uint64_t max);
/// A CLI11 check that the option's value is a finite number in [min, max]: CLI::Range lets NaN through (every
/// comparison with NaN is false).
CLI::Validator finite_number_in(double min, double max);

/// --lod-levels of rgs-convert and rgs-bench: "auto" gives 0 (converter::LodBuildOptions::levels' auto), "1".."16"
/// that count. kInvalidArgument otherwise.
Result<uint32_t> parse_lod_levels(const std::string& text);
/// Adds --lod-levels to `app`, into `levels`, checked with parse_lod_levels().
void add_lod_levels_option(CLI::App& app, std::string& levels, const std::string& help);

/// The input formats every scene-reading tool accepts, found by content (converter::supported_scene_formats),
/// as one sentence for --help.
std::string scene_formats_help();

}  // namespace rgs::tools
