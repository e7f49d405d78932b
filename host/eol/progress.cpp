#include "host/eol/progress.h"

#include <cmath>

namespace imuforge::eol {

std::string format_hms(double s) {
  if (!std::isfinite(s) || s < 0) s = 0;
  long t = std::lround(s);
  char b[32];
  std::snprintf(b, sizeof b, "%02ld:%02ld:%02ld", t / 3600, (t / 60) % 60, t % 60);
  return b;
}

std::string progress_line(const ProgressState& s) {
  double frac = s.total_steps > 0 ? static_cast<double>(s.done_steps) / s.total_steps : 0.0;
  int filled = static_cast<int>(std::lround(frac * 20));
  std::string bar = "[" + std::string(static_cast<std::size_t>(filled), '#') +
                    std::string(static_cast<std::size_t>(20 - filled), '-') + "]";
  double wall_left = s.fixture_elapsed_s > 0 ? s.fixture_remaining_s * s.wall_elapsed_s / s.fixture_elapsed_s : 0.0;
  int met = 0, with_spec = 0;
  double worst = 0;
  std::string worst_name = "-";
  for (int i = 0; i < s.sigma.size() && i < s.spec.size(); ++i) {
    if (!(s.spec[i] > 0)) continue;
    ++with_spec;
    double r = s.sigma[i] / s.spec[i];
    if (r <= 1.0) ++met;
    if (!(r <= worst)) {
      worst = r;
      worst_name = s.names ? (*s.names)[static_cast<std::size_t>(i)] : std::to_string(i);
    }
  }
  char b[512];
  std::snprintf(b, sizeof b,
                "%s %3.0f%% p%d/%d %+.1fC step %d/%d '%s' | wall %s fixture %s | left <= %s (wall ~%s) | "
                "sigma/spec worst %s %s, %d/%d met",
                bar.c_str(), 100 * frac, s.phase + 1, s.phases, s.setpoint_C, s.done_steps, s.total_steps,
                s.label.c_str(), format_hms(s.wall_elapsed_s).c_str(), format_hms(s.fixture_elapsed_s).c_str(),
                format_hms(s.fixture_remaining_s).c_str(), format_hms(wall_left).c_str(), worst_name.c_str(),
                std::isfinite(worst) ? std::to_string(worst).substr(0, 5).c_str() : "inf", met, with_spec);
  return b;
}

std::string sigma_table(const ProgressState& s) {
  std::string out;
  for (int i = 0; i < s.sigma.size(); ++i) {
    const std::string& n = s.names ? (*s.names)[static_cast<std::size_t>(i)] : std::to_string(i);
    double spec = i < s.spec.size() ? s.spec[i] : 0.0;
    char b[256];
    if (spec > 0) {
      double r = s.sigma[i] / spec;
      int w = std::isfinite(r) ? static_cast<int>(std::lround(std::min(r, 4.0) * 5)) : 20;
      std::snprintf(b, sizeof b, "  %-28s sigma %10.3g  spec %10.3g  %6.2f %s%s\n", n.c_str(), s.sigma[i], spec,
                    std::isfinite(r) ? r : INFINITY, std::string(static_cast<std::size_t>(w), r <= 1 ? '=' : '#').c_str(),
                    r <= 1 ? " ok" : "");
    } else {
      std::snprintf(b, sizeof b, "  %-28s sigma %10.3g  (no spec)\n", n.c_str(), s.sigma[i]);
    }
    out += b;
  }
  return out;
}

}  // namespace imuforge::eol
