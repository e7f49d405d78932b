// The effect catalog: every sensor error effect, its parameters and their stable names
// (docs/error-model.md is the contract). Shared by the simulator, the solver and the diagnosis.
//
// Parameter names are `<sensor>.<effect>.<component>`, e.g. `accel.bias.x`, `gyro.misalign.xy`
// (row x, column y), `accel.bias_temp.z.t2`, `gyro.g2_sensitivity.x.xy`, `accel.size_effect.y.rz`,
// `gyro.timing.latency_s`, `gyro.bias_instability.tau_s`.
// Every parameter has a dense index (ParamId) into the catalog's parameter table, so per-sample code
// never looks names up. Values are SI (m/s², rad/s, s, °C, dimensionless; `timing.ppm` is in ppm).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace imuforge::model {

enum class Sensor : std::uint8_t { kAccel = 0, kGyro = 1 };
constexpr int kNumSensors = 2;
const char* sensor_name(Sensor s);  // "accel" / "gyro"

enum class EffectKind : std::uint8_t {
  kDeterministic,  // enters the measurement equation linearly: has a regressor (measure.h)
  kStochastic,     // noise / output effects realised by the simulator only
};

// Which triads an effect applies to (bit mask).
enum SensorMask : std::uint8_t { kMaskAccel = 1, kMaskGyro = 2, kMaskBoth = 3 };

enum class Effect : std::uint8_t {
  kBias, kScale, kMisalign,                                  // basic
  kBiasTemp, kScaleTemp, kMisalignTemp,                      // temperature
  kScaleNonlinearity, kScaleAsymmetry, kCrossCoupling,       // input dependence
  kCrossAxisNonlinearity,                                    // input dependence (accelerometer, IEEE 1293)
  kGSensitivity, kG2Sensitivity,                             // gyro g-dependence
  kSizeEffect,                                               // accelerometer geometry
  kTempHysteresis, kTempRate,                                // thermal history
  kTiming,                                                   // timing
  kWhiteNoise, kBiasInstability, kRateRandomWalk, kQuantization, kSaturation, kTurnOnBias,  // noise/output
  kCount
};
constexpr int kNumEffects = static_cast<int>(Effect::kCount);

struct EffectInfo {
  Effect effect;
  const char* name;        // stable name, e.g. "bias_temp"
  const char* group;       // "basic", "temperature", "input dependence", ...
  std::uint8_t sensors;    // SensorMask
  EffectKind kind;
  std::vector<std::string> components;  // full component list, e.g. {"x.t1","x.t2",...}
  const char* units;       // human-readable units of the components
  const char* doc;         // one line; the equation is in docs/error-model.md
};

// The catalog, indexed by Effect.
const std::vector<EffectInfo>& effects();
const EffectInfo& effect_info(Effect e);
// Effect by name ("bias"); returns false if unknown.
bool find_effect(std::string_view name, Effect& out);

using ParamId = int;  // dense index into params(); −1 = none

// One scalar parameter. The indices describe where it acts in the measurement equation:
//   j      output axis (0..2) or −1 (sensor-wide, e.g. timing, tau_s)
//   k, l   second/third index: column of M, cross axis, g component(s), lever-arm component; −1 if unused
//   power  temperature power p (1..3) for *_temp, nonlinearity order (2, 3) for scale_nonlinearity; else 0
struct ParamInfo {
  ParamId id;
  std::string name;  // "<sensor>.<effect>.<component>"
  Sensor sensor;
  Effect effect;
  std::string component;
  int j, k, l, power;
  bool deterministic;  // has a regressor
};

// All catalog parameters for both sensors, in a fixed order (sensor, then effect, then component).
const std::vector<ParamInfo>& params();
int num_params();
const ParamInfo& param_info(ParamId id);
// Lookup by full name; −1 if unknown.
ParamId find_param(std::string_view name);
// Like find_param but throws std::invalid_argument naming the bad name and suggesting the effect's
// valid components (used when validating user files).
ParamId param_id_or_throw(std::string_view name);
// All parameter ids of one effect of one sensor (empty if the effect does not apply to the sensor).
std::vector<ParamId> effect_params(Sensor s, Effect e);

// A dense vector of catalog parameter values, indexed by ParamId; unset = 0.
class ParamSet {
 public:
  ParamSet();
  double operator[](ParamId id) const { return v_[static_cast<std::size_t>(id)]; }
  double& operator[](ParamId id) { return v_[static_cast<std::size_t>(id)]; }
  // By name; throws std::invalid_argument for an unknown name.
  double get(std::string_view name) const;
  void set(std::string_view name, double value);
  const std::vector<double>& values() const { return v_; }
  std::vector<double>& values() { return v_; }

 private:
  std::vector<double> v_;
};

}  // namespace imuforge::model
