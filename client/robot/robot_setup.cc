#include "client/robot/robot_setup.h"

#include <fmt/format.h>

#include "absl/strings/match.h"
#include "client/devices/lms200_scanner.h"
#include "client/devices/pioneer_base.h"
#include "client/devices/reconnecting_devices.h"
#include "client/sim/sim_realtime.h"
#include "client/sim/sim_world.h"

namespace waymark::cli {

RobotDevices::RobotDevices() = default;
RobotDevices::~RobotDevices() = default;
RobotDevices::RobotDevices(RobotDevices&&) noexcept = default;
RobotDevices& RobotDevices::operator=(RobotDevices&&) noexcept = default;

absl::StatusOr<DeviceSpec> ParseDeviceSpec(const std::string& text, const std::string& flag) {
  DeviceSpec spec;
  if (absl::StartsWith(text, "serial:") && text.size() > 7) {
    spec.kind = DeviceSpec::Kind::kSerial;
    spec.argument = text.substr(7);
    return spec;
  }
  if (text == "sim" || (absl::StartsWith(text, "sim:") && text.size() > 4)) {
    spec.kind = DeviceSpec::Kind::kSim;
    spec.argument = text == "sim" ? "" : text.substr(4);
    return spec;
  }
  return absl::InvalidArgumentError(fmt::format(
      "{} '{}': expected serial:DEVICE (e.g. serial:/dev/ttyS0) or sim:WORLD (a built-in world "
      "or a world file; bare 'sim' for the laser)",
      flag, text));
}

absl::StatusOr<RobotDevices> OpenRobotDevices(const RobotSetupOptions& options) {
  auto base_spec = ParseDeviceSpec(options.base, "--base");
  if (!base_spec.ok()) return base_spec.status();
  auto laser_spec = ParseDeviceSpec(options.laser, "--laser");
  if (!laser_spec.ok()) return laser_spec.status();
  const bool sim_base = base_spec->kind == DeviceSpec::Kind::kSim;
  const bool sim_laser = laser_spec->kind == DeviceSpec::Kind::kSim;
  if (sim_base != sim_laser) {
    return absl::InvalidArgumentError(
        "--base and --laser must both be serial devices or both simulated (--base sim:WORLD "
        "--laser sim): a simulated laser needs the simulated robot's world");
  }
  if (sim_base && base_spec->argument.empty()) {
    return absl::InvalidArgumentError(
        "--base sim needs a world: sim:NAME (a built-in world, see `waymark sim worlds`) or "
        "sim:FILE");
  }
  if (sim_laser && !laser_spec->argument.empty()) {
    return absl::InvalidArgumentError("--laser takes a bare 'sim': the world comes from --base");
  }
  if (!(options.sim_speed > 0)) {
    return absl::InvalidArgumentError("--sim-speed must be > 0");
  }

  RobotDevices devices;
  if (sim_base) {
    auto world = adapters::LoadWorld(base_spec->argument);
    if (!world.ok()) return world.status();
    const std::string world_name = world->name.empty() ? base_spec->argument : world->name;
    adapters::RealTimeSimOptions sim_options;
    sim_options.sim.seed = options.seed;
    sim_options.sim.half_degree = options.half_degree;
    sim_options.speed = options.sim_speed;
    // The serial LMS200 at 38400 baud delivers ~10 Hz at 1 degree and ~5 Hz at 0.5 degree.
    sim_options.scan_period = options.half_degree ? 0.2 : 0.1;
    devices.sim = std::make_unique<adapters::RealTimeSimulation>(*std::move(world), sim_options);
    devices.base = &devices.sim->base();
    devices.laser = &devices.sim->laser();
    devices.time_scale = options.sim_speed;
    devices.description = fmt::format("simulated Pioneer with LMS200 in world '{}' ({}x real time)",
                                      world_name, options.sim_speed);
    return devices;
  }

  // Laser first: it takes the longest to answer, and a robot that cannot see must not move.
  adapters::Lms200Options laser_options;
  laser_options.baud = options.laser_baud;
  laser_options.half_degree = options.half_degree;
  auto laser = adapters::ReconnectingLaser::Create(
      [device = laser_spec->argument,
       laser_options]() -> absl::StatusOr<std::unique_ptr<adapters::LaserScanner>> {
        auto scanner = adapters::Lms200Scanner::Connect(device, laser_options);
        if (!scanner.ok()) return scanner.status();
        return std::unique_ptr<adapters::LaserScanner>(*std::move(scanner));
      });
  if (!laser.ok()) return laser.status();
  adapters::PioneerOptions base_options;
  base_options.baud = options.base_baud;
  auto base = adapters::ReconnectingBase::Create(
      [device = base_spec->argument,
       base_options]() -> absl::StatusOr<std::unique_ptr<adapters::MobileBase>> {
        auto pioneer = adapters::PioneerBase::Connect(device, base_options);
        if (!pioneer.ok()) return pioneer.status();
        return std::unique_ptr<adapters::MobileBase>(*std::move(pioneer));
      });
  if (!base.ok()) return base.status();
  devices.serial_laser = *std::move(laser);
  devices.serial_base = *std::move(base);
  devices.base = devices.serial_base.get();
  devices.laser = devices.serial_laser.get();
  devices.description = fmt::format("Pioneer on {}, LMS200 on {} ({} beams)", base_spec->argument,
                                    laser_spec->argument, devices.laser->layout().beam_count);
  return devices;
}

}  // namespace waymark::cli
