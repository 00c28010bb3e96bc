#include "hardware/sim_devices.h"

#include <sstream>

namespace sweepscan {
namespace hardware {

bool SimDevicesOptions::IsValid(std::string* error) const {
  if (lidar_samples_per_packet < 1 || lidar_samples_per_packet > kX4MaxSamplesPerPacket) {
    *error = "lidar_samples_per_packet must be within 1..255";
    return false;
  }
  if (!(motor_time_constant_s >= 0) || !(motor_control_period_s > 0)) {
    *error = "motor_time_constant_s must be >= 0 and motor_control_period_s > 0";
    return false;
  }
  return true;
}

std::string SimDevicesStats::ToString() const {
  std::ostringstream s;
  s << "lidar packets " << lidar_packets << ", imu frames " << imu_frames << ", motor frames "
    << motor_frames;
  return s.str();
}

// The emulation proper; first version: runs the world, devices stay silent.
class SimDevices::Impl : public sim::SensorSink {
 public:
  explicit Impl(const sim::SimConfig& config) : world(config) {}
  void OnWheels(const WheelSpeedMeasurement&) override {}
  void OnImu(const ImuMeasurement&) override {}
  void OnLidarSample(uint32_t, bool, const LidarSample&) override {}

  sim::SimWorld world;
  SimDevicesStats stats;
};

SimDevices::SimDevices(const sim::SimConfig& config, Mode mode, const SimDevicesOptions& options)
    : mode_(mode), options_(options), impl_(std::make_unique<Impl>(config)) {}
SimDevices::~SimDevices() = default;

void SimDevices::WriteToDevice(LinkDevice device, const uint8_t*, size_t n, Time) {
  impl_->stats.bytes_in[static_cast<int>(device) - 1] += n;
}
void SimDevices::SetLidarMotor(bool, Time) {}
void SimDevices::AdvanceTo(Time now, std::vector<TimedBytes>*) {
  now_ = now;
  impl_->world.RunUntil(now, impl_.get());
}
const sim::SimWorld& SimDevices::world() const { return impl_->world; }
bool SimDevices::finished() const { return mode_ == Mode::kScripted && impl_->world.finished(); }
const SimDevicesStats& SimDevices::stats() const { return impl_->stats; }
Duration SimDevices::ImuTransmissionTime() const {
  return options_.imu_baud > 0 ? FromSeconds(82 * 10.0 / options_.imu_baud) : Duration(0);
}
Duration SimDevices::MotorTransmissionTime() const {
  return options_.motor_baud > 0 ? FromSeconds(24 * 10.0 / options_.motor_baud) : Duration(0);
}
Twist2d SimDevices::CurrentTwist() const { return {}; }

}  // namespace hardware
}  // namespace sweepscan
