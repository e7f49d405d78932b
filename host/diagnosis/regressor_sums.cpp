#include "host/diagnosis/regressor_sums.h"

#include <system_error>
#include <utility>

#include "host/diagnosis/concurrency.h"

namespace imuforge::diagnosis {

RegressorSums::RegressorSums(const model::RegressorPlan& accel, const model::RegressorPlan& gyro, double T_ref_C)
    : plan_{&accel, &gyro}, T_ref_C_(T_ref_C), threaded_(concurrency_allowed()) {
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
    {
      std::lock_guard<std::mutex> lk(mu_);
      stop_ = true;
    }
    cv_.notify_all();
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
  std::vector<Entry> next;
  {
    std::unique_lock<std::mutex> lk(mu_);
    cv_.wait(lk, [&] { return queued_.size() < kQueued || error_; });
    queued_.push_back(std::move(filling_));
    if (!spare_.empty()) {
      next = std::move(spare_.back());
      spare_.pop_back();
    }
  }
  cv_.notify_all();
  next.clear();
  next.reserve(kChunk);
  filling_ = std::move(next);
}

void RegressorSums::work() {
  for (;;) {
    std::vector<Entry> chunk;
    {
      std::unique_lock<std::mutex> lk(mu_);
      cv_.wait(lk, [&] { return stop_ || !queued_.empty(); });
      if (stop_) return;
      chunk = std::move(queued_.front());
      queued_.pop_front();
      busy_ = true;
    }
    std::exception_ptr err;
    try {
      for (const Entry& e : chunk) add_now(e);
    } catch (...) {
      err = std::current_exception();
    }
    {
      std::lock_guard<std::mutex> lk(mu_);
      busy_ = false;
      chunk.clear();
      spare_.push_back(std::move(chunk));
      if (err && !error_) error_ = err;
    }
    cv_.notify_all();
    if (err) return;
  }
}

std::vector<std::array<Eigen::MatrixXd, 2>> RegressorSums::take() {
  if (threaded_) {
    submit();
    std::exception_ptr err;
    {
      std::unique_lock<std::mutex> lk(mu_);
      cv_.wait(lk, [&] { return (queued_.empty() && !busy_) || error_; });
      err = error_;
      stop_ = true;
    }
    cv_.notify_all();
    worker_.join();
    if (err) std::rethrow_exception(err);
  }
  return std::move(sums_);
}

}  // namespace imuforge::diagnosis
