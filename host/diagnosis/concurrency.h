// Two pieces of the diagnosis's work at once, on a machine with two cores or more.
//
// The diagnosis is single-threaded by design: every figure it prints must be the same on every machine and every
// run. What runs here concurrently therefore shares no mutable state, and each piece is the same arithmetic in the
// same order as when run alone, so the answer does not depend on which piece runs where, or on whether they run
// at once at all (tests/diagnosis/concurrency_test.cpp: the pieces and a whole diagnosis, bit for bit).
//
// IMUFORGE_DIAG_THREADS=1 in the environment runs everything on the calling thread (profiling, comparisons);
// IMUFORGE_DIAG_THREADS=2 runs the pieces at once even on one core (the tests' threaded side); otherwise the core
// count decides.
#pragma once

#include <functional>

namespace imuforge::diagnosis {

// False where IMUFORGE_DIAG_THREADS=1 asks for one thread, true where it is 2, else whether the machine has two cores
// or more. Read on every call (a getenv, O(environment)), so a test can change it.
bool concurrency_allowed();

// Runs a() and b() at once and returns when both have finished: b() on the caller's thread, a() on the process's
// helper thread (one, started at the first call and kept, so that what a thread keeps for itself, such as
// line_power_spectrum's sums, serves later calls too), or on a thread of its own while the helper is busy (another
// caller's a(), or a() calling this again). Where concurrency_allowed() is false, or no thread can be started,
// a() then b() on the caller's thread. An exception from either is rethrown once both have finished (a's first).
// a and b must not write anything the other reads. Cost: a hand-over to the helper (µs).
void run_concurrently(const std::function<void()>& a, const std::function<void()>& b);

}  // namespace imuforge::diagnosis
