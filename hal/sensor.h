// Sensor seam: one raw IMU sample as the sensor front end delivers it, before any compensation.
//
// Raw counts are what the coefficient table and the host solver expect (docs/error-model.md: counts =
// clamp(round(y / lsb))). Temperature is the die temperature in 0.01 degC steps (int16: -327.68..327.67).
// Backends: the virtual IMU's simulated sensor (host/vimu/, fed by the bench simulator or a stand-in
// signal), a real SPI/I2C driver on target.
#pragma once
#include <cstdint>

namespace imuforge::hal {

struct ImuRawSample {
  std::int16_t accel_counts[3] = {0, 0, 0};  // x, y, z
  std::int16_t gyro_counts[3] = {0, 0, 0};   // x, y, z
  std::int16_t temp_cdegC = 0;               // die temperature, 0.01 degC per count
};

enum SensorError : int {
  kSensorOk = 0,
  kSensorErrNotReady = -1,  // no new sample yet
  kSensorErrIo = -2,        // bus/driver failure
};

class Sensor {
 public:
  // Samples the sensor at sensor time t_us (the node's clock). Returns kSensorOk or a negative code.
  virtual int read(std::uint64_t t_us, ImuRawSample& out) noexcept = 0;

 protected:
  ~Sensor() = default;
};

}  // namespace imuforge::hal
