// imuforge import: real recordings -> log v1 with empty references.
#include <cstdio>

#include <CLI/CLI.hpp>

#include "host/app/command.h"
#include "host/io/staged_file.h"
#include "host/io/import.h"

namespace {

int run_import(int argc, char** argv) {
  CLI::App app{"Convert a real recording to log v1 (no fixture reference, temperature unknown).\n"
               "  xsens-imutk: --in xsens_acc.txt --in-gyro xsens_gyro.txt\n"
               "  mpu6050-csv: --in example_data_calibration.csv",
               "imuforge import"};
  imuforge::io::ImportOptions o;
  std::string out, format = "auto";
  app.add_option("--format", o.format, "xsens-imutk | mpu6050-csv")
      ->required()
      ->check(CLI::IsMember({"xsens-imutk", "mpu6050-csv"}));
  app.add_option("--in", o.in, "input file (xsens: accelerometer file)")->required();
  app.add_option("--in-gyro", o.in_gyro, "xsens: gyro file");
  app.add_option("--out", out, "output log (.csv or .bin)")->required();
  app.add_option("--serial", o.serial, "serial for the metadata (default: from the file name)");
  app.add_option("--rate", o.sample_rate_hz, "override the sample rate (Hz)")->check(CLI::PositiveNumber);
  app.add_option("--log-format", format, "auto|csv|bin")->check(CLI::IsMember({"auto", "csv", "bin"}));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? imuforge::app::kExitOk : imuforge::app::kExitUsage;
  }
  if (o.format == "xsens-imutk" && o.in_gyro.empty()) {
    std::fprintf(stderr, "imuforge import: xsens-imutk needs --in-gyro\n");
    return imuforge::app::kExitUsage;
  }
  using imuforge::io::LogEncoding;
  LogEncoding enc = format == "csv" ? LogEncoding::kCsv : format == "bin" ? LogEncoding::kBinary : LogEncoding::kAuto;
  try {
    if (enc == LogEncoding::kAuto) enc = imuforge::io::encoding_from_path(out);
    imuforge::io::StagedFile staged(out);
    auto s = imuforge::io::import_recording(o, staged.path(), enc);
    staged.commit();
    std::fprintf(stderr, "imported %llu rows, %.1f s at %.3f Hz -> %s\n", static_cast<unsigned long long>(s.rows),
                 s.duration_s, s.sample_rate_hz, out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge import: %s\n", e.what());
    return imuforge::app::exit_code_for(e);
  }
  return imuforge::app::kExitOk;
}

}  // namespace

IMUFORGE_COMMAND(import, "convert a real recording (xsens-imutk, mpu6050-csv) to log v1", run_import);
