// Property checks inside fuzz targets: a failed check is reported like a crash (libFuzzer keeps the input),
// with the message and the Status that broke the property.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>

#define RGS_FUZZ_CHECK(cond, what)                                                       \
  do {                                                                                   \
    if (!(cond)) {                                                                       \
      std::fprintf(stderr, "%s:%d: fuzz property failed: %s\n  %s\n", __FILE__, __LINE__, \
                   #cond, std::string(what).c_str());                                    \
      std::abort();                                                                      \
    }                                                                                    \
  } while (false)
