// imuforge compensate: apply a coefficient table to a raw log with the firmware kernel (same source as
// the MCU), writing compensated SI values as CSV (columns: docs/kernel.md).
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include <CLI/CLI.hpp>

#include "host/app/command.h"
#include "host/io/staged_file.h"
#include "host/io/log.h"
#include "host/table/host_kernel.h"
#include "host/table/table_writer.h"

namespace {

int run_compensate(int argc, char** argv) {
  CLI::App app{"Compensate a raw log v1 (CSV or binary) with a coefficient table v1, using the firmware kernel.\n"
               "Output: CSV t_s,segment,temp_C,ax_mps2,ay_mps2,az_mps2,gx_rad_s,gy_rad_s,gz_rad_s,status "
               "(docs/kernel.md).",
               "imuforge compensate"};
  std::string table_path, in_path, out_path, path_name = "f32";
  double step_degC = 0.0;
  double temp_override = std::numeric_limits<double>::quiet_NaN();
  bool quiet = false;
  app.add_option("--table", table_path, "coefficient table v1 (binary, docs/table-format.md)")->required();
  app.add_option("--in", in_path, "raw log v1 (.csv, .bin or .h5)")->required();
  app.add_option("--out", out_path, "compensated CSV to write")->required();
  app.add_option("--path", path_name, "kernel arithmetic: f32 (FPU parts) or fixed (integer-only parts)")
      ->check(CLI::IsMember({"f32", "fixed"}));
  app.add_option("--step", step_degC, "re-interpolation step in degC (0: on every temperature change)")
      ->check(CLI::Range(0.0, 1000.0));
  app.add_option("--temp-c", temp_override, "use this die temperature instead of the log's temp_C");
  app.add_flag("--quiet", quiet, "no summary on stderr");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? imuforge::app::kExitOk : imuforge::app::kExitUsage;
  }
  using namespace imuforge;
  try {
    const fw::Table t = table::read_table_file(table_path);
    const table::KernelPath path = path_name == "fixed" ? table::KernelPath::kFixed : table::KernelPath::kF32;
    io::StagedFile out(out_path);
    const table::CompensateSummary s = table::compensate_log(t, path, step_degC, in_path, out.path(), temp_override);
    out.commit();
    if (!quiet)
      std::fprintf(stderr, "imuforge compensate: %llu rows -> %s (%s path); temperature clamped %llu, accel saturated %llu, "
                   "gyro saturated %llu\n",
                   static_cast<unsigned long long>(s.rows), out_path.c_str(), path_name.c_str(),
                   static_cast<unsigned long long>(s.temp_clamped), static_cast<unsigned long long>(s.accel_saturated),
                   static_cast<unsigned long long>(s.gyro_saturated));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge compensate: error: %s\n", e.what());
    return app::exit_code_for(e);
  }
  return app::kExitOk;
}

}  // namespace

IMUFORGE_COMMAND(compensate, "apply a coefficient table to a raw log with the firmware kernel", run_compensate);
