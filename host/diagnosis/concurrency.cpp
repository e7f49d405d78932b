#include "host/diagnosis/concurrency.h"

#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>

#include <unistd.h>

namespace imuforge::diagnosis {

namespace {

// The helper thread: one task at a time, handed over under its mutex. acquire() fails while a task is running
// (the caller then starts a thread of its own), so a task that calls run_concurrently never waits on itself.
class Helper {
 public:
  ~Helper() {
    if (th_.joinable() && owner_ != getpid()) {
      th_.detach();  // a forked child's copy: the thread is its parent's
      return;
    }
    {
      std::lock_guard<std::mutex> lk(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    if (th_.joinable()) th_.join();
  }
  bool acquire() {
    std::lock_guard<std::mutex> lk(mu_);
    // A forked child has the object but not the thread: it starts threads of its own.
    if (taken_ || (th_.joinable() && owner_ != getpid())) return false;
    if (!th_.joinable()) {
      try {
        th_ = std::thread([this] { loop(); });
        owner_ = getpid();
      } catch (const std::system_error&) {
        return false;
      }
    }
    taken_ = true;
    return true;
  }
  // After acquire(): runs f on the helper; wait() returns f's exception, if any, once it has finished.
  void start(const std::function<void()>* f) {
    {
      std::lock_guard<std::mutex> lk(mu_);
      task_ = f;
      error_ = nullptr;
    }
    cv_.notify_all();
  }
  std::exception_ptr wait() {
    std::unique_lock<std::mutex> lk(mu_);
    cv_.wait(lk, [&] { return task_ == nullptr; });
    taken_ = false;
    return error_;
  }

 private:
  void loop() {
    std::unique_lock<std::mutex> lk(mu_);
    for (;;) {
      cv_.wait(lk, [&] { return stop_ || task_ != nullptr; });
      if (task_ == nullptr) return;  // stopped while idle
      const std::function<void()>* f = task_;
      lk.unlock();
      std::exception_ptr err;
      try {
        (*f)();
      } catch (...) {
        err = std::current_exception();
      }
      lk.lock();
      error_ = err;
      task_ = nullptr;
      cv_.notify_all();
    }
  }
  std::mutex mu_;
  std::condition_variable cv_;
  std::thread th_;
  const std::function<void()>* task_ = nullptr;
  std::exception_ptr error_;
  bool taken_ = false, stop_ = false;
  pid_t owner_ = 0;
};

Helper& helper() {
  static Helper h;
  return h;
}

}  // namespace

bool concurrency_allowed() {
  const char* e = std::getenv("IMUFORGE_DIAG_THREADS");
  if (e && std::strcmp(e, "1") == 0) return false;
  if (e && std::strcmp(e, "2") == 0) return true;
  return std::thread::hardware_concurrency() > 1;
}

void run_concurrently(const std::function<void()>& a, const std::function<void()>& b) {
  if (!concurrency_allowed()) {
    a();
    b();
    return;
  }
  std::exception_ptr ea, eb;
  Helper& h = helper();
  if (h.acquire()) {
    h.start(&a);
    try {
      b();
    } catch (...) {
      eb = std::current_exception();
    }
    ea = h.wait();
  } else {
    std::thread th;
    try {
      th = std::thread([&] {
        try {
          a();
        } catch (...) {
          ea = std::current_exception();
        }
      });
    } catch (const std::system_error&) {
      a();
      b();
      return;
    }
    try {
      b();
    } catch (...) {
      eb = std::current_exception();
    }
    th.join();
  }
  if (ea) std::rethrow_exception(ea);
  if (eb) std::rethrow_exception(eb);
}

}  // namespace imuforge::diagnosis
