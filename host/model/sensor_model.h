// Sensor-model JSON (what a simulated part IS) and model-spec JSON (what the solver ESTIMATES).
// Both formats are documented in docs/formats.md; names are validated against the catalog.
#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/model/catalog.h"

namespace imuforge::model {

// Output stage of one triad.
struct TriadOutput {
  double lsb = 0.0;      // SI per count (m/s² or rad/s)
  int bits = 16;         // signed output word width, 2..32
  double range = 0.0;    // full-scale (SI); 0 = derived from lsb·2^(bits−1)
};

struct ThermalConstants {
  double die_tau_s = 60.0;              // die lags chamber air with this first-order time constant
  double self_heating_C = 0.0;          // steady-state die rise above air when powered
  double self_heating_tau_s = 30.0;     // time constant of the self-heating rise after power-up
  double hysteresis_threshold_C = 0.5;  // d(t) turning threshold (docs/error-model.md)
  double dTdt_window_s = 10.0;          // centred-difference half window used by the solver for Ṫ
};

// A complete sensor description: which effects are on and every parameter's value.
struct SensorModel {
  std::string name;
  std::string source;                   // citation(s) for the magnitudes
  double T_ref_C = 25.0;
  std::array<TriadOutput, kNumSensors> out;  // indexed by Sensor
  ThermalConstants thermal;
  // enabled[sensor][effect]: an effect present in the file is on unless "enabled": false.
  std::array<std::array<bool, kNumEffects>, kNumSensors> enabled{};
  ParamSet params;                      // unset = 0; disabled effects' values are kept but ignored

  bool on(Sensor s, Effect e) const { return enabled[static_cast<int>(s)][static_cast<int>(e)]; }
  const TriadOutput& triad(Sensor s) const { return out[static_cast<std::size_t>(s)]; }
  // Parameters with their value zeroed when their effect is disabled (what the physics actually uses).
  ParamSet effective_params() const;
};

// Parse / serialise. Throws std::invalid_argument with a message naming the offending key
// (unknown effect, unknown component, effect not applicable to that sensor, non-number, bad LSB ...).
SensorModel sensor_model_from_json(const nlohmann::json& j);
SensorModel load_sensor_model(const std::string& path);  // prefixes errors with the path
nlohmann::json sensor_model_to_json(const SensorModel& m);

// Model spec: the parameters a solver estimates.
//   per_plateau: the basic effect's value is fitted per temperature plateau instead of by polynomial.
struct ModelEffect {
  Sensor sensor;
  Effect effect;
  int order = 0;                        // *_temp effects: polynomial order 1..3 (components t1..t<order>)
  bool per_plateau = false;             // basic effects only
  std::vector<std::string> components;  // subset to estimate; empty = all applicable
};

struct ModelSpec {
  std::string name;
  double T_ref_C = 25.0;
  std::vector<ModelEffect> effects;     // sorted by key ("accel.bias" < "gyro.bias": nlohmann::json objects are ordered maps)
  nlohmann::json extra;                 // solver options kept verbatim (e.g. "noise", "mode")
  // "hysteresis_threshold_C" (°C, > 0): the turning threshold of the temp_hysteresis tracker on the logged
  // temperature, when the file gives one (`imuforge diagnose --emit-model` writes the one its profile chose,
  // docs/diagnosis.md § temp_hysteresis). NaN: not given (the solver takes ThermalConstants' default; the
  // diagnosis profiles it).
  double hysteresis_threshold_C = std::numeric_limits<double>::quiet_NaN();

  // Deterministic parameter ids to estimate, in a stable order (effects as in `effects`, components in
  // catalog order). Stochastic effects listed in a model are accepted and ignored here.
  std::vector<ParamId> parameters() const;
  bool has(Sensor s, Effect e) const;
};

ModelSpec model_spec_from_json(const nlohmann::json& j);
ModelSpec load_model_spec(const std::string& path);
nlohmann::json model_spec_to_json(const ModelSpec& m);

}  // namespace imuforge::model
