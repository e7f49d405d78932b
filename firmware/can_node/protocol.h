// The imuforge CAN protocol: identifiers, stream frame layout, command and status codes.
// docs/can-protocol.md is the prose version of this header; the two must agree.
// Shared by the firmware node, the host client (host/can/) and the tests. Header only, no heap.
#pragma once
#include <cstddef>
#include <cstdint>

#include "firmware/table/table.h"

namespace imuforge::proto {

constexpr std::uint8_t kMaxNodeId = 63;

// ---- identifiers ----------------------------------------------------------------------------------
// 11-bit: stream part k (0 accel, 1 gyro, 2 temp+time) = 0x100 + 4*node + k; command request 0x600+node,
//         response 0x680+node. Stream IDs are lower, so samples win arbitration over command traffic.
// 29-bit: stream 0x0A100000 | k<<8 | node; request 0x0A600000 | node; response 0x0A680000 | node.
// k = 3 is the CAN FD stream frame (all channels of 4 samples in one frame, see below).
enum StreamPart : std::uint8_t { kPartAccel = 0, kPartGyro = 1, kPartTemp = 2, kPartCount = 3, kPartFd = 3 };

constexpr std::uint32_t stream_id(std::uint8_t node, std::uint8_t part, bool extended) noexcept {
  return extended ? (0x0A100000u | (static_cast<std::uint32_t>(part) << 8) | node)
                  : (0x100u + 4u * static_cast<std::uint32_t>(node) + part);
}
constexpr std::uint32_t request_id(std::uint8_t node, bool extended) noexcept {
  return extended ? (0x0A600000u | node) : (0x600u + node);
}
constexpr std::uint32_t response_id(std::uint8_t node, bool extended) noexcept {
  return extended ? (0x0A680000u | node) : (0x680u + node);
}

// ---- stream -----------------------------------------------------------------------------------------
// Every stream frame is 8 bytes, little endian, and starts with the 16-bit sample sequence counter:
//   accel: seq u16 | ax i16 | ay i16 | az i16          (raw counts)
//   gyro : seq u16 | gx i16 | gy i16 | gz i16          (raw counts)
//   temp : seq u16 | temp i16 (0.01 degC) | t_us u32   (sensor timestamp, microseconds, wraps)
enum Channel : std::uint8_t { kChAccel = 1u, kChGyro = 2u, kChTemp = 4u, kChAll = 7u };
constexpr std::uint16_t kMinRateHz = 1;
constexpr std::uint16_t kMaxRateHz = 2000;
// Stream start's optional 4th argument byte, flags (absent = 0: classic).
constexpr std::uint8_t kStreamFlagFd = 0x01u;  // CAN FD stream frames

// CAN FD stream frame (stream_id part kPartFd, FDF+BRS, always 64 bytes), little endian:
//   0-1 seq u16 (first sample) | 2 count u8 (1..4) | 3 channels u8 | 4-7 t_us u32 (first sample) |
//   8-9 temp i16 of sample 0 (0.01 degC) | 10 + 12i: sample i { ax ay az gx gy gz i16 } |
//   58 + 2(i-1): temp i16 of sample i = 1..3 | 0xCC in every byte of a sample the frame does not hold.
// Every sample keeps its own temperature, so an FD stream decodes to exactly the classic samples.
// Sample i has seq + i and t_us + i * period_us, period_us = 1000000 / rate_hz (integer division, the
// node's own sample period). A frame with count < 4 ends a run of consecutive samples: the last frame
// before a stop, a reboot or a sequence gap (sensor read error, FIFO overflow).
constexpr unsigned kFdSamplesPerFrame = 4;
constexpr unsigned kFdFrameBytes = 64;
constexpr unsigned kFdHeaderBytes = 10;
constexpr unsigned kFdSampleBytes = 12;
constexpr std::uint8_t kFdPadByte = 0xCC;
constexpr unsigned kFdTempTailOffset = 58;  // temp of samples 1..3
// Bytes a frame of `count` samples needs (1..4); the node always sends kFdFrameBytes.
constexpr unsigned fd_frame_min_len(unsigned count) noexcept {
  return count <= 1u ? kFdHeaderBytes + kFdSampleBytes : kFdTempTailOffset + 2u * (count - 1u);
}
static_assert(kFdHeaderBytes + kFdSamplesPerFrame * kFdSampleBytes == kFdTempTailOffset &&
                  kFdTempTailOffset + 2u * (kFdSamplesPerFrame - 1u) == kFdFrameBytes,
              "FD stream frame layout");

// ---- commands (ISO-TP payloads) ------------------------------------------------------------------
// Request : cmd u8 | arguments
// Response: cmd|0x80 u8 | status u8 | results   (always, also on error; errors carry no results)
enum Command : std::uint8_t {
  kCmdIdentify = 0x01,     // -> serial u64 | fw_version char[16] (NUL padded) | table_present u8 |
                           //    table_seq u32 | table_crc32 u32 | table_len u32 | node_id u8 | flags u8
  kCmdStreamStart = 0x02,  // rate_hz u16 | channels u8 [| flags u8 (kStreamFlagFd)]  ->  (nothing)
  kCmdStreamStop = 0x03,   // -> samples_sent u32
  kCmdReadTable = 0x04,    // -> table_seq u32 | table bytes
  kCmdWriteTable = 0x05,   // seq u32 | tag[32] | table bytes  ->  crc32 u32 of the staged table
  kCmdCommit = 0x06,       // seq u32  ->  active seq u32 | active crc32 u32
  kCmdReboot = 0x07,       // -> (nothing); the node resets after the response left
  kCmdStatus = 0x08,       // -> NodeStatus block, see kStatusBytes
};
constexpr std::uint8_t kResponseFlag = 0x80;

enum Status : std::uint8_t {
  kStOk = 0x00,
  kStUnknownCommand = 0x01,  // cmd byte not in the table above
  kStBadLength = 0x02,       // request shorter/longer than the command's layout
  kStBadArgument = 0x03,     // rate out of 1..2000 Hz, channels 0 or > 7
  kStAuthFailed = 0x04,      // HMAC-SHA256 tag does not verify under the device key
  kStReplay = 0x05,          // table seq <= active table seq
  kStTableInvalid = 0x06,    // table parser (firmware/table) rejected the blob
  kStTableTooLarge = 0x07,   // blob larger than a store slot
  kStFlashError = 0x08,      // erase/program/verify failed; active table unchanged
  kStNotStaged = 0x09,       // commit without a successful write of the same seq
  kStNoTable = 0x0A,         // read-table on a device without a valid table
  kStBusy = 0x0B,            // a previous response is still being sent
  kStNoKey = 0x0C,           // device has no provisioned key: table writes are refused
  kStWrongDevice = 0x0D,     // table's device_serial is not this device's serial
  kStSeqMismatch = 0x0E,     // table's table_sequence differs from the seq of the write request
  kStFdUnsupported = 0x0F,   // stream start asked for CAN FD; this node's controller/bus has none
};

// Identify's flags byte.
constexpr std::uint8_t kIdExtendedIds = 0x01u;
constexpr std::uint8_t kIdKeyProvisioned = 0x02u;
constexpr std::uint8_t kIdCanFd = 0x04u;

// Status response layout (after cmd|0x80, status), all u32 little endian unless noted:
//   uptime_ms | samples_sent | stream_frames_tx | stream_frames_dropped | bus_off_events |
//   isotp_rx_errors | isotp_tx_errors | commands_ok | commands_rejected | auth_failures |
//   boots u32 | active_slot i8 | staged_slot i8 | streaming u8 (0 no, 1 classic, 2 CAN FD) |
//   channels u8 | rate_hz u16 |
//   samples_fifo_overflow u32
constexpr std::size_t kStatusBytes = 11u * 4u + 6u + 4u;
constexpr std::size_t kIdentifyBytes = 8u + 16u + 1u + 4u + 4u + 4u + 1u + 1u;

// ---- authorisation ---------------------------------------------------------------------------------
// tag = HMAC-SHA256(device_key, "IFTB" | serial u64 | seq u32 | table bytes)
constexpr std::uint8_t kTagDomain[4] = {'I', 'F', 'T', 'B'};
constexpr std::size_t kTagBytes = 32;
constexpr std::size_t kKeyBytes = 32;

// Largest table blob the node accepts: the largest coefficient table v1 (16 breakpoints, 2244 bytes).
// It sizes the ISO-TP buffers (table + command header + tag); the Linux kernel's ISO-TP limit is 8200.
constexpr std::size_t kMaxTableBytes = fw::kTableMaxSize;
constexpr std::size_t kWriteHeaderBytes = 1u + 4u + kTagBytes;
constexpr std::size_t kMaxMessageBytes = kWriteHeaderBytes + kMaxTableBytes;

}  // namespace imuforge::proto
