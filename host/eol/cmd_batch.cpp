// `imuforge batch`: solve the logs of a batch of units on a thread pool, judge each against the
// station's limits with honest σ, and write the batch report (host/eol/batch.h, docs/eol.md "Batches").
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "host/app/command.h"
#include "host/eol/batch.h"
#include "host/eol/report.h"
#include "host/eol/station.h"
#include "host/io/campaign_file.h"
#include "host/records/store.h"
#include "host/solver/sha256.h"

namespace {

int run_batch(int argc, char** argv) {
  using namespace imuforge;
  namespace fs = std::filesystem;
  CLI::App app{"Solve a batch of units' logs in parallel: per-unit cal.json and verdict, batch.json, batch-report.html "
               "with each parameter's spread and outliers. Exit 0 when every unit passes, 1 otherwise, 2 usage."};
  std::string station_path, campaign_path, out, db;
  std::vector<std::string> unit_args;
  int threads = 0;
  app.add_option("--station", station_path, "station file (limits, model, fixture_tolerance)")->required();
  app.add_option("--campaign", campaign_path, "campaign file (table geometry)")->required();
  app.add_option("--unit", unit_args, "SLOT:SERIAL:LOG, once per unit")->required();
  app.add_option("--out", out, "output folder")->required();
  app.add_option("--db", db, "record store (SQLite path or postgresql://...): one record per unit and the batch record");
  app.add_option("--threads", threads, "solver threads (default: the cores)")->check(CLI::Range(0, 256));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? app::kExitOk : app::kExitUsage;
  }
  try {
    std::vector<eol::BatchUnit> units;
    for (const auto& a : unit_args) {
      const auto c1 = a.find(':'), c2 = c1 == std::string::npos ? c1 : a.find(':', c1 + 1);
      if (c2 == std::string::npos) {
        std::fprintf(stderr, "imuforge batch: --unit '%s': expected SLOT:SERIAL:LOG\n", a.c_str());
        return app::kExitUsage;
      }
      units.push_back({a.substr(0, c1), a.substr(c1 + 1, c2 - c1 - 1), a.substr(c2 + 1)});
    }
    const eol::StationConfig st = eol::load_station(station_path);
    if (st.model_path.empty()) throw std::invalid_argument("station " + station_path + ": \"model\" is required");
    const std::string model_path = fs::path(st.model_path).is_absolute() ? st.model_path : (fs::path(st.dir) / st.model_path).string();
    const model::ModelSpec spec = model::load_model_spec(model_path);
    const physics::Campaign camp = io::load_campaign(campaign_path);
    eol::BatchOptions bo;
    bo.threads = threads;
    const std::string started = records::utc_now_iso8601();
    const eol::BatchOutcome b = eol::solve_batch(units, st, spec, camp, bo);
    fs::create_directories(out);
    for (const auto& u : b.units)
      if (u.solved) {
        fs::create_directories(fs::path(out) / u.slot);
        eol::write_file_atomic((fs::path(out) / u.slot / "cal.json").string(), u.cal.dump(2) + "\n");
      }
    eol::write_file_atomic((fs::path(out) / "batch.json").string(), eol::batch_to_json(b).dump(2) + "\n");
    const std::string report = (fs::path(out) / "batch-report.html").string();
    eol::write_file_atomic(report, eol::render_batch_report(b, "Batch " + st.name));
    std::printf("batch: %d of %zu units pass (%d threads, %.1f s wall)\n", b.passed, b.units.size(), b.threads, b.wall_s);
    for (const auto& u : b.units) {
      std::printf("  %-8s %-12s %s", u.slot.c_str(), u.serial.c_str(), u.pass ? "PASS" : "FAIL");
      if (!u.reasons.empty()) std::printf("  %s%s", u.reasons[0].c_str(), u.reasons.size() > 1 ? " (+more)" : "");
      if (!u.outliers.empty()) std::printf("  outlier: %zu parameter(s), first %s", u.outliers.size(), u.outliers[0].c_str());
      std::printf("\n");
    }
    std::printf("report %s\n", report.c_str());
    if (!db.empty()) {
      auto store = records::open_store(db);
      const std::string id = eol::record_batch(
          *store, b, {st.name, camp.name, solver::sha256_file_hex(campaign_path), started, records::utc_now_iso8601(), ""});
      std::printf("batch record %s in %s (%s)\n", id.c_str(), db.c_str(), store->backend().c_str());
    }
    return b.passed == static_cast<int>(b.units.size()) ? app::kExitOk : app::kExitFailed;
  } catch (const records::RecordError& e) {
    std::fprintf(stderr, "imuforge batch: records: %s\n", e.what());
    return app::kExitPeer;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "imuforge batch: %s\n", e.what());
    return app::kExitFailed;
  }
}

}  // namespace

IMUFORGE_COMMAND(batch, "solve a batch of units' logs in parallel; per-unit verdicts and the batch report", run_batch);
