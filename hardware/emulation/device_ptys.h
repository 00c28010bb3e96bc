// The simulated devices on pseudo-terminals: each of the X4, the HI219 and
// the motor board gets a pty whose slave a real sweepscan-robotd opens as its
// --lidar, --imu and --motor port, byte-exact as on the robot (SimDevices).
// This is how robotd itself is tested end to end, on this machine and, built
// for arm64, under qemu (scripts/arm64-e2e.sh).
//
// `copies` > 1 serves the same bytes on that many sets of ptys, so that two
// agents (say the amd64 and the arm64 build) read the very same device
// stream at the same time; only the first set's writes (X4 and motor
// commands) reach the devices, the others' are read and ignored.
//
// The world's clock starts when every set's lidar port has been written to
// (robotd stops a possibly running X4 as soon as it opens the port), so no
// device byte is sent before every agent reads, and none is lost in a pty's
// buffer while an agent is still starting (qemu takes a while).
#ifndef SWEEPSCAN_HARDWARE_EMULATION_DEVICE_PTYS_H_
#define SWEEPSCAN_HARDWARE_EMULATION_DEVICE_PTYS_H_

#include <QElapsedTimer>
#include <QObject>
#include <QString>
#include <array>
#include <memory>
#include <vector>

#include "hardware/emulation/sim_devices.h"
#include "hardware/link/qt_transport.h"

class QTimer;

namespace sweepscan {
namespace hardware {

class DevicePtys : public QObject {
  Q_OBJECT
 public:
  DevicePtys(std::unique_ptr<SimDevices> devices, int copies, QObject* parent = nullptr);
  ~DevicePtys() override;

  // Opens the ptys. False with a message if the system has none to give.
  bool Open(QString* error);
  // The slave paths of set `copy`: lidar, imu, motor board.
  std::array<QString, 3> SlavePaths(int copy) const;
  bool started() const { return started_; }
  uint64_t bytes_dropped() const;  // Not taken by a pty (an agent not reading).
  const SimDevices& devices() const { return *devices_; }

 signals:
  void worldStarted();
  // Bytes an agent wrote to a device (`device`: a LinkDevice), any set.
  void hostBytes(int copy, int device, const QByteArray& bytes);

 private:
  void OnHostBytes(int copy, LinkDevice device, const QByteArray& bytes);
  void OnStep();
  Time Now() const;

  std::unique_ptr<SimDevices> devices_;
  int copies_;
  std::vector<std::array<PtyMasterStream*, 3>> ptys_;
  std::vector<bool> lidar_heard_;
  bool started_ = false;
  QElapsedTimer clock_;
  QTimer* step_timer_ = nullptr;
  std::vector<TimedBytes> chunks_;
};

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_EMULATION_DEVICE_PTYS_H_
