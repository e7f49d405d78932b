#include "host/eol/journal.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "firmware/common/crc32.h"

namespace imuforge::eol {

namespace {
std::string errno_text() { return std::strerror(errno); }

std::string crc_hex(const std::string& s) {
  char buf[9];
  std::snprintf(buf, sizeof buf, "%08x", static_cast<unsigned>(imuforge::fw::crc32(s.data(), s.size())));
  return buf;
}

// Parses one line (without newline); returns false with a reason if it is not a valid entry.
bool parse_line(const std::string& line, nlohmann::json& out, std::string& why) {
  if (line.size() < 13 || line.compare(0, 3, "J1 ") != 0 || line[11] != ' ') {
    why = "not a 'J1 <crc> <json>' line";
    return false;
  }
  std::string crc = line.substr(3, 8), body = line.substr(12);
  if (crc != crc_hex(body)) {
    why = "checksum mismatch";
    return false;
  }
  try {
    out = nlohmann::json::parse(body);
  } catch (const std::exception& e) {
    why = std::string("bad JSON: ") + e.what();
    return false;
  }
  if (!out.is_object() || !out.contains("type") || !out["type"].is_string()) {
    why = "entry without a string \"type\"";
    return false;
  }
  return true;
}
}  // namespace

std::string journal_line(const nlohmann::json& entry) {
  std::string body = entry.dump();  // compact, and JSON escapes any newline inside strings
  return "J1 " + crc_hex(body) + " " + body + "\n";
}

JournalContents read_journal(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw JournalError("journal " + path + ": cannot open: " + errno_text());
  // A run's journal is a few hundred bytes per segment; a file far beyond that is not one (and is not
  // read into memory).
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(path, ec);
  if (!ec && bytes > io::kMaxJsonFileBytes) {
    throw JournalCorruptError("journal " + path + ": " + std::to_string(bytes) + " bytes, larger than " +
                              std::to_string(io::kMaxJsonFileBytes >> 20) + " MiB: not a run journal");
  }
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string data = ss.str();
  JournalContents c;
  std::size_t pos = 0, lineno = 0;
  while (pos < data.size()) {
    ++lineno;
    std::size_t nl = data.find('\n', pos);
    bool last = (nl == std::string::npos) || (nl + 1 == data.size());
    if (nl == std::string::npos) {  // no newline: the append never finished
      c.torn_tail = true;
      break;
    }
    nlohmann::json e;
    std::string why;
    if (!parse_line(data.substr(pos, nl - pos), e, why)) {
      if (last) {
        c.torn_tail = true;
        break;
      }
      throw JournalCorruptError("journal " + path + " line " + std::to_string(lineno) + " is corrupt (" + why +
                         ") and is not the last line: refusing to resume from a damaged journal");
    }
    c.entries.push_back(std::move(e));
    pos = nl + 1;
    c.valid_bytes = pos;
  }
  return c;
}

Journal Journal::create(const std::string& path) {
  int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) throw JournalError("journal " + path + ": cannot create: " + errno_text());
  auto parent = std::filesystem::path(path).parent_path().string();
  fsync_dir(parent.empty() ? "." : parent);
  return Journal(path, fd);
}

Journal Journal::open_existing(const std::string& path, JournalContents* contents_out) {
  JournalContents c = read_journal(path);
  int fd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  if (fd < 0) throw JournalError("journal " + path + ": cannot open for append: " + errno_text());
  if (c.torn_tail) {
    // Cut the torn line so the next entry starts on a line boundary.
    if (::ftruncate(fd, static_cast<off_t>(c.valid_bytes)) != 0 || ::fsync(fd) != 0) {
      int e = errno;
      ::close(fd);
      throw JournalError("journal " + path + ": cannot truncate torn tail: " + std::strerror(e));
    }
  }
  if (contents_out) *contents_out = std::move(c);
  return Journal(path, fd);
}

Journal::Journal(Journal&& o) noexcept : path_(std::move(o.path_)), fd_(o.fd_) { o.fd_ = -1; }
Journal& Journal::operator=(Journal&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    path_ = std::move(o.path_);
    fd_ = o.fd_;
    o.fd_ = -1;
  }
  return *this;
}
Journal::~Journal() {
  if (fd_ >= 0) ::close(fd_);
}

void Journal::append(const nlohmann::json& entry) {
  if (fd_ < 0) throw JournalError("journal " + path_ + ": not open");
  const std::string line = journal_line(entry);
  const char* p = line.data();
  std::size_t left = line.size();
  while (left > 0) {
    ssize_t n = ::write(fd_, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw JournalError("journal " + path_ + ": write failed: " + errno_text());
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (::fsync(fd_) != 0) throw JournalError("journal " + path_ + ": fsync failed: " + errno_text());
}

void fsync_dir(const std::string& dir) {
  int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw JournalError("cannot open directory " + dir + " to sync it: " + errno_text());
  int rc = ::fsync(fd);
  int e = errno;
  ::close(fd);
  if (rc != 0) throw JournalError("cannot fsync directory " + dir + ": " + std::strerror(e));
}

}  // namespace imuforge::eol
