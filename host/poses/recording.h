// A recording held in memory in SI units, for the consumers that need every sample (static-pose
// detection, reference-free calibration: the motion between poses matters, not only the pose means).
// 56 bytes per sample plus two flags; a hand-held recording is minutes long.
#pragma once

#include <array>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/io/log.h"

namespace imuforge::poses {

class PoseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Recording {
  std::vector<double> t_s;
  std::vector<std::array<double, 6>> y;  // ax ay az (m/s²) gx gy gz (rad/s)
  double gravity_mps2 = 9.80665;
  std::string gravity_source;            // where gravity_mps2 came from (log metadata, site, standard)
  double rate_hz = 0.0;
  // One count in SI per triad (0 = unknown, e.g. synthetic data): floors the noise estimate of the
  // detector for quantised sensors whose noise is below one count.
  double accel_lsb = 0.0, gyro_lsb = 0.0;
  int accel_bits = 16, gyro_bits = 16;   // declared raw word widths (io::LogMeta)
  // Per sample: a count of the triad sits at a limit of its declared word (io::raw_clipped). A clipped
  // rate loses rotation (transitions containing one are left out of gyro fits); a clipped acceleration
  // biases a pose mean (poses containing one are rejected). Empty = nothing clipped.
  std::vector<bool> gyro_clipped, accel_clipped;
  std::size_t clipped_samples = 0;        // gyro
  std::size_t accel_clipped_samples = 0;
};

// Reads a whole log. Gravity: the log's gravity_mps2, else normal gravity at its latitude/height, else
// standard gravity. Throws PoseError (no LSB, too few samples, time not increasing) or io::LogError.
Recording read_recording(io::LogReader& log);
// The same from rows already in memory (a fixture step's segment); what names them in errors.
Recording recording_from_rows(const io::LogMeta& meta, const std::vector<io::LogRow>& rows, const std::string& what);

}  // namespace imuforge::poses
