#include "host/eol/passfail.h"

#include <cmath>
#include <cstdio>

namespace imuforge::eol {

namespace {
std::string num(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", x);
  return b;
}
}  // namespace

Verdict evaluate(const StationConfig& st, std::vector<records::ParameterRecord>& params,
                 std::vector<records::VerificationRecord>& verification, const std::vector<std::string>& extra,
                 bool require_verification) {
  Verdict v;
  v.reasons = extra;
  for (auto& p : params) {
    p.pass = true;
    const ParamLimit* l = st.limit_for(p.name);
    p.limit_abs = l ? l->abs_max : 0.0;
    p.sigma_spec = l ? l->sigma_max : 0.0;
    if (!std::isfinite(p.value) || !std::isfinite(p.sigma)) {
      p.pass = false;
      v.reasons.push_back(p.name + ": not determined (value " + num(p.value) + ", sigma " + num(p.sigma) + ")");
      continue;
    }
    if (p.limit_abs > 0 && std::fabs(p.value) > p.limit_abs) {
      p.pass = false;
      v.reasons.push_back(p.name + ": |value| " + num(std::fabs(p.value)) + " > limit " + num(p.limit_abs));
    }
    if (p.sigma_spec > 0 && p.sigma > p.sigma_spec) {
      p.pass = false;
      v.reasons.push_back(p.name + ": sigma " + num(p.sigma) + " > spec " + num(p.sigma_spec));
    }
  }
  if (verification.empty() && require_verification) v.reasons.push_back("verification: no verification results (an unverified table never passes)");
  for (auto& r : verification) {
    r.pass = std::isfinite(r.residual) && (r.limit <= 0 || std::fabs(r.residual) <= r.limit);
    if (!r.pass)
      v.reasons.push_back("verification " + r.name + ": |residual| " + num(std::fabs(r.residual)) + " > limit " +
                          num(r.limit));
  }
  v.pass = v.reasons.empty();
  return v;
}

}  // namespace imuforge::eol
