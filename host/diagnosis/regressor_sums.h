// The regressors' block sums of a diagnosis pass, added on a thread of their own.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

#include "host/diagnosis/concurrency.h"
#include "host/model/measure.h"

namespace imuforge::diagnosis {

// Σ ∂y/∂θ over each block's samples, for both triads (model::RegressorPlan::accumulate: a 3 × P matrix per triad
// and block). The pass over the log queues each sample's inputs with its block's number and goes on; a worker
// thread adds them, while the pass cuts blocks and sums everything else (on a 1 h, 1 kHz log the regressors are a
// third of a pass). take() waits for the queue and hands the sums over. Each block's sums are added in sample
// order by one thread, so they are the single-threaded sums to the last bit; where concurrency.h allows no second
// thread, add() adds at once.
//
// Block numbers start at 0 and never decrease; a block with no sample has zero sums. An exception in the worker
// (memory) is rethrown by take(). The destructor stops the worker without waiting for the queue (the pass threw).
// Cost: O(P) per sample on the worker, O(1) on the caller (a copy of the inputs); memory kQueued + 2 chunks of
// kChunk samples' inputs, and the sums (2 · 3 · P doubles per block).
class RegressorSums {
 public:
  static constexpr std::size_t kChunk = 1024, kQueued = 4;
  RegressorSums(const model::RegressorPlan& accel, const model::RegressorPlan& gyro, double T_ref_C);
  ~RegressorSums();
  RegressorSums(const RegressorSums&) = delete;
  RegressorSums& operator=(const RegressorSums&) = delete;
  // Queues one sample of block `block` (≥ every block number queued before): ins[0] the accelerometer's inputs,
  // ins[1] the gyro's.
  void add(int block, const model::MeasureInput ins[2]);
  // Every queued sample added; the sums per block, [accel, gyro]. The object is then spent.
  std::vector<std::array<Eigen::MatrixXd, 2>> take();

 private:
  struct Entry {
    int block;
    model::MeasureInput ins[2];
  };
  void add_now(const Entry& e);
  void submit();
  void work();

  const model::RegressorPlan* plan_[2];
  const double T_ref_C_;
  std::vector<std::array<Eigen::MatrixXd, 2>> sums_;  // the worker's while it runs
  bool threaded_;
  std::thread worker_;
  ChunkQueue<Entry> queue_;
  std::exception_ptr error_;  // the worker's; read after it has been joined
  // The caller's chunk being filled.
  std::vector<Entry> filling_;
};

}  // namespace imuforge::diagnosis
