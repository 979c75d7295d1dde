// format::OutputTransaction: outputs appear together at commit, a failed or interrupted run changes nothing and
// leaves nothing (files and folders), identities (an output is never an input or another output), and the
// temporaries of killed runs.
#include <doctest/doctest.h>

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
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
#include "rgs/format/output_transaction.h"
#include "rgs/format/writer.h"

namespace {

namespace fs = std::filesystem;
using namespace rgs;
using namespace rgs::format;
using test::TempDir;
using test::slurp;

/// The temporary a StagedFile uses for `name` in this process.
std::string partial_name(const std::string& name) {
  return name + "." + std::to_string(::getpid()) + rgs::format::kPartialSuffix;
}

/// A process id that no longer exists: a child that has exited and been reaped.
pid_t dead_pid() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  int status = 0;
  ::waitpid(child, &status, 0);
  return child;
}

bool contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

}  // namespace

TEST_CASE("OutputTransaction: outputs appear together at commit, never before") {
  TempDir dir;
  const std::string a = dir.file("a.rgs"), b = dir.file("b.json");
  REQUIRE(write_file_atomic(b, "old json", 8).ok());
  {
    OutputTransaction set;
    REQUIRE(set.add_output(a).ok());
    REQUIRE(set.add_output(b).ok());
    CHECK(set.remove_stale_temporaries().empty());
    REQUIRE(set.write(a, "scene", 5).ok());
    REQUIRE(set.write(b, "new json", 8).ok());
    CHECK_FALSE(fs::exists(a));
    CHECK(slurp(b) == "old json");
    CHECK(contains(dir.entries(), partial_name("a.rgs")));
    CHECK(contains(dir.entries(), partial_name("b.json")));
    REQUIRE(set.commit().ok());
    CHECK(set.write(a, "again", 5).code() == StatusCode::kInvalidArgument);  // closed
  }
  CHECK(slurp(a) == "scene");
  CHECK(slurp(b) == "new json");
  std::vector<std::string> names = dir.entries();
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{"a.rgs", "b.json"});
}

TEST_CASE("OutputTransaction: a run that fails after staging changes nothing") {
  TempDir dir;
  const std::string a = dir.file("a.rgs"), b = dir.file("b.json");
  REQUIRE(write_file_atomic(a, "old scene", 9).ok());
  {
    OutputTransaction set;
    REQUIRE(set.add_output(a).ok());
    REQUIRE(set.add_output(b).ok());
    REQUIRE(set.write(a, "new scene", 9).ok());
    // The second output fails (a full disk, a failed serialization): the tool returns without commit().
    Status s = set.write(b, [](const ChunkSink& sink) {
      RGS_RETURN_IF_ERROR(sink("{", 1));
      return Status(StatusCode::kIoError, "No space left on device");
    });
    CHECK(s.code() == StatusCode::kIoError);
    CHECK(set.write(dir.file("undeclared"), "x", 1).code() == StatusCode::kInvalidArgument);
  }
  CHECK(slurp(a) == "old scene");
  CHECK(dir.entries() == std::vector<std::string>{"a.rgs"});
}

TEST_CASE("OutputTransaction: a library writer given the set stages into it, others write in place") {
  TempDir dir;
  const std::string rgs = dir.file("scene.rgs");
  const EncodedScene scene = test::make_random_scene(16, 0, 5);
  OutputTransaction set;
  REQUIRE(set.add_output(rgs).ok());
  auto written = write_scene_file(rgs, scene, {}, set);
  REQUIRE_MESSAGE(written.ok(), written.status().to_string());
  CHECK_FALSE(fs::exists(rgs));
  CHECK(dir.entries() == std::vector<std::string>{partial_name("scene.rgs")});
  REQUIRE(atomic_files().write_by_name(dir.file("by_name.bin"), [](const std::string& temp) {
            std::ofstream(temp, std::ios::binary) << "named";
            return Status();
          }).ok());  // not given the set: committed at once
  CHECK(slurp(dir.file("by_name.bin")) == "named");
  REQUIRE(set.commit().ok());
  CHECK(fs::file_size(rgs) == *written);
}

TEST_CASE("OutputTransaction: an output may not be an input or another output, whatever path names it") {
  TempDir dir;
  const std::string input = dir.file("in.ply");
  REQUIRE(write_file_atomic(input, "ply", 3).ok());
  fs::create_directory(dir.file("sub"));
  fs::create_hard_link(input, dir.file("hard.ply"));
  fs::create_symlink(input, dir.file("soft.ply"));
  fs::create_directory_symlink(dir.path(), dir.file("again"));

  OutputTransaction set;
  REQUIRE(set.add_input(input).ok());
  CHECK(set.add_input(dir.file("missing.ply")).ok());  // its reader reports it
  for (const std::string& alias : {input, dir.file("hard.ply"), dir.file("soft.ply"), dir.file("sub/../in.ply"),
                                   dir.file("again/in.ply")}) {
    Status s = set.add_output(alias);
    CHECK_MESSAGE(s.code() == StatusCode::kInvalidArgument, alias);
    CHECK_MESSAGE(s.message().find("is the input file") != std::string::npos, s.message());
  }
  // Two outputs that do not exist yet, named differently.
  REQUIRE(set.add_output(dir.file("out.json")).ok());
  Status twice = set.add_output(dir.file("sub/../out.json"));
  CHECK(twice.code() == StatusCode::kInvalidArgument);
  CHECK_MESSAGE(twice.message().find("is also the output " + dir.file("out.json")) != std::string::npos,
                twice.message());
  CHECK(set.add_output(dir.file("again/out.json")).code() == StatusCode::kInvalidArgument);
  // An input declared after the output it would be.
  REQUIRE(set.add_output(dir.file("late.rgs")).ok());
  REQUIRE(write_file_atomic(dir.file("late_src"), "x", 1).ok());
  fs::rename(dir.file("late_src"), dir.file("late.rgs"));
  OutputTransaction late;
  REQUIRE(late.add_output(dir.file("late.rgs")).ok());
  CHECK(late.add_input(dir.file("late.rgs")).code() == StatusCode::kInvalidArgument);

  // Devices and pipes would be replaced by the rename, not written; directories cannot be replaced.
  CHECK(set.add_output("/dev/null").code() == StatusCode::kInvalidArgument);
  REQUIRE(::mkfifo(dir.file("pipe").c_str(), 0600) == 0);
  CHECK(set.add_output(dir.file("pipe")).code() == StatusCode::kInvalidArgument);
  CHECK(set.add_output(dir.file("sub")).code() == StatusCode::kIoError);
  CHECK(set.add_output("").code() == StatusCode::kInvalidArgument);
  CHECK(set.add_output(dir.file("sub/")).code() == StatusCode::kIoError);
  CHECK(slurp(input) == "ply");
}

TEST_CASE("OutputTransaction: temporaries of killed runs are removed once their process is gone") {
  TempDir dir;
  const std::string out = dir.file("out.rgs");
  const std::string stale = "out.rgs." + std::to_string(dead_pid()) + kPartialSuffix;
  const std::string stale_second = "out.rgs." + std::to_string(dead_pid()) + "-1" + kPartialSuffix;
  const std::string alive = "out.rgs." + std::to_string(::getppid()) + kPartialSuffix;
  const std::string other = "other.rgs." + std::to_string(dead_pid()) + kPartialSuffix;
  const std::string not_ours = "out.rgs.backup" + std::string(kPartialSuffix);
  for (const std::string& name : {stale, stale_second, alive, other, not_ours}) {
    REQUIRE(write_file_atomic(dir.file(name), "partial", 7).ok());
  }
  OutputTransaction set;
  REQUIRE(set.add_output(out).ok());
  const std::vector<std::string> notes = set.remove_stale_temporaries();
  std::string all;
  for (const std::string& n : notes) all += n + "\n";
  CHECK_MESSAGE(notes.size() == 3, all);
  CHECK_MESSAGE(all.find("removed " + dir.file(stale) + ", left by an interrupted run") != std::string::npos, all);
  CHECK_MESSAGE(all.find("removed " + dir.file(stale_second)) != std::string::npos, all);
  CHECK_MESSAGE(all.find(dir.file(alive) + " belongs to process " + std::to_string(::getppid()) +
                         ", which is still running") != std::string::npos, all);
  CHECK_FALSE(fs::exists(dir.file(stale)));
  CHECK_FALSE(fs::exists(dir.file(stale_second)));
  CHECK(fs::exists(dir.file(alive)));
  CHECK(fs::exists(dir.file(other)));     // another output's
  CHECK(fs::exists(dir.file(not_ours)));  // no process id in the name

  // A same-named file that is an input of the run is never removed.
  const std::string input_like = "in.rgs." + std::to_string(dead_pid()) + kPartialSuffix;
  REQUIRE(write_file_atomic(dir.file(input_like), "input", 5).ok());
  OutputTransaction second;
  REQUIRE(second.add_input(dir.file(input_like)).ok());
  REQUIRE(second.add_output(dir.file("in.rgs")).ok());
  const auto kept = second.remove_stale_temporaries();
  REQUIRE(kept.size() == 1);
  CHECK(kept[0].find("is an input of this one; left in place") != std::string::npos);
  CHECK(slurp(dir.file(input_like)) == "input");
}

TEST_CASE("OutputTransaction: writers declare what they find they must write, with the same checks") {
  TempDir dir;
  const std::string input = dir.file("in.ply"), out = dir.file("out.rgs");
  REQUIRE(write_file_atomic(input, "ply", 3).ok());
  fs::create_directory_symlink(dir.path(), dir.file("again"));
  OutputTransaction set;
  REQUIRE(set.add_input(input).ok());
  REQUIRE(set.add_input(dir.file("again/in.ply")).ok());  // the same input twice: harmless
  REQUIRE(set.add_output(out).ok());
  CHECK(set.declare({out, dir.file("again/out.rgs")}).ok());  // declared already, in any spelling
  CHECK(set.declare({dir.file("more.json")}).ok());
  CHECK(set.has_output(dir.file("more.json")));
  const Status refused = set.declare({dir.file("chunk.json"), dir.file("again/in.ply")});
  CHECK(refused.code() == StatusCode::kInvalidArgument);
  CHECK_MESSAGE(refused.message().find("is the input file") != std::string::npos, refused.message());
  CHECK(set.write(dir.file("again/in.ply"), "x", 1).code() == StatusCode::kInvalidArgument);
  CHECK(slurp(input) == "ply");
}

TEST_CASE("OutputTransaction: folders it created go when it is not committed, stay when it is") {
  TempDir dir;
  fs::create_directory(dir.file("existing"));
  const std::string nested = dir.file("new/deeper/leaf");
  {
    OutputTransaction set;
    REQUIRE(set.create_folder(nested).ok());
    REQUIRE(set.create_folder(dir.file("existing")).ok());
    REQUIRE(set.add_output(nested + "/a.json").ok());
    REQUIRE(set.write(nested + "/a.json", "{}", 2).ok());
    CHECK(fs::is_directory(nested));
  }  // failed run: not committed
  CHECK_FALSE(fs::exists(dir.file("new")));
  CHECK(fs::is_directory(dir.file("existing")));
  {
    OutputTransaction set;
    REQUIRE(set.create_folder(nested).ok());
    REQUIRE(set.add_output(nested + "/a.json").ok());
    REQUIRE(set.write(nested + "/a.json", "{}", 2).ok());
    REQUIRE(set.commit().ok());
  }
  CHECK(slurp(nested + "/a.json") == "{}");
  REQUIRE(write_file_atomic(dir.file("plain"), "x", 1).ok());
  OutputTransaction set;
  CHECK(set.create_folder(dir.file("plain/sub")).code() == StatusCode::kIoError);
}

TEST_CASE("OutputTransaction: replaced() names the outputs that existed and were replaced") {
  TempDir dir;
  const std::string old_file = dir.file("old.rgs"), new_file = dir.file("new.json"), unwritten = dir.file("x.png");
  REQUIRE(write_file_atomic(old_file, "old", 3).ok());
  REQUIRE(write_file_atomic(unwritten, "keep", 4).ok());
  OutputTransaction set;
  for (const std::string& path : {old_file, new_file, unwritten}) REQUIRE(set.add_output(path).ok());
  REQUIRE(set.write(old_file, "new", 3).ok());
  REQUIRE(set.write(new_file, "{}", 2).ok());
  CHECK(set.replaced().empty());
  REQUIRE(set.commit().ok());
  CHECK(set.replaced() == std::vector<std::string>{old_file});
  CHECK(slurp(unwritten) == "keep");
}

namespace {
void remove_and_exit(int) {
  remove_pending_temporaries();
  ::_exit(0);
}
}  // namespace

TEST_CASE("OutputTransaction: an interrupt removes its temporaries and the folders it created") {
  TempDir dir;
  REQUIRE(write_file_atomic(dir.file("kept.json"), "old", 3).ok());
  const pid_t child = ::fork();
  if (child == 0) {
    ::signal(SIGTERM, remove_and_exit);
    OutputTransaction set;
    const std::string folder = dir.file("0_0/inner");
    const bool ok = set.create_folder(folder).ok() && set.add_output(folder + "/meta.json").ok() &&
                    set.add_output(dir.file("kept.json")).ok() && set.write(folder + "/meta.json", "{}", 2).ok() &&
                    set.write(dir.file("kept.json"), "new", 3).ok();
    if (!ok) ::_exit(3);
    ::raise(SIGTERM);  // as the tools' handler does: remove_pending_temporaries(), then end
    ::_exit(4);
  }
  int status = 0;
  REQUIRE(::waitpid(child, &status, 0) == child);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  CHECK(dir.entries() == std::vector<std::string>{"kept.json"});
  CHECK(slurp(dir.file("kept.json")) == "old");
}
