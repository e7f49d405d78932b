#include "host/diagnosis/prefetch.h"

#include <algorithm>
#include <system_error>

#include "host/diagnosis/concurrency.h"

namespace imuforge::diagnosis {

PrefetchSource::PrefetchSource(SampleSource& inner, std::size_t batch)
    : inner_(inner), batch_(std::max<std::size_t>(batch, 1)), threaded_(concurrency_allowed()) {}

PrefetchSource::~PrefetchSource() { idle(); }

void PrefetchSource::idle() {
  if (reader_.joinable()) {
    {
      std::lock_guard<std::mutex> lk(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    reader_.join();
  }
}

void PrefetchSource::rewind() {
  idle();
  inner_.rewind();
  full_.clear();
  full_head_ = 0;
  done_ = stop_ = false;
  error_ = nullptr;
  cur_.clear();
  pos_ = 0;
  started_ = finished_ = false;
}

void PrefetchSource::produce() {
  for (;;) {
    std::vector<Sample> b;
    {
      std::unique_lock<std::mutex> lk(mu_);
      cv_.wait(lk, [&] { return stop_ || full_.size() - full_head_ < kDepth; });
      if (stop_) return;
      if (!spare_.empty()) {
        b = std::move(spare_.back());
        spare_.pop_back();
      }
    }
    b.resize(batch_);
    std::size_t n = 0;
    bool end = false;
    std::exception_ptr err;
    try {
      while (n < batch_ && !end) {
        if (inner_.next(b[n]))
          ++n;
        else
          end = true;
      }
    } catch (...) {
      err = std::current_exception();
      end = true;
    }
    b.resize(n);
    {
      std::lock_guard<std::mutex> lk(mu_);
      if (n > 0) full_.push_back(std::move(b));
      if (end) {
        done_ = true;
        error_ = err;
      }
    }
    cv_.notify_all();
    if (end) return;
  }
}

bool PrefetchSource::next(Sample& s) {
  if (!threaded_) return inner_.next(s);
  if (pos_ < cur_.size()) {
    s = cur_[pos_++];
    return true;
  }
  if (finished_) return false;
  if (!started_) {
    started_ = true;
    try {
      reader_ = std::thread([this] { produce(); });
    } catch (const std::system_error&) {
      threaded_ = false;  // no thread to be had: read in the caller's, from where the inner source stands
      return inner_.next(s);
    }
  }
  std::exception_ptr err;
  {
    std::unique_lock<std::mutex> lk(mu_);
    if (!cur_.empty()) spare_.push_back(std::move(cur_));
    cur_.clear();
    pos_ = 0;
    cv_.wait(lk, [&] { return full_head_ < full_.size() || done_; });
    if (full_head_ < full_.size()) {
      cur_ = std::move(full_[full_head_++]);
      // Drop the moved-from slots now and then (the vector only grows by kDepth between compactions).
      if (full_head_ == full_.size()) {
        full_.clear();
        full_head_ = 0;
      }
    } else {
      finished_ = true;
      err = error_;
      error_ = nullptr;
    }
  }
  cv_.notify_all();
  if (err) std::rethrow_exception(err);
  if (finished_) return false;
  s = cur_[pos_++];
  return true;
}

}  // namespace imuforge::diagnosis
