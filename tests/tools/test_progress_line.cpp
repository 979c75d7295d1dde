// progress_line: the text of rgs-convert's progress line (stage, percent, time left) and how it is drawn:
// nothing in the first second or when disabled, redrawn in place with carriage returns, blanked at the end.
#include <doctest/doctest.h>

#include <cstdio>
#include <string>

#include "progress_line.h"

using rgs::api::ConvertProgress;
using rgs::tools::duration_text;
using rgs::tools::progress_text;
using rgs::tools::ProgressLine;
using rgs::tools::seconds_left;

namespace {

/// Everything written to `file` so far.
std::string contents(std::FILE* file) {
  std::fflush(file);
  std::string text;
  std::rewind(file);
  for (int c; (c = std::fgetc(file)) != EOF;) text.push_back(static_cast<char>(c));
  return text;
}

}  // namespace

TEST_CASE("duration_text: seconds, minutes and hours, rounded") {
  CHECK(duration_text(0.2) == "<1 s");
  CHECK(duration_text(-3) == "<1 s");
  CHECK(duration_text(1.0) == "1 s");
  CHECK(duration_text(7.4) == "7 s");
  CHECK(duration_text(59.4) == "59 s");
  CHECK(duration_text(59.6) == "1 min 00 s");
  CHECK(duration_text(125) == "2 min 05 s");
  CHECK(duration_text(3725) == "1 h 02 min");
}

TEST_CASE("progress_text and seconds_left: stage, percent rounded down, time left from the fraction done") {
  CHECK(progress_text("reading", 0.0, std::nullopt) == "reading 0%");
  CHECK(progress_text("quantizing", 0.5, 3.0) == "quantizing 50%, about 3 s left");
  CHECK(progress_text("writing", 0.999, 0.1) == "writing 99%, about <1 s left");
  CHECK(progress_text("writing", 1.5, std::nullopt) == "writing 100%");
  CHECK(progress_text("writing", -1, std::nullopt) == "writing 0%");

  CHECK(!seconds_left(0.0, 5.0, 5.0));  // nothing done yet: no estimate
  CHECK(*seconds_left(0.25, 2.0, 2.0) == doctest::Approx(6.0));
  CHECK(*seconds_left(0.25, 2.0, 5.0) == doctest::Approx(3.0));  // counts down between reports
  CHECK(!seconds_left(0.25, 2.0, 9.0));                          // the estimate ran out
  CHECK(*seconds_left(1.0, 4.0, 4.0) == doctest::Approx(0.0));
}

TEST_CASE("ProgressLine: silent for the first second, then redrawn in place, blanked when done") {
  std::FILE* file = std::tmpfile();
  REQUIRE(file != nullptr);
  {
    ProgressLine line(file, "rgs-convert", true, 1.0, false);
    line.update(ConvertProgress{"reading", 0.0}, 0.1);
    line.update(ConvertProgress{"quantizing", 0.5}, 0.9);
    CHECK(contents(file).empty());
    line.update(ConvertProgress{"writing", 0.9}, 1.8);
    const std::string first = "\rrgs-convert: writing 90%, about <1 s left";
    CHECK(contents(file) == first);
    line.update(ConvertProgress{"encoding the archive", 0.9}, 1.9);
    const std::string second = "\rrgs-convert: encoding the archive 90%, about <1 s left";
    CHECK(contents(file) == first + second);
    line.update(ConvertProgress{"writing", 0.95}, 2.0);  // shorter: padded over the longer line before
    const std::string third_text = "rgs-convert: writing 95%, about <1 s left";
    const std::string third = "\r" + third_text + std::string(second.size() - 1 - third_text.size(), ' ');
    CHECK(contents(file) == first + second + third);
    line.update(ConvertProgress{"done", 1.0}, 2.1);
    const std::string blank = "\r" + std::string(third_text.size(), ' ') + "\r";  // the padding is blank already
    CHECK(contents(file) == first + second + third + blank);
    line.update(ConvertProgress{"writing", 0.5}, 3.0);  // nothing after the end
  }
  CHECK(contents(file).size() > 0);
  CHECK(contents(file).back() == '\r');
  std::fclose(file);
}

TEST_CASE("ProgressLine: disabled (-q, or stderr not a terminal) it writes nothing") {
  std::FILE* file = std::tmpfile();
  REQUIRE(file != nullptr);
  {
    ProgressLine line(file, "rgs-convert", false, 1.0);
    line.update(ConvertProgress{"quantizing", 0.5}, 5.0);
    line.update(ConvertProgress{"done", 1.0}, 6.0);
  }
  CHECK(contents(file).empty());
  std::fclose(file);
}
