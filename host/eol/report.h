// report.html: one self-contained file (inline CSS and SVG, no scripts, no external resources) with the
// verdict, parameters with σ against limits, residuals per segment before/after compensation, the
// temperature profile, σ convergence and the verification results (docs/eol.md "Report").
#pragma once
#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "host/eol/tracker.h"
#include "host/records/record.h"

namespace imuforge::eol {

struct ReportData {
  records::CalibrationRecord rec;       // verdict, parameters, verification, provenance
  std::string db;                       // where the record went
  std::vector<SegmentResidual> residuals;
  std::vector<Tracker::Rejection> rejections;          // static steps the pose detector left out, why
  std::vector<std::pair<double, double>> imu_temp_C;      // (run time s, IMU temperature)
  std::vector<std::pair<double, double>> chamber_temp_C;  // (run time s, chamber air)
  std::vector<std::string> names;
  std::vector<double> sigma_t_s;                          // run time after each segment
  std::vector<Eigen::VectorXd> sigma_hist;                // σ after each segment
  Eigen::VectorXd spec;                                   // σ spec per parameter (0 = none)
  double schedule_time_s = 0.0;
  int segments_total = 0, segments_used = 0, segments_resumed = 0;
  std::string stream_note;                                // loss counters
};

std::string render_report(const ReportData& d);
// Writes text to path atomically (temp file + rename). Throws std::runtime_error on I/O failure.
void write_file_atomic(const std::string& path, const std::string& text);
// Writes atomically (temp file + rename). Throws std::runtime_error on I/O failure.
void write_report(const std::string& path, const ReportData& d);

}  // namespace imuforge::eol
