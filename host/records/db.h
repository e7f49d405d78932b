// Internal: the thin SQL seam both back ends implement, so the store's SQL is written once.
// Placeholders are $1, $2, ... in order of first use (native in PostgreSQL; SQLite binds them by name).
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace imuforge::records::detail {

struct Value {
  enum Kind { kNull, kText, kInt, kReal, kBlob } kind = kNull;
  std::string text;                 // kText (and the text form PostgreSQL returns)
  std::int64_t i = 0;               // kInt
  double d = 0.0;                   // kReal
  std::vector<std::uint8_t> blob;   // kBlob

  static Value of(std::string s) { Value v; v.kind = kText; v.text = std::move(s); return v; }
  static Value of(const char* s) { return of(std::string(s)); }
  static Value of(std::int64_t x) { Value v; v.kind = kInt; v.i = x; return v; }
  static Value of(double x) { Value v; v.kind = kReal; v.d = x; return v; }
  static Value of(std::vector<std::uint8_t> b) { Value v; v.kind = kBlob; v.blob = std::move(b); return v; }

  std::string as_text() const;
  std::int64_t as_int() const;
  double as_real() const;
  std::vector<std::uint8_t> as_blob() const;
};

using Row = std::vector<Value>;

class Db {
 public:
  virtual ~Db() = default;
  // Runs one statement; returns its rows (empty for DDL/DML). Throws RecordError naming the statement.
  // blob_columns: result column indexes that hold binary data (PostgreSQL returns bytea as hex text).
  virtual std::vector<Row> exec(const std::string& sql, const std::vector<Value>& params = {},
                                const std::vector<int>& blob_columns = {}) = 0;
  virtual std::string backend() const = 0;
};

std::unique_ptr<Db> open_sqlite(const std::string& path);
std::unique_ptr<Db> open_postgres(const std::string& url);

}  // namespace imuforge::records::detail
