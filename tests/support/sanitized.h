// RGS_TEST_SANITIZED: defined to 1 in a build with AddressSanitizer, ThreadSanitizer or MemorySanitizer
// (RGS_SANITIZE=ON, the fuzz build), where a test may check memory limits differently or run its costliest
// part on fewer inputs, saying so with a "skipped: " line.
#pragma once

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define RGS_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define RGS_TEST_SANITIZED 1
#endif
#endif

namespace rgs::test {
#ifdef RGS_TEST_SANITIZED
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
}  // namespace rgs::test
