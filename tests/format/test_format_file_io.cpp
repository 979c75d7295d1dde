// MappedFile, write_file_atomic and StagedFile: contents, error codes and messages, the no-partial-file,
// never-clobber guarantees (docs/DESIGN.md#the-rgs-format, "deterministic and atomic"), and check_output_file.
#include <doctest/doctest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "format_test_util.h"
#include "temp_dir.h"
#include "rgs/format/file_io.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace {

namespace fs = std::filesystem;
using namespace rgs;
using namespace rgs::format;
using test::TempDir;
using test::slurp;

}  // namespace

TEST_CASE("write_file_atomic: writes, replaces, streams chunks") {
  TempDir dir;
  const std::string path = dir.file("out.bin");
  REQUIRE(write_file_atomic(path, "hello", 5).ok());
  CHECK(slurp(path) == "hello");
  REQUIRE(write_file_atomic(path, "bye", 3).ok());  // replaces
  CHECK(slurp(path) == "bye");
  Status s = write_file_atomic(path, [](const ChunkSink& sink) {
    for (int i = 0; i < 100; ++i) RGS_RETURN_IF_ERROR(sink("0123456789", 10));
    return Status();
  });
  REQUIRE(s.ok());
  CHECK(slurp(path).size() == 1000);
  REQUIRE(write_file_atomic(path, nullptr, 0).ok());
  CHECK(fs::file_size(path) == 0);
  CHECK(dir.entries() == std::vector<std::string>{"out.bin"});
}

TEST_CASE("write_file_atomic: a failing producer leaves the old file and no temporary") {
  TempDir dir;
  const std::string path = dir.file("keep.bin");
  REQUIRE(write_file_atomic(path, "original", 8).ok());
  Status s = write_file_atomic(path, [](const ChunkSink& sink) {
    RGS_RETURN_IF_ERROR(sink("partial", 7));
    return Status(StatusCode::kCorruptData, "producer gave up");
  });
  CHECK(s.code() == StatusCode::kCorruptData);
  CHECK(s.message() == "producer gave up");
  CHECK(slurp(path) == "original");
  CHECK(dir.entries() == std::vector<std::string>{"keep.bin"});

  // No existing file: nothing at all is left behind.
  const std::string fresh = dir.file("fresh.bin");
  CHECK_FALSE(write_file_atomic(fresh, [](const ChunkSink&) { return Status(StatusCode::kIoError, "x"); }).ok());
  CHECK_FALSE(fs::exists(fresh));
  CHECK(dir.entries() == std::vector<std::string>{"keep.bin"});
}

TEST_CASE("write_file_atomic: missing or unwritable directories give kIoError naming the path") {
  TempDir dir;
  const std::string missing = dir.file("no_such_dir/out.rgs");
  Status s = write_file_atomic(missing, "x", 1);
  CHECK(s.code() == StatusCode::kIoError);
  CHECK_MESSAGE(s.message().find(missing) != std::string::npos, s.message());
  CHECK_MESSAGE(s.message().find("in directory " + dir.file("no_such_dir")) != std::string::npos, s.message());
  CHECK_MESSAGE(s.message().find("No such file or directory") != std::string::npos, s.message());

  // The target is a directory: rename fails, the temporary is removed.
  fs::create_directory(dir.file("a_dir"));
  s = write_file_atomic(dir.file("a_dir"), "x", 1);
  CHECK(s.code() == StatusCode::kIoError);
  CHECK(s.message().find(dir.file("a_dir")) != std::string::npos);
  CHECK(dir.entries() == std::vector<std::string>{"a_dir"});

  if (::geteuid() == 0) {
    MESSAGE("skipped: permission checks do not apply to root");
    return;
  }
  const std::string locked = dir.file("locked");
  fs::create_directory(locked);
  fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec);
  s = write_file_atomic(locked + "/out.rgs", "x", 1);
  CHECK(s.code() == StatusCode::kIoError);
  CHECK_MESSAGE(s.message().find("cannot create " + locked + "/out.rgs") != std::string::npos, s.message());
  CHECK_MESSAGE(s.message().find("Permission denied") != std::string::npos, s.message());
  fs::permissions(locked, fs::perms::owner_all);
}

TEST_CASE("MappedFile: contents, empty files, and errors naming the path") {
  TempDir dir;
  const std::string path = dir.file("data.bin");
  REQUIRE(write_file_atomic(path, "mapped bytes", 12).ok());
  auto mapped = MappedFile::open(path);
  REQUIRE(mapped.ok());
  CHECK((*mapped)->size() == 12);
  CHECK(std::string(reinterpret_cast<const char*>((*mapped)->data()), 12) == "mapped bytes");
  CHECK((*mapped)->path() == path);

  const std::string empty = dir.file("empty.bin");
  REQUIRE(write_file_atomic(empty, nullptr, 0).ok());
  auto empty_map = MappedFile::open(empty);
  REQUIRE(empty_map.ok());
  CHECK((*empty_map)->size() == 0);
  auto empty_rgs = RgsFile::open(empty);
  CHECK(empty_rgs.status().code() == StatusCode::kNotRgsFile);
  CHECK(empty_rgs.status().message().rfind(empty + ": ", 0) == 0);

  auto missing = MappedFile::open(dir.file("nope.rgs"));
  CHECK(missing.status().code() == StatusCode::kIoError);
  CHECK(missing.status().message() == dir.file("nope.rgs") + ": cannot open for reading: No such file or directory");
  auto directory = MappedFile::open(dir.path().string());
  CHECK(directory.status().code() == StatusCode::kIoError);
  CHECK(directory.status().message().find("is a directory") != std::string::npos);
  CHECK(RgsFile::open(dir.path().string()).status().code() == StatusCode::kIoError);

  // A FIFO is refused at once instead of blocking until a writer appears.
  const std::string fifo = dir.file("pipe");
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  auto piped = MappedFile::open(fifo);
  CHECK(piped.status().code() == StatusCode::kIoError);
  CHECK(piped.status().message().find("not a regular file") != std::string::npos);
}

TEST_CASE("write_scene_file: round trip through disk, and failures leave an existing file untouched") {
  TempDir dir;
  const std::string path = dir.file("scene.rgs");
  const EncodedScene scene = test::make_random_scene(64, 1, 77);
  auto written = write_scene_file(path, scene);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  CHECK(*written == fs::file_size(path));
  auto bytes = serialize_scene(scene);
  REQUIRE(bytes.ok());
  CHECK(test::read_file_bytes(path) == *bytes);
  auto file = RgsFile::open(path);
  REQUIRE(file.ok());
  test::check_same_scene(file->read_scene().value(), scene);

  EncodedScene broken = scene;
  broken.opacities.pop_back();
  auto failed = write_scene_file(path, broken);
  CHECK(failed.status().code() == StatusCode::kInvalidArgument);
  CHECK(failed.status().message().rfind(path + ": ", 0) == 0);
  CHECK(test::read_file_bytes(path) == *bytes);
  CHECK(dir.entries() == std::vector<std::string>{"scene.rgs"});

  auto unwritable = write_scene_file(dir.file("missing/scene.rgs"), scene);
  CHECK(unwritable.status().code() == StatusCode::kIoError);
  CHECK(unwritable.status().message().find(dir.file("missing/scene.rgs")) != std::string::npos);
}

namespace {

/// The temporary write_file_atomic uses for `name` in this process.
std::string partial_name(const std::string& name) {
  return name + "." + std::to_string(::getpid()) + rgs::format::kPartialSuffix;
}

bool contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

}  // namespace

TEST_CASE("write_file_atomic: the temporary is named <name>.<pid>.rgs-partial and registered for interrupts") {
  TempDir dir;
  const std::string path = dir.file("out.rgs");
  std::vector<std::string> during;
  REQUIRE(write_file_atomic(path, [&](const ChunkSink& sink) {
            during = dir.entries();
            return sink("x", 1);
          }).ok());
  CHECK(during == std::vector<std::string>{partial_name("out.rgs")});
  CHECK(dir.entries() == std::vector<std::string>{"out.rgs"});

  // An interrupt handler removes it (the rename then fails: nothing to rename).
  Status s = write_file_atomic(dir.file("second.rgs"), [&](const ChunkSink& sink) {
    RGS_RETURN_IF_ERROR(sink("y", 1));
    CHECK(contains(dir.entries(), partial_name("second.rgs")));
    remove_pending_temporaries();
    CHECK_FALSE(contains(dir.entries(), partial_name("second.rgs")));
    return Status();
  });
  CHECK(s.code() == StatusCode::kIoError);
  CHECK(dir.entries() == std::vector<std::string>{"out.rgs"});
}
