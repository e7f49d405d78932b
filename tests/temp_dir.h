// Test helper: a private directory under /tmp for a test's files (pty links, tables, virtual CAN buses), removed
// with everything in it when the object goes, whether the test passed or not. No gtest dependency: benchmarks
// use it too.
#pragma once
#include <stdlib.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>

namespace imuforge::testing {

struct TempDir {
  std::string path;
  // prefix: the directory's name before mkdtemp's six random characters, e.g. "imuforge-modbus-".
  explicit TempDir(const std::string& prefix) {
    std::string t = "/tmp/" + prefix + "XXXXXX";
    if (!::mkdtemp(t.data())) throw std::runtime_error("mkdtemp " + t + ": " + std::strerror(errno));
    path = t;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

}  // namespace imuforge::testing
