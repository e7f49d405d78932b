// The record store: where every calibration goes. One schema, the same SQL text, on two back ends:
//   - SQLite (embedded default): a file path, or "sqlite:PATH"
//   - PostgreSQL (many stations, one database): "postgresql://..." or "postgres://..." (libpq URI)
// Schema: docs/eol.md "Records". Errors throw RecordError naming the back end and the cause; a
// database that cannot be reached is a peer failure (exit code 3).
#pragma once
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/records/record.h"

namespace imuforge::records {

class RecordError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The version stored in imuforge_schema; bumped on any incompatible change.
constexpr int kSchemaVersion = 1;

// The DDL, as statements. Identical text on both back ends (portable types only).
const std::vector<std::string>& schema_sql();

struct RecordSummary {
  std::string id, serial, station, finished_utc;
  bool pass = false;
};

class RecordStore {
 public:
  virtual ~RecordStore() = default;
  // Creates the schema if missing; checks its version otherwise. Idempotent.
  virtual void ensure_schema() = 0;
  // Inserts the record and its children in one transaction. Fills rec.id if empty. Returns the id.
  virtual std::string insert(CalibrationRecord& rec) = 0;
  // Reads a full record back; throws RecordError if absent.
  virtual CalibrationRecord get(const std::string& id) = 0;
  // Every record of one device serial, oldest first.
  virtual std::vector<RecordSummary> find_by_serial(const std::string& serial) = 0;
  // A batch and its units in one transaction (the units' calibration records are inserted before, with
  // insert()). Fills b.id if empty. Returns the id.
  virtual std::string insert_batch(BatchRecord& b) = 0;
  // Reads a batch back; throws RecordError if absent.
  virtual BatchRecord get_batch(const std::string& id) = 0;
  virtual std::string backend() const = 0;  // "sqlite" or "postgresql"
};

// Opens a store from a URL or path (see above). Does not create the schema: call ensure_schema().
std::unique_ptr<RecordStore> open_store(const std::string& url_or_path);

bool is_postgres_url(const std::string& s);

}  // namespace imuforge::records
