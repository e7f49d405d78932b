// Reading cal.json back, apart from writing it (calfile.cpp): the reader is all that input checks and the
// cal.json fuzz target need, without the solver behind the writer.
#include <cmath>

#include "host/io/input_error.h"
#include "host/solver/calfile.h"

namespace imuforge::solver {

// More parameters than any model has (the catalog holds a few hundred): the covariance is n × n.
constexpr long kMaxCalParameters = 4096;

Estimate calibration_from_json(const nlohmann::json& j) {
  if (!j.is_object() || j.value("format", "") != kCalFormat)
    throw io::InputError("not an imuforge cal.json (\"format\" must be \"imuforge-cal\")");
  const auto it = j.find("parameters");
  if (it == j.end() || !it->is_array()) throw io::InputError("cal.json: missing array \"parameters\"");
  Estimate e;
  const long n = static_cast<long>(it->size());
  if (n > kMaxCalParameters)
    throw io::InputError("cal.json: \"parameters\" has " + std::to_string(n) + " entries (at most " +
                         std::to_string(kMaxCalParameters) + ")");
  e.value.resize(n);
  e.covariance = Eigen::MatrixXd::Zero(n, n);
  long i = 0;
  for (const auto& p : *it) {
    if (!p.is_object() || !p.contains("name") || !p["name"].is_string() || !p.contains("value") || !p["value"].is_number())
      throw io::InputError("cal.json: parameters[" + std::to_string(i) + "] needs a string name and a numeric value");
    e.names.push_back(p["name"].get<std::string>());
    e.value[i] = p["value"].get<double>();
    const double s = p.contains("sigma") && p["sigma"].is_number() ? p["sigma"].get<double>() : NAN;
    e.covariance(i, i) = s * s;
    ++i;
  }
  return e;
}

}  // namespace imuforge::solver
