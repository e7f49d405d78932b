// PostgreSQL back end of the record store (many stations, one server), through libpq.
#include <libpq-fe.h>

#include <string>

#include "host/records/db.h"
#include "host/records/store.h"

namespace imuforge::records::detail {
namespace {

// Strips the password from a URI before it goes into an error message.
std::string redact(const std::string& url) {
  auto at = url.find('@');
  auto scheme = url.find("://");
  if (at == std::string::npos || scheme == std::string::npos || at < scheme) return url;
  auto colon = url.find(':', scheme + 3);
  if (colon == std::string::npos || colon > at) return url;
  return url.substr(0, colon) + ":***" + url.substr(at);
}

class PgDb final : public Db {
 public:
  explicit PgDb(const std::string& url) : url_(redact(url)) {
    conn_ = PQconnectdb(url.c_str());
    if (!conn_ || PQstatus(conn_) != CONNECTION_OK) {
      std::string msg = conn_ ? PQerrorMessage(conn_) : "out of memory";
      if (conn_) PQfinish(conn_);
      conn_ = nullptr;
      while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
      throw RecordError("postgresql: cannot connect to '" + url_ + "': " + msg);
    }
    // Round-trip floats exactly in text form; silence NOTICEs from CREATE ... IF NOT EXISTS.
    exec("SET extra_float_digits = 3", {}, {});
    exec("SET client_min_messages = WARNING", {}, {});
  }
  ~PgDb() override {
    if (conn_) PQfinish(conn_);
  }

  std::vector<Row> exec(const std::string& sql, const std::vector<Value>& params,
                        const std::vector<int>& blob_columns) override {
    std::vector<std::string> texts(params.size());
    std::vector<const char*> values(params.size(), nullptr);
    std::vector<int> lengths(params.size(), 0), formats(params.size(), 0);
    for (std::size_t k = 0; k < params.size(); ++k) {
      const Value& v = params[k];
      if (v.kind == Value::kNull) continue;
      if (v.kind == Value::kBlob) {
        values[k] = reinterpret_cast<const char*>(v.blob.data());
        if (v.blob.empty()) values[k] = "";
        lengths[k] = static_cast<int>(v.blob.size());
        formats[k] = 1;  // binary: no escaping of the table blob
        continue;
      }
      texts[k] = v.as_text();
      values[k] = texts[k].c_str();
    }
    PGresult* res = PQexecParams(conn_, sql.c_str(), static_cast<int>(params.size()), nullptr,
                                 params.empty() ? nullptr : values.data(), lengths.data(), formats.data(), 0);
    struct Clear {
      PGresult* r;
      ~Clear() { PQclear(r); }
    } clr{res};
    ExecStatusType st = res ? PQresultStatus(res) : PGRES_FATAL_ERROR;
    if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK) {
      std::string msg = res ? PQresultErrorMessage(res) : PQerrorMessage(conn_);
      while (!msg.empty() && (msg.back() == '\n' || msg.back() == ' ')) msg.pop_back();
      throw RecordError("postgresql '" + url_ + "': " + msg + " in: " + sql.substr(0, 120));
    }
    std::vector<Row> rows;
    int nr = PQntuples(res), nc = PQnfields(res);
    for (int r = 0; r < nr; ++r) {
      Row row(static_cast<std::size_t>(nc));
      for (int c = 0; c < nc; ++c) {
        if (PQgetisnull(res, r, c)) continue;
        const char* s = PQgetvalue(res, r, c);
        bool is_blob = false;
        for (int b : blob_columns) is_blob |= (b == c);
        if (is_blob) {
          std::size_t n = 0;
          unsigned char* raw = PQunescapeBytea(reinterpret_cast<const unsigned char*>(s), &n);
          if (!raw) throw RecordError("postgresql: cannot decode bytea column");
          row[static_cast<std::size_t>(c)] = Value::of(std::vector<std::uint8_t>(raw, raw + n));
          PQfreemem(raw);
        } else {
          row[static_cast<std::size_t>(c)] = Value::of(std::string(s, static_cast<std::size_t>(PQgetlength(res, r, c))));
        }
      }
      rows.push_back(std::move(row));
    }
    return rows;
  }
  std::string backend() const override { return "postgresql"; }

 private:
  std::string url_;
  PGconn* conn_ = nullptr;
};

}  // namespace

std::unique_ptr<Db> open_postgres(const std::string& url) { return std::make_unique<PgDb>(url); }

}  // namespace imuforge::records::detail
