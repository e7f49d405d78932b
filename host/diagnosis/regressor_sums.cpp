#include "host/diagnosis/regressor_sums.h"

#include <system_error>
#include <utility>

#include "host/diagnosis/concurrency.h"

namespace imuforge::diagnosis {

RegressorSums::RegressorSums(const model::RegressorPlan& accel, const model::RegressorPlan& gyro, double T_ref_C)
    : plan_{&accel, &gyro}, T_ref_C_(T_ref_C), threaded_(concurrency_allowed()), queue_(kQueued) {
  if (!threaded_) return;
  filling_.reserve(kChunk);
  try {
    worker_ = std::thread([this] { work(); });
  } catch (const std::system_error&) {
    threaded_ = false;  // no thread to be had: add at once
  }
}

RegressorSums::~RegressorSums() {
  if (worker_.joinable()) {
    queue_.stop();
    worker_.join();
  }
}

void RegressorSums::add_now(const Entry& e) {
  while (static_cast<int>(sums_.size()) <= e.block)
    sums_.push_back({Eigen::MatrixXd::Zero(3, static_cast<Eigen::Index>(plan_[0]->size())),
                     Eigen::MatrixXd::Zero(3, static_cast<Eigen::Index>(plan_[1]->size()))});
  auto& J = sums_[static_cast<std::size_t>(e.block)];
  for (int s = 0; s < 2; ++s) plan_[s]->accumulate(e.ins[s], T_ref_C_, J[static_cast<std::size_t>(s)]);
}

void RegressorSums::add(int block, const model::MeasureInput ins[2]) {
  if (!threaded_) {
    add_now(Entry{block, {ins[0], ins[1]}});
    return;
  }
  filling_.push_back(Entry{block, {ins[0], ins[1]}});
  if (filling_.size() >= kChunk) submit();
}

void RegressorSums::submit() {
  if (filling_.empty()) return;
  queue_.push(std::move(filling_));  // false: the worker has failed, and take() says why
  filling_ = queue_.blank();
  filling_.clear();
  filling_.reserve(kChunk);
}

void RegressorSums::work() {
  std::vector<Entry> chunk;
  std::exception_ptr closed;
  while (queue_.pop(chunk, closed)) {
    try {
      for (const Entry& e : chunk) add_now(e);
    } catch (...) {
      error_ = std::current_exception();
      queue_.stop();  // the caller's push() no longer waits for room
      return;
    }
  }
}

std::vector<std::array<Eigen::MatrixXd, 2>> RegressorSums::take() {
  if (threaded_) {
    submit();
    queue_.close();
    worker_.join();  // the worker has added every queued chunk, or failed
    if (error_) std::rethrow_exception(error_);
  }
  return std::move(sums_);
}

}  // namespace imuforge::diagnosis
