// The run journal: an append-only, checksummed, fsync'd record of what a run has made safe.
//
// File DIR/journal.log, one entry per line:   J1 <crc32, 8 lowercase hex> <compact JSON object>\n
// The CRC-32 (IEEE, as firmware/common/crc32.h) covers the JSON text exactly. Every append is written with
// one write(2) and fsync'd before append() returns, so an entry the runner saw "done" survives power loss.
// Reading tolerates a torn LAST line (no newline, or bad CRC/JSON on the last line: a crash during the
// append); it is reported and dropped, and the next append truncates it away. A bad line anywhere else is
// corruption and an error naming the line. Format and entry types: docs/eol.md "Journal".
#pragma once
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/io/input_error.h"

namespace imuforge::eol {

class JournalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// A journal damaged before its last line (bad input to --resume: exit code 2, not an I/O failure).
class JournalCorruptError : public JournalError, public io::BadInput {
 public:
  using JournalError::JournalError;
};

struct JournalContents {
  std::vector<nlohmann::json> entries;  // in file order; each has at least "type"
  bool torn_tail = false;               // a torn last line was found and dropped
  std::size_t valid_bytes = 0;          // length of the valid prefix of the file
};

// Reads a journal file. Throws JournalError if it cannot be read or is corrupt before its last line.
JournalContents read_journal(const std::string& path);

// Encodes one entry as a journal line (with the trailing newline). Exposed for tests.
std::string journal_line(const nlohmann::json& entry);

class Journal {
 public:
  // Creates a new journal (fails if the file exists) or opens an existing one for appending, cutting
  // off a torn tail first. Throws JournalError.
  static Journal create(const std::string& path);
  static Journal open_existing(const std::string& path, JournalContents* contents_out);

  Journal(Journal&& o) noexcept;
  Journal& operator=(Journal&& o) noexcept;
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;
  ~Journal();

  // Appends and fsyncs. Throws JournalError (the run must stop: nothing is safe without the journal).
  void append(const nlohmann::json& entry);
  const std::string& path() const { return path_; }

 private:
  Journal(std::string path, int fd) : path_(std::move(path)), fd_(fd) {}
  std::string path_;
  int fd_ = -1;
};

// fsync a directory, so that a file created in it survives power loss.
void fsync_dir(const std::string& dir);

}  // namespace imuforge::eol
