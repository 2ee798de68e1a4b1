#pragma once
/// \file
/// RED_ASSERT: checks programming errors. It stays on in every build (tests included);
/// a failed assertion prints the condition and location and aborts.

#include <cstdio>
#include <cstdlib>

#define RED_ASSERT(cond)                                                                 \
  do {                                                                                   \
    if (!(cond)) [[unlikely]] {                                                          \
      std::fprintf(stderr, "%s:%d: RED_ASSERT(%s) failed\n", __FILE__, __LINE__, #cond); \
      std::abort();                                                                      \
    }                                                                                    \
  } while (false)
