// bench-sim's register space: the union of a rate-table map and a chamber map (host/fixture/maps),
// filled from the World before each request and interpreted after each accepted write.
//
// Engineering units at the map level are fixed (docs/modbus.md): table angles deg, rates deg/s,
// temperatures degC, ramps degC/min, clock s. The bank converts to the World's SI units.
// Write semantics:
//   table  with cmd_seq: mode+command are staged; a new cmd_seq value applies them (seq_ack follows).
//          without cmd_seq: any write to mode or command applies the pair at once.
//   chamber: setpoint, ramp and run apply when written.
// A write that touches a register no writable point owns is refused with exception 2 (illegal data
// address); a value outside the point's [min, max] or not one of its enumerated values with 3 (illegal
// data value). Refused writes change nothing.
#pragma once

#include <cstdint>
#include <vector>

#include "host/benchsim/world.h"
#include "host/fixture/register_map.h"

namespace imuforge::benchsim {

class RegisterBank {
 public:
  // Throws std::runtime_error if the maps claim the same register for different points.
  RegisterBank(fixture::RegisterMap table, fixture::RegisterMap chamber);
  RegisterBank(RegisterBank&&) = default;
  RegisterBank& operator=(RegisterBank&&) = default;

  // Writable registers start from the world's state (setpoint, ramp, run, idle axes, cmd_seq 0).
  void init_from(const World& w);
  // Refresh every read-only point from the world.
  void publish(const World& w);
  // 0 if the write is acceptable, else the Modbus exception code (2 or 3). `why` gets a reason.
  int check_write(uint16_t address, const uint16_t* words, int n, std::string* why) const;
  // Store the words and act on them (command the world). Call only after check_write() == 0.
  void apply_write(uint16_t address, const uint16_t* words, int n, World& w);

  uint16_t* registers() { return regs_.data(); }
  int size() const { return static_cast<int>(regs_.size()); }
  const fixture::RegisterMap& table_map() const { return table_; }
  const fixture::RegisterMap& chamber_map() const { return chamber_; }
  uint64_t commands_applied() const { return commands_applied_; }

 private:
  void put(const fixture::RegisterMap& m, const char* name, double value, int axis = 0);
  double get(const fixture::RegisterMap& m, const char* name, int axis, double dflt) const;
  // Indices, not pointers, so the bank can be moved.
  struct Owner {
    int map = -1;    // 0 table, 1 chamber, -1 unmapped
    int point = -1;  // index in that map's points()
    int axis = 0;
  };
  const fixture::RegisterMap& map_of(const Owner& o) const { return o.map == 0 ? table_ : chamber_; }
  const fixture::Point& point_of(const Owner& o) const {
    return map_of(o).points()[static_cast<size_t>(o.point)];
  }

  fixture::RegisterMap table_, chamber_;
  std::vector<uint16_t> regs_;
  std::vector<Owner> owner_;  // per register
  std::vector<uint16_t> seq_applied_;
  uint64_t commands_applied_ = 0;
};

}  // namespace imuforge::benchsim
