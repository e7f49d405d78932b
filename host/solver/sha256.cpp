#include "host/solver/sha256.h"

#include <cstdio>
#include <cstring>
#include <memory>

#include "host/solver/estimate.h"

namespace imuforge::solver {

std::array<std::uint8_t, 32> Sha256::finish() {
  std::array<std::uint8_t, 32> d{};
  fw::sha256_final(state_, d.data());
  return d;
}

std::string Sha256::hex(const std::array<std::uint8_t, 32>& d) {
  static const char* x = "0123456789abcdef";
  std::string s;
  for (auto b : d) { s += x[b >> 4]; s += x[b & 15]; }
  return s;
}

std::string sha256_file_hex(const std::string& path) {
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) throw SolverError("cannot read '" + path + "' to hash it");
  Sha256 h;
  std::array<char, 1 << 16> buf;
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), f.get())) > 0) h.update(buf.data(), n);
  if (std::ferror(f.get())) throw SolverError("read error while hashing '" + path + "'");
  return Sha256::hex(h.finish());
}

}  // namespace imuforge::solver
