// The values a streaming filter of the log found on its first pass (glitches.h, dropouts.h) and replays on every
// later pass: (row, axis, value) in ascending (row, axis) once sorted, applied to each row as the pass goes by.
// Cost: O(fixes at the row) per row replayed; O(n log n) to sort; memory one entry per fix.
#pragma once

#include <algorithm>
#include <vector>

#include "host/diagnosis/diagnose.h"

namespace imuforge::diagnosis {

class RowFixes {
 public:
  struct Fix {
    long long row;
    int axis;
    double value;
  };
  void clear() { fixes_.clear(); }
  void push(long long row, int axis, double value) { fixes_.push_back({row, axis, value}); }
  // Before the first replay.
  void sort() {
    std::sort(fixes_.begin(), fixes_.end(), [](const Fix& p, const Fix& q) { return p.row != q.row ? p.row < q.row : p.axis < q.axis; });
  }
  const std::vector<Fix>& all() const { return fixes_; }
  // A replayed pass starts at row 0.
  void rewind() {
    row_ = 0;
    next_ = 0;
  }
  // The next row of a replayed pass: its fixes applied.
  void apply(Sample& s) {
    while (next_ < fixes_.size() && fixes_[next_].row == row_) {
      s.y[fixes_[next_].axis] = fixes_[next_].value;
      ++next_;
    }
    ++row_;
  }

 private:
  std::vector<Fix> fixes_;
  long long row_ = 0;
  std::size_t next_ = 0;
};

}  // namespace imuforge::diagnosis
