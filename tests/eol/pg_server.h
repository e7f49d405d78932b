// Test helper: a throwaway PostgreSQL 15 server, started and stopped by the test itself.
// The data directory and the Unix socket live in a fresh temp dir; no TCP port is opened, so parallel
// test runs never collide. As root (CI) the server runs as the unprivileged `postgres` user (PostgreSQL
// refuses to run as root); otherwise as the current user.
#pragma once
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace imuforge::testing {

class PgServer {
 public:
  static constexpr const char* kBin = "/usr/lib/postgresql/15/bin";

  PgServer() {
    if (!std::filesystem::exists(std::string(kBin) + "/initdb"))
      throw std::runtime_error(std::string("PostgreSQL server not installed: ") + kBin + "/initdb (run setup.sh)");
    char tmpl[] = "/tmp/imuforge-pg-XXXXXX";
    if (!mkdtemp(tmpl)) throw std::runtime_error("mkdtemp failed");
    dir_ = tmpl;
    std::string as_user;
    if (geteuid() == 0) {
      struct passwd* pw = getpwnam("postgres");
      if (!pw) pw = getpwnam("nobody");
      if (!pw) throw std::runtime_error("running as root and no 'postgres' or 'nobody' user to run the server");
      if (chown(dir_.c_str(), pw->pw_uid, pw->pw_gid) != 0) throw std::runtime_error("chown of " + dir_ + " failed");
      as_user = std::string("runuser -u ") + pw->pw_name + " -- ";
    }
    run(as_user + kBin + "/initdb -D " + dir_ + "/data -A trust -U imuforge -E UTF8 --no-sync >" + dir_ +
        "/initdb.log 2>&1");
    as_user_ = as_user;
    start();
    url_ = "postgresql://imuforge@/postgres?host=" + dir_ + "&port=5432";
  }
  // Stops and starts the server on the same data directory (a server restarted under a running client).
  void stop(const char* mode = "fast") {
    run(as_user_ + kBin + "/pg_ctl -D " + dir_ + "/data -m " + mode + " -w stop >/dev/null 2>&1");
    started_ = false;
  }
  void start() {
    run(as_user_ + kBin + "/pg_ctl -D " + dir_ + "/data -w -t 60 -l " + dir_ +
        "/server.log -o \"-k " + dir_ + " -c listen_addresses='' -p 5432 -c fsync=off\" start >/dev/null 2>&1");
    started_ = true;
  }
  // Runs SQL through psql on a connection of its own (a second client); returns psql's output
  // (unaligned, tuples only). The SQL goes through a file: no shell quoting of $$ or quotes.
  std::string psql(const std::string& sql) const {
    const std::string f = dir_ + "/q.sql";
    {
      std::FILE* q = std::fopen(f.c_str(), "w");
      if (!q) throw std::runtime_error("cannot write " + f);
      std::fputs(sql.c_str(), q);
      std::fclose(q);
    }
    const std::string cmd = "psql -X -A -t -q -v ON_ERROR_STOP=1 -d '" + url_ + "' -f " + f + " 2>&1";
    std::FILE* p = ::popen(cmd.c_str(), "r");
    if (!p) throw std::runtime_error("popen psql failed");
    std::string out;
    char buf[512];
    while (std::fgets(buf, sizeof buf, p)) out += buf;
    if (::pclose(p) != 0) throw std::runtime_error("psql failed: " + out + " for: " + sql);
    while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
    return out;
  }
  ~PgServer() {
    if (started_)
      std::system((as_user_ + kBin + "/pg_ctl -D " + dir_ + "/data -m immediate -w stop >/dev/null 2>&1").c_str());
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  PgServer(const PgServer&) = delete;
  PgServer& operator=(const PgServer&) = delete;

  const std::string& url() const { return url_; }
  const std::string& dir() const { return dir_; }

 private:
  void run(const std::string& cmd) {
    if (std::system(cmd.c_str()) != 0) throw std::runtime_error("failed: " + cmd + " (logs in " + dir_ + ")");
  }
  std::string dir_, url_, as_user_;
  bool started_ = false;
};

}  // namespace imuforge::testing
