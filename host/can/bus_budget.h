// Bus budget of a multi-unit station (docs/can-protocol.md "Bus budget"): how much of each CAN bus the
// sample streams of N units take, with worst-case bit stuffing, and whether a plan fits under the limit.
//
// The stream of one unit at rate f with every channel is 3 classic 8-byte frames per sample, or, on CAN
// FD, one 64-byte frame per kFdSamplesPerFrame samples. A frame's worst-case length counts every
// stuff bit the standard allows (ISO 11898-1: one after each run of five equal bits in the stuffed
// region; CAN FD adds the stuff count and the fixed stuff bits of the CRC field), so the load is an
// upper bound a real bus never exceeds. Commands (ISO-TP, table flashing) need what is left: the
// station refuses a plan above kDefaultLoadLimit.
//
// Pure functions, no I/O; O(1) each except plan_message (O(buses)).
#pragma once

#include <string>
#include <vector>

#include "firmware/can_node/protocol.h"

namespace imuforge::can {

// Above this fraction of a bus's time the runner refuses to start (docs/can-protocol.md): the rest is
// for ISO-TP commands, flashing several units and error frames / retransmissions.
constexpr double kDefaultLoadLimit = 0.70;
// Samples in one CAN FD stream frame (docs/can-protocol.md "CAN FD stream frame"; the node's number).
constexpr int kFdSamplesPerFrame = static_cast<int>(proto::kFdSamplesPerFrame);

struct BusTiming {
  bool fd = false;                     // CAN FD with bit-rate switch
  bool ext_id = false;                 // 29-bit identifiers
  double nominal_bit_s = 1e6;          // arbitration bit rate (classic: the only one), bit/s
  double data_bit_s = 5e6;             // CAN FD data-phase bit rate, bit/s (ignored for classic)
};

// Worst-case duration (s) of one data frame with `data_bytes` payload bytes (classic 0..8; FD one of
// 0..8, 12, 16, 20, 24, 32, 48, 64), stuff bits and the 3-bit interframe space included. Throws
// std::invalid_argument on a length the format does not have.
double frame_time_worst_s(const BusTiming& t, int data_bytes);
// The same without stuff bits (the best case), for the nominal column of the tables.
double frame_time_nominal_s(const BusTiming& t, int data_bytes);

// Fraction of bus time (worst case) that `units` streams at `rate_hz` take: classic 3 frames of 8 bytes
// per sample; FD ceil(rate / kFdSamplesPerFrame) frames of 64 bytes per second per unit.
double stream_load_worst(const BusTiming& t, int units, double rate_hz);
double stream_load_nominal(const BusTiming& t, int units, double rate_hz);

struct BusPlan {
  std::string bus;   // "socketcan:can0", "virtual:bench1"
  int units = 0;     // units streaming on it
};

struct BudgetVerdict {
  bool ok = true;
  std::vector<double> load;  // per bus, worst case
  // Empty when ok; else what is over the limit and what would fit: the highest rate, the number of
  // buses at this rate, and the load on CAN FD.
  std::string message;
};

// Checks every bus of the plan at rate_hz against limit. O(buses).
BudgetVerdict check_budget(const BusTiming& t, const std::vector<BusPlan>& buses, double rate_hz,
                           double limit = kDefaultLoadLimit);

// Highest stream rate (Hz, whole) at which `units` fit on one bus under limit; 0 if none.
int max_rate_hz(const BusTiming& t, int units, double limit = kDefaultLoadLimit);

}  // namespace imuforge::can
