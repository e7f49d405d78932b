#include "host/records/store.h"

#include <cstdio>
#include <ctime>
#include <fstream>
#include <nlohmann/json.hpp>

#include "host/records/db.h"

namespace imuforge::records {

using detail::Db;
using detail::Row;
using detail::Value;

const std::vector<std::string>& schema_sql() {
  // Portable types only, so this exact text runs on SQLite and PostgreSQL:
  //   VARCHAR/TEXT, INTEGER/BIGINT, DOUBLE PRECISION (SQLite: REAL affinity), BYTEA (SQLite: stores the
  //   bound BLOB as is). Booleans are INTEGER 0/1. Times are ISO-8601 UTC text. Ids are random 128-bit
  //   hex made by the station, so many stations insert without a shared sequence.
  static const std::vector<std::string> ddl = {
      "CREATE TABLE IF NOT EXISTS imuforge_schema (version INTEGER NOT NULL)",
      "CREATE TABLE IF NOT EXISTS calibration ("
      " id VARCHAR(32) PRIMARY KEY,"
      " serial TEXT NOT NULL,"
      " station TEXT NOT NULL,"
      " fixture TEXT NOT NULL,"
      " campaign TEXT NOT NULL,"
      " campaign_sha256 VARCHAR(64) NOT NULL,"
      " software_version TEXT NOT NULL,"
      " firmware_version TEXT NOT NULL,"
      " started_utc VARCHAR(20) NOT NULL,"
      " finished_utc VARCHAR(20) NOT NULL,"
      " pass INTEGER NOT NULL,"
      " reasons TEXT NOT NULL,"
      " table_blob BYTEA,"
      " table_crc32 BIGINT NOT NULL,"
      " log_path TEXT NOT NULL,"
      " log_sha256 VARCHAR(64) NOT NULL,"
      " run_dir TEXT NOT NULL,"
      " campaign_time_s DOUBLE PRECISION NOT NULL,"
      " early_stop INTEGER NOT NULL)",
      "CREATE INDEX IF NOT EXISTS calibration_serial_idx ON calibration (serial)",
      "CREATE TABLE IF NOT EXISTS calibration_parameter ("
      " calibration_id VARCHAR(32) NOT NULL REFERENCES calibration (id),"
      " ord INTEGER NOT NULL,"
      " name TEXT NOT NULL,"
      " value DOUBLE PRECISION NOT NULL,"
      " sigma DOUBLE PRECISION NOT NULL,"
      " limit_abs DOUBLE PRECISION NOT NULL,"
      " sigma_spec DOUBLE PRECISION NOT NULL,"
      " pass INTEGER NOT NULL,"
      " PRIMARY KEY (calibration_id, ord))",
      "CREATE TABLE IF NOT EXISTS calibration_verification ("
      " calibration_id VARCHAR(32) NOT NULL REFERENCES calibration (id),"
      " ord INTEGER NOT NULL,"
      " name TEXT NOT NULL,"
      " residual DOUBLE PRECISION NOT NULL,"
      " limit_abs DOUBLE PRECISION NOT NULL,"
      " pass INTEGER NOT NULL,"
      " PRIMARY KEY (calibration_id, ord))",
      // Batches (added without a version bump: new tables only, older databases gain them here).
      "CREATE TABLE IF NOT EXISTS calibration_batch ("
      " id VARCHAR(32) PRIMARY KEY,"
      " station TEXT NOT NULL,"
      " campaign TEXT NOT NULL,"
      " campaign_sha256 VARCHAR(64) NOT NULL,"
      " software_version TEXT NOT NULL,"
      " started_utc VARCHAR(20) NOT NULL,"
      " finished_utc VARCHAR(20) NOT NULL,"
      " units_total INTEGER NOT NULL,"
      " units_passed INTEGER NOT NULL)",
      "CREATE TABLE IF NOT EXISTS calibration_batch_unit ("
      " batch_id VARCHAR(32) NOT NULL REFERENCES calibration_batch (id),"
      " ord INTEGER NOT NULL,"
      " slot TEXT NOT NULL,"
      " serial TEXT NOT NULL,"
      " calibration_id VARCHAR(32) NOT NULL,"
      " pass INTEGER NOT NULL,"
      " reasons TEXT NOT NULL,"
      " outliers TEXT NOT NULL,"
      " PRIMARY KEY (batch_id, ord))",
  };
  return ddl;
}

std::string new_record_id() {
  unsigned char b[16] = {};
  std::ifstream f("/dev/urandom", std::ios::binary);
  if (!f.read(reinterpret_cast<char*>(b), sizeof b)) throw RecordError("records: cannot read /dev/urandom for a record id");
  char hex[33];
  for (int i = 0; i < 16; ++i) std::snprintf(hex + 2 * i, 3, "%02x", b[i]);
  return std::string(hex, 32);
}

bool is_postgres_url(const std::string& s) {
  return s.rfind("postgresql://", 0) == 0 || s.rfind("postgres://", 0) == 0;
}

namespace {

class SqlStore final : public RecordStore {
 public:
  explicit SqlStore(std::unique_ptr<Db> db) : db_(std::move(db)) {}

  void ensure_schema() override {
    db_->exec("BEGIN");
    try {
      for (const auto& s : schema_sql()) db_->exec(s);
      auto rows = db_->exec("SELECT version FROM imuforge_schema");
      if (rows.empty()) {
        db_->exec("INSERT INTO imuforge_schema (version) VALUES ($1)", {Value::of(std::int64_t{kSchemaVersion})});
      } else if (rows[0][0].as_int() != kSchemaVersion) {
        throw RecordError(backend() + ": database schema version " + std::to_string(rows[0][0].as_int()) +
                          ", this imuforge writes version " + std::to_string(kSchemaVersion));
      }
      db_->exec("COMMIT");
    } catch (...) {
      rollback();
      throw;
    }
  }

  std::string insert(CalibrationRecord& r) override {
    if (r.id.empty()) r.id = new_record_id();
    nlohmann::json reasons = r.reasons;
    db_->exec("BEGIN");
    try {
      db_->exec(
          "INSERT INTO calibration (id, serial, station, fixture, campaign, campaign_sha256, software_version,"
          " firmware_version, started_utc, finished_utc, pass, reasons, table_blob, table_crc32, log_path,"
          " log_sha256, run_dir, campaign_time_s, early_stop)"
          " VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, $16, $17, $18, $19)",
          {Value::of(r.id), Value::of(r.serial), Value::of(r.station), Value::of(r.fixture), Value::of(r.campaign),
           Value::of(r.campaign_sha256), Value::of(r.software_version), Value::of(r.firmware_version),
           Value::of(r.started_utc), Value::of(r.finished_utc), Value::of(std::int64_t{r.pass ? 1 : 0}),
           Value::of(reasons.dump()), Value::of(r.table_blob), Value::of(std::int64_t{r.table_crc32}),
           Value::of(r.log_path), Value::of(r.log_sha256), Value::of(r.run_dir), Value::of(r.campaign_time_s),
           Value::of(std::int64_t{r.early_stop ? 1 : 0})});
      for (std::size_t k = 0; k < r.parameters.size(); ++k) {
        const auto& p = r.parameters[k];
        db_->exec(
            "INSERT INTO calibration_parameter (calibration_id, ord, name, value, sigma, limit_abs, sigma_spec, pass)"
            " VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
            {Value::of(r.id), Value::of(static_cast<std::int64_t>(k)), Value::of(p.name), Value::of(p.value),
             Value::of(p.sigma), Value::of(p.limit_abs), Value::of(p.sigma_spec),
             Value::of(std::int64_t{p.pass ? 1 : 0})});
      }
      for (std::size_t k = 0; k < r.verification.size(); ++k) {
        const auto& v = r.verification[k];
        db_->exec(
            "INSERT INTO calibration_verification (calibration_id, ord, name, residual, limit_abs, pass)"
            " VALUES ($1, $2, $3, $4, $5, $6)",
            {Value::of(r.id), Value::of(static_cast<std::int64_t>(k)), Value::of(v.name), Value::of(v.residual),
             Value::of(v.limit), Value::of(std::int64_t{v.pass ? 1 : 0})});
      }
      db_->exec("COMMIT");
    } catch (...) {
      rollback();
      throw;
    }
    return r.id;
  }

  CalibrationRecord get(const std::string& id) override {
    auto rows = db_->exec(
        "SELECT id, serial, station, fixture, campaign, campaign_sha256, software_version, firmware_version,"
        " started_utc, finished_utc, pass, reasons, table_blob, table_crc32, log_path, log_sha256, run_dir,"
        " campaign_time_s, early_stop FROM calibration WHERE id = $1",
        {Value::of(id)}, {12});
    if (rows.empty()) throw RecordError(backend() + ": no calibration record with id " + id);
    const Row& x = rows[0];
    CalibrationRecord r;
    r.id = x[0].as_text();
    r.serial = x[1].as_text();
    r.station = x[2].as_text();
    r.fixture = x[3].as_text();
    r.campaign = x[4].as_text();
    r.campaign_sha256 = x[5].as_text();
    r.software_version = x[6].as_text();
    r.firmware_version = x[7].as_text();
    r.started_utc = x[8].as_text();
    r.finished_utc = x[9].as_text();
    r.pass = x[10].as_int() != 0;
    try {
      r.reasons = nlohmann::json::parse(x[11].as_text()).get<std::vector<std::string>>();
    } catch (const std::exception& e) {
      throw RecordError(backend() + ": record " + id + " has malformed reasons: " + e.what());
    }
    r.table_blob = x[12].as_blob();
    r.table_crc32 = static_cast<std::uint32_t>(x[13].as_int());
    r.log_path = x[14].as_text();
    r.log_sha256 = x[15].as_text();
    r.run_dir = x[16].as_text();
    r.campaign_time_s = x[17].as_real();
    r.early_stop = x[18].as_int() != 0;
    for (const auto& p : db_->exec("SELECT name, value, sigma, limit_abs, sigma_spec, pass FROM calibration_parameter"
                                   " WHERE calibration_id = $1 ORDER BY ord",
                                   {Value::of(id)})) {
      r.parameters.push_back({p[0].as_text(), p[1].as_real(), p[2].as_real(), p[3].as_real(), p[4].as_real(),
                              p[5].as_int() != 0});
    }
    for (const auto& v : db_->exec("SELECT name, residual, limit_abs, pass FROM calibration_verification"
                                   " WHERE calibration_id = $1 ORDER BY ord",
                                   {Value::of(id)})) {
      r.verification.push_back({v[0].as_text(), v[1].as_real(), v[2].as_real(), v[3].as_int() != 0});
    }
    return r;
  }

  std::vector<RecordSummary> find_by_serial(const std::string& serial) override {
    std::vector<RecordSummary> out;
    for (const auto& x : db_->exec("SELECT id, serial, station, finished_utc, pass FROM calibration"
                                   " WHERE serial = $1 ORDER BY finished_utc, id",
                                   {Value::of(serial)}))
      out.push_back({x[0].as_text(), x[1].as_text(), x[2].as_text(), x[3].as_text(), x[4].as_int() != 0});
    return out;
  }

  std::string insert_batch(BatchRecord& b) override {
    if (b.id.empty()) b.id = new_record_id();
    db_->exec("BEGIN");
    try {
      db_->exec(
          "INSERT INTO calibration_batch (id, station, campaign, campaign_sha256, software_version, started_utc,"
          " finished_utc, units_total, units_passed) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9)",
          {Value::of(b.id), Value::of(b.station), Value::of(b.campaign), Value::of(b.campaign_sha256),
           Value::of(b.software_version), Value::of(b.started_utc), Value::of(b.finished_utc),
           Value::of(static_cast<std::int64_t>(b.units.size())), Value::of(static_cast<std::int64_t>(b.units_passed))});
      for (std::size_t k = 0; k < b.units.size(); ++k) {
        const auto& u = b.units[k];
        db_->exec(
            "INSERT INTO calibration_batch_unit (batch_id, ord, slot, serial, calibration_id, pass, reasons, outliers)"
            " VALUES ($1, $2, $3, $4, $5, $6, $7, $8)",
            {Value::of(b.id), Value::of(static_cast<std::int64_t>(k)), Value::of(u.slot), Value::of(u.serial),
             Value::of(u.calibration_id), Value::of(std::int64_t{u.pass ? 1 : 0}),
             Value::of(nlohmann::json(u.reasons).dump()), Value::of(nlohmann::json(u.outliers).dump())});
      }
      db_->exec("COMMIT");
    } catch (...) {
      rollback();
      throw;
    }
    return b.id;
  }

  BatchRecord get_batch(const std::string& id) override {
    auto rows = db_->exec(
        "SELECT id, station, campaign, campaign_sha256, software_version, started_utc, finished_utc, units_passed"
        " FROM calibration_batch WHERE id = $1",
        {Value::of(id)});
    if (rows.empty()) throw RecordError(backend() + ": no batch record with id " + id);
    BatchRecord b;
    const Row& x = rows[0];
    b.id = x[0].as_text();
    b.station = x[1].as_text();
    b.campaign = x[2].as_text();
    b.campaign_sha256 = x[3].as_text();
    b.software_version = x[4].as_text();
    b.started_utc = x[5].as_text();
    b.finished_utc = x[6].as_text();
    b.units_passed = static_cast<int>(x[7].as_int());
    for (const auto& u : db_->exec("SELECT slot, serial, calibration_id, pass, reasons, outliers FROM calibration_batch_unit"
                                   " WHERE batch_id = $1 ORDER BY ord",
                                   {Value::of(id)})) {
      BatchUnitRecord r{u[0].as_text(), u[1].as_text(), u[2].as_text(), u[3].as_int() != 0, {}, {}};
      try {
        r.reasons = nlohmann::json::parse(u[4].as_text()).get<std::vector<std::string>>();
        r.outliers = nlohmann::json::parse(u[5].as_text()).get<std::vector<std::string>>();
      } catch (const std::exception& e) {
        throw RecordError(backend() + ": batch " + id + " has a malformed unit row: " + e.what());
      }
      b.units.push_back(std::move(r));
    }
    return b;
  }

  std::string backend() const override { return db_->backend(); }

 private:
  void rollback() noexcept {
    try {
      db_->exec("ROLLBACK");
    } catch (...) {
    }
  }
  std::unique_ptr<Db> db_;
};

}  // namespace

std::unique_ptr<RecordStore> open_store(const std::string& url_or_path) {
  if (url_or_path.empty()) throw RecordError("records: empty database path");
  if (is_postgres_url(url_or_path)) return std::make_unique<SqlStore>(detail::open_postgres(url_or_path));
  std::string path = url_or_path;
  if (path.rfind("sqlite:", 0) == 0) path = path.substr(7);
  return std::make_unique<SqlStore>(detail::open_sqlite(path));
}

}  // namespace imuforge::records
