// An output file that appears only whole: written under a hidden staging name in the same directory and
// renamed into place by commit(). A command that fails (bad input found halfway through a stream, a
// write error) leaves the output directory as it was: no partial file, an older file of that name intact.
//
//   io::StagedFile out(out_path);
//   io::LogWriter w(out.path(), meta);  ... w.close();
//   out.commit();                       // rename(2): atomic on POSIX file systems
//
// If the process is killed before commit(), the staging file ".<name>.partial-<pid>" stays (a kill
// cannot clean up); it never takes the final name.
#pragma once

#include <string>

namespace imuforge::io {

class StagedFile {
 public:
  explicit StagedFile(std::string final_path);
  ~StagedFile();  // removes the staging file unless committed
  StagedFile(const StagedFile&) = delete;
  StagedFile& operator=(const StagedFile&) = delete;

  const std::string& path() const { return staging_; }
  const std::string& final_path() const { return final_; }
  // Renames the staging file to the final path. Throws InputError if that fails.
  void commit();

 private:
  std::string final_, staging_;
  bool committed_ = false;
};

}  // namespace imuforge::io
