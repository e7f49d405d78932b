#include "firmware/common/error.h"

namespace imuforge::fw {

const char* fw_strerror(int code) noexcept {
  switch (code) {
    case kOk: return "ok";
    case kErrNullArgument: return "null argument";
    case kErrBufferTooSmall: return "buffer too small";
    case kErrInvalidArgument: return "invalid argument";
    case kErrNotReady: return "not ready";
    case kErrTimeout: return "timeout";
    case kErrBusy: return "busy";
    case kErrIo: return "I/O error";
    case kErrUnsupported: return "unsupported";
    default: return "unknown";
  }
}

}  // namespace imuforge::fw
