// `imuforge run`: one end-of-line calibration on a station (host/eol/runner.h, docs/eol.md).
#include <CLI/CLI.hpp>
#include <cstdio>

#include "host/app/command.h"
#include "host/can/client.h"
#include "host/fixture/fixture.h"
#include "host/eol/adapters.h"
#include "host/eol/journal.h"
#include "host/eol/runner.h"
#include "host/eol/station.h"
#include "host/eol/station_runner.h"
#include "host/records/store.h"

namespace {

// A multi-slot station: every unit through one campaign (host/eol/station_runner.h). Exit 0 when every
// unit passes, 1 otherwise (each unit's verdict on stdout, its reasons on stderr).
int run_station(const imuforge::eol::RunOptions& o, const imuforge::eol::StationConfig& st, const std::string& station_path) {
  using namespace imuforge;
  eol::StationRunOptions so;
  so.out_dir = o.out_dir;
  so.campaign_path = o.campaign_path;
  so.station_path = o.station_path;
  so.db = o.db;
  so.resume = o.resume;
  so.early_stop = o.early_stop;
  so.progress = o.progress;
  std::unique_ptr<eol::Bench> bench;
  try {
    bench = eol::make_fixture_bench(st);
  } catch (const eol::StationError& e) {
    throw eol::StationError(station_path + ": " + e.what());
  }
  eol::StationRunner runner(so, *bench, [](const eol::StationConfig& s) { return eol::make_can_device(s); },
                            [] { return eol::make_table_ops(); });
  eol::StationRunResult r = runner.run();
  for (const auto& u : r.units) {
    std::printf("%-8s %s %-12s record %s\n", u.slot.c_str(), u.pass ? "PASS" : "FAIL", u.serial.empty() ? "-" : u.serial.c_str(),
                u.record_id.c_str());
    for (const auto& x : u.reasons) std::fprintf(stderr, "%s FAIL: %s\n", u.slot.c_str(), x.c_str());
  }
  std::printf("%d of %zu units PASS  campaign %.0f s%s  batch %s\nreport %s\n", r.passed, r.units.size(), r.campaign_time_s,
              r.early_stopped ? " (stopped early)" : "", r.batch_id.c_str(), r.batch_report_path.c_str());
  return r.passed == static_cast<int>(r.units.size()) ? app::kExitOk : app::kExitFailed;
}

int run_run(int argc, char** argv) {
  using namespace imuforge;
  CLI::App app{"End-of-line calibration: fixture -> samples over CAN -> solve -> table flashed, verified, recorded, "
               "reported. Exit 0 PASS, 1 FAIL (reasons on stderr and in the record), 2 usage, 3 fixture/CAN/database."};
  eol::RunOptions o;
  bool resume_flag = false, full = false, quiet = false;
  std::string resume_dir;
  app.add_option("--campaign", o.campaign_path, "campaign file (docs/formats.md)");
  app.add_option("--station", o.station_path, "station file (docs/eol.md)");
  app.add_option("--serial", o.serial, "the device serial expected on the bus");
  app.add_option("--out", o.out_dir, "run folder: journal, segments, log, cal.json, table.bin, report.html");
  auto* res = app.add_option("--resume", resume_dir, "continue the run in this folder from its journal");
  app.add_option("--db", o.db, "record store: SQLite path or postgresql://... (default: the station's records.db)");
  app.add_flag("--full-schedule", full, "run every step even when every sigma already meets its spec");
  app.add_flag("--quiet", quiet, "no progress display");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? app::kExitOk : app::kExitUsage;
  }
  (void)resume_flag;
  if (*res) {
    o.resume = true;
    if (!o.out_dir.empty() && o.out_dir != resume_dir) {
      std::fprintf(stderr, "imuforge run: --resume DIR and --out differ\n");
      return app::kExitUsage;
    }
    o.out_dir = resume_dir;
  } else if (o.campaign_path.empty() || o.station_path.empty() || o.out_dir.empty()) {
    std::fprintf(stderr, "imuforge run: --campaign, --station and --out are required (and --serial for a "
                         "single-unit station), or --resume DIR\n");
    return app::kExitUsage;
  }
  o.early_stop = !full;
  o.progress = quiet ? nullptr : stderr;
  try {
    std::string station_path = o.station_path;
    bool station_run = false;  // a multi-unit run (its run_start lists the slots)
    if (o.resume) {
      auto jc = eol::read_journal(o.out_dir + "/journal.log");
      const std::string jp = o.out_dir + "/journal.log";
      if (jc.entries.empty() || !jc.entries[0].is_object() || jc.entries[0].value("type", "") != "run_start" ||
          !jc.entries[0].contains("station_path") || !jc.entries[0]["station_path"].is_string()) {
        throw eol::JournalCorruptError("journal " + jp + " line 1: no run_start entry with a station_path: nothing to resume");
      }
      if (station_path.empty()) station_path = jc.entries[0]["station_path"].get<std::string>();
      station_run = jc.entries[0].contains("slots");
    }
    eol::StationConfig st = eol::load_station(station_path);
    if (!o.resume) station_run = st.slots.size() > 1;
    if (station_run) return run_station(o, st, station_path);
    if (o.serial.empty() && !o.resume) {
      std::fprintf(stderr, "imuforge run: --serial is required for a single-unit station\n");
      return app::kExitUsage;
    }
    std::unique_ptr<eol::Bench> bench;
    std::unique_ptr<eol::Device> dev;
    try {
      bench = eol::make_fixture_bench(st);
      dev = eol::make_can_device(st);
    } catch (const eol::StationError& e) {  // what the adapters find missing is still the station file's
      throw eol::StationError(station_path + ": " + e.what());
    }
    auto ops = eol::make_table_ops();
    eol::Runner runner(o, *bench, *dev, *ops);
    eol::RunResult r = runner.run();
    std::printf("%s %s  campaign %.0f s%s  record %s\nreport %s\n", r.pass ? "PASS" : "FAIL", r.record.serial.c_str(),
                r.campaign_time_s, r.early_stopped ? " (stopped early)" : "", r.record_id.c_str(), r.report_path.c_str());
    for (const auto& x : r.reasons) std::fprintf(stderr, "FAIL: %s\n", x.c_str());
    return r.pass ? app::kExitOk : app::kExitFailed;
  } catch (const eol::PeerError& e) {
    std::fprintf(stderr, "imuforge run: peer failure: %s\n", e.what());
    return app::kExitPeer;
  } catch (const records::RecordError& e) {
    std::fprintf(stderr, "imuforge run: records: %s\n", e.what());
    return app::kExitPeer;
  } catch (const fixture::FixtureError& e) {
    std::fprintf(stderr, "imuforge run: fixture: %s\n", e.what());
    return app::kExitPeer;
  } catch (const can::Error& e) {
    std::fprintf(stderr, "imuforge run: CAN: %s\n", e.what());
    return e.is_peer_refusal() ? app::kExitFailed : app::kExitPeer;
  } catch (const std::exception& e) {
    // Station/campaign/model problems, a damaged journal: bad input.
    std::fprintf(stderr, "imuforge run: %s\n", e.what());
    return app::exit_code_for(e);
  }
}

}  // namespace

IMUFORGE_COMMAND(run, "end-of-line calibration of one IMU on a station (resumable; records; report.html)", run_run);
