// Two pieces of the diagnosis's work at once, on a machine with two cores or more.
//
// The diagnosis is single-threaded by design: every figure it prints must be the same on every machine and every
// run. What runs here concurrently therefore shares no mutable state, and each piece is the same arithmetic in the
// same order as when run alone, so the answer does not depend on which piece runs where, or on whether they run
// at once at all (tests/diagnosis/concurrency_test.cpp: the pieces and a whole diagnosis, bit for bit).
//
// IMUFORGE_DIAG_THREADS=1 in the environment runs everything on the calling thread (profiling, comparisons);
// IMUFORGE_DIAG_THREADS=2 runs the pieces at once even on one core (the tests' threaded side); otherwise the core
// count decides.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <utility>
#include <vector>

namespace imuforge::diagnosis {

// False where IMUFORGE_DIAG_THREADS=1 asks for one thread, true where it is 2, else whether the machine has two cores
// or more. Read on every call (a getenv, O(environment)), so a test can change it.
bool concurrency_allowed();

// Runs a() and b() at once and returns when both have finished: b() on the caller's thread, a() on the process's
// helper thread (one, started at the first call and kept, so that what a thread keeps for itself, such as
// line_power_spectrum's sums, serves later calls too), or on a thread of its own while the helper is busy (another
// caller's a(), or a() calling this again). Where concurrency_allowed() is false, or no thread can be started,
// a() then b() on the caller's thread. An exception from either is rethrown once both have finished (a's first).
// a and b must not write anything the other reads. Cost: a hand-over to the helper (µs).
void run_concurrently(const std::function<void()>& a, const std::function<void()>& b);

// Chunks of T handed from one producer thread to one consumer thread, in order, at most `depth` waiting: the
// hand-off behind PrefetchSource (the log read ahead) and RegressorSums (the regressors summed beside pass 1).
// Chunks are vectors whose storage goes round: the consumer's spent chunk becomes the producer's next blank(), so
// a steady stream allocates and constructs nothing after its first depth + 2 chunks.
//
// The producer ends the stream with close(), passing on the exception that ended it, if any: the consumer gets every
// chunk pushed before, then the exception. Either side may stop() instead: a waiting or later push() or pop()
// returns false at once (the other side's thread has failed or is no longer wanted). reset() makes a stopped or
// closed queue new again, once neither side is using it. Every call locks one mutex; push() and pop() wait on it.
template <class T>
class ChunkQueue {
 public:
  explicit ChunkQueue(std::size_t depth) : depth_(depth < 1 ? 1 : depth) {}
  ChunkQueue(const ChunkQueue&) = delete;
  ChunkQueue& operator=(const ChunkQueue&) = delete;

  // Producer: a spent chunk as the consumer left it (its old elements, to be overwritten or cleared: a chunk of
  // samples refilled in place costs no construction), or an empty one where none is spare. O(1).
  std::vector<T> blank() {
    std::lock_guard<std::mutex> lk(mu_);
    if (spare_.empty()) return {};
    std::vector<T> c = std::move(spare_.back());
    spare_.pop_back();
    return c;
  }
  // Producer: queues c once fewer than depth chunks wait. False, c dropped, where the queue is stopped.
  bool push(std::vector<T>&& c) {
    {
      std::unique_lock<std::mutex> lk(mu_);
      cv_.wait(lk, [&] { return stopped_ || full_.size() < depth_; });
      if (stopped_) return false;
      full_.push_back(std::move(c));
    }
    cv_.notify_all();
    return true;
  }
  // Producer: nothing more will be pushed; err (may be null) reaches the consumer after the last chunk.
  void close(std::exception_ptr err = nullptr) {
    {
      std::lock_guard<std::mutex> lk(mu_);
      closed_ = true;
      error_ = std::move(err);
    }
    cv_.notify_all();
  }
  // Consumer: out's storage is kept for blank(), then out becomes the next chunk: true. At the end of a closed
  // stream false, with err set to close()'s exception (once; null after); false too where the queue is stopped.
  bool pop(std::vector<T>& out, std::exception_ptr& err) {
    bool got = false;
    {
      std::unique_lock<std::mutex> lk(mu_);
      if (out.capacity() > 0) spare_.push_back(std::move(out));
      out = std::vector<T>();
      cv_.wait(lk, [&] { return stopped_ || closed_ || !full_.empty(); });
      if (!stopped_ && !full_.empty()) {
        out = std::move(full_.front());
        full_.pop_front();
        got = true;
      } else if (!stopped_) {
        err = std::move(error_);
        error_ = nullptr;
      }
    }
    cv_.notify_all();
    return got;
  }
  // Either side: the other's waiting and later push() and pop() return false.
  void stop() {
    {
      std::lock_guard<std::mutex> lk(mu_);
      stopped_ = true;
    }
    cv_.notify_all();
  }
  // Neither side using the queue: queued chunks become spare, and the queue is open again.
  void reset() {
    std::lock_guard<std::mutex> lk(mu_);
    for (auto& c : full_) spare_.push_back(std::move(c));
    full_.clear();
    closed_ = stopped_ = false;
    error_ = nullptr;
  }

 private:
  const std::size_t depth_;
  std::mutex mu_;
  std::condition_variable cv_;
  // Guarded by mu_.
  std::deque<std::vector<T>> full_;
  std::vector<std::vector<T>> spare_;
  bool closed_ = false, stopped_ = false;
  std::exception_ptr error_;
};

}  // namespace imuforge::diagnosis
