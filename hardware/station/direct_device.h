// Direct device mode, for bench checks: an X4 lidar or an HI219 IMU plugged
// straight into the workstation (USB adapter), no robot agent in between.
// Opens the port at the device's rate (X4 128000, HI219 115200), sends the
// X4 requests (device info A5 90, health A5 92, scan A5 60 / stop A5 65) and
// decodes what comes back with the same codecs the agent's telemetry goes
// through; times are the workstation's monotonic clock.
//
// Threading: a DirectDevice lives on the thread that created it (an I/O
// thread) and is used only there.
#ifndef SWEEPSCAN_HARDWARE_STATION_DIRECT_DEVICE_H_
#define SWEEPSCAN_HARDWARE_STATION_DIRECT_DEVICE_H_

#include <QObject>
#include <QString>
#include <memory>
#include <vector>

#include "core/common/time.h"
#include "hardware/codecs/hi219_codec.h"
#include "hardware/codecs/x4_codec.h"
#include "hardware/link/qt_transport.h"

namespace sweepscan {
namespace hardware {

class DirectDevice : public QObject {
  Q_OBJECT
 public:
  enum class Kind { kX4, kHi219 };
  // baud 0 = the device's default.
  DirectDevice(Kind kind, const QString& port, qint32 baud = 0, QObject* parent = nullptr);
  ~DirectDevice() override;

  bool Open(QString* error);
  void Close();
  bool IsOpen() const;
  Kind kind() const { return kind_; }

  // X4 only (false for an HI219 or a closed port).
  bool RequestDeviceInfo();
  bool RequestHealth();
  bool StartScan();
  bool StopScan();

  // Last replies (X4), valid once the matching signal was emitted.
  const X4DeviceInfo& device_info() const { return device_info_; }
  const X4Health& health() const { return health_; }
  // Everything decoded since the previous call.
  std::vector<X4Scan> TakeScans();
  std::vector<ImuSample> TakeImuSamples();
  // Decoder counters (checksum errors etc.): the bench check's verdict on the cable.
  const DecoderStats& stats() const;
  uint64_t scans_received() const { return scans_received_; }
  uint64_t imu_samples_received() const { return imu_samples_received_; }

 signals:
  void deviceInfoReceived();
  void healthReceived();
  void scanReceived();  // One more revolution in TakeScans().
  void imuSampleReceived();
  void portError(const QString& reason);

 private:
  void OnBytes(const QByteArray& bytes);
  bool SendX4(uint8_t command);

  Kind kind_;
  QString port_name_;
  qint32 baud_;
  std::unique_ptr<SerialStream> port_;
  X4Decoder x4_;
  Hi219Decoder hi219_;
  X4DeviceInfo device_info_;
  X4Health health_;
  std::vector<X4Scan> scans_;
  std::vector<ImuSample> imu_;
  uint64_t scans_received_ = 0;
  uint64_t imu_samples_received_ = 0;
};

}  // namespace hardware
}  // namespace sweepscan

#endif  // SWEEPSCAN_HARDWARE_STATION_DIRECT_DEVICE_H_
