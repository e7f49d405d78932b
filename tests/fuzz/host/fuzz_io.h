// Shared by the host-parser fuzz targets: the parsers under test take paths (as the CLI hands them
// files), so each input is written to a private scratch file first; and the one rule every target
// enforces on a refusal: it must be an input error (io::is_input_error), which the CLI turns into exit
// code 2 with one message, never another exception type (exit 1) and never a crash.
#pragma once
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "host/io/input_error.h"

namespace fuzzio {

inline std::string scratch(const char* tag) {
  static const std::string dir = [] {
    return access("/dev/shm", W_OK) == 0 ? std::string("/dev/shm") : std::string("/tmp");
  }();
  return dir + "/imuforge-fuzz-" + std::to_string(getpid()) + "-" + tag;
}

inline std::string write_file(const char* tag, const std::uint8_t* data, std::size_t size) {
  const std::string p = scratch(tag);
  std::FILE* f = std::fopen(p.c_str(), "wb");
  if (f == nullptr) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return p;
}

// A refusal that is not an input error: report it and stop (libFuzzer keeps the input as a crash).
[[noreturn]] inline void wrong_refusal(const std::exception& e) {
  std::fprintf(stderr, "refused with an exception that is not an input error (CLI exit 1, not 2): %s\n", e.what());
  std::abort();
}

inline void check_refusal(const std::exception& e) {
  if (!imuforge::io::is_input_error(e)) wrong_refusal(e);
}

#define FUZZ_CHECK(cond)                                                        \
  do {                                                                          \
    if (!(cond)) {                                                              \
      std::fprintf(stderr, "%s:%d: invariant failed: %s\n", __FILE__, __LINE__, #cond); \
      std::abort();                                                             \
    }                                                                           \
  } while (0)

}  // namespace fuzzio
