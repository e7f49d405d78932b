#include "host/io/staged_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "host/io/input_error.h"

namespace imuforge::io {

StagedFile::StagedFile(std::string final_path) : final_(std::move(final_path)) {
  const auto slash = final_.find_last_of('/');
  const std::string dir = slash == std::string::npos ? std::string() : final_.substr(0, slash + 1);
  const std::string name = slash == std::string::npos ? final_ : final_.substr(slash + 1);
  staging_ = dir + "." + name + ".partial-" + std::to_string(::getpid());
}

StagedFile::~StagedFile() {
  if (!committed_) (void)std::remove(staging_.c_str());
}

void StagedFile::commit() {
  if (std::rename(staging_.c_str(), final_.c_str()) != 0) {
    throw InputError(final_ + ": cannot put the output in place: " + std::strerror(errno));
  }
  committed_ = true;
}

}  // namespace imuforge::io
