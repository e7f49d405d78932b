// The progress display of a run: one line per segment (elapsed, remaining, worst σ/spec) and, at the end
// of each plateau, every parameter's σ against its spec.
#pragma once
#include <Eigen/Core>
#include <cstdio>
#include <string>
#include <vector>

namespace imuforge::eol {

std::string format_hms(double s);

struct ProgressState {
  int phase = 0, phases = 0;
  double setpoint_C = 0.0;
  int done_steps = 0, total_steps = 0;
  std::string label;
  double wall_elapsed_s = 0.0;
  double fixture_elapsed_s = 0.0;
  double fixture_remaining_s = 0.0;  // full remaining schedule (an upper bound with early stop)
  const std::vector<std::string>* names = nullptr;
  Eigen::VectorXd sigma;             // current σ (inf = not yet observable)
  Eigen::VectorXd spec;              // 0 = no spec
};

// "[####------] 40% p2/4 +25.0C step 12/60 'tumble 7' | wall 00:00:31 fixture 01:02:00 | left <= 00:40:00
//  (wall ~00:00:20) | sigma/spec worst gyro.scale.z 2.31, 20/27 met"
std::string progress_line(const ProgressState& s);
// One line per parameter: name, σ, spec, ratio, a bar.
std::string sigma_table(const ProgressState& s);

}  // namespace imuforge::eol
