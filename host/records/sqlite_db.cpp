// SQLite back end of the record store (the embedded default).
#include <sqlite3.h>

#include <string>

#include "host/records/db.h"
#include "host/records/store.h"

namespace imuforge::records::detail {
namespace {

class SqliteDb final : public Db {
 public:
  explicit SqliteDb(const std::string& path) : path_(path) {
    int rc = sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                             nullptr);
    if (rc != SQLITE_OK) {
      std::string msg = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
      if (db_) sqlite3_close(db_);
      db_ = nullptr;
      throw RecordError("sqlite: cannot open '" + path + "': " + msg);
    }
    // Another station process may hold the write lock for a moment; wait rather than fail.
    sqlite3_busy_timeout(db_, 10000);
    exec("PRAGMA foreign_keys = ON");
    // A record must survive a power loss once insert() returns.
    exec("PRAGMA synchronous = FULL");
  }
  ~SqliteDb() override {
    if (db_) sqlite3_close(db_);
  }

  std::vector<Row> exec(const std::string& sql, const std::vector<Value>& params,
                        const std::vector<int>& /*blob_columns*/) override {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
      throw RecordError("sqlite '" + path_ + "': prepare failed (" + sqlite3_errmsg(db_) + ") for: " + sql);
    struct Fin {
      sqlite3_stmt* s;
      ~Fin() { sqlite3_finalize(s); }
    } fin{st};
    for (std::size_t k = 0; k < params.size(); ++k) {
      std::string name = "$" + std::to_string(k + 1);
      int idx = sqlite3_bind_parameter_index(st, name.c_str());
      if (idx == 0) throw RecordError("sqlite: statement has no parameter " + name + ": " + sql);
      const Value& v = params[k];
      int rc = SQLITE_OK;
      switch (v.kind) {
        case Value::kNull: rc = sqlite3_bind_null(st, idx); break;
        case Value::kText: rc = sqlite3_bind_text(st, idx, v.text.c_str(), static_cast<int>(v.text.size()), SQLITE_TRANSIENT); break;
        case Value::kInt: rc = sqlite3_bind_int64(st, idx, v.i); break;
        case Value::kReal: rc = sqlite3_bind_double(st, idx, v.d); break;
        case Value::kBlob:
          rc = sqlite3_bind_blob(st, idx, v.blob.empty() ? "" : static_cast<const void*>(v.blob.data()),
                                 static_cast<int>(v.blob.size()), SQLITE_TRANSIENT);
          break;
      }
      if (rc != SQLITE_OK) throw RecordError(std::string("sqlite: bind failed: ") + sqlite3_errmsg(db_));
    }
    std::vector<Row> rows;
    for (;;) {
      int rc = sqlite3_step(st);
      if (rc == SQLITE_DONE) break;
      if (rc != SQLITE_ROW)
        throw RecordError("sqlite '" + path_ + "': " + sqlite3_errmsg(db_) + " in: " + sql.substr(0, 120));
      int n = sqlite3_column_count(st);
      Row r(static_cast<std::size_t>(n));
      for (int c = 0; c < n; ++c) {
        Value& v = r[static_cast<std::size_t>(c)];
        switch (sqlite3_column_type(st, c)) {
          case SQLITE_NULL: v.kind = Value::kNull; break;
          case SQLITE_INTEGER: v = Value::of(static_cast<std::int64_t>(sqlite3_column_int64(st, c))); break;
          case SQLITE_FLOAT: v = Value::of(sqlite3_column_double(st, c)); break;
          case SQLITE_BLOB: {
            const auto* p = static_cast<const std::uint8_t*>(sqlite3_column_blob(st, c));
            int len = sqlite3_column_bytes(st, c);
            v = Value::of(std::vector<std::uint8_t>(p, p + len));
            break;
          }
          default: {
            const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(st, c));
            v = Value::of(std::string(p ? p : "", static_cast<std::size_t>(sqlite3_column_bytes(st, c))));
          }
        }
      }
      rows.push_back(std::move(r));
    }
    return rows;
  }
  std::string backend() const override { return "sqlite"; }

 private:
  std::vector<Row> exec(const char* sql) { return exec(std::string(sql), {}, {}); }
  std::string path_;
  sqlite3* db_ = nullptr;
};

}  // namespace

std::unique_ptr<Db> open_sqlite(const std::string& path) { return std::make_unique<SqliteDb>(path); }

}  // namespace imuforge::records::detail
