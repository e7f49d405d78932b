#include <cerrno>
#include <cstdlib>
#include <string>

#include "host/records/db.h"
#include "host/records/store.h"

namespace imuforge::records::detail {

std::string Value::as_text() const {
  switch (kind) {
    case kNull: return {};
    case kText: return text;
    case kInt: return std::to_string(i);
    case kReal: {
      char buf[40];
      std::snprintf(buf, sizeof buf, "%.17g", d);
      return buf;
    }
    case kBlob: return std::string(blob.begin(), blob.end());
  }
  return {};
}

std::int64_t Value::as_int() const {
  if (kind == kInt) return i;
  if (kind == kReal) return static_cast<std::int64_t>(d);
  if (kind == kNull) return 0;
  errno = 0;
  char* end = nullptr;
  long long x = std::strtoll(text.c_str(), &end, 10);
  if (errno || end == text.c_str() || *end) throw RecordError("records: expected an integer, got '" + text + "'");
  return x;
}

double Value::as_real() const {
  if (kind == kReal) return d;
  if (kind == kInt) return static_cast<double>(i);
  if (kind == kNull) return 0.0;
  char* end = nullptr;
  double x = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end) throw RecordError("records: expected a number, got '" + text + "'");
  return x;
}

std::vector<std::uint8_t> Value::as_blob() const {
  if (kind == kBlob) return blob;
  if (kind == kNull) return {};
  return std::vector<std::uint8_t>(text.begin(), text.end());
}

}  // namespace imuforge::records::detail
