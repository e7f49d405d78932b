#include "firmware/can_node/node.h"

namespace imuforge::fw {

std::uint8_t node_table_check(const std::uint8_t* table, std::size_t len, std::uint64_t serial,
                              std::uint32_t seq, Table& scratch) noexcept {
  if (table_parse(table, len, &scratch) != kTableOk || !table_is_valid(&scratch)) return proto::kStTableInvalid;
  if (scratch.device_serial != serial) return proto::kStWrongDevice;
  if (scratch.table_sequence != seq) return proto::kStSeqMismatch;
  return proto::kStOk;
}

}  // namespace imuforge::fw
