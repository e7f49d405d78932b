// imuforge import: real recordings -> log v1 with empty references.
#include <cstdio>

#include <CLI/CLI.hpp>

#include "host/app/cli_options.h"
#include "host/app/command.h"
#include "host/io/import.h"
#include "host/poses/detect.h"
#include "host/poses/recording.h"

namespace {

int run_import(int argc, char** argv) {
  CLI::App app{"Convert a real recording to log v1 (no fixture reference, temperature unknown).\n"
               "  xsens-imutk: --in xsens_acc.txt --in-gyro xsens_gyro.txt\n"
               "  mpu6050-csv: --in example_data_calibration.csv\n"
               "  si-csv:      --in rec.csv (t_s,ax,ay,az,gx,gy,gz in m/s^2, rad/s) [--accel-lsb --gyro-lsb --bits]\n"
               "  csv:         --in export.csv --map map.json (column map: docs/formats.md)\n"
               "Then previews the static poses the reference-free front end finds (--explain-poses: every stretch).",
               "imuforge import"};
  imuforge::io::ImportOptions o;
  std::string out, format = "auto";
  app.add_option("--format", o.format, "xsens-imutk | mpu6050-csv | si-csv | csv")
      ->required()
      ->check(CLI::IsMember({"xsens-imutk", "mpu6050-csv", "si-csv", "csv"}));
  app.add_option("--accel-lsb", o.accel_lsb_mps2, "si-csv: m/s^2 per count")->check(CLI::PositiveNumber);
  app.add_option("--gyro-lsb", o.gyro_lsb_rad_s, "si-csv: rad/s per count")->check(CLI::PositiveNumber);
  app.add_option("--bits", o.bits, "si-csv: raw word width declared in the log")->check(CLI::Range(2, 32));
  app.add_option("--map", o.map, "csv: the column map (JSON)");
  bool explain = false, no_preview = false;
  app.add_flag("--explain-poses", explain, "print the pose detector's table (start, end, duration, mean, verdict)");
  app.add_flag("--no-preview", no_preview, "skip the static-pose preview");
  app.add_option("--in", o.in, "input file (xsens: accelerometer file)")->required();
  app.add_option("--in-gyro", o.in_gyro, "xsens: gyro file");
  app.add_option("--out", out, "output log (.csv, .bin or .h5)")->required();
  app.add_option("--serial", o.serial, "serial for the metadata (default: from the file name)");
  app.add_option("--rate", o.sample_rate_hz, "override the sample rate (Hz)")->check(CLI::PositiveNumber);
  imuforge::app::add_log_format_option(app, format);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? imuforge::app::kExitOk : imuforge::app::kExitUsage;
  }
  if (o.format == "xsens-imutk" && o.in_gyro.empty()) {
    std::fprintf(stderr, "imuforge import: xsens-imutk needs --in-gyro\n");
    return imuforge::app::kExitUsage;
  }
  if (o.format == "csv" && o.map.empty()) {
    std::fprintf(stderr, "imuforge import: csv needs --map MAP.json\n");
    return imuforge::app::kExitUsage;
  }
  using imuforge::io::LogEncoding;
  LogEncoding enc = imuforge::io::encoding_from_name(format);
  try {
    if (enc == LogEncoding::kAuto) enc = imuforge::io::encoding_from_path(out);
    auto s = imuforge::io::import_recording(o, out, enc);  // staged inside: nothing left behind on failure
    std::fprintf(stderr, "imported %llu rows, %.1f s at %.3f Hz -> %s\n", static_cast<unsigned long long>(s.rows),
                 s.duration_s, s.sample_rate_hz, out.c_str());
    if (!no_preview) {
      // The same front end as solve/diagnose: what a reference-free calibration would use.
      imuforge::io::LogReader r(out);
      const auto rec = imuforge::poses::read_recording(r);
      const auto det = imuforge::poses::detect_poses(rec);
      if (explain) std::printf("%s", imuforge::poses::explain_table(det).c_str());
      std::fprintf(stderr, "preview: %zu static poses (%.1f s still); %zu gyro samples clipped at the %d-bit word%s\n",
                   det.poses.size(), det.still_s, rec.clipped_samples, rec.gyro_bits,
                   det.poses.size() < 10 ? " (reference-free calibration needs >= 10 poses)" : "");
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge import: %s\n", e.what());
    return imuforge::app::exit_code_for(e);
  }
  return imuforge::app::kExitOk;
}

}  // namespace

IMUFORGE_COMMAND(import, "convert a real recording (xsens-imutk, mpu6050-csv, any CSV with a column map) to log v1", run_import);
