// A sample source read ahead on a thread of its own (the diagnosis's passes over a log).
#pragma once

#include <cstddef>
#include <thread>
#include <vector>

#include "host/diagnosis/concurrency.h"
#include "host/diagnosis/diagnose.h"

namespace imuforge::diagnosis {

// Reads the inner source on a thread of its own, up to kDepth batches of `batch` samples ahead of the caller, so that
// reading and decoding the log (and the filters in front of it) overlaps the diagnosis's own work on each pass. The
// caller sees the inner source's samples in the same order, and its errors at the same sample: an exception the
// inner next() throws is rethrown by the next() that reaches that point, after every sample read before it.
// Where concurrency.h allows no second thread, next() and rewind() pass straight through.
//
// The inner source must not be used by anyone else while this one is (its next() runs on the reading thread);
// idle() stops that thread, after which the inner source may be asked for anything (a filter's summary) and next()
// returns false until rewind(). rewind()
// stops it too and rewinds the inner source; reading starts again at the next next(). The inner source may have
// read up to kDepth · batch samples further than the caller when the caller rewinds before the end (a filter that
// restarts its search on such a rewind, glitches.h, then sees a later point; the diagnosis reads every pass to the
// end).
// Cost: O(1) per sample beyond the inner source's (one copy); memory kDepth + 2 batches (about 2.5 MB at the default).
class PrefetchSource : public SampleSource {
 public:
  static constexpr std::size_t kDepth = 3;
  explicit PrefetchSource(SampleSource& inner, std::size_t batch = 4096);
  ~PrefetchSource() override;
  PrefetchSource(const PrefetchSource&) = delete;
  PrefetchSource& operator=(const PrefetchSource&) = delete;
  void rewind() override;
  bool next(Sample& s) override;
  void idle();

 private:
  void produce();

  SampleSource& inner_;
  const std::size_t batch_;
  bool threaded_;
  std::thread reader_;
  ChunkQueue<Sample> queue_;
  // The caller's side: the batch it reads from.
  std::vector<Sample> cur_;
  std::size_t pos_ = 0;
  bool started_ = false, finished_ = false;
};

}  // namespace imuforge::diagnosis
