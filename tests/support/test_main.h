// The doctest main of every suite: it runs doctest and reports skips to CTest.
//
// A case skips by printing MESSAGE("skipped: <why>") (no CUDA device, a real scene of $RGS_DATA_DIR absent,
// ...). A case that printed such a line and made no assertion did nothing, and the run is reported as skipped:
// when every case that ran skipped (or none ran: a case excluded by doctest::skip(), a filter that matched
// nothing) and none failed, main() returns kSkipReturnCode, which rgs_add_test_suite() gives CTest as the
// tests' SKIP_RETURN_CODE. CTest runs one case per test (doctest_discover_tests), so each such case shows as
// "Skipped", not "Passed". A case that checked something and skipped a part of its work passes; its
// "skipped: ..." line stays in the log (scripts/run_tests.sh lists them). A run of several cases where some
// ran exits 0 as before. Include this header from exactly one source file of a suite.
#pragma once

#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include <cstring>

namespace rgs::test {

/// Exit status of a run whose cases all skipped (the Automake convention; tests/CMakeLists.txt).
constexpr int kSkipReturnCode = 77;

/// Counts the cases that ran and those of them that skipped (a "skipped: " message and no assertion).
class SkipListener : public doctest::IReporter {
 public:
  explicit SkipListener(const doctest::ContextOptions&) {}

  static int& cases_ended() {
    static int n = 0;
    return n;
  }
  static int& cases_skipped() {
    static int n = 0;
    return n;
  }

  void test_case_start(const doctest::TestCaseData&) override { said_skipped_ = false; }
  void log_message(const doctest::MessageData& message) override {
    if (std::strncmp(message.m_string.c_str(), "skipped: ", 9) == 0) said_skipped_ = true;
  }
  void test_case_end(const doctest::CurrentTestCaseStats& stats) override {
    ++cases_ended();
    if (said_skipped_ && stats.testCaseSuccess && stats.numAssertsCurrentTest == 0) ++cases_skipped();
  }

  void report_query(const doctest::QueryData&) override {}
  void test_run_start() override {}
  void test_run_end(const doctest::TestRunStats&) override {}
  void test_case_reenter(const doctest::TestCaseData&) override {}
  void test_case_exception(const doctest::TestCaseException&) override {}
  void subcase_start(const doctest::SubcaseSignature&) override {}
  void subcase_end() override {}
  void log_assert(const doctest::AssertData&) override {}
  void test_case_skipped(const doctest::TestCaseData&) override {}

 private:
  bool said_skipped_ = false;
};

REGISTER_LISTENER("rgs_skips", 1, SkipListener);

}  // namespace rgs::test

int main(int argc, char** argv) {
  doctest::Context context(argc, argv);
  const int result = context.run();
  if (result != 0 || context.shouldExit()) return result;  // failures, or a query such as --list-test-cases
  using rgs::test::SkipListener;
  return SkipListener::cases_skipped() == SkipListener::cases_ended() ? rgs::test::kSkipReturnCode : 0;
}
