#include "host/solver/fixture_errors.h"

namespace imuforge::solver {

FixtureErrorsResult solve_fixture_errors(io::LogReader&, const model::ModelSpec&, const std::string&) {
  throw SolverError("fixture+errors mode is not implemented yet");
}

}  // namespace imuforge::solver
