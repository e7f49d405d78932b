// SHA-256 (FIPS 180-4) for the provenance of cal.json: the log's hash, streamed so a 1-hour log never
// sits in memory. A host-side face on the firmware's implementation (firmware/crypto/sha256.h), so the
// project has one SHA-256, the one the CAN node's HMAC relies on.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "firmware/crypto/sha256.h"

namespace imuforge::solver {

class Sha256 {
 public:
  Sha256() { fw::sha256_init(state_); }
  void update(const void* data, std::size_t len) { fw::sha256_update(state_, data, len); }
  std::array<std::uint8_t, 32> finish();
  static std::string hex(const std::array<std::uint8_t, 32>& d);

 private:
  fw::Sha256 state_{};
};

// Hex SHA-256 of a whole file; throws SolverError if it cannot be read.
std::string sha256_file_hex(const std::string& path);

}  // namespace imuforge::solver
