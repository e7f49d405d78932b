#include "host/can/bus_budget.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace imuforge::can {

namespace {

bool fd_length_ok(int n) {
  return (n >= 0 && n <= 8) || n == 12 || n == 16 || n == 20 || n == 24 || n == 32 || n == 48 || n == 64;
}

// Bit counts of one data frame: bits sent at the nominal rate and at the data rate (FD with BRS).
struct FrameBits {
  double nominal = 0.0, data = 0.0;
};

FrameBits frame_bits(const BusTiming& t, int n, bool stuffing) {
  if (!t.fd) {
    if (n < 0 || n > 8) throw std::invalid_argument("classic CAN frame: " + std::to_string(n) + " data bytes (0..8)");
    // SOF, identifier (+ SRR, IDE, 18-bit extension), RTR, r0 (r1), DLC, data, CRC-15: the stuffed region.
    const int stuffed = (t.ext_id ? 54 : 34) + 8 * n;
    // CRC delimiter, ACK slot and delimiter, EOF 7, interframe space 3.
    const int tail = 13;
    return {static_cast<double>(stuffed + tail + (stuffing ? (stuffed - 1) / 4 : 0)), 0.0};
  }
  if (!fd_length_ok(n)) throw std::invalid_argument("CAN FD frame: " + std::to_string(n) + " data bytes (0..8, 12, 16, 20, 24, 32, 48, 64)");
  // Arbitration phase: SOF, identifier (+ SRR, IDE, extension), RRS, IDE/FDF, res, BRS.
  const int arb = t.ext_id ? 36 : 17;
  // Data phase: ESI, DLC, data (dynamic stuffing), stuff count (4), CRC-17/21 with its fixed stuff bits
  // (one before the stuff count, then one after every 4 bits), CRC delimiter.
  const int crc = n > 16 ? 21 : 17;
  const int fixed_stuff = (4 + crc) / 4 + 1;
  const int dyn = 5 + 8 * n;
  FrameBits b;
  b.nominal = arb + 12 + (stuffing ? (arb - 1) / 4 : 0);  // + ACK slot/delimiter, EOF 7, IFS 3
  b.data = dyn + 4 + crc + fixed_stuff + 1 + (stuffing ? dyn / 4 : 0);
  return b;
}

double frame_time(const BusTiming& t, int n, bool stuffing) {
  if (!(t.nominal_bit_s > 0) || (t.fd && !(t.data_bit_s > 0))) throw std::invalid_argument("bus bit rates must be > 0");
  const FrameBits b = frame_bits(t, n, stuffing);
  return b.nominal / t.nominal_bit_s + (t.fd ? b.data / t.data_bit_s : 0.0);
}

double stream_load(const BusTiming& t, int units, double rate_hz, bool stuffing) {
  if (units < 0 || !(rate_hz >= 0)) throw std::invalid_argument("bus load: units and rate must be >= 0");
  if (!t.fd) return units * rate_hz * 3.0 * frame_time(t, 8, stuffing);
  return units * std::ceil(rate_hz / kFdSamplesPerFrame) * frame_time(t, 64, stuffing);
}

std::string pct(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f %%", 100.0 * x);
  return b;
}

}  // namespace

double frame_time_worst_s(const BusTiming& t, int data_bytes) { return frame_time(t, data_bytes, true); }
double frame_time_nominal_s(const BusTiming& t, int data_bytes) { return frame_time(t, data_bytes, false); }
double stream_load_worst(const BusTiming& t, int units, double rate_hz) { return stream_load(t, units, rate_hz, true); }
double stream_load_nominal(const BusTiming& t, int units, double rate_hz) { return stream_load(t, units, rate_hz, false); }

int max_rate_hz(const BusTiming& t, int units, double limit) {
  if (units <= 0) return 0;
  // The load is monotone in the rate: bisection over whole Hz (the node streams 1..2000 Hz).
  int lo = 0, hi = 2000;
  while (lo < hi) {
    const int mid = (lo + hi + 1) / 2;
    if (stream_load_worst(t, units, mid) <= limit) lo = mid;
    else hi = mid - 1;
  }
  return lo;
}

BudgetVerdict check_budget(const BusTiming& t, const std::vector<BusPlan>& buses, double rate_hz, double limit) {
  BudgetVerdict v;
  for (const auto& b : buses) {
    const double load = stream_load_worst(t, b.units, rate_hz);
    v.load.push_back(load);
    if (load <= limit) continue;
    v.ok = false;
    char head[256];
    std::snprintf(head, sizeof head, "bus %s: %d units at %.0f Hz take %s of the bus (worst-case stuffing, %s at %.0f kbit/s",
                  b.bus.c_str(), b.units, rate_hz, pct(load).c_str(), t.fd ? "CAN FD" : "classic CAN",
                  t.nominal_bit_s / 1e3);
    std::string m = head;
    if (t.fd) m += "/" + std::to_string(static_cast<int>(t.data_bit_s / 1e3)) + " kbit/s";
    m += "), above the " + pct(limit) + " limit. What would fit: ";
    const int r = max_rate_hz(t, b.units, limit);
    m += r > 0 ? "a stream rate of at most " + std::to_string(r) + " Hz" : "no stream rate";
    const double per_unit = stream_load_worst(t, 1, rate_hz);
    const int per_bus = per_unit > 0 ? static_cast<int>(std::floor(limit / per_unit)) : b.units;
    if (per_bus >= 1) {
      const int need = (b.units + per_bus - 1) / per_bus;
      m += "; or " + std::to_string(need) + " buses at " + std::to_string(static_cast<int>(rate_hz)) + " Hz (" +
           std::to_string(per_bus) + " units per bus)";
    }
    if (!t.fd) {
      BusTiming fd = t;
      fd.fd = true;
      const double lfd = stream_load_worst(fd, b.units, rate_hz);
      m += "; or CAN FD (" + std::to_string(kFdSamplesPerFrame) + " samples per 64-byte frame, " +
           std::to_string(static_cast<int>(fd.nominal_bit_s / 1e3)) + "/" + std::to_string(static_cast<int>(fd.data_bit_s / 1e3)) +
           " kbit/s): " + pct(lfd) + (lfd <= limit ? "" : ", also too much");
    }
    if (!v.message.empty()) v.message += "\n";
    v.message += m;
  }
  return v;
}

}  // namespace imuforge::can
