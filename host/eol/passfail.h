// Pass/fail: the station's limits applied to one calibration. Both the record and the exit code carry
// the verdict and every reason (docs/eol.md "Pass/fail").
#pragma once
#include <string>
#include <vector>

#include "host/eol/station.h"
#include "host/records/record.h"

namespace imuforge::eol {

struct Verdict {
  bool pass = false;
  std::vector<std::string> reasons;  // one line per failed check; empty on pass
};

// Fills limit_abs / sigma_spec / pass of each parameter and pass of each verification entry, and returns
// the verdict. Fails on: a non-finite value or σ; |value| > abs limit; σ > σ limit; a verification
// residual above its limit or non-finite; no verification entries at all (an unverified table never
// passes, unless require_verification is false: a batch solve of logs judges the parameters only); and
// every extra reason passed in (e.g. "flash: read-back differs").
Verdict evaluate(const StationConfig& st, std::vector<records::ParameterRecord>& params,
                 std::vector<records::VerificationRecord>& verification,
                 const std::vector<std::string>& extra_reasons = {}, bool require_verification = true);

}  // namespace imuforge::eol
