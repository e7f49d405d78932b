// SHA-256 (FIPS 180-4) for the provenance of cal.json: the log's hash, streamed so a 1-hour log never
// sits in memory.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

namespace imuforge::solver {

class Sha256 {
 public:
  Sha256();
  void update(const void* data, std::size_t len);
  std::array<std::uint8_t, 32> finish();
  static std::string hex(const std::array<std::uint8_t, 32>& d);

 private:
  void block(const std::uint8_t* p);
  std::array<std::uint32_t, 8> h_;
  std::array<std::uint8_t, 64> buf_{};
  std::size_t used_ = 0;
  std::uint64_t total_ = 0;
};

// Hex SHA-256 of a whole file; throws SolverError if it cannot be read.
std::string sha256_file_hex(const std::string& path);

}  // namespace imuforge::solver
