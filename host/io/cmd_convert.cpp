// imuforge convert: a log v1 from one encoding to another (CSV, binary, HDF5), content unchanged.
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "host/app/cli_options.h"
#include "host/app/command.h"
#include "host/io/log.h"
#include "host/io/staged_file.h"

namespace {

int run_convert(int argc, char** argv) {
  CLI::App app{"Convert a log v1 between its encodings (docs/formats.md): CSV, binary, HDF5.\n"
               "Metadata and every row are carried over bit for bit; the output is written to a temporary\n"
               "file and renamed, so a failure leaves no partial output.",
               "imuforge convert"};
  std::string in, out, format = "auto";
  app.add_option("--in", in, "input log (any encoding, detected from its first bytes)")->required();
  app.add_option("--out", out, "output log (.csv, .bin or .h5)")->required();
  imuforge::app::add_log_format_option(app, format);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? imuforge::app::kExitOk : imuforge::app::kExitUsage;
  }
  namespace io = imuforge::io;
  try {
    io::LogEncoding enc = io::encoding_from_name(format);
    if (enc == io::LogEncoding::kAuto) enc = io::encoding_from_path(out);
    io::LogReader r(in);
    io::StagedFile staged(out);  // a failure halfway leaves no output
    io::LogWriter w(staged.path(), r.meta(), enc);
    io::LogRow row;
    while (r.next(row)) w.write(row);
    w.close();
    staged.commit();
    std::fprintf(stderr, "converted %llu rows -> %s\n", static_cast<unsigned long long>(r.rows_read()), out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge convert: %s\n", e.what());
    return imuforge::app::exit_code_for(e);  // 2 on a bad input file, like every other command
  }
  return imuforge::app::kExitOk;
}

}  // namespace

IMUFORGE_COMMAND(convert, "convert a log between CSV, binary and HDF5", run_convert);
