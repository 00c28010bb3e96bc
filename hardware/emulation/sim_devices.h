// Byte-exact emulations of the robot's three serial devices (YDLIDAR X4,
// HiPNUC HI219, STM32 motor board) on top of sim::SimWorld, so that the robot
// agent, and through it the workstation, cannot tell the simulator from a
// robot. docs/simulator.md describes what each device sends and when.
//
// Time model. Everything runs on robot time. AdvanceTo(now) runs the world up
// to `now` and returns every chunk of device bytes that the agent could have
// read by `now`: a frame's bytes become available when the data in it was
// measured plus its serial transmission time (bytes * 10 / baud, 8N1). For
// the X4 the decoder's time-stamp rule (X4DecoderOptions: the transmission
// time, and the sample clock for the short packets before a ring start,
// which it sees as queued) recovers the simulated sample times. For the
// HI219 and the motor board the decoded receive time is the sample time plus
// ImuTransmissionTime() resp. MotorTransmissionTime(), which is what
// TelemetryDecoder subtracts by default (each frame's length at
// TelemetryDecoderOptions::imu_baud / motor_baud).
//
// Output does not depend on how AdvanceTo is chunked (the world's noise does
// not either), and writes take effect at the time they are given.
//
// Threading: one SimDevices is used from one thread at a time (the agent's).
#ifndef SWEEPSCAN_HARDWARE_EMULATION_SIM_DEVICES_H_
#define SWEEPSCAN_HARDWARE_EMULATION_SIM_DEVICES_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/common/time.h"
#include "core/sim/world.h"
#include "hardware/codecs/codec_common.h"
#include "hardware/codecs/motor_board_codec.h"
#include "hardware/codecs/x4_codec.h"  // Callers build X4 commands with it.
#include "hardware/link/link_protocol.h"

namespace sweepscan {
namespace hardware {

// Bytes one device sent, and the robot time at which the agent can read them
// (the time the last of them arrived).
struct TimedBytes {
  LinkDevice device = LinkDevice::kLidar;
  Time time;
  std::vector<uint8_t> bytes;
};

struct SimDevicesOptions {
  // Serial line rates (bits per second, 8N1 = 10 bits per byte). <= 0 drops
  // the transmission time (bytes available the instant the data is measured).
  double lidar_baud = 128000.0;
  double imu_baud = 115200.0;
  double motor_baud = 115200.0;

  // 0: one TimedBytes per frame / packet / response. > 0: frames are split
  // into chunks of at most this many bytes, each available when its last
  // byte has arrived (what a serial port read returns), to exercise the
  // decoders' resynchronisation across reads.
  size_t max_chunk_bytes = 0;

  // X4: samples per packet (the real device sends 40) and what the device
  // info response carries.
  size_t lidar_samples_per_packet = 40;
  uint16_t lidar_firmware = 0x0108;  // 1.8
  uint8_t lidar_hardware = 1;
  std::array<uint8_t, 16> lidar_serial = {2, 0, 2, 4, 0, 3, 1, 5, 0, 0, 0, 0, 0, 0, 4, 2};
  // Before the X4 streams it needs `A5 60`; true starts streaming at once
  // (offline use without an agent). The scan start header is then sent at
  // time zero of the world.
  bool lidar_start_scanning = false;

  // Motor board (kCommanded): the board's speed loop, modelled as a first
  // order lag with this time constant, applied every control period as a
  // piecewise-constant twist (so the true trajectory stays exact closed-form
  // arcs). time constant 0 = the commanded twist is applied at the control
  // tick following the command.
  double motor_time_constant_s = 0.05;
  double motor_control_period_s = 0.01;
  // The robot's footprint, a circle of this radius around the centre of
  // motion: the simulated robot stops at walls and furniture instead of
  // driving through them (as a bumper stop does; turning on the spot stays
  // allowed). <= 0: no collisions (a robot that drives through walls).
  double body_radius_m = 0.22;
  // Battery voltage reported in the feedback: start, and linear drop.
  double battery_start_v = 12.1;
  double battery_drop_v_per_hour = 0.4;

  // HI219 0x91 extras.
  int8_t imu_temperature_c = 31;
  float imu_pressure_pa = 101325.0f;

  bool IsValid(std::string* error) const;
};

struct SimDevicesStats {
  // Output.
  uint64_t lidar_packets = 0;
  uint64_t lidar_samples_sent = 0;
  uint64_t lidar_samples_dropped = 0;  // Measured while not streaming (or motor off).
  uint64_t lidar_responses = 0;        // Device info, health, scan start headers.
  uint64_t imu_frames = 0;
  uint64_t motor_frames = 0;
  uint64_t bytes_out[3] = {0, 0, 0};  // Lidar, IMU, motor board (as returned by AdvanceTo).
  // Input.
  uint64_t bytes_in[3] = {0, 0, 0};
  uint64_t lidar_commands = 0;          // Well-formed X4 commands acted on.
  uint64_t lidar_unknown_commands = 0;  // Well-formed but unknown (ignored).
  uint64_t lidar_garbage_bytes = 0;     // Bytes that were not part of a command.
  uint64_t imu_bytes_ignored = 0;       // The emulated HI219 takes no input.
  uint64_t motor_commands = 0;          // Decoded command frames.
  uint64_t motor_commands_ignored = 0;  // Decoded in kScripted mode (the path drives).
  DecoderStats motor_command_decoder;   // Garbage and bad frames written to the board.
  uint64_t late_writes = 0;  // Writes with a time before the last AdvanceTo (clamped to it).

  std::string ToString() const;
};

class SimDevices {
 public:
  enum class Mode {
    kScripted,   // The robot follows the scenario's path; motor commands are ignored.
    kCommanded,  // The robot follows motor-board velocity commands; never finishes.
  };

  SimDevices(const sim::SimConfig& config, Mode mode,
             const SimDevicesOptions& options = SimDevicesOptions());
  ~SimDevices();
  SimDevices(const SimDevices&) = delete;
  SimDevices& operator=(const SimDevices&) = delete;

  // Host-to-device bytes written at robot time `now` (any chunking, garbage
  // allowed: it is ignored and counted). X4: `A5 60` start scan (scan start
  // header, then packets), `A5 65` stop, `A5 90` device info, `A5 92`
  // health, `A5 80` reset (stops). Motor board: 11-byte command frames.
  // `now` should not be before the last AdvanceTo; if it is, it is clamped.
  void WriteToDevice(LinkDevice device, const uint8_t* data, size_t n, Time now);
  void WriteToDevice(LinkDevice device, const std::vector<uint8_t>& bytes, Time now) {
    WriteToDevice(device, bytes.data(), bytes.size(), now);
  }
  // The X4's motor, switched through the adapter's DTR line: while it is
  // off no packets are sent (samples are dropped). On by default.
  void SetLidarMotor(bool on, Time now);

  // Runs the world to `now` and appends to *out every device output that is
  // available by `now`, in time order (ties: lidar, IMU, motor board).
  void AdvanceTo(Time now, std::vector<TimedBytes>* out);

  const sim::SimWorld& world() const;
  Mode mode() const { return mode_; }
  const SimDevicesOptions& options() const { return options_; }
  // kScripted: the path is done and every byte it produced was returned.
  // kCommanded: never.
  bool finished() const;
  // The latest time given to AdvanceTo (robot time); Time::min() before.
  Time now() const { return now_; }
  const SimDevicesStats& stats() const;

  // Serial transmission time of one HI219 0x91 frame / motor feedback frame
  // at the configured baud: the delay between a sample and its availability.
  Duration ImuTransmissionTime() const;
  Duration MotorTransmissionTime() const;
  // The twist the motor board currently drives (kCommanded), after the lag.
  Twist2d CurrentTwist() const;

 private:
  class Impl;
  Mode mode_;
  SimDevicesOptions options_;
  Time now_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_EMULATION_SIM_DEVICES_H_
