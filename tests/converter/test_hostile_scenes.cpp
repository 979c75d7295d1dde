// Hostile scenes: read_scene on the corpus of tests/data/hostile/ (make_hostile_corpus.py lists each file) and
// on what git cannot hold, made here in a scratch folder (symbolic links, FIFOs, JSON nested 70,000 deep).
// The contract every scene reader keeps:
// - a reference that leaves the scene folder ('..', an absolute path, their percent-encoded spellings, a URI
//   scheme other than data:) is kCorruptData naming the referring file and saying "outside the scene";
// - a symbolic link met while opening a file the scene names (the file or a folder on the way) is kCorruptData
//   "symbolic link", saying nothing of the link's target;
// - a named file that is not a regular file (FIFO, directory) is kIoError "not a regular file", at once;
// - declared sizes the file's bytes cannot hold are kLimitExceeded or kCorruptData, and valid scenes that
//   expand past the decompression-ratio limit (format::ReadLimits::max_decompression_ratio, 8 per byte of a
//   file counted as at least 1 MiB) are kLimitExceeded, both before anything is allocated for them;
// - JSON nested deeper than 64 levels is kCorruptData "nested"; glTF node cycles are kCorruptData "cycle"
//   and a node reachable by 2^40 paths is visited once;
// - messages quote at most about 200 characters of what the input holds.
// Every read runs in a child process (fork) with its own time limit and, without sanitizers, an address-space
// limit, so that a crash, a hang or a memory blow-up fails its case and not the suite; the child reports the
// Status, the read's time and its peak resident memory above where it started.
#include <doctest/doctest.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <zlib.h>

#include "ply_test_util.h"
#include "rgs/converter/scene_reader.h"
#include "sanitized.h"
#include "test_data.h"


namespace rgs::test {
namespace {

namespace fs = std::filesystem;
using converter::SceneReadOptions;

/// Peak resident memory a refused read may add: far below any declared size of the corpus (1 GiB and up),
/// above what reading a file under 100 KB and a few threads take. Sanitizer builds hold freed blocks in
/// AddressSanitizer's quarantine (256 MiB by default), which a read's peak then includes.
#ifdef RGS_TEST_SANITIZED
constexpr uint64_t kPeakGrowthLimit = uint64_t{256} << 20;
#else
constexpr uint64_t kPeakGrowthLimit = uint64_t{64} << 20;
#endif
/// Address space the child may add to what it holds at the fork (sanitizer builds set none).
constexpr uint64_t kAddressSpaceHeadroom = uint64_t{512} << 20;
/// Longest run of one filler character a message may quote from a 5,000- or 10,000-character field.
constexpr size_t kMaxQuotedRun = 256;

std::string hostile(const std::string& relative) { return repo_path("tests/data/hostile/" + relative); }

// ---------------------------------------------------------------------------------------------------
// Reads in a child process.

/// What a read_scene in a child process gave.
struct ChildRead {
  enum class End { kReturned, kSignal, kTimedOut, kHarnessError };
  End end = End::kHarnessError;
  int signal = 0;
  bool ok = false;
  StatusCode code = StatusCode::kOk;
  std::string message;
  uint64_t gaussians = 0;
  double seconds = 0;
  uint64_t peak_growth = 0;  ///< bytes of resident memory above the child's at the start of the read

  bool returned() const { return end == End::kReturned; }
  std::string describe() const {
    std::ostringstream s;
    switch (end) {
      case End::kReturned:
        s << (ok ? "ok, " + std::to_string(gaussians) + " Gaussians" : message + " [" + status_code_name(code) + "]");
        s << " in " << seconds << " s, peak memory +" << (peak_growth >> 20) << " MiB";
        break;
      case End::kSignal: s << "the read crashed (signal " << signal << ": " << strsignal(signal) << ")"; break;
      case End::kTimedOut: s << "the read did not return within the time limit (killed)"; break;
      case End::kHarnessError: s << "the child process could not be run: " << message; break;
    }
    return s.str();
  }
};

/// A field of /proc/self/status in bytes ("VmRSS", "VmHWM", "VmSize"), or 0.
uint64_t proc_status_bytes(const char* field) {
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (f == nullptr) return 0;
  char line[256];
  uint64_t kib = 0;
  const size_t n = std::strlen(field);
  while (std::fgets(line, sizeof(line), f) != nullptr) {
    if (std::strncmp(line, field, n) == 0 && line[n] == ':') {
      kib = std::strtoull(line + n + 1, nullptr, 10);
      break;
    }
  }
  std::fclose(f);
  return kib << 10;
}

void write_all(int fd, const std::string& text) {
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n <= 0) return;
    done += static_cast<size_t>(n);
  }
}

/// The child's side: limits, the read, and a report on `fd` ("ok code gaussians seconds growth\nmessage").
[[noreturn]] void child_read(int fd, const std::string& path, const SceneReadOptions& options) {
  // A crash ends the child with its signal, which the parent reports (not the test framework's handlers).
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) std::signal(sig, SIG_DFL);
#if !defined(RGS_TEST_SANITIZED)
#if defined(__GLIBC__)
  mallopt(M_ARENA_MAX, 1);  // one arena: thread arenas would reserve 64 MiB of address space each
#endif
  const uint64_t vm = proc_status_bytes("VmSize");
  if (vm != 0) {
    const rlimit limit{vm + kAddressSpaceHeadroom, vm + kAddressSpaceHeadroom};
    ::setrlimit(RLIMIT_AS, &limit);
  }
#endif
  // Reset the peak resident size to the current one (Linux clear_refs "5"), so VmHWM measures the read.
  if (std::FILE* f = std::fopen("/proc/self/clear_refs", "w")) {
    std::fputs("5", f);
    std::fclose(f);
  }
  const uint64_t rss_before = proc_status_bytes("VmRSS");
  const auto start = std::chrono::steady_clock::now();
  auto result = converter::read_scene(path, options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const uint64_t peak = std::max(proc_status_bytes("VmHWM"), rss_before);
  std::ostringstream report;
  report << (result.ok() ? 1 : 0) << ' ' << static_cast<int>(result.status().code()) << ' '
         << (result.ok() ? result->cloud.size() : 0) << ' ' << seconds << ' ' << (peak - rss_before) << '\n'
         << result.status().message();
  write_all(fd, report.str());
  ::_exit(0);
}

/// read_scene(path, options) in a child process, killed after `timeout_s` seconds.
ChildRead read_in_child(const std::string& path, const SceneReadOptions& options = {}, double timeout_s = 20) {
  ChildRead out;
  int fds[2];
  if (::pipe(fds) != 0) {
    out.message = std::string("pipe: ") + std::strerror(errno);
    return out;
  }
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    out.message = std::string("fork: ") + std::strerror(errno);
    ::close(fds[0]);
    ::close(fds[1]);
    return out;
  }
  if (pid == 0) {
    ::close(fds[0]);
    child_read(fds[1], path, options);
  }
  ::close(fds[1]);
  std::string report;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  bool timed_out = false;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int r = ::poll(&p, 1, static_cast<int>(std::min<int64_t>(left.count(), 1000)));
    if (r < 0 && errno != EINTR) break;
    if (r <= 0) continue;
    char buf[4096];
    const ssize_t n = ::read(fds[0], buf, sizeof(buf));
    if (n <= 0) break;  // EOF: the child has written its report
    report.append(buf, static_cast<size_t>(n));
  }
  ::close(fds[0]);
  if (timed_out) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timed_out) {
    out.end = ChildRead::End::kTimedOut;
  } else if (WIFSIGNALED(status)) {
    out.end = ChildRead::End::kSignal;
    out.signal = WTERMSIG(status);
  } else {
    std::istringstream in(report);
    int ok = 0, code = 0;
    if (!(in >> ok >> code >> out.gaussians >> out.seconds >> out.peak_growth)) {
      out.message = "no report from the child (exit status " + std::to_string(status) + ")";
      return out;
    }
    in.get();
    out.end = ChildRead::End::kReturned;
    out.ok = ok != 0;
    out.code = static_cast<StatusCode>(code);
    out.message.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return out;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// Longest run of `c` in `text`.
size_t longest_run(const std::string& text, char c) {
  size_t best = 0, run = 0;
  for (char ch : text) {
    run = ch == c ? run + 1 : 0;
    best = std::max(best, run);
  }
  return best;
}

/// The read returned an error with one of `codes`, naming `names` and containing `part` (when given),
/// without allocating for what the file declares.
void check_refused(const ChildRead& r, const std::vector<StatusCode>& codes, const std::string& names,
                   const char* part) {
  INFO(r.describe());
  CHECK(r.returned());
  if (!r.returned()) return;
  CHECK_FALSE(r.ok);
  if (r.ok) return;
  CHECK(std::find(codes.begin(), codes.end(), r.code) != codes.end());
  CHECK_MESSAGE(contains(r.message, names), "the message does not name " << names);
  if (part != nullptr) {
    CHECK_MESSAGE(contains(r.message, part), "the message does not say '" << std::string(part) << "'");
  }
  CHECK(r.peak_growth < kPeakGrowthLimit);
}

// ---------------------------------------------------------------------------------------------------
// Scratch folders.

/// A scratch folder (its canonical path, so that no symbolic link of the temp path is met) removed at the end.
struct ScratchDir {
  fs::path path;
  ScratchDir() {
    std::random_device rd;
    path = fs::canonical(fs::temp_directory_path()) /
           ("rgs_hostile_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
    fs::create_directories(path);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  REQUIRE(out.good());
}

std::string read_file(const std::string& path) {
  const auto bytes = load_bytes(path);
  return std::string(bytes.begin(), bytes.end());
}

/// `text` with its first `from` replaced by `to` (which must be there).
std::string replace_first(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  REQUIRE_MESSAGE(at != std::string::npos, from);
  return text.replace(at, from.size(), to);
}

std::string nested_arrays(size_t depth) { return std::string(depth, '[') + "\"x\"" + std::string(depth, ']'); }

/// The five images of the hostile SOG folder (the guitar crop).
const char* const kSogImages[] = {"means_l.webp", "means_u.webp", "quats.webp", "scales.webp", "sh0.webp"};

/// A copy of the hostile corpus's SOG scene in `dir`: the five images and meta.json.
void make_sog_folder(const std::string& dir) {
  fs::create_directories(dir);
  for (const char* image : kSogImages) fs::copy_file(hostile(std::string("sog/") + image), dir + "/" + image);
  fs::copy_file(hostile("sog/meta.json"), dir + "/meta.json");
}

/// A streamed SOG in `dir`: lod-meta.json over the chunk folder `chunk/` (a copy of the SOG scene).
void make_lod_scene(const std::string& dir) {
  make_sog_folder(dir + "/chunk");
  write_file(dir + "/lod-meta.json",
             replace_first(read_file(hostile("sog/lod.json")), "\"meta.json\"", "\"chunk/meta.json\""));
}

/// A .gltf scene in `dir`: scene.gltf and its buffer scene.bin.
void make_gltf_scene(const std::string& dir) {
  fs::create_directories(dir);
  fs::copy_file(hostile("gltf/scene.gltf"), dir + "/scene.gltf");
  fs::copy_file(hostile("gltf/scene.bin"), dir + "/scene.bin");
}


/// A lossless WebP of one colour (`argb`: a, r, g, b bytes) of width x height: five single-symbol prefix
/// codes, zero bits a pixel (as make_hostile_corpus.py's solid_webp).
std::string solid_webp(uint32_t width, uint32_t height, const uint8_t argb[4]) {
  std::vector<int> bits;
  auto put = [&](uint32_t value, int n) {
    for (int i = 0; i < n; ++i) bits.push_back(static_cast<int>((value >> i) & 1));
  };
  put(width - 1, 14);
  put(height - 1, 14);
  put(1, 1);  // alpha_is_used
  put(0, 3);  // version
  put(0, 1);  // no transform
  put(0, 1);  // no colour cache
  put(0, 1);  // no meta prefix codes
  for (uint32_t symbol : {uint32_t{argb[2]}, uint32_t{argb[1]}, uint32_t{argb[3]}, uint32_t{argb[0]}, 0u}) {
    put(1, 1);  // simple code
    put(0, 1);  // one symbol
    put(1, 1);  // 8-bit symbol
    put(symbol, 8);
  }
  while (bits.size() % 8 != 0) bits.push_back(0);
  std::string data = "\x2f";
  for (size_t i = 0; i < bits.size(); i += 8) {
    int byte = 0;
    for (int j = 0; j < 8; ++j) byte |= bits[i + j] << j;
    data += static_cast<char>(byte);
  }
  data += std::string(2, '\0');
  auto le32 = [](uint32_t v) {
    std::string out(4, '\0');
    for (int b = 0; b < 4; ++b) out[b] = static_cast<char>(v >> (8 * b));
    return out;
  };
  std::string chunk = "VP8L" + le32(static_cast<uint32_t>(data.size())) + data;
  if (data.size() % 2 != 0) chunk += '\0';
  return "RIFF" + le32(static_cast<uint32_t>(4 + chunk.size())) + "WEBP" + chunk;
}

/// A SOG chunk in `dir` of side x side Gaussians in single-colour images (a few dozen bytes each) whose
/// meta.json is padded with spaces to `meta_bytes`: a chunk whose bytes are its meta file's and which decodes
/// to 20 bytes of RGBA8 a Gaussian.
void make_solid_chunk(const std::string& dir, uint32_t side, size_t meta_bytes) {
  fs::create_directories(dir);
  const uint8_t colours[5][4] = {{255, 0, 0, 0}, {255, 128, 128, 128}, {252, 128, 128, 128}, {255, 128, 128, 128},
                                 {200, 128, 128, 128}};  // a, r, g, b; the quaternion tag 252: w largest
  for (size_t i = 0; i < 5; ++i) write_file(dir + "/" + kSogImages[i], solid_webp(side, side, colours[i]));
  std::string meta = replace_first(read_file(hostile("sog/meta.json")), "\"count\":877",
                                   "\"count\":" + std::to_string(uint64_t{side} * side));
  REQUIRE(meta.size() < meta_bytes);
  write_file(dir + "/meta.json", meta + std::string(meta_bytes - meta.size(), ' '));
}

/// A streamed SOG's lod-meta.json of one level whose `filenames` are `names`, each referenced whole (`count`
/// Gaussians) by a node of its own.
std::string lod_meta_naming(const std::vector<std::string>& names, uint64_t count) {
  std::string files, nodes;
  for (size_t i = 0; i < names.size(); ++i) {
    files += (i ? "," : "") + ("\"" + names[i] + "\"");
    nodes += (i ? "," : "") + ("{\"bound\":{\"min\":[0,0,0],\"max\":[1,1,1]},\"lods\":{\"0\":{\"file\":" +
                               std::to_string(i) + ",\"offset\":0,\"count\":" + std::to_string(count) + "}}}");
  }
  const std::string total = std::to_string(count * names.size());
  return "{\"version\":1,\"count\":" + total + ",\"counts\":[" + total + "],\"lodLevels\":1,\"filenames\":[" +
         files + "],\"tree\":{\"bound\":{\"min\":[0,0,0],\"max\":[1,1,1]},\"children\":[" + nodes + "]}}";
}

/// A ZIP archive of `entries` (name, bytes, deflated?), no extra fields, as a bundled .sog is written.
std::string zip_archive(const std::vector<std::tuple<std::string, std::string, bool>>& entries) {
  auto le = [](uint64_t v, int n) {
    std::string out(static_cast<size_t>(n), '\0');
    for (int b = 0; b < n; ++b) out[static_cast<size_t>(b)] = static_cast<char>(v >> (8 * b));
    return out;
  };
  std::string out, central;
  for (const auto& [name, data, deflated] : entries) {
    std::string stored = data;
    if (deflated) {
      z_stream z{};
      REQUIRE(deflateInit2(&z, 9, Z_DEFLATED, -15, 9, Z_DEFAULT_STRATEGY) == Z_OK);
      stored.resize(deflateBound(&z, static_cast<uLong>(data.size())));
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
      z.avail_in = static_cast<uInt>(data.size());
      z.next_out = reinterpret_cast<Bytef*>(&stored[0]);
      z.avail_out = static_cast<uInt>(stored.size());
      REQUIRE(deflate(&z, Z_FINISH) == Z_STREAM_END);
      stored.resize(z.total_out);
      deflateEnd(&z);
    }
    const uint32_t crc = static_cast<uint32_t>(
        crc32(0, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(data.size())));
    const std::string fields = le(20, 2) + le(0, 2) + le(deflated ? 8 : 0, 2) + le(0, 2) + le(0x21, 2) +
                               le(crc, 4) + le(stored.size(), 4) + le(data.size(), 4) + le(name.size(), 2) + le(0, 2);
    central += le(0x02014b50, 4) + le(20, 2) + fields + le(0, 2) + le(0, 2) + le(0, 2) + le(0, 4) +
               le(out.size(), 4) + name;
    out += le(0x04034b50, 4) + fields + name + stored;
  }
  const size_t central_at = out.size();
  return out + central + le(0x06054b50, 4) + le(0, 2) + le(0, 2) + le(entries.size(), 2) + le(entries.size(), 2) +
         le(central.size(), 4) + le(central_at, 4) + le(0, 2);
}

// ---------------------------------------------------------------------------------------------------

TEST_CASE("hostile scenes: the corpus's valid scenes read in a child process, within the memory bound") {
  // The harness and the corpus's base scenes: these must read, so the refusals below come from the hostile
  // parts alone. deep_*_32 nest 32 levels, well inside the limit of 64.
  struct Valid {
    const char* path;
    uint64_t gaussians;
  };
  for (const Valid& v :
       {Valid{"gltf/scene.gltf", 256}, Valid{"gltf/deep_extras_32.gltf", 256}, Valid{"sog/meta.json", 877},
        Valid{"sog/deep_32.json", 877}, Valid{"sog/lod.json", 877}, Valid{"sog", 877}}) {
    const std::string path = v.path;
    CAPTURE(path);
    const ChildRead r = read_in_child(hostile(v.path));
    INFO(r.describe());
    CHECK(r.returned());
    if (!r.returned()) continue;
    CHECK(r.ok);
    CHECK(r.gaussians == v.gaussians);
    CHECK(r.peak_growth < kPeakGrowthLimit);
  }
  for (const std::string shipped :
       {"tests/data/sog/guitar_crop.sog", "tests/data/interop/guitar_256_splat_transform_v4.spz",
        "tests/data/interop/guitar_256_splat_transform.glb", "tests/data/ksplat/guitar_sh3_1024_l1_sh2.ksplat"}) {
    CAPTURE(shipped);
    const ChildRead r = read_in_child(repo_path(shipped));
    INFO(r.describe());
    CHECK(r.returned());
    if (!r.returned()) continue;
    CHECK(r.ok);
  }
  // The memory bound measures something: reading samples/guitar.ply (90,854 Gaussians, 5 MB of floats)
  // grows the child by more than 1 MiB.
  const ChildRead big = read_in_child(repo_path("samples/guitar.ply"));
  INFO(big.describe());
  REQUIRE(big.returned());
  CHECK(big.ok);
  CHECK(big.peak_growth > (uint64_t{1} << 20));
}

TEST_CASE("hostile scenes: any spelling of a reference out of the scene folder is kCorruptData 'outside the scene'") {
  // Relative targets exist (gltf_escape/ -> ../gltf/scene.bin, sog/ -> ../../sog/guitar_crop/), so a reader
  // that followed them would read a whole scene.
  const char* const gltf[] = {"dotdot",   "nested_dotdot", "pct_dotdot_lower", "pct_dotdot_upper", "pct_dots_only",
                              "absolute", "pct_absolute",  "file_scheme",      "http_scheme",      "long_dotdot"};
  for (const char* name : gltf) {
    const std::string file = std::string(name) + ".gltf";
    CAPTURE(file);
    check_refused(read_in_child(hostile("gltf_escape/" + file)), {StatusCode::kCorruptData}, file, "outside the scene");
  }
  const char* const sog[] = {"dotdot", "nested_dotdot", "pct_dotdot", "absolute", "pct_absolute", "file_scheme"};
  for (const char* name : sog) {
    for (const char* prefix : {"escape_", "lod_escape_"}) {
      const std::string file = prefix + std::string(name) + ".json";
      CAPTURE(file);
      check_refused(read_in_child(hostile("sog/" + file)), {StatusCode::kCorruptData}, file, "outside the scene");
    }
  }
  // Inside a bundle the archive is the scene: a name with '..' leaves it too.
  check_refused(read_in_child(hostile("sog_bundle/escape_dotdot.sog")), {StatusCode::kCorruptData}, "escape_dotdot.sog",
                "outside the scene");
}

TEST_CASE("hostile scenes: declared sizes the file cannot hold are refused before allocating") {
  struct Case {
    const char* path;
    const char* names;
    std::vector<StatusCode> codes;
  };
  const std::vector<StatusCode> size_codes = {StatusCode::kLimitExceeded, StatusCode::kCorruptData};
  const Case cases[] = {
      {"gltf/bytelength_3gib.gltf", "bytelength_3gib.gltf", size_codes},  // 3 GiB over a 15,360-byte .bin
      {"gltf/data_uri_bytelength_3gib.gltf", "data_uri_bytelength_3gib.gltf", size_codes},
      {"gltf/no_bufferview_40m.gltf", "no_bufferview_40m.gltf", size_codes},  // 40M values no byte holds
      {"glb/bytelength_3gib.glb", "bytelength_3gib.glb", size_codes},
      {"sog/count_40m.json", "count_40m.json", size_codes},  // 40M Gaussians over 877-pixel images
      // No image at all: naming the first missing image is as good as refusing the count.
      {"sog_no_images/count_40m.json",
       "count_40m.json",
       {StatusCode::kLimitExceeded, StatusCode::kCorruptData, StatusCode::kIoError}},
      {"sog/lod_count_40m.json", "count_40m.json", size_codes},
      {"sog_bundle/entry_deflate_1gib.sog", "entry_deflate_1gib.sog", size_codes},  // 1 GiB from 2.7 KB deflated
      {"sog_bundle/entry_stored_1gib.sog", "entry_stored_1gib.sog", size_codes},    // stored: sizes differ
      {"spz/v4_garbage_40m.spz", "v4_garbage_40m.spz", size_codes},                 // 24 KB of noise declaring 800 MB
      // .ksplat has no codec: every count must be held by the file's bytes (5-79 KB declaring 2^32 - 1 of a kind).
      {"ksplat/count_4g.ksplat", "count_4g.ksplat", size_codes},
      {"ksplat/sections_4g.ksplat", "sections_4g.ksplat", size_codes},
      {"ksplat/buckets_4g.ksplat", "buckets_4g.ksplat", size_codes},
      {"ksplat/bucket_size_4g.ksplat", "bucket_size_4g.ksplat", size_codes},
      {"ksplat/partial_4g.ksplat", "partial_4g.ksplat", size_codes},
  };
  for (const Case& c : cases) {
    const std::string path = c.path;
    CAPTURE(path);
    check_refused(read_in_child(hostile(path)), c.codes, c.names, nullptr);
  }
}

TEST_CASE("hostile scenes: valid scenes expanding past the decompression-ratio limit are kLimitExceeded") {
  // Each is a well-formed scene that the default max_gaussians (2^28) admits; only the ratio of what it
  // decodes to its size refuses it, before the cloud is allocated.
  struct Case {
    const char* path;
    const char* names;
  };
  const Case cases[] = {
      {"glb/instanced_40m.glb", "instanced_40m.glb"},  // 40,009,728 Gaussians: one mesh drawn by 1,776 nodes
      {"sog_solid_33m", "sog_solid_33m"},              // 33,547,264 Gaussians in 5 KB of WebP
      {"sog_bundle/solid_33m.sog", "solid_33m.sog"},
      {"spz/v4_rle_16m.spz", "v4_rle_16m.spz"},  // 16,777,216 Gaussians in zstd RLE blocks
      {"spz/v3_gzip_1m.spz", "v3_gzip_1m.spz"},  // 20 MiB of gzip-ed zero bytes in 20 KB
  };
  for (const Case& c : cases) {
    const std::string path = c.path;
    CAPTURE(path);
    check_refused(read_in_child(hostile(path)), {StatusCode::kLimitExceeded}, c.names, nullptr);
  }
}

TEST_CASE("hostile scenes: a file named again, by any spelling or hard link, counts once towards the ratio limit") {
  // One chunk of 65,536 Gaussians, its bytes a 1.5 MiB meta.json, named 16 times by a streamed SOG: 21 MB of
  // images to decode from 1.5 MiB of distinct files, over the limit of 8 x 1.5 MiB. Counted once per name,
  // the scene would seem to hold 24 MiB and its 1,048,576 Gaussians would be decoded.
  ScratchDir tmp;
  constexpr uint32_t kSide = 256;
  constexpr size_t kMetaBytes = size_t{3} << 19;
  constexpr int kNames = 16;
  std::vector<std::string> spellings, links;
  for (int i = 0; i < kNames; ++i) {
    std::string prefix;
    for (int k = 0; k < i; ++k) prefix += "./";
    spellings.push_back(prefix + "chunk/meta.json");  // chunk/meta.json, ./chunk/meta.json, ././chunk/...
    links.push_back("chunk_" + std::to_string(i) + "/meta.json");
  }
  make_solid_chunk(tmp / "spellings/chunk", kSide, kMetaBytes);
  write_file(tmp / "spellings/lod-meta.json", lod_meta_naming(spellings, uint64_t{kSide} * kSide));

  make_solid_chunk(tmp / "links/chunk_0", kSide, kMetaBytes);
  for (int i = 1; i < kNames; ++i) {
    const std::string dir = tmp / ("links/chunk_" + std::to_string(i));
    fs::create_directories(dir);
    for (const char* name : {"meta.json", "means_l.webp", "means_u.webp", "quats.webp", "scales.webp", "sh0.webp"}) {
      fs::create_hard_link(tmp / ("links/chunk_0/" + std::string(name)), dir + "/" + name);
    }
  }
  write_file(tmp / "links/lod-meta.json", lod_meta_naming(links, uint64_t{kSide} * kSide));

  // The chunk once is a valid scene well within the limit.
  make_solid_chunk(tmp / "once/chunk", kSide, kMetaBytes);
  write_file(tmp / "once/lod-meta.json", lod_meta_naming({"chunk/meta.json"}, uint64_t{kSide} * kSide));
  const ChildRead once = read_in_child(tmp / "once/lod-meta.json");
  INFO(once.describe());
  CHECK(once.ok);
  CHECK(once.gaussians == uint64_t{kSide} * kSide);

  for (const char* what : {"spellings", "links"}) {
    CAPTURE(what);
    check_refused(read_in_child(tmp / (std::string(what) + "/lod-meta.json")), {StatusCode::kLimitExceeded},
                  "lod-meta.json", "decompression-ratio limit");
  }
}

TEST_CASE("hostile scenes: a bundled .sog entry inflating past the ratio limit is kLimitExceeded, meta.json too") {
  // meta.json padded with 9 MiB of spaces deflates to a few KB: over 8 x 1 MiB, whatever entry it is.
  ScratchDir tmp;
  const std::string meta = read_file(hostile("sog/meta.json"));
  std::vector<std::tuple<std::string, std::string, bool>> entries = {
      {"meta.json", meta + std::string(size_t{9} << 20, ' '), true}};
  for (const char* image : kSogImages) entries.emplace_back(image, read_file(hostile(std::string("sog/") + image)), false);
  write_file(tmp / "inflating_meta.sog", zip_archive(entries));
  CHECK(fs::file_size(tmp / "inflating_meta.sog") < 100000);
  check_refused(read_in_child(tmp / "inflating_meta.sog"), {StatusCode::kLimitExceeded}, "inflating_meta.sog",
                "'meta.json'");

  // The same archive with meta.json as written is read.
  std::get<1>(entries[0]) = meta;
  write_file(tmp / "plain.sog", zip_archive(entries));
  const ChildRead plain = read_in_child(tmp / "plain.sog");
  INFO(plain.describe());
  CHECK(plain.ok);
  CHECK(plain.gaussians == 877);
}

TEST_CASE("hostile scenes: JSON nested deeper than 64 levels is kCorruptData 'nested'") {
  const char* const corpus[] = {"gltf/deep_extras_100.gltf",
                                "gltf/deep_extensions_required_100.gltf",
                                "gltf/deep_accessor_type_100.gltf",
                                "glb/deep_100.glb",
                                "sog/deep_100.json",
                                "sog/lod_deep_100.json",
                                "sog_bundle/deep_100.sog"};
  for (const std::string path : corpus) {
    CAPTURE(path);
    check_refused(read_in_child(hostile(path)), {StatusCode::kCorruptData}, fs::path(path).filename().string(),
                  "nested");
  }
  // 70,000 levels: deep enough to exhaust a recursive parser's, printer's or destructor's stack.
  ScratchDir tmp;
  const std::string deep = nested_arrays(70000);
  const std::string gltf = read_file(hostile("gltf/scene.gltf"));
  make_gltf_scene(tmp / "gltf");
  write_file(tmp / "gltf/required.gltf",
             replace_first(gltf, "\"extensionsUsed\":", "\"extensionsRequired\":" + deep + ",\"extensionsUsed\":"));
  write_file(tmp / "gltf/accessor_type.gltf", replace_first(gltf, "\"type\":\"VEC3\"", "\"type\":" + deep));
  make_sog_folder(tmp / "sog");
  write_file(tmp / "sog/deep.json",
             replace_first(read_file(hostile("sog/meta.json")), "\"asset\":{", "\"asset\":{\"extras\":" + deep + ","));
  write_file(tmp / "sog/lod_deep.json",
             replace_first(read_file(hostile("sog/lod.json")), "\"asset\":{", "\"asset\":{\"extras\":" + deep + ","));
  write_file(tmp / "sog/lod_deep_chunk.json",
             replace_first(read_file(hostile("sog/lod.json")), "\"meta.json\"", "\"deep.json\""));
  const char* const runtime[][2] = {{"gltf/required.gltf", "required.gltf"},
                                    {"gltf/accessor_type.gltf", "accessor_type.gltf"},
                                    {"sog/deep.json", "deep.json"},
                                    {"sog/lod_deep.json", "lod_deep.json"},
                                    {"sog/lod_deep_chunk.json", "deep.json"}};
  for (const auto& c : runtime) {
    const std::string file = c[0];
    CAPTURE(file);
    check_refused(read_in_child(tmp / c[0]), {StatusCode::kCorruptData}, c[1], "nested");
  }
}

TEST_CASE("hostile scenes: glTF node cycles are kCorruptData 'cycle', a node with 2^40 paths is visited once") {
  for (const std::string path : {"gltf/node_cycle.gltf", "gltf/node_self_cycle.gltf"}) {
    CAPTURE(path);
    check_refused(read_in_child(hostile(path)), {StatusCode::kCorruptData}, fs::path(path).filename().string(),
                  "cycle");
  }
  // Node i has children [i+1, i+1] for i < 40: ok (the mesh once) or an error (a node with two parents), but
  // at once.
  const ChildRead dag = read_in_child(hostile("gltf/node_dag_40.gltf"), {}, 10);
  INFO(dag.describe());
  REQUIRE(dag.returned());
  CHECK(dag.seconds < 1.0);
  CHECK(dag.peak_growth < kPeakGrowthLimit);
  if (dag.ok) CHECK(dag.gaussians == 256);
  if (!dag.ok) CHECK(contains(dag.message, "node_dag_40.gltf"));
}

TEST_CASE("hostile scenes: messages quote at most about 200 characters of a long field") {
  struct Case {
    const char* path;
    char filler;  // the character the field repeats 5,000 or 10,000 times
  };
  const Case cases[] = {
      {"gltf/long_extension_name.gltf", 'X'}, {"gltf/long_accessor_type.gltf", 'T'}, {"gltf/long_version.gltf", 'V'},
      {"gltf/long_kernel.gltf", 'K'},
      {"gltf_escape/long_dotdot.gltf", 'A'},  {"sog/long_name.json", 'A'},           {"sog/lod_long_name.json", 'B'}};
  for (const Case& c : cases) {
    const std::string path = c.path;
    CAPTURE(path);
    const ChildRead r = read_in_child(hostile(path));
    INFO(r.describe().substr(0, 2000));
    CHECK(r.returned());
    if (!r.returned()) continue;
    CHECK_FALSE(r.ok);
    CHECK(longest_run(r.message, c.filler) <= kMaxQuotedRun);
    CHECK(r.message.size() < 1024);
    CHECK(contains(r.message, fs::path(c.path).filename().string()));
  }
}

TEST_CASE("hostile scenes: symbolic links in a scene are kCorruptData 'symbolic link' and hide their target") {
  ScratchDir tmp;
  // The targets: whole scene files outside the scene folders, so that a reader following a link reads a
  // valid scene. Their names and sizes must not appear in the messages.
  const std::string outside = tmp / "canary_outside";
  fs::create_directories(outside);
  fs::copy_file(hostile("sog/means_l.webp"), outside + "/canary_means_l.webp");
  fs::copy_file(hostile("sog/meta.json"), outside + "/canary_meta.json");
  fs::copy_file(hostile("gltf/scene.bin"), outside + "/canary_scene.bin");
  make_sog_folder(outside + "/canary_chunk");
  fs::copy_file(hostile("gltf/scene.bin"), outside + "/scene.bin");

  struct Case {
    std::string what, read, names, target;
  };
  std::vector<Case> cases;
  auto relink = [](const std::string& link, const std::string& target) {
    fs::remove_all(link);
    fs::create_symlink(target, link);
  };
  make_sog_folder(tmp / "sog_image");
  relink(tmp / "sog_image/means_l.webp", outside + "/canary_means_l.webp");
  cases.push_back({"SOG image -> outside", tmp / "sog_image", "means_l.webp", outside + "/canary_means_l.webp"});

  make_sog_folder(tmp / "sog_inside");
  fs::copy_file(tmp / "sog_inside/means_l.webp", tmp / "sog_inside/means_l_copy.webp");
  relink(tmp / "sog_inside/means_l.webp", "means_l_copy.webp");
  cases.push_back({"SOG image -> a file of the same folder", tmp / "sog_inside/meta.json", "means_l.webp",
                   tmp / "sog_inside/means_l_copy.webp"});

  make_sog_folder(tmp / "sog_meta");
  relink(tmp / "sog_meta/meta.json", outside + "/canary_meta.json");
  cases.push_back(
      {"SOG meta.json of a folder -> outside", tmp / "sog_meta", "meta.json", outside + "/canary_meta.json"});

  make_lod_scene(tmp / "lod_folder");
  relink(tmp / "lod_folder/chunk", outside + "/canary_chunk");
  cases.push_back({"streamed-SOG chunk folder -> outside", tmp / "lod_folder/lod-meta.json", "chunk/meta.json", ""});

  make_lod_scene(tmp / "lod_meta");
  relink(tmp / "lod_meta/chunk/meta.json", outside + "/canary_meta.json");
  cases.push_back({"streamed-SOG chunk meta.json -> outside", tmp / "lod_meta/lod-meta.json", "meta.json",
                   outside + "/canary_meta.json"});

  make_lod_scene(tmp / "lod_image");
  relink(tmp / "lod_image/chunk/quats.webp", outside + "/canary_chunk/quats.webp");
  cases.push_back({"streamed-SOG chunk image -> outside", tmp / "lod_image/lod-meta.json", "quats.webp",
                   outside + "/canary_chunk/quats.webp"});

  make_gltf_scene(tmp / "gltf_bin");
  relink(tmp / "gltf_bin/scene.bin", outside + "/canary_scene.bin");
  cases.push_back({"glTF buffer -> outside", tmp / "gltf_bin/scene.gltf", "scene.bin", outside + "/canary_scene.bin"});

  make_gltf_scene(tmp / "gltf_dir");
  fs::create_symlink(outside, tmp / "gltf_dir/sub");
  write_file(tmp / "gltf_dir/scene.gltf", replace_first(read_file(hostile("gltf/scene.gltf")), "\"uri\":\"scene.bin\"",
                                                        "\"uri\":\"sub/scene.bin\""));
  cases.push_back({"glTF buffer in a linked folder", tmp / "gltf_dir/scene.gltf", "sub/scene.bin", ""});

  for (const Case& c : cases) {
    CAPTURE(c.what);
    const ChildRead r = read_in_child(c.read);
    check_refused(r, {StatusCode::kCorruptData}, c.names, "symbolic link");
    CHECK_FALSE(contains(r.message, "canary"));
    if (!c.target.empty()) {
      CHECK_FALSE(contains(r.message, c.target));
      CHECK_FALSE(contains(r.message, " " + std::to_string(fs::file_size(c.target))));
    }
  }
}

TEST_CASE("hostile scenes: named files that are not regular files are kIoError 'not a regular file', at once") {
  ScratchDir tmp;
  struct Case {
    std::string what, read, names;
  };
  std::vector<Case> cases;
  auto fifo = [](const std::string& path) {
    fs::remove(path);
    REQUIRE(::mkfifo(path.c_str(), 0600) == 0);
  };
  auto directory = [](const std::string& path) {
    fs::remove(path);
    fs::create_directory(path);
  };
  make_sog_folder(tmp / "sog_fifo");
  fifo(tmp / "sog_fifo/means_u.webp");
  cases.push_back({"SOG image FIFO", tmp / "sog_fifo/meta.json", "means_u.webp"});
  make_sog_folder(tmp / "sog_meta_fifo");
  fifo(tmp / "sog_meta_fifo/meta.json");
  cases.push_back({"SOG meta.json FIFO (folder given)", tmp / "sog_meta_fifo", "meta.json"});
  make_lod_scene(tmp / "lod_fifo");
  fifo(tmp / "lod_fifo/chunk/meta.json");
  cases.push_back({"streamed-SOG chunk meta.json FIFO", tmp / "lod_fifo/lod-meta.json", "meta.json"});
  make_gltf_scene(tmp / "gltf_fifo");
  fifo(tmp / "gltf_fifo/scene.bin");
  cases.push_back({"glTF buffer FIFO", tmp / "gltf_fifo/scene.gltf", "scene.bin"});
  make_sog_folder(tmp / "sog_dir");
  directory(tmp / "sog_dir/scales.webp");
  cases.push_back({"SOG image directory", tmp / "sog_dir/meta.json", "scales.webp"});
  make_gltf_scene(tmp / "gltf_dir");
  directory(tmp / "gltf_dir/scene.bin");
  cases.push_back({"glTF buffer directory", tmp / "gltf_dir/scene.gltf", "scene.bin"});
  make_lod_scene(tmp / "lod_dir");
  directory(tmp / "lod_dir/chunk/meta.json");
  cases.push_back({"streamed-SOG chunk meta.json directory", tmp / "lod_dir/lod-meta.json", "meta.json"});

  for (const Case& c : cases) {
    CAPTURE(c.what);
    const ChildRead r = read_in_child(c.read, {}, 5);
    check_refused(r, {StatusCode::kIoError}, c.names, "not a regular file");
    if (r.returned()) CHECK(r.seconds < 1.0);
  }
}

}  // namespace
}  // namespace rgs::test
