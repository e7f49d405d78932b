// Error codes shared by the firmware library. Every fallible firmware function returns `int`
// (or a struct holding one): 0 on success, a stable negative code on failure. Codes are part of the
// on-wire/diagnostic contract (the CAN node reports them, host tools print them): never renumber,
// only append. Each module owns a block of 100 codes:
//
//   -1   .. -99    common (this file)
//   -100 .. -199   coefficient table v1           firmware/table/table.h   (TableError)
//   -200 .. -299   compensation kernel            firmware/kernel/compensation.h
//   -300 .. -399   crypto (SHA-256, HMAC)         firmware/crypto/
//   -400 .. -499   A/B table store                firmware/store/
//   -500 .. -599   ISO-TP                         firmware/isotp/
//   -600 .. -699   CAN node                       firmware/can_node/
//   -700 .. -799   hal backends                   hal/
#pragma once
#include <cstdint>

namespace imuforge::fw {

enum FwError : int {
  kOk = 0,
  kErrNullArgument = -1,    // a required pointer argument was null
  kErrBufferTooSmall = -2,  // output buffer shorter than required
  kErrInvalidArgument = -3, // an argument outside its documented range
  kErrNotReady = -4,        // the object was not initialised / has no valid state
  kErrTimeout = -5,         // an operation did not finish in its allotted time
  kErrBusy = -6,            // the resource is in use; retry later
  kErrIo = -7,              // a hal backend reported an I/O failure
  kErrUnsupported = -8,     // the request is valid but not supported by this build
};

// First code of each module block (see above).
constexpr int kErrBaseCommon = 0;
constexpr int kErrBaseTable = -100;
constexpr int kErrBaseKernel = -200;
constexpr int kErrBaseCrypto = -300;
constexpr int kErrBaseStore = -400;
constexpr int kErrBaseIsotp = -500;
constexpr int kErrBaseCanNode = -600;
constexpr int kErrBaseHal = -700;

// Short, static, human-readable name of a common code ("null argument"...); "unknown" otherwise.
// Module codes have their own *_strerror() next to their enum.
const char* fw_strerror(int code) noexcept;

}  // namespace imuforge::fw
