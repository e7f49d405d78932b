#include "host/diagnosis/prefetch.h"

#include <algorithm>
#include <system_error>
#include <utility>

#include "host/diagnosis/concurrency.h"

namespace imuforge::diagnosis {

PrefetchSource::PrefetchSource(SampleSource& inner, std::size_t batch)
    : inner_(inner), batch_(std::max<std::size_t>(batch, 1)), threaded_(concurrency_allowed()), queue_(kDepth) {}

PrefetchSource::~PrefetchSource() { idle(); }

void PrefetchSource::idle() {
  if (reader_.joinable()) {
    queue_.stop();
    reader_.join();
  }
}

void PrefetchSource::rewind() {
  idle();
  inner_.rewind();
  queue_.reset();
  cur_.clear();
  pos_ = 0;
  started_ = finished_ = false;
}

void PrefetchSource::produce() {
  for (;;) {
    std::vector<Sample> b = queue_.blank();
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
    if (n > 0 && !queue_.push(std::move(b))) return;  // stopped
    if (end) {
      queue_.close(std::move(err));  // the reader keeps no reference: the exception is freed by the thread that catches it
      return;
    }
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
  pos_ = 0;
  std::exception_ptr err;
  if (!queue_.pop(cur_, err)) {
    finished_ = true;
    if (err) std::rethrow_exception(err);
    return false;
  }
  s = cur_[pos_++];
  return true;
}

}  // namespace imuforge::diagnosis
