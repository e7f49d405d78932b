// Writes seed inputs for the fuzzers (valid tables, valid command scripts, ISO-TP frame scripts), so
// the bounded fuzz runs start from deep states instead of random bytes. Host g++ program.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "firmware/can_node/protocol.h"
#include "firmware/common/endian.h"
#include "firmware/table/table.h"

using namespace imuforge;
using namespace imuforge::fw;

static void put(const std::string& path, const std::vector<std::uint8_t>& b) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return;
  std::fwrite(b.data(), 1, b.size(), f);
  std::fclose(f);
}

static std::vector<std::uint8_t> table(std::uint64_t serial, std::uint32_t seq, int n) {
  static Table t;
  table_init_identity(&t, 0.0024f, 0.0005f, 16, 16);
  t.device_serial = serial;
  t.table_sequence = seq;
  if (n > 1) {
    t.model_flags |= kModelTemperature;
    t.n_breakpoints = static_cast<std::uint8_t>(n);
    for (int i = 0; i < n; ++i) {
      t.breakpoints_degC[i] = -40.0f + 10.0f * static_cast<float>(i);
      t.coeffs[i] = t.coeffs[0];
    }
  }
  std::vector<std::uint8_t> b(kTableMaxSize);
  const int k = table_serialize(&t, b.data(), b.size());
  b.resize(k > 0 ? static_cast<std::size_t>(k) : 0);
  return b;
}

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: seedgen TABLE_DIR ISOTP_DIR COMMAND_DIR\n");
    return 2;
  }
  const std::string td = argv[1], id = argv[2], cd = argv[3];
  put(td + "/t1", table(1, 1, 1));
  put(td + "/t4", table(2, 9, 4));
  put(td + "/t16", table(3, 5, 16));
  // command script: identify, write(seq 1, signed by harness), commit 1, read, status, reboot-flag
  std::vector<std::uint8_t> s;
  auto add = [&](std::vector<std::uint8_t> r, std::uint8_t flags) {
    s.push_back(static_cast<std::uint8_t>(r.size()));
    s.push_back(static_cast<std::uint8_t>(r.size() >> 8));
    s.push_back(flags);
    s.insert(s.end(), r.begin(), r.end());
  };
  add({proto::kCmdIdentify}, 0);
  for (std::uint32_t seq : {1u, 2u}) {
    const auto t = table(99, seq, seq == 1 ? 1 : 3);
    std::vector<std::uint8_t> w(proto::kWriteHeaderBytes + t.size());
    w[0] = proto::kCmdWriteTable;
    store_le32(w.data() + 1, seq);
    std::memcpy(w.data() + proto::kWriteHeaderBytes, t.data(), t.size());
    add(w, 1);
    add({proto::kCmdCommit, static_cast<std::uint8_t>(seq), 0, 0, 0}, seq == 1 ? 2 : 0);
  }
  add({proto::kCmdReadTable}, 0);
  add({proto::kCmdStatus}, 0);
  add({proto::kCmdStreamStart, 0xE8, 0x03, 7}, 0);
  add({proto::kCmdStreamStop}, 0);
  add({proto::kCmdStreamStart, 0xE8, 0x03, 7, proto::kStreamFlagFd}, 0);  // CAN FD stream
  add({proto::kCmdStatus}, 0);
  add({proto::kCmdStreamStop}, 0);
  put(cd + "/script", s);
  // ISO-TP: FF of 20 bytes + 2 CFs; and an SF
  std::vector<std::uint8_t> f = {0};
  auto frame = [&](std::uint8_t dt, std::vector<std::uint8_t> d) {
    f.push_back(dt);
    f.push_back(0);
    f.push_back(8);
    d.resize(8, 0xCC);
    f.insert(f.end(), d.begin(), d.end());
  };
  frame(0, {0x10, 20, 1, 2, 3, 4, 5, 6});
  frame(1, {0x21, 7, 8, 9, 10, 11, 12, 13});
  frame(1, {0x22, 14, 15, 16, 17, 18, 19, 20});
  frame(1, {0x03, 1, 2, 3});
  frame(1, {0x30, 0, 0});
  put(id + "/frames", f);
  return 0;
}
