// The bench: one World, its register bank, one simulated clock, and the lock every server thread (TCP,
// RTU, the virtual IMU's sample callback) takes before touching them.
//
// Clock: simulated time = time_scale x wall time since the bench was created. The world is advanced
// lazily to "now" whenever someone looks at it, so fixture registers and IMU samples always agree on
// the time, whatever the scale.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>

#include "host/benchsim/register_bank.h"
#include "host/benchsim/world.h"

namespace imuforge::benchsim {

// Fault injection, for tests and for rehearsing a station's error handling against bench-sim.
// Counters count down per request received (TCP and RTU alike).
struct Faults {
  std::atomic<int> exception_code{0};   // answer the next `exception_count` requests with this exception
  std::atomic<int> exception_count{0};
  std::atomic<int> drop_count{0};       // act on the next N requests but send no answer (answer lost)
  std::atomic<int> ignore_count{0};     // neither act on nor answer the next N requests (request lost)
  std::atomic<int> delay_ms{0};         // answer the next `delay_count` requests this late (-1: all)
  std::atomic<int> delay_count{0};
};

class Bench {
 public:
  Bench(std::unique_ptr<World> world, RegisterBank bank, double time_scale);

  std::mutex& mutex() { return mu_; }
  World& world() { return *world_; }
  RegisterBank& bank() { return bank_; }
  Faults& faults() { return faults_; }
  double time_scale() const { return time_scale_; }

  // Simulated seconds now, from the wall clock (or the manual clock when set).
  double now_s() const;
  // Replace the wall clock (tests): the world follows `clock()` instead.
  void set_clock(std::function<double()> clock) { clock_ = std::move(clock); }
  // Advance the world to now_s() and refresh the registers. Caller holds mutex().
  void sync();

 private:
  std::unique_ptr<World> world_;
  RegisterBank bank_;
  double time_scale_;
  std::chrono::steady_clock::time_point t0_;
  std::function<double()> clock_;
  std::mutex mu_;
  Faults faults_;
};

}  // namespace imuforge::benchsim
