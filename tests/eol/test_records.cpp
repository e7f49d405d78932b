// Records: the same schema and SQL round-trip a calibration record on SQLite and on a real PostgreSQL.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>

#include "host/records/store.h"
#include "tests/eol/pg_server.h"

// A folder's tests build one unity program (tests/CMakeLists.txt): this file's names stay its own.
namespace eol_test_records {

using namespace imuforge::records;

namespace {

CalibrationRecord sample_record(const std::string& serial, bool pass) {
  CalibrationRecord r;
  r.serial = serial;
  r.station = "station-A";
  r.fixture = "table-1 + chamber-1";
  r.campaign = "eol-demo";
  r.campaign_sha256 = std::string(64, 'a');
  r.software_version = "0.1.0";
  r.firmware_version = "fw-0.1.0";
  r.started_utc = "2026-11-22T10:00:00Z";
  r.finished_utc = "2026-11-22T10:02:00Z";
  r.pass = pass;
  if (!pass) r.reasons = {"accel.bias.x: |value| 0.5 > limit 0.2", "quote ' and \"double\" survive"};
  r.parameters = {{"accel.bias.x", 0.012345678901234567, 1.5e-5, 0.2, 2e-5, true},
                  {"gyro.scale.z", -3.25e-4, 7.1e-7, 1e-2, 1e-6, true},
                  {"accel.misalign.xy", 1.0 / 3.0, 0.0, 0.0, 0.0, pass}};
  r.verification = {{"readback", 0.0, 0.0, true}, {"ver00.accel.x", -1.25e-4, 2e-3, true}};
  // Every byte value, including NUL and 0x5C, must survive the blob path.
  for (int i = 0; i < 600; ++i) r.table_blob.push_back(static_cast<std::uint8_t>(i * 7));
  r.table_crc32 = 0xDEADBEEFu;
  r.log_path = "/tmp/run/log.csv";
  r.log_sha256 = std::string(64, 'b');
  r.run_dir = "/tmp/run";
  r.campaign_time_s = 1234.5;
  r.early_stop = true;
  return r;
}

void expect_equal(const CalibrationRecord& a, const CalibrationRecord& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.serial, b.serial);
  EXPECT_EQ(a.station, b.station);
  EXPECT_EQ(a.fixture, b.fixture);
  EXPECT_EQ(a.campaign, b.campaign);
  EXPECT_EQ(a.campaign_sha256, b.campaign_sha256);
  EXPECT_EQ(a.software_version, b.software_version);
  EXPECT_EQ(a.firmware_version, b.firmware_version);
  EXPECT_EQ(a.started_utc, b.started_utc);
  EXPECT_EQ(a.finished_utc, b.finished_utc);
  EXPECT_EQ(a.pass, b.pass);
  EXPECT_EQ(a.reasons, b.reasons);
  EXPECT_EQ(a.table_blob, b.table_blob);
  EXPECT_EQ(a.table_crc32, b.table_crc32);
  EXPECT_EQ(a.log_path, b.log_path);
  EXPECT_EQ(a.log_sha256, b.log_sha256);
  EXPECT_EQ(a.run_dir, b.run_dir);
  EXPECT_EQ(a.campaign_time_s, b.campaign_time_s);
  EXPECT_EQ(a.early_stop, b.early_stop);
  ASSERT_EQ(a.parameters.size(), b.parameters.size());
  for (std::size_t k = 0; k < a.parameters.size(); ++k) {
    EXPECT_EQ(a.parameters[k].name, b.parameters[k].name);
    EXPECT_EQ(a.parameters[k].value, b.parameters[k].value) << "exact double round trip";
    EXPECT_EQ(a.parameters[k].sigma, b.parameters[k].sigma);
    EXPECT_EQ(a.parameters[k].limit_abs, b.parameters[k].limit_abs);
    EXPECT_EQ(a.parameters[k].sigma_spec, b.parameters[k].sigma_spec);
    EXPECT_EQ(a.parameters[k].pass, b.parameters[k].pass);
  }
  ASSERT_EQ(a.verification.size(), b.verification.size());
  for (std::size_t k = 0; k < a.verification.size(); ++k) {
    EXPECT_EQ(a.verification[k].name, b.verification[k].name);
    EXPECT_EQ(a.verification[k].residual, b.verification[k].residual);
    EXPECT_EQ(a.verification[k].limit, b.verification[k].limit);
    EXPECT_EQ(a.verification[k].pass, b.verification[k].pass);
  }
}

void round_trip(RecordStore& store) {
  store.ensure_schema();
  store.ensure_schema();  // idempotent
  auto r1 = sample_record("SN-1", true);
  auto r2 = sample_record("SN-1", false);
  r2.finished_utc = "2026-11-22T11:00:00Z";
  auto r3 = sample_record("SN-2", true);
  std::string id1 = store.insert(r1);
  store.insert(r2);
  store.insert(r3);
  ASSERT_EQ(id1.size(), 32u);
  EXPECT_NE(r1.id, r2.id);
  expect_equal(r1, store.get(r1.id));
  expect_equal(r2, store.get(r2.id));
  auto list = store.find_by_serial("SN-1");
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].id, r1.id);
  EXPECT_TRUE(list[0].pass);
  EXPECT_FALSE(list[1].pass);
  EXPECT_TRUE(store.find_by_serial("nope").empty());
  EXPECT_THROW(store.get("0123"), RecordError);
  // The same id twice is a constraint violation, and the failed transaction leaves nothing behind.
  auto dup = sample_record("SN-3", true);
  dup.id = r3.id;
  EXPECT_THROW(store.insert(dup), RecordError);
  EXPECT_TRUE(store.find_by_serial("SN-3").empty());
  // A batch: its units' records (one without: a dead unit), then the batch in one transaction.
  BatchRecord b;
  b.station = "station-07";
  b.campaign = "eol";
  b.campaign_sha256 = std::string(64, 'a');
  b.software_version = "test";
  b.started_utc = "2026-11-22T10:00:00Z";
  b.finished_utc = "2026-11-22T13:00:00Z";
  b.units_passed = 2;
  b.units = {{"slot01", "SN-1", r1.id, true, {}, {}},
             {"slot02", "SN-2", r3.id, true, {}, {"accel.scale.x"}},
             {"slot03", "SN-9", "", false, {"no calibration: node 3 never answered"}, {}}};
  const std::string bid = store.insert_batch(b);
  ASSERT_EQ(bid.size(), 32u);
  const BatchRecord g = store.get_batch(bid);
  EXPECT_EQ(g.station, b.station);
  EXPECT_EQ(g.finished_utc, b.finished_utc);
  EXPECT_EQ(g.units_passed, 2);
  ASSERT_EQ(g.units.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(g.units[k].slot, b.units[k].slot);
    EXPECT_EQ(g.units[k].serial, b.units[k].serial);
    EXPECT_EQ(g.units[k].calibration_id, b.units[k].calibration_id);
    EXPECT_EQ(g.units[k].pass, b.units[k].pass);
    EXPECT_EQ(g.units[k].reasons, b.units[k].reasons);
    EXPECT_EQ(g.units[k].outliers, b.units[k].outliers);
  }
  EXPECT_THROW(store.get_batch("0123"), RecordError);
  BatchRecord again = b;  // same id: refused, nothing half-written
  again.units.push_back({"slot04", "SN-10", "", false, {}, {}});
  EXPECT_THROW(store.insert_batch(again), RecordError);
  EXPECT_EQ(store.get_batch(bid).units.size(), 3u);
}

}  // namespace

TEST(Records, SqliteRoundTrip) {
  auto dir = std::filesystem::temp_directory_path() / ("imuforge-rec-" + new_record_id());
  std::filesystem::create_directories(dir);
  {
    auto store = open_store((dir / "records.sqlite").string());
    EXPECT_EQ(store->backend(), "sqlite");
    round_trip(*store);
  }
  {
    // Reopening the file sees the same records (and the "sqlite:" prefix means the same thing).
    auto store = open_store("sqlite:" + (dir / "records.sqlite").string());
    store->ensure_schema();
    EXPECT_EQ(store->find_by_serial("SN-1").size(), 2u);
  }
  std::filesystem::remove_all(dir);
}

TEST(Records, SqliteUnopenablePathIsAClearError) {
  try {
    open_store("/nonexistent-dir/x/records.sqlite");
    FAIL() << "expected RecordError";
  } catch (const RecordError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x/records.sqlite"), std::string::npos) << e.what();
  }
}

TEST(Records, SchemaVersionMismatchIsRefused) {
  auto dir = std::filesystem::temp_directory_path() / ("imuforge-rec-" + new_record_id());
  std::filesystem::create_directories(dir);
  auto path = (dir / "r.sqlite").string();
  open_store(path)->ensure_schema();
  ASSERT_EQ(std::system(("sqlite3 " + path + " 'UPDATE imuforge_schema SET version = 99'").c_str()), 0);
  EXPECT_THROW(open_store(path)->ensure_schema(), RecordError);
  std::filesystem::remove_all(dir);
}

TEST(RecordsPostgres, RoundTripOnARealServer) {
  imuforge::testing::PgServer pg;
  auto store = open_store(pg.url());
  EXPECT_EQ(store->backend(), "postgresql");
  round_trip(*store);
  // A second connection (another station) sees the same data.
  auto other = open_store(pg.url());
  other->ensure_schema();
  EXPECT_EQ(other->find_by_serial("SN-1").size(), 2u);
}

TEST(RecordsPostgres, UnreachableServerIsAClearError) {
  try {
    open_store("postgresql://imuforge:secret@/postgres?host=/nonexistent-socket-dir&port=5999&connect_timeout=2");
    FAIL() << "expected RecordError";
  } catch (const RecordError& e) {
    std::string m = e.what();
    EXPECT_NE(m.find("postgresql"), std::string::npos) << m;
    EXPECT_EQ(m.find("secret"), std::string::npos) << "password must not leak: " << m;
  }
}
}  // namespace eol_test_records
