// ConvertOptions::memory_limit: the estimate of a conversion's peak memory and the refusal, before reading, of an
// input whose estimate is above the limit.
#include <doctest/doctest.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "rgs/api/convert.h"
#include "rgs/converter/cloud_edits.h"
#include "temp_dir.h"
#include "test_data.h"

namespace {

using namespace rgs;

TEST_CASE("estimate_convert_memory: above the input's bytes, growing with them, compact formats more per byte") {
  const std::string ply = test::repo_path(test::kGuitarSh3);
  const std::string spz = test::repo_path("tests/data/interop/guitar_256_splat_transform_v4.spz");
  auto ply_estimate = api::estimate_convert_memory(ply);
  auto spz_estimate = api::estimate_convert_memory(spz);
  REQUIRE_MESSAGE(ply_estimate.ok(), ply_estimate.status().to_string());
  REQUIRE_MESSAGE(spz_estimate.ok(), spz_estimate.status().to_string());
  const uint64_t ply_bytes = std::filesystem::file_size(ply);
  const uint64_t spz_bytes = std::filesystem::file_size(spz);
  CHECK(*ply_estimate > ply_bytes);
  CHECK(*spz_estimate > spz_bytes);
  constexpr uint64_t kBase = uint64_t{64} << 20;  // what every conversion holds (convert_memory.cpp)
  CHECK(double(*spz_estimate - kBase) / double(spz_bytes) > double(*ply_estimate - kBase) / double(ply_bytes));
  CHECK(api::estimate_convert_memory(test::repo_path("tests/data/no_such_scene.ply")).status().code() ==
        StatusCode::kIoError);
}

TEST_CASE("convert_memory_limit: the option, else half the physical memory") {
  api::ConvertOptions options;
  const uint64_t machine = api::convert_memory_limit(options);
  CHECK(machine > (uint64_t{64} << 20));  // any machine that runs the suite
  options.memory_limit = 12345;
  CHECK(api::convert_memory_limit(options) == 12345);
}

TEST_CASE("max_whole_input_bytes: the largest input of a format whose estimate is within the memory limit") {
  const std::string ply = test::repo_path(test::kGuitarSh3);
  const uint64_t bytes = std::filesystem::file_size(ply);
  auto estimate = api::estimate_convert_memory(ply);
  REQUIRE(estimate.ok());
  api::ConvertOptions options;
  // A PLY stream is held whole while it is converted, a PLY file is not: the stream needs a byte more a byte.
  options.memory_limit = *estimate + bytes;
  CHECK(api::max_whole_input_bytes("ply", options) >= bytes);
  options.memory_limit = *estimate + bytes - 1;
  CHECK(api::max_whole_input_bytes("ply", options) < bytes);
  options.memory_limit = uint64_t{96} << 20;  // 32 MiB above what every conversion holds
  CHECK(api::max_whole_input_bytes("ply", options) == ((uint64_t{32} << 20) * 2 + 1) / 5);  // n · 2.5 rounds down
  CHECK(api::max_whole_input_bytes("rgs", options) == (uint64_t{32} << 20) / 4);
  CHECK(api::max_whole_input_bytes("spz", options) == (uint64_t{32} << 20) / 8);
  options.memory_limit = uint64_t{64} << 20;
  CHECK(api::max_whole_input_bytes("ply", options) == 0);
  options.memory_limit = 1;
  CHECK(api::max_whole_input_bytes("rgs", options) == 0);
}

TEST_CASE("convert: an input over memory_limit that cannot be read in batches is refused before it is read") {
  test::TempDir dir;
  const std::string src = test::repo_path("tests/data/interop/guitar_256_splat_transform_v4.spz");
  const std::string dst = (dir.path() / "limited.rgs").string();
  auto estimate = api::estimate_convert_memory(src);
  REQUIRE(estimate.ok());
  api::ConvertOptions options;
  options.lod_levels = 0;
  options.memory_limit = *estimate - 1;
  auto refused = api::convert(src, dst, options);
  REQUIRE(!refused.ok());
  CHECK(refused.status().code() == StatusCode::kLimitExceeded);
  CHECK(refused.status().message().find("guitar_256_splat_transform_v4.spz: converting it is estimated to need") !=
        std::string::npos);
  CHECK(refused.status().message().find("memory_limit (--memory-limit)") != std::string::npos);
  CHECK(dir.entries().empty());
  options.memory_limit = *estimate;
  auto written = api::convert(src, dst, options);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  CHECK(written->rgs->lod_levels > 0);
  CHECK(written->rgs->out_of_core_partitions == 0);
  CHECK(std::filesystem::exists(dst));
}

/// The resident memory of this process (Linux), 0 when unknown.
uint64_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  uint64_t size = 0, pages = 0;
  statm >> size >> pages;
  return pages * uint64_t(sysconf(_SC_PAGE_SIZE));
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST_CASE("convert: a binary PLY over memory_limit converts out of core to the bytes of the conversion in memory") {
  test::TempDir dir;
  const std::string src = test::repo_path(test::kGuitarSh3);
  const std::string in_memory = (dir.path() / "in_memory.rgs").string();
  const std::string out_of_core = (dir.path() / "out_of_core.rgs").string();
  api::ConvertOptions options;
  options.lod_levels = 0;
  options.lod_chunk_gaussians = 512;
  options.scale_encoding = format::ScaleEncoding::kLog;
  auto memory = api::convert(src, in_memory, options);
  REQUIRE_MESSAGE(memory.ok(), memory.status().to_string());
  CHECK(memory->rgs->out_of_core_partitions == 0);
  auto estimate = api::estimate_convert_memory(src);
  REQUIRE(estimate.ok());
  // The limit bounds the whole process: a suite run in one process (the GPU host's) may already hold more than
  // this small scene's estimate leaves the build. ctest runs each case in a process of its own.
  if (resident_bytes() + (uint64_t{40} << 20) > *estimate) {
    MESSAGE("skipped: this process already holds " << resident_bytes() << " bytes, too many for a limit of "
                                                   << *estimate - 1);
    return;
  }
  options.memory_limit = *estimate - 1;
  std::vector<std::string> stages;
  options.progress = [&](const api::ConvertProgress& p) { stages.push_back(p.stage); };
  auto streamed = api::convert(src, out_of_core, options);
  REQUIRE_MESSAGE(streamed.ok(), streamed.status().to_string());
  CHECK(streamed->rgs->out_of_core_partitions >= 1);
  CHECK(streamed->output_bytes == memory->output_bytes);
  CHECK(streamed->gaussians == memory->gaussians);
  CHECK(streamed->rgs->lod_gaussians == memory->rgs->lod_gaussians);
  CHECK(streamed->rgs->errors.sh[3].max == doctest::Approx(memory->rgs->errors.sh[3].max));
  CHECK(read_bytes(out_of_core) == read_bytes(in_memory));
  for (const char* stage : {"reading", "counting", "partitioning", "building levels of detail", "writing", "done"}) {
    CHECK_MESSAGE(std::find(stages.begin(), stages.end(), stage) != stages.end(), stage);
  }
  CHECK(dir.entries().size() == 2);  // the temporary folder is gone
}

/// Every file under `root`, by path relative to it, with its bytes.
std::vector<std::pair<std::string, std::string>> folder_files(const std::filesystem::path& root) {
  std::vector<std::pair<std::string, std::string>> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(root)) {
    if (entry.is_regular_file()) {
      files.emplace_back(std::filesystem::relative(entry.path(), root).string(), read_bytes(entry.path().string()));
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST_CASE("convert: a streamed SOG of a binary PLY over memory_limit is written out of core, the same files") {
  test::TempDir dir;
  const std::string src = test::repo_path(test::kGuitarSh3);
  std::filesystem::create_directories(dir.path() / "memory");  // "batches/new" does not exist: the sink makes it
  api::ConvertOptions options;
  options.lod_chunk_gaussians = 512;
  auto memory = api::convert(src, (dir.path() / "memory" / "lod-meta.json").string(), options);
  REQUIRE_MESSAGE(memory.ok(), memory.status().to_string());
  auto estimate = api::estimate_convert_memory(src);
  REQUIRE(estimate.ok());
  if (resident_bytes() + (uint64_t{40} << 20) > *estimate) {
    MESSAGE("skipped: this process already holds " << resident_bytes() << " bytes, too many for a limit of "
                                                   << *estimate - 1);
    return;
  }
  options.memory_limit = *estimate - 1;
  auto batched = api::convert(src, (dir.path() / "batches" / "new" / "lod-meta.json").string(), options);
  REQUIRE_MESSAGE(batched.ok(), batched.status().to_string());
  CHECK(batched->output_bytes == memory->output_bytes);
  CHECK(batched->gaussians == memory->gaussians);
  CHECK(std::find_if(batched->output_notes.begin(), batched->output_notes.end(), [](const std::string& note) {
          return note.rfind("built out of core", 0) == 0;
        }) != batched->output_notes.end());
  const auto expected = folder_files(dir.path() / "memory");
  CHECK(expected.size() > 8);  // lod-meta.json and the chunk folders of every level
  CHECK(folder_files(dir.path() / "batches" / "new") == expected);
}

TEST_CASE("convert: every sink over memory_limit: levels of detail built out of core to the same files, others refused") {
  // Every output format (--to) and container: those of levels of detail (a .rgs with levels, a streamed SOG) read a
  // PLY over the limit in batches and write what the conversion in memory writes; every other sink needs the scene
  // whole and is refused by name before it is read; --decimate, an edit of the whole scene, is refused in batches.
  struct Sink {
    const char* dst;
    bool levels;
  };
  const Sink sinks[] = {{"out.rgs", true},  {"out.rgs", false},         {"out.ply", false}, {"out.spz", false},
                        {"out.glb", false}, {"out.sog", false},         {"sog/meta.json", false},
                        {"lod/lod-meta.json", true}};
  const std::string src = test::repo_path(test::kGuitarSh3);
  auto estimate = api::estimate_convert_memory(src);
  REQUIRE(estimate.ok());
  if (resident_bytes() + (uint64_t{40} << 20) > *estimate) {
    MESSAGE("skipped: this process already holds " << resident_bytes() << " bytes");
    return;
  }
  for (const Sink& sink : sinks) {
    CAPTURE(std::string(sink.dst));
    CAPTURE(sink.levels);
    test::TempDir dir;
    std::filesystem::create_directories(dir.path() / "memory" / "sog");
    std::filesystem::create_directories(dir.path() / "memory" / "lod");
    std::filesystem::create_directories(dir.path() / "batches" / "sog");
    std::filesystem::create_directories(dir.path() / "batches" / "lod");
    api::ConvertOptions options;
    options.lod_chunk_gaussians = 1024;
    if (sink.levels && std::string(sink.dst) == "out.rgs") options.lod_levels = 0;
    REQUIRE(api::convert(src, (dir.path() / "memory" / sink.dst).string(), options).ok());
    options.memory_limit = *estimate - 1;
    const std::string dst = (dir.path() / "batches" / sink.dst).string();
    auto batched = api::convert(src, dst, options);
    if (!sink.levels) {
      REQUIRE_FALSE(batched.ok());
      CHECK(batched.status().code() == StatusCode::kLimitExceeded);
      CHECK(batched.status().message().find("only a binary PLY converted with levels of detail is read in batches") !=
            std::string::npos);
      CHECK(folder_files(dir.path() / "batches").empty());
      continue;
    }
    REQUIRE_MESSAGE(batched.ok(), batched.status().to_string());
    CHECK(folder_files(dir.path() / "batches") == folder_files(dir.path() / "memory"));
    options.edits.push_back(converter::parse_edit_action("decimate", "1000").value());
    auto decimated = api::convert(src, dst, options);
    REQUIRE_FALSE(decimated.ok());
    CHECK(decimated.status().message().find("decimate needs the whole scene (or input) in memory") != std::string::npos);
  }
}

/// A version an input PLY is rewritten to while it is converted out of core: a new file renamed over it, or
/// written in place (the same inode), then given back its modification time or not.
struct Rewrite {
  std::string bytes;
  bool renamed = false;
  bool keep_time = false;
};

/// What the versions of kRewrites change.
constexpr const char* kRewrites[] = {"means moved outside the box, the same size",
                                     "means moved among the vertices, inside the box",
                                     "other colours, the same means and size",
                                     "truncated to half",
                                     "grown by 50 vertices",
                                     "the same bytes, a new file renamed over it",
                                     "other colours, the same means, size and modification time",
                                     "means moved outside the box, the same size and modification time"};

/// Version `kind` (an index of kRewrites) of a binary PLY of float properties, x y z first.
Rewrite rewrite_of(const std::string& ply, size_t kind) {
  const size_t header = ply.find("end_header\n") + 11;
  const std::string head = ply.substr(0, header);
  size_t properties = 0, f_dc_0 = 0;
  for (size_t at = head.find("property float "); at != std::string::npos; at = head.find("property float ", at + 1)) {
    if (head.compare(at + 15, 7, "f_dc_0\n") == 0) f_dc_0 = properties;
    ++properties;
  }
  REQUIRE(head.find("property float x\nproperty float y\nproperty float z\n") != std::string::npos);
  const size_t stride = 4 * properties;
  const size_t count = (ply.size() - header) / stride;
  REQUIRE(count > 100);
  auto get = [&](size_t vertex, size_t column) {
    float v;
    std::memcpy(&v, &ply[header + vertex * stride + 4 * column], 4);
    return v;
  };
  Rewrite r{ply};
  auto put = [&](size_t vertex, size_t column, float v) {
    std::memcpy(&r.bytes[header + vertex * stride + 4 * column], &v, 4);
  };
  const std::string declared = "element vertex " + std::to_string(count) + "\n";
  r.keep_time = kind >= 6;
  switch (kind) {
    case 0:
    case 7:
      for (size_t i = 0; i < count; i += 7) put(i, 0, get(i, 0) + 1e4f);  // far beyond the box along x
      break;
    case 1:
      for (size_t i = 0; i < count; ++i) {
        for (size_t a = 0; a < 3; ++a) put(i, a, get((i + 1) % count, a));
      }
      break;
    case 2:
    case 6:
      for (size_t i = 0; i < count; ++i) put(i, f_dc_0, get(i, f_dc_0) + 0.5f);
      break;
    case 3:
      r.bytes.resize(ply.size() / 2);
      break;
    case 4:
      r.bytes.replace(r.bytes.find(declared), declared.size(), "element vertex " + std::to_string(count + 50) + "\n");
      r.bytes += ply.substr(header, 50 * stride);
      break;
    case 5:
      r.renamed = true;
      break;
  }
  return r;
}

/// Replaces the file at `path` by `r`: written over it from its first byte and cut to its size, or renamed over it.
void rewrite(const std::string& path, const Rewrite& r) {
  const auto time = std::filesystem::last_write_time(path);
  const std::string target = r.renamed ? path + ".new" : path;
  {
    std::fstream out(target, r.renamed ? std::ios::out | std::ios::binary | std::ios::trunc
                                       : std::ios::in | std::ios::out | std::ios::binary);
    REQUIRE(out.good());
    out.write(r.bytes.data(), static_cast<std::streamsize>(r.bytes.size()));
  }
  std::filesystem::resize_file(target, r.bytes.size());
  if (r.renamed) std::filesystem::rename(target, path);
  if (r.keep_time) std::filesystem::last_write_time(path, time);
}

TEST_CASE("convert: a PLY that changes between or during the passes of the out-of-core build fails, no output") {
  test::TempDir dir;
  const std::string original = read_bytes(test::repo_path("samples/guitar.ply"));
  const std::string src = dir.file("input.ply");
  const std::string dst = dir.file("out.rgs");
  const std::string reference = dir.file("reference.rgs");
  api::ConvertOptions options;
  options.lod_levels = 0;
  options.lod_chunk_gaussians = 4096;
  {
    std::ofstream(src, std::ios::binary) << original;
  }
  auto estimate = api::estimate_convert_memory(src);
  REQUIRE(estimate.ok());
  if (resident_bytes() + (uint64_t{40} << 20) > *estimate) {
    MESSAGE("skipped: this process already holds " << resident_bytes() << " bytes, too many for a limit of "
                                                   << *estimate - 1);
    return;
  }
  options.memory_limit = *estimate - 1;
  // The file of the unchanged input, out of core as well (the same bytes as in memory: the case above), so that
  // this process stays within the limit.
  auto unchanged = api::convert(src, reference, options);
  REQUIRE_MESSAGE(unchanged.ok(), unchanged.status().to_string());
  REQUIRE(unchanged->rgs->out_of_core_partitions >= 1);
  // Where the file is rewritten: the n-th progress call of a stage. The stages report as they start and after
  // each batch (two a pass here): "reading" 2 is within the first pass, "counting" 1 and "partitioning" 1
  // between passes, "counting" 2 and "partitioning" 2 within a later pass; once the levels are built every pass
  // is over, and the output is the original's.
  const std::pair<const char*, int> within_passes[] = {
      {"reading", 2}, {"counting", 1}, {"counting", 2}, {"partitioning", 1}, {"partitioning", 2}};
  const std::pair<const char*, int> after_passes = {"building levels of detail", 1};
  const std::string changed = "the file changed during the passes of the out-of-core build (";
  constexpr int kRounds = 10;  // the checks race nothing here; repeated, file times fall in one clock tick or two
  for (int round = 0; round < kRounds; ++round) {
    for (size_t kind = 0; kind < std::size(kRewrites); ++kind) {
      const Rewrite r = rewrite_of(original, kind);
      for (const auto& [stage, call] : within_passes) {
        const std::string where = std::string(kRewrites[kind]) + ", at " + stage + " " + std::to_string(call);
        CAPTURE(round);
        CAPTURE(where);
        {
          std::ofstream(src, std::ios::binary | std::ios::trunc) << original;
        }
        int calls = 0;
        options.progress = [&, stage = stage, call = call](const api::ConvertProgress& p) {
          if (std::string(p.stage) == stage && ++calls == call) rewrite(src, r);
        };
        auto converted = api::convert(src, dst, options);
        REQUIRE_MESSAGE(calls >= call, converted.status().to_string());
        REQUIRE(!converted.ok());
        const std::string message = converted.status().message();
        const bool named_change = message.rfind(src + ": " + changed, 0) == 0;
        if (kind == 7) {
          // A mean outside the box is refused where it is found, before anything is built from it; only the hash
          // at the pass's end would say more, and the file's time does not tell.
          const bool refused_mean = message.rfind(src + ": the input gave a mean (", 0) == 0;
          CHECK_MESSAGE((named_change || refused_mean), message);
        } else {
          CHECK(converted.status().code() == StatusCode::kIoError);
          CHECK_MESSAGE(named_change, message);
        }
        if (kind == 6) {
          CHECK_MESSAGE(message.find("(other bytes of the same size and time: XXH64 ") != std::string::npos, message);
        }
        CHECK(!std::filesystem::exists(dst));
        CHECK(dir.entries().size() == 2);  // input.ply and reference.rgs: no temporary left
      }
    }
  }
  const std::string expected = read_bytes(reference);
  for (size_t kind = 0; kind < std::size(kRewrites); ++kind) {
    const std::string what = kRewrites[kind];
    CAPTURE(what);
    const Rewrite r = rewrite_of(original, kind);
    {
      std::ofstream(src, std::ios::binary | std::ios::trunc) << original;
    }
    int calls = 0;
    options.progress = [&](const api::ConvertProgress& p) {
      if (std::string(p.stage) == after_passes.first && ++calls == after_passes.second) rewrite(src, r);
    };
    auto converted = api::convert(src, dst, options);
    REQUIRE_MESSAGE(converted.ok(), converted.status().to_string());
    CHECK(converted->rgs->out_of_core_partitions >= 1);
    CHECK(read_bytes(dst) == expected);
    std::filesystem::remove(dst);
  }
}

TEST_CASE("convert: an ascii PLY over memory_limit is refused, as it is read whole") {
  test::TempDir dir;
  const std::string src = (dir.path() / "ascii.ply").string();
  {
    std::ofstream ply(src);
    ply << "ply\nformat ascii 1.0\nelement vertex 1\n";
    for (const char* p : {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
                          "rot_0", "rot_1", "rot_2", "rot_3"}) {
      ply << "property float " << p << "\n";
    }
    ply << "end_header\n0 0 0 0 0 0 0 0 0 0 1 0 0 0\n";
  }
  api::ConvertOptions options;
  options.lod_levels = 0;
  options.memory_limit = 1 << 20;
  auto refused = api::convert(src, (dir.path() / "out.rgs").string(), options);
  REQUIRE(!refused.ok());
  CHECK(refused.status().code() == StatusCode::kLimitExceeded);
  CHECK(refused.status().message().find("only a binary PLY converted with levels of detail is read in batches") !=
        std::string::npos);
}

}  // namespace
