// cli_common: the escaping every tool applies to bytes from files and arguments before printing them, the
// error line of report_error (a NUL no longer cuts it short and drops the error code), counts and view names.
#include <doctest/doctest.h>

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "cli_common.h"

using rgs::Status;
using rgs::StatusCode;
using rgs::tools::escape_text;

TEST_CASE("escape_text: control bytes, C1 controls, bidi overrides and invalid UTF-8 are escaped") {
  CHECK(escape_text("plain scene.ply") == "plain scene.ply");
  CHECK(escape_text(std::string("a\0b", 3)) == "a\\x00b");
  CHECK(escape_text("\x1b[31mred\x1b[0m") == "\\x1b[31mred\\x1b[0m");
  CHECK(escape_text("line\nbreak\ttab\x7f") == "line\\x0abreak\\x09tab\\x7f");
  CHECK(escape_text("\xc2\x9b" "2J") == "\\u009b2J");               // C1 CSI encoded in UTF-8
  CHECK(escape_text("\x9b" "2J") == "\\x9b2J");                     // raw 8-bit CSI: not UTF-8
  CHECK(escape_text("evil\xe2\x80\xaetxt.ply") == "evil\\u202etxt.ply");  // right-to-left override
  CHECK(escape_text("caf\xc3\xa9 \xe6\x97\xa5\xf0\x9f\x98\x80") == "caf\xc3\xa9 \xe6\x97\xa5\xf0\x9f\x98\x80");
  CHECK(escape_text("\xc0\xaf") == "\\xc0\\xaf");                   // overlong '/'
  CHECK(escape_text("\xed\xa0\x80") == "\\xed\\xa0\\x80");          // surrogate
  CHECK(escape_text("cut\xe6\x97") == "cut\\xe6\\x97");             // truncated sequence
}

TEST_CASE("report_error: the whole message and its code reach stderr, escaped") {
  std::FILE* capture = std::tmpfile();
  REQUIRE(capture != nullptr);
  std::fflush(stderr);
  const int saved = ::dup(STDERR_FILENO);
  REQUIRE(::dup2(::fileno(capture), STDERR_FILENO) >= 0);
  const int code = rgs::tools::report_error("rgs-test", Status(StatusCode::kCorruptData,
                                                               std::string("name\0\x1b]0;pwned\x07 tail", 20)));
  std::fflush(stderr);
  ::dup2(saved, STDERR_FILENO);
  ::close(saved);
  std::rewind(capture);
  char buffer[256] = {};
  const size_t n = std::fread(buffer, 1, sizeof(buffer) - 1, capture);
  std::fclose(capture);
  CHECK(code == rgs::tools::kExitFailure);
  CHECK(std::string(buffer, n) == "rgs-test: error: name\\x00\\x1b]0;pwned\\x07 tail [kCorruptData]\n");
}

TEST_CASE("file_safe_names and group_digits") {
  using rgs::group_digits;
  // A name an earlier one already has gets its index, also when that name itself was made so.
  const std::vector<std::string> names = {"a/b\\c", "", "..", "a_b_c", "a_b_c_3"};
  CHECK(rgs::tools::file_safe_names(names) ==
        std::vector<std::string>{"a_b_c", "view_001", "view_2", "a_b_c_3", "a_b_c_3_4"});
  CHECK(group_digits(0) == "0");
  CHECK(group_digits(999) == "999");
  CHECK(group_digits(1000) == "1,000");
  CHECK(group_digits(2725620000) == "2,725,620,000");
  CHECK(group_digits(-1234) == "-1,234");
  CHECK(group_digits(-999) == "-999");
  CHECK(group_digits(INT64_MIN) == "-9,223,372,036,854,775,808");
}

TEST_CASE("parse_whole_number: decimal digits alone, nothing that wraps or saturates") {
  using rgs::tools::parse_whole_number;
  constexpr uint64_t kMax = UINT64_MAX;
  CHECK(*parse_whole_number("1", 1, kMax) == 1);
  CHECK(*parse_whole_number("18446744073709551615", 1, kMax) == kMax);
  CHECK(*parse_whole_number("007", 1, kMax) == 7);
  for (const char* bad : {"", "0", "-1", "+5", "18446744073709551616", "99999999999999999999", "5e21", "1e3",
                          "1.5", " 5", "5 ", "0x10", "nan", "inf"}) {
    CAPTURE(bad);
    const auto parsed = parse_whole_number(bad, 1, kMax);
    REQUIRE_FALSE(parsed.ok());
    CHECK(parsed.status().code() == StatusCode::kInvalidArgument);
    CHECK(parsed.status().message().find("1..18446744073709551615") != std::string::npos);
  }
  CHECK_FALSE(parse_whole_number("11", 1, 10).ok());
}

TEST_CASE("finite_number_in and whole_number_in: NaN, infinities and out-of-range values are refused") {
  CLI::Validator finite = rgs::tools::finite_number_in(1.0, 200.0);
  for (std::string good : {"1", "40", "200", "3.5e1"}) {
    CAPTURE(good);
    CHECK(finite(good).empty());
  }
  for (std::string bad : {"nan", "NaN", "-nan", "inf", "-inf", "0.5", "201", "x"}) {
    CAPTURE(bad);
    CHECK(finite(bad).find("is not a finite number in [1, 200]") != std::string::npos);
  }
  CLI::Validator whole = rgs::tools::whole_number_in(1, 100);
  std::string ok = "100", negative = "-1";
  CHECK(whole(ok).empty());
  CHECK_FALSE(whole(negative).empty());
}

TEST_CASE("nearest_option and parse_command_line: an unknown option's error names the option it is nearest to") {
  using rgs::tools::nearest_option;
  CLI::App app("test");
  bool filter_nan = false;
  double scale = 1;
  std::string levels;
  app.add_flag("--filter-nan", filter_nan, "");
  app.add_option("--scale", scale, "");
  app.add_option("--lod-levels", levels, "");
  CHECK(nearest_option(app, "--filtr-nan") == "--filter-nan");
  CHECK(nearest_option(app, "-filter-nan") == "--filter-nan");
  CHECK(nearest_option(app, "--scael=2") == "--scale");
  CHECK(nearest_option(app, "--lod-level") == "--lod-levels");
  CHECK(nearest_option(app, "--hlep") == "--help");
  CHECK(nearest_option(app, "--colour").empty());  // nothing near it
  CHECK(nearest_option(app, "scale").empty());     // not an option
  std::FILE* capture = std::tmpfile();
  REQUIRE(capture != nullptr);
  std::fflush(stderr);
  const int saved = ::dup(STDERR_FILENO);
  REQUIRE(::dup2(::fileno(capture), STDERR_FILENO) >= 0);
  const char* argv[] = {"rgs-test", "--scale", "2", "--filtr-nan"};
  const auto code = rgs::tools::parse_command_line(app, 4, const_cast<char**>(argv), "rgs-test");
  std::fflush(stderr);
  ::dup2(saved, STDERR_FILENO);
  ::close(saved);
  std::rewind(capture);
  char buffer[512] = {};
  const size_t n = std::fread(buffer, 1, sizeof(buffer) - 1, capture);
  std::fclose(capture);
  CHECK(code == rgs::tools::kExitUsage);
  CHECK_MESSAGE(std::string(buffer, n).find("--filtr-nan: did you mean --filter-nan?") != std::string::npos,
                std::string(buffer, n));
}
