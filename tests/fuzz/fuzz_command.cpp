// libFuzzer: the CAN node's command parser (node_handle_command) with a real table store on simulated
// flash. The input is a sequence of requests: [len u16 le][flags u8][request bytes]. flags bit0: the
// harness signs a write request with the device key (so table contents reach the parser instead of
// stopping at the tag check); bit1: reboot the node afterwards (store re-mounted from flash).
// Invariants (abort on violation):
//   - every response is >= 2 bytes, echoes cmd|0x80, fits the buffer;
//   - the active table, whenever there is one, parses as a valid v1 table for this device's serial and
//     its store seq equals the table's own sequence number; it never goes backwards;
//   - a request with a wrong tag never changes the active table;
//   - the CAN FD stream's frame under construction (node_poll runs after every request) holds 0..3
//     samples, and none once the stream is stopped.
#include <cstdlib>
#include <cstring>

#include "firmware/can_node/node.h"
#include "firmware/common/endian.h"
#include "hal/sim/sim_flash.h"

using namespace imuforge;
using namespace imuforge::fw;

namespace {
class NullPort final : public hal::CanPort {
 public:
  int send(const hal::CanFrame&) noexcept override { return hal::kCanOk; }
  int receive(hal::CanFrame&) noexcept override { return hal::kCanErrWouldBlock; }
  int send_fd(const hal::CanFdFrame& f) noexcept override {
    if (!hal::can_fd_frame_valid(f) || f.len != proto::kFdFrameBytes) std::abort();
    const unsigned count = f.data[2];
    if (count == 0u || count > proto::kFdSamplesPerFrame) std::abort();
    return hal::kCanOk;
  }
};
class ZeroSensor final : public hal::Sensor {
 public:
  int read(std::uint64_t, hal::ImuRawSample& s) noexcept override {
    s = hal::ImuRawSample{};
    return hal::kSensorOk;
  }
};
constexpr std::uint64_t kSerial = 99;
std::uint8_t flash_mem[16384];
CanNode node;
Table check;
std::uint8_t resp[proto::kMaxMessageBytes];
std::uint8_t req[proto::kMaxMessageBytes];
std::uint8_t blob[proto::kMaxTableBytes];

void boot(hal::SimFlash& flash, NullPort& port, ZeroSensor& sensor, const NodeConfig& cfg) {
  node_init(node, cfg, port, flash, sensor);
  (void)node_boot(node, 0);
}

void check_active(std::uint32_t& last_seq) {
  const StoreSlotInfo* a = store_active(node.store);
  if (a == nullptr) {
    if (last_seq != 0) std::abort();  // there was a table: there must still be one
    return;
  }
  if (a->len > sizeof blob || store_read(node.store, 0, blob, a->len) != kStoreOk) std::abort();
  if (table_parse(blob, a->len, &check) != 0) std::abort();
  if (check.device_serial != kSerial || check.table_sequence != a->seq) std::abort();
  if (a->seq < last_seq) std::abort();
  last_seq = a->seq;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  NullPort port;
  ZeroSensor sensor;
  hal::SimFlash flash(flash_mem, sizeof flash_mem, 2048);
  flash.erase_all();
  NodeConfig cfg;
  cfg.node_id = 1;
  cfg.serial = kSerial;
  for (unsigned i = 0; i < sizeof cfg.key; ++i) cfg.key[i] = static_cast<std::uint8_t>(i * 3u);
  cfg.key_provisioned = true;
  cfg.can_fd = true;
  cfg.store.slot_addr[0] = 0;
  cfg.store.slot_addr[1] = 8192;
  cfg.store.slot_bytes = 4096;
  boot(flash, port, sensor, cfg);
  std::uint32_t last_seq = 0;
  std::size_t i = 0;
  std::uint64_t t = 0;
  while (i + 3 <= size) {
    std::size_t len = load_le16(data + i) % (sizeof req + 1);
    const std::uint8_t flags = data[i + 2];
    i += 3;
    if (len > size - i) len = size - i;
    std::memcpy(req, data + i, len);
    i += len;
    const bool sign = (flags & 1u) != 0 && len >= proto::kWriteHeaderBytes && req[0] == proto::kCmdWriteTable;
    if (sign) {
      node_table_tag(cfg.key, kSerial, load_le32(req + 1), req + proto::kWriteHeaderBytes,
                     len - proto::kWriteHeaderBytes, req + 5);
    }
    const StoreSlotInfo* before = store_active(node.store);
    const std::uint32_t seq_before = before ? before->seq : 0;
    const std::size_t n = node_handle_command(node, req, len, resp, sizeof resp, t);
    t += 1000;
    if (n < 2 || n > sizeof resp) std::abort();
    if (len > 0 && resp[0] != (req[0] | proto::kResponseFlag)) std::abort();
    if (!sign && len > 0 && req[0] == proto::kCmdWriteTable && resp[1] == proto::kStOk) {
      // unsigned write accepted: only possible if the fuzzer forged a valid HMAC tag
      std::abort();
    }
    const StoreSlotInfo* after = store_active(node.store);
    if (req[0] == proto::kCmdWriteTable && (after ? after->seq : 0) != seq_before) std::abort();
    node_poll(node, t);  // streams what is due: classic frames or FD packing
    if (node.fd_count >= proto::kFdSamplesPerFrame || (!node.streaming && node.fd_count != 0u)) std::abort();
    if (flags & 2u) boot(flash, port, sensor, cfg);
    check_active(last_seq);
  }
  return 0;
}
