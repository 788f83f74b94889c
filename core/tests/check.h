// check.h: the C++ tests' one assertion macro. A failed CHECK prints where
// and what and is counted; the test goes on, and main() returns
// check_summary("name"), non-zero when anything failed. One header per
// test executable (each test is its own program, so `failures` is its own).
#pragma once

#include <cstdio>

static int failures = 0;

#define CHECK(cond)                                                                        \
    do {                                                                                   \
        if (!(cond)) {                                                                     \
            std::fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
            ++failures;                                                                    \
        }                                                                                  \
    } while (0)

/// Prints the test's verdict; returns the exit status (0 iff nothing failed).
inline int check_summary(const char* name) {
    if (failures) {
        std::fprintf(stderr, "%s: %d failure(s)\n", name, failures);
        return 1;
    }
    std::printf("%s: all checks passed\n", name);
    return 0;
}
