#include "cli_common.h"

#include <CLI/CLI.hpp>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <sstream>
#include <string_view>
#include <tuple>
#include <utility>

#include "rgs/converter/ply_reader.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/file_io.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"
#include "rgs/config.h"
#include "rgs_tool_version.h"

namespace rgs::tools {

namespace {

void append_hex_byte(std::string* out, unsigned char byte) {
  static const char kDigits[] = "0123456789abcdef";
  out->append("\\x");
  out->push_back(kDigits[byte >> 4]);
  out->push_back(kDigits[byte & 15]);
}

/// Length of the well-formed UTF-8 sequence at text[i] (no overlongs, surrogates or values above U+10FFFF)
/// and its code point; 0 when the bytes there are not UTF-8.
size_t decode_utf8(std::string_view text, size_t i, uint32_t* code_point) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char lead = byte(i);
  size_t length = 0;
  uint32_t cp = 0, min = 0;
  if (lead >= 0xc2 && lead <= 0xdf) {
    length = 2, cp = lead & 0x1f, min = 0x80;
  } else if (lead >= 0xe0 && lead <= 0xef) {
    length = 3, cp = lead & 0x0f, min = 0x800;
  } else if (lead >= 0xf0 && lead <= 0xf4) {
    length = 4, cp = lead & 0x07, min = 0x10000;
  } else {
    return 0;
  }
  if (i + length > text.size()) return 0;
  for (size_t k = 1; k < length; ++k) {
    if ((byte(i + k) & 0xc0) != 0x80) return 0;
    cp = (cp << 6) | (byte(i + k) & 0x3f);
  }
  if (cp < min || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
  *code_point = cp;
  return length;
}

/// `text` with the libraries' hints that name an API setting turned into the option that sets it.
std::string with_options(std::string text) {
  static const std::pair<std::string_view, std::string_view> kHints[] = {
      {"spz frame as-stored", "--spz-frame as-stored"},
      {"use device cpu", "use --backend cpu"},
      {"LoadOptions::lod.enabled = false", "--no-lod"}};
  for (const auto& [api_words, option] : kHints) {  // no option holds its API words: each loop ends
    for (size_t at; (at = text.find(api_words)) != std::string::npos;) text.replace(at, api_words.size(), option);
  }
  return text;
}

void print_error_line(const char* tool, const Status& status) {
  const std::string text = escape_text(with_options(status.to_string()));
  std::fprintf(stderr, "%s: error: %s\n", tool, text.c_str());
}

/// Set once a signal handler runs, so that a second signal does not start the cleanup again.
volatile sig_atomic_t g_interrupted = 0;

void on_interrupt(int signal_number) {
  if (g_interrupted == 0) {
    g_interrupted = 1;
    format::remove_pending_temporaries();
  }
  ::_exit(128 + signal_number);
}

/// SIGINT, SIGTERM and SIGHUP, less those the parent set to be ignored.
sigset_t termination_signals() {
  sigset_t set;
  sigemptyset(&set);
  for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction current {};
    if (::sigaction(signal_number, nullptr, &current) == 0 && current.sa_handler == SIG_IGN) continue;
    sigaddset(&set, signal_number);
  }
  return set;
}

/// What --version prints: "<tool> <version> (commit <hash>)", the commit CMake was configured from.
std::string version_line(const char* tool) {
  return std::string(tool) + " " + RGS_VERSION_STRING + " (commit " + RGS_TOOL_COMMIT + ")";
}

}  // namespace

std::string escape_text(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f) {
      append_hex_byte(&out, c);
      ++i;
      continue;
    }
    if (c < 0x80) {
      out.push_back(static_cast<char>(c));
      ++i;
      continue;
    }
    uint32_t cp = 0;
    const size_t length = decode_utf8(text, i, &cp);
    if (length == 0) {
      append_hex_byte(&out, c);
      ++i;
      continue;
    }
    // C1 controls (8-bit CSI and friends) and the bidirectional overrides that can reorder what is shown.
    if (cp <= 0x9f || (cp >= 0x202a && cp <= 0x202e) || (cp >= 0x2066 && cp <= 0x2069)) {
      char buf[16];
      std::snprintf(buf, sizeof(buf), "\\u%04x", static_cast<unsigned>(cp));
      out += buf;
    } else {
      out.append(text.substr(i, length));
    }
    i += length;
  }
  return out;
}

int report_error(const char* tool, const Status& status) {
  print_error_line(tool, status);
  return kExitFailure;
}

int report_usage_error(const char* tool, const Status& status) {
  print_error_line(tool, status);
  std::fprintf(stderr, "Run with --help for more information.\n");
  return kExitUsage;
}

void report_note(const char* tool, const std::string& note) {
  std::fprintf(stderr, "%s: %s\n", tool, escape_text(with_options(note)).c_str());
}

void report_notes(const char* tool, const std::vector<std::string>& notes, bool quiet) {
  if (quiet) return;
  for (const std::string& note : notes) report_note(tool, note);
}

std::string nearest_option(const CLI::App& app, const std::string& arg) {
  const std::string name = arg.substr(0, arg.find('='));
  std::string best;
  size_t best_distance = SIZE_MAX;
  for (const CLI::Option* option : app.get_options()) {
    for (const std::string& long_name : option->get_lnames()) {
      const std::string candidate = "--" + long_name;
      std::vector<size_t> row(candidate.size() + 1);  // Levenshtein distance, one row at a time
      for (size_t j = 0; j < row.size(); ++j) row[j] = j;
      for (size_t i = 1; i <= name.size(); ++i) {
        size_t diagonal = row[0]++;
        for (size_t j = 1; j < row.size(); ++j) {
          const size_t up = row[j];
          row[j] = std::min({up + 1, row[j - 1] + 1, diagonal + (name[i - 1] != candidate[j - 1])});
          diagonal = up;
        }
      }
      if (row.back() < best_distance) std::tie(best_distance, best) = std::tie(row.back(), candidate);
    }
  }
  return !name.empty() && name[0] == '-' && best_distance * 3 <= name.size() ? best : "";
}

std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv, const char* tool,
                                      const std::function<std::string()>& check) {
  app.set_version_flag("--version", version_line(tool));
  try {
    app.parse(argc, argv);
    const std::string problem = check ? check() : std::string();
    if (!problem.empty()) throw CLI::ValidationError(problem);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return finish(tool, app.exit(e) == 0 ? kExitOk : kExitUsage);
    std::string what = e.what();
    if (dynamic_cast<const CLI::ExtrasError*>(&e) != nullptr) {
      for (const std::string& arg : app.remaining()) {
        const std::string near = nearest_option(app, arg);
        if (!near.empty()) what += "; " + arg + ": did you mean " + near + "?";
      }
    }
    return finish(tool, report_usage_error(tool, Status(StatusCode::kInvalidArgument, what)));
  }
  return std::nullopt;
}

Status flush_standard_streams() {
  errno = 0;
  const char* failed = std::fflush(stdout) != 0 || std::ferror(stdout)   ? "standard output"
                       : std::fflush(stderr) != 0 || std::ferror(stderr) ? "standard error"
                                                                          : nullptr;
  const int err = errno;
  if (failed == nullptr) return Status();
  return Status(StatusCode::kIoError,
                std::string("cannot write to ") + failed + (err != 0 ? std::string(": ") + std::strerror(err) : ""));
}

int finish(const char* tool, int code) {
  Status flushed = flush_standard_streams();
  // A failed run has reported its error already (or found stderr broken while doing so).
  if (flushed.ok() || code != kExitOk) return code;
  print_error_line(tool, flushed);
  return kExitFailure;
}

void install_interrupt_cleanup() {
  const sigset_t set = termination_signals();
  for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
    if (!sigismember(&set, signal_number)) continue;
    struct sigaction action {};
    action.sa_handler = on_interrupt;
    sigemptyset(&action.sa_mask);
    ::sigaction(signal_number, &action, nullptr);
  }
}

void block_termination_signals() {
  const sigset_t set = termination_signals();
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
}

int wait_for_termination_signal() {
  const sigset_t set = termination_signals();
  int signal_number = 0;
  while (sigwait(&set, &signal_number) != 0) {
  }
  return signal_number;
}

Status check_input_file(const std::string& path) {
  int fd;
  do {
    // O_NONBLOCK: a FIFO without a writer must not block the open; regular files ignore the flag.
    fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) {
    const int err = errno;
    if (err == ENOENT) return Status(StatusCode::kIoError, path + ": no such file");
    return Status(StatusCode::kIoError, path + ": cannot open for reading: " + std::strerror(err));
  }
  struct stat st {};
  const int stat_result = ::fstat(fd, &st);
  const int stat_errno = errno;
  ::close(fd);
  if (stat_result != 0) return Status(StatusCode::kIoError, path + ": cannot stat: " + std::strerror(stat_errno));
  if (S_ISREG(st.st_mode)) return Status();
  if (S_ISDIR(st.st_mode)) return Status(StatusCode::kIoError, path + ": is a directory, not a file");
  const char* what = S_ISFIFO(st.st_mode)  ? "a FIFO (named pipe)"
                     : S_ISCHR(st.st_mode) ? "a character device"
                     : S_ISBLK(st.st_mode) ? "a block device"
                     : S_ISSOCK(st.st_mode) ? "a socket"
                                             : "not a regular file";
  return Status(StatusCode::kIoError, path + ": is " + std::string(what) +
                                          "; the tools read regular files (or - for standard input where the "
                                          "tool accepts it)");
}

namespace {

Status check_scene_input(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_directory(path, ec)) return check_input_file(path);
  for (const char* name : {"lod-meta.json", "meta.json"}) {
    if (std::filesystem::is_regular_file(std::filesystem::path(path) / name, ec)) return Status();
  }
  return Status(StatusCode::kIoError, path + ": is a directory with neither lod-meta.json nor meta.json (the SOG "
                                             "folders the tools read); give a scene file");
}

}  // namespace

int declare_input(const char* tool, format::OutputTransaction& outputs, const std::string& path, bool scene) {
  Status readable = scene ? check_scene_input(path) : check_input_file(path);
  if (!readable.ok()) return report_error(tool, readable);
  std::vector<std::string> files = {path};
  if (scene && !format::is_rgs_path(path)) {
    // Every file the scene names (a SOG's images, a streamed SOG's chunks, a .gltf's buffers) is an input too.
    auto listed = converter::list_scene_files(path);
    if (!listed.ok()) return report_error(tool, listed.status());
    files.insert(files.end(), listed->begin(), listed->end());
  }
  for (const std::string& file : files) {
    if (Status declared = outputs.add_input(file); !declared.ok()) return report_usage_error(tool, declared);
  }
  return kExitOk;
}

int declare_inputs(const char* tool, format::OutputTransaction& outputs, const std::vector<std::string>& scenes,
                   const std::string& cameras_path) {
  for (const std::string& scene : scenes) {
    if (int code = declare_input(tool, outputs, scene, true); code != kExitOk) return code;
  }
  return cameras_path.empty() ? kExitOk : declare_input(tool, outputs, cameras_path);
}

int declare_output(const char* tool, format::OutputTransaction& outputs, const std::string& path) {
  Status declared = outputs.add_output(path);
  if (declared.ok()) return kExitOk;
  return declared.code() == StatusCode::kInvalidArgument ? report_usage_error(tool, declared)
                                                         : report_error(tool, declared);
}

int commit_outputs(const char* tool, format::OutputTransaction& outputs, bool quiet) {
  if (Status flushed = flush_standard_streams(); !flushed.ok()) return report_error(tool, flushed);
  if (Status committed = outputs.commit(); !committed.ok()) return report_error(tool, committed);
  const std::vector<std::string> replaced = outputs.replaced();
  if (!quiet && !replaced.empty()) {
    std::string list;
    for (size_t i = 0; i < replaced.size() && i < 3; ++i) list += (i ? ", " : "") + replaced[i];
    if (replaced.size() > 3) list += " and " + std::to_string(replaced.size() - 3) + " more";
    report_note(tool, "note: replaced " + std::string(replaced.size() == 1 ? "the existing file " : "existing files: ") +
                          list);
  }
  return kExitOk;
}

namespace {

/// Appends up to `n` bytes of standard input to `bytes`; returns false at the end of the input.
Result<bool> append_standard_input(std::vector<uint8_t>* bytes, uint64_t n) {
  uint8_t buffer[1 << 16];
  const ssize_t got = ::read(STDIN_FILENO, buffer, static_cast<size_t>(std::min<uint64_t>(n, sizeof(buffer))));
  if (got < 0) {
    if (errno == EINTR) return true;
    return Status(StatusCode::kIoError, std::string("-: cannot read standard input: ") + std::strerror(errno));
  }
  RGS_RETURN_IF_ERROR(catch_bad_alloc([&] {
    // Grow by an eighth, not the vector's doubling: what is held stays close to the bytes received, however
    // many the stream's header declares.
    const size_t need = bytes->size() + static_cast<size_t>(got);
    if (need > bytes->capacity()) bytes->reserve(std::max(need, bytes->size() + bytes->size() / 8 + (size_t{1} << 20)));
    bytes->insert(bytes->end(), buffer, buffer + got);
    return Status();
  }, [&] { return "-: out of memory after " + std::to_string(bytes->size()) + " bytes of standard input"; }));
  return got > 0;
}

}  // namespace

Result<std::vector<uint8_t>> read_standard_input(const api::ConvertOptions* convert) {
  std::vector<uint8_t> bytes;
  // How much the stream may hold: known from its first bytes (a .rgs header's file_size, a PLY header's
  // element counts); until then, the head. Content that is neither stops at its first bytes.
  uint64_t limit = format::kHeaderSize;
  bool known = false, rgs = false;
  // The most the conversion may hold of it, once its format is known: what the memory limit allows a file of
  // that format read whole.
  const char* format_id = nullptr;
  uint64_t most = UINT64_MAX;
  for (;;) {
    if (!known && bytes.size() >= 8) {
      if (std::memcmp(bytes.data(), format::kMagic, 8) == 0) {
        format_id = "rgs";
        if (bytes.size() >= 56) {
          limit = 0;
          for (int b = 7; b >= 0; --b) limit = (limit << 8) | bytes[48 + b];  // file_size (SPEC §2)
          if (limit > read_options().limits.max_file_bytes) {
            return Status(StatusCode::kLimitExceeded, "-: the .rgs header declares " + std::to_string(limit) +
                                                          " bytes, above the limit of " +
                                                          std::to_string(read_options().limits.max_file_bytes));
          }
          known = rgs = true;
        }
      } else if (std::memcmp(bytes.data(), "ply", 3) == 0 && (bytes[3] == '\n' || bytes[3] == '\r')) {
        format_id = "ply";
        auto size = converter::ply_stream_bytes(bytes.data(), bytes.size(), scene_read_options().max_gaussians);
        if (!size.ok()) return Status(size.status()).prepend("-");
        if (*size != 0) {
          limit = *size;
          known = true;
        } else {
          limit = bytes.size() + (1 << 16);  // the header is not complete yet
        }
      } else {
        return bytes;  // neither: the reader names what it is from these bytes
      }
      if (convert != nullptr) most = api::max_whole_input_bytes(format_id, *convert);
    }
    if (bytes.size() > most) {
      return Status(StatusCode::kLimitExceeded,
                    "standard input: more than " + group_digits(most) + " bytes, the most a " +
                        (std::strcmp(format_id, "rgs") == 0 ? ".rgs" : "PLY") +
                        " read whole may have within the memory limit of " +
                        group_digits(api::convert_memory_limit(*convert)) +
                        " bytes (--memory-limit); convert it from a file instead (a binary PLY converted with "
                        "--lod-levels is then built out of core)");
    }
    if (bytes.size() >= limit) break;
    const uint64_t until = most == UINT64_MAX ? limit : std::min(limit, most + 1);
    RGS_ASSIGN_OR_RETURN(bool more, append_standard_input(&bytes, until - bytes.size()));
    if (!more) return bytes;
  }
  if (rgs) {
    // A .rgs ends where its header says (SPEC §2): say so of more bytes without reading them all. A PLY's
    // reader ignores what follows its last element, so the rest of the stream is left unread.
    std::vector<uint8_t> extra;
    RGS_ASSIGN_OR_RETURN(bool more, append_standard_input(&extra, 1));
    if (more) {
      return Status(StatusCode::kCorruptData, "-: standard input continues past the " + std::to_string(limit) +
                                                  " bytes its header declares");
    }
  }
  return bytes;
}

Result<std::array<float, 3>> parse_background(const std::string& text) {
  std::array<float, 3> bg{};
  std::istringstream in(text);
  std::string part;
  int i = 0;
  while (std::getline(in, part, ',')) {
    RGS_RETURN_ERROR_IF(i >= 3, StatusCode::kInvalidArgument, "--background: expected r,g,b, got '" + text + "'");
    try {
      size_t used = 0;
      bg[i] = std::stof(part, &used);
      RGS_RETURN_ERROR_IF(used != part.size() || !std::isfinite(bg[i]), StatusCode::kInvalidArgument,
                          "--background: '" + part + "' is not a finite number");
    } catch (const std::exception&) {
      return Status(StatusCode::kInvalidArgument, "--background: '" + part + "' is not a finite number");
    }
    ++i;
  }
  RGS_RETURN_ERROR_IF(i != 3, StatusCode::kInvalidArgument, "--background: expected r,g,b, got '" + text + "'");
  return bg;
}

std::vector<std::string> file_safe_names(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  for (size_t i = 0; i < names.size(); ++i) {
    std::string name = names[i];
    for (char& ch : name) {
      if (ch == '/' || ch == '\\' || static_cast<unsigned char>(ch) < 32) ch = '_';
    }
    if (name.empty()) {
      char buf[32];
      std::snprintf(buf, sizeof(buf), "view_%03zu", i);
      name = buf;
    } else if (name == "." || name == "..") {
      name = "view_" + std::to_string(i);
    }
    if (std::find(out.begin(), out.end(), name) != out.end()) name += "_" + std::to_string(i);
    out.push_back(std::move(name));
  }
  return out;
}

std::string fixed(double value, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, value);
  return buf;
}

std::string sci(double value) {
  if (value == 0.0) return "0";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.3e", value);
  return buf;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

converter::SceneReadOptions& scene_read_options() {
  static converter::SceneReadOptions options;
  return options;
}

void add_scene_read_options(CLI::App& app, bool with_spz_frame) {
  converter::SceneReadOptions& options = scene_read_options();
  app.add_option("--max-gaussians", options.max_gaussians,
                 "Refuse scenes that declare more Gaussians than this, before allocating for them (SPEC 5.5)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-decompression-ratio", options.max_decompression_ratio,
                 "Refuse scenes whose compressed data (.rgs sections, SPZ zstd/gzip streams, SOG WebP images and "
                 "ZIP entries, glTF accessors without data) decodes to more than this many bytes per byte of "
                 "input, counting inputs under 1 MiB as 1 MiB; bounds the memory a small file can demand "
                 "(SPEC 5.5; zstd allows up to 32768)")
      ->check(CLI::Range(1u, 32768u))
      ->capture_default_str();
  app.add_flag("--antialiased", options.antialiased,
               "The input was trained with the 2D Mip filter (Mip-Splatting; gsplat's rasterize_mode=\"antialiased\"), "
               "which PLY, glTF, SOG and .splat files cannot say: render it with the filter's opacity compensation "
               "and write the flag into .rgs and SPZ outputs. A .rgs or SPZ file that carries the flag needs no "
               "option (docs/RENDERER.md#anti-aliased-scenes)");
  if (!with_spz_frame) return;
  app.add_option_function<std::vector<std::string>>(
         "--spz-frame",
         [&options](const std::vector<std::string>& values) {
           for (const std::string& value : values) {
             const size_t eq = value.rfind('=');
             if (eq == std::string::npos) {
               options.spz_frame = *converter::parse_spz_frame(value);
             } else {
               options.spz_frame_by_path[value.substr(0, eq)] = *converter::parse_spz_frame(value.substr(eq + 1));
             }
           }
         },
         "Axes of SPZ files read or written, when a file does not declare them: rub (Niantic's convention, "
         "turned to and from RoofGS's RDF) or as-stored (no turn: the PLY's axes, as splat-transform 3.7 writes "
         "and reads SPZ); FILE=rub or FILE=as-stored for one file (repeat the option for several: "
         "--spz-frame theirs.spz=as-stored). Only a coordinate-system extension in the file tells them apart, "
         "and it wins (converter/INTEROP.md)")
      ->check([](const std::string& value) -> std::string {
        const size_t eq = value.rfind('=');
        const std::string frame = eq == std::string::npos ? value : value.substr(eq + 1);
        if (eq == 0) return value + " names no file before '='";
        return converter::parse_spz_frame(frame) ? ""
                                                 : value + " is not a frame (rub, as-stored, FILE=rub, FILE=as-stored)";
      })
      ->expected(1)
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->default_str("rub");
}

void add_camera_options(CLI::App& app, api::CameraChoice& choice, const std::string& cameras_help,
                        const std::string& limit_help, const std::string& orbit_help) {
  auto* cameras = app.add_option("--cameras", choice.cameras_path, cameras_help);
  app.add_option("--every", choice.every, "Use every K-th camera of --cameras")
      ->check(CLI::Range(1, 2147483647))
      ->needs(cameras);
  app.add_option("--limit", choice.limit, limit_help)->check(CLI::Range(1, 2147483647));
  auto* orbit = app.add_option("--orbit", choice.orbit, orbit_help)->check(CLI::Range(1, 100000))->excludes(cameras);
  auto* path = app.add_option("--path", choice.path,
                              "Camera path of N views around the scene (runtime::path_cameras): two turns of a "
                              "spiral rising from 5 to 60 degrees, swinging between 0.3x and 1x the distance that "
                              "frames its content (as --orbit)")
                   ->check(CLI::Range(1, 100000))
                   ->excludes(cameras)
                   ->excludes(orbit);
  app.add_option("--fly", choice.fly,
                 "With --cameras: N views flown through the file's cameras in order, after --every and --limit "
                 "(runtime::fly_through_cameras: a centripetal Catmull-Rom spline through their centres at steady "
                 "speed, rotations slerped, the first camera's intrinsics)")
      ->check(CLI::Range(1, 100000))
      ->needs(cameras)
      ->excludes(orbit)
      ->excludes(path);
  cameras->excludes(orbit)->excludes(path);
  orbit->excludes(path);
}

void add_render_options(CLI::App& app, RenderOptions& options, unsigned offered, const std::string& cpu_threads_name) {
  if (offered & kBackendOption) {
    app.add_option("--backend", options.backend,
                   "Renderer: auto (cuda when a device answers, else cpu), cuda or cpu (the CPU reference)")
        ->check(CLI::IsMember({"auto", "cuda", "cpu"}))
        ->capture_default_str();
  }
  app.add_option("--device", options.device, "CUDA device ordinal")->check(CLI::Range(0, 1023))->capture_default_str();
  if (offered & kPresetOption) {
    app.add_option("--preset", options.preset,
                   "fastest (the default: RoofGS+ on the GPU, the 3DGS rules on the CPU, where they are faster), "
                   "faithful (the 3DGS rasterizer) or paper (the paper's techniques)")
        ->check(CLI::IsMember({"fastest", "faithful", "paper"}))
        ->capture_default_str();
  }
  if (offered & kScratchBudgetOption) {
    app.add_option("--scratch-budget", options.scratch_budget,
                   "GPU: bound on the renderer's scratch memory (e.g. 1GiB, 512MB; 0: none); frames whose pairs do "
                   "not fit render in groups of tile rows, with the same image (docs/RENDERER.md#bounded-pair-memory)")
        ->transform(CLI::AsSizeValue(false))
        ->capture_default_str();
  }
  if (offered & kLodOptions) {
    const std::string lod_help = "Level-of-detail .rgs (rgs-convert --lod-levels; docs/LOD.md): ";
    api::LodSettings& lod = options.lod;
    auto* splat_budget = app.add_option("--splat-budget", lod.splat_budget,
                                        lod_help + "most Gaussians a frame draws (0: no limit); chunks are drawn at "
                                                   "coarser levels until the frame fits")
                             ->capture_default_str();
    auto* memory_budget =
        app.add_option("--memory-budget", lod.memory_budget,
                       lod_help + "GPU: device memory for the level pool, the frame arrays and the upload buffer (e.g. "
                                  "3GiB, 512MB); 0: a pool that holds every level. The renderer's scratch is bounded "
                                  "by --scratch-budget; the CPU holds every level in host memory")
            ->transform(CLI::AsSizeValue(false))
            ->capture_default_str();
    auto* pixel_error =
        app.add_option("--pixel-error", lod.pixel_error,
                       lod_help + "largest projected error of a drawn level, in pixels (format/SPEC.md 4.9.1)")
            ->check(CLI::Range(0.0f, 1000.0f))
            ->capture_default_str();
    auto* stream_bytes =
        app.add_option("--stream-bytes", lod.stream_bytes_per_frame,
                       lod_help + "GPU: most bytes read and uploaded a frame, the bound on a frame's wait for the disk "
                                  "(levels that do not fit come in later frames)")
            ->transform(CLI::AsSizeValue(false))
            ->check(CLI::Range(uint64_t{1}, std::numeric_limits<uint64_t>::max()))
            ->capture_default_str();
    app.add_flag_callback("--no-lod", [&lod] { lod.enabled = false; },
                          lod_help + "render the full detail (level 0 of every chunk), no budgets")
        ->excludes(splat_budget)
        ->excludes(memory_budget)
        ->excludes(pixel_error)
        ->excludes(stream_bytes);
  }
  if (!cpu_threads_name.empty()) {
    app.add_option(cpu_threads_name, options.cpu_threads, "CPU backend: threads per frame (0: all cores)")
        ->capture_default_str();
  }
}

api::LoadOptions load_options(const RenderOptions& options, api::Device device) {
  api::LoadOptions load;
  load.device = device;
  load.cuda_device = options.device;
  load.read_options = scene_read_options();
  load.lod = options.lod;
  return load;
}

format::ReadOptions read_options() { return converter::rgs_read_options(scene_read_options()); }

std::string scene_formats_help() {
  std::string text = "found by its content: ";
  const std::vector<std::string> formats = converter::supported_scene_formats();
  for (size_t i = 0; i < formats.size(); ++i) text += (i ? "; " : "") + formats[i];
  return text;
}

Result<uint64_t> parse_whole_number(const std::string& text, uint64_t min, uint64_t max) {
  const std::string rule = "a whole number of decimal digits in " + std::to_string(min) + ".." + std::to_string(max);
  uint64_t value = 0;
  bool fits = !text.empty() && text.size() <= 20;
  for (size_t i = 0; fits && i < text.size(); ++i) {
    const char c = text[i];
    const uint64_t digit = static_cast<uint64_t>(c - '0');
    fits = c >= '0' && c <= '9' && value <= (UINT64_MAX - digit) / 10;
    value = value * 10 + digit;
  }
  if (!fits || value < min || value > max) {
    return Status(StatusCode::kInvalidArgument, "'" + text + "' is not " + rule);
  }
  return value;
}

CLI::Validator status_check(std::function<Status(const std::string&)> check, const std::string& description) {
  return CLI::Validator([check](std::string& text) { return check(text).message(); }, description);
}

CLI::Validator whole_number_in(uint64_t min, uint64_t max) {
  return status_check([min, max](const std::string& text) { return parse_whole_number(text, min, max).status(); },
                      "UINT in " + std::to_string(min) + ".." + std::to_string(max));
}

CLI::Validator finite_number_in(double min, double max) {
  return CLI::Validator(
      [min, max](std::string& text) -> std::string {
        double value = 0;
        const bool number = CLI::detail::lexical_cast(text, value);
        if (number && std::isfinite(value) && value >= min && value <= max) return std::string();
        return "'" + text + "' is not a finite number in [" + CLI::detail::to_string(min) + ", " +
               CLI::detail::to_string(max) + "]";
      },
      "FLOAT in [" + CLI::detail::to_string(min) + ", " + CLI::detail::to_string(max) + "], finite");
}

Result<uint32_t> parse_lod_levels(const std::string& text) {
  if (text == "auto") return 0u;
  for (uint32_t n = 1; n <= 16; ++n) {
    if (text == std::to_string(n)) return n;
  }
  return Status(StatusCode::kInvalidArgument, "auto or 1..16, not '" + text + "'");
}

void add_lod_levels_option(CLI::App& app, std::string& levels, const std::string& help) {
  app.add_option("--lod-levels", levels, help)
      ->check(status_check([](const std::string& text) { return parse_lod_levels(text).status(); }, "auto|1..16"));
}

}  // namespace rgs::tools
