#ifndef WAYMARK_CLIENT_ROBOT_ROBOT_SETUP_H_
#define WAYMARK_CLIENT_ROBOT_ROBOT_SETUP_H_

// Opens the devices `waymark robot` names: `--base serial:DEVICE` (Pioneer over ARCOS/P2OS) or
// `sim:WORLD` (the simulator, running in real time or faster), `--laser serial:DEVICE` (SICK
// LMS200) or `sim` (the simulator's laser; needs --base sim:WORLD: one simulated world).

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "client/devices/robot_devices.h"

namespace waymark::adapters {
class RealTimeSimulation;
class ReconnectingBase;
class ReconnectingLaser;
}  // namespace waymark::adapters

namespace waymark::cli {

struct DeviceSpec {
  enum class Kind { kSerial, kSim };
  Kind kind = Kind::kSerial;
  std::string argument;  // device path, world name or file; empty for a bare "sim"
};
// "serial:/dev/ttyS0", "sim:corridor", "sim". INVALID_ARGUMENT naming the accepted forms.
absl::StatusOr<DeviceSpec> ParseDeviceSpec(const std::string& text, const std::string& flag);

struct RobotSetupOptions {
  std::string base = "sim:corridor";
  std::string laser = "sim";
  int base_baud = 9600;      // ARCOS default
  int laser_baud = 38400;    // the rate the laser is switched to (it powers up at 9600)
  bool half_degree = false;  // 361 beams at 0.5 degree
  double sim_speed = 1.0;    // simulated seconds per wall second
  uint64_t seed = 1;
};

// The opened devices. Destroying it stops and releases them (serial adapters send stop / CLOSE).
struct RobotDevices {
  RobotDevices();
  ~RobotDevices();
  RobotDevices(RobotDevices&&) noexcept;
  RobotDevices& operator=(RobotDevices&&) noexcept;

  std::unique_ptr<adapters::RealTimeSimulation> sim;
  // Serial devices reconnect by themselves after an unplugged cable (reconnecting_devices.h).
  std::unique_ptr<adapters::ReconnectingBase> serial_base;
  std::unique_ptr<adapters::ReconnectingLaser> serial_laser;
  adapters::MobileBase* base = nullptr;
  adapters::LaserScanner* laser = nullptr;
  double time_scale = 1.0;  // device seconds per wall second
  std::string description;  // "Pioneer 'PIONEER3' on /dev/ttyS0, LMS200 on /dev/ttyUSB0"
};

absl::StatusOr<RobotDevices> OpenRobotDevices(const RobotSetupOptions& options);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_ROBOT_ROBOT_SETUP_H_
