#include "hardware/station/direct_device.h"

#include <chrono>
#include <utility>

namespace sweepscan {
namespace hardware {
namespace {

Time SteadyNow() {
  return Time(
      std::chrono::duration_cast<Duration>(std::chrono::steady_clock::now().time_since_epoch()));
}

X4DecoderOptions BenchX4Options(qint32 baud) {
  X4DecoderOptions options;
  options.baud_rate = baud;
  options.keep_packets = false;  // Only revolutions are shown; the queue must not grow.
  return options;
}

}  // namespace

DirectDevice::DirectDevice(Kind kind, const QString& port, qint32 baud, QObject* parent)
    : QObject(parent),
      kind_(kind),
      port_name_(port),
      baud_(baud > 0 ? baud : (kind == Kind::kX4 ? 128000 : 115200)),
      x4_(BenchX4Options(baud_)) {}

DirectDevice::~DirectDevice() { Close(); }

bool DirectDevice::Open(QString* error) {
  port_ = std::make_unique<SerialStream>();
  if (!port_->Open(port_name_, baud_, error)) {
    port_.reset();
    return false;
  }
  connect(port_.get(), &ByteStream::bytesReceived, this, &DirectDevice::OnBytes);
  connect(port_.get(), &ByteStream::closed, this, &DirectDevice::portError);
  if (kind_ == Kind::kX4) port_->SetDataTerminalReady(true);  // Motor enable on the adapter.
  return true;
}

void DirectDevice::Close() {
  if (port_ == nullptr) return;
  if (kind_ == Kind::kX4 && port_->IsOpen()) SendX4(kX4CmdStop);
  port_->disconnect(this);
  port_->Close();
  port_.reset();
}

bool DirectDevice::IsOpen() const { return port_ != nullptr && port_->IsOpen(); }

bool DirectDevice::SendX4(uint8_t command) {
  if (kind_ != Kind::kX4 || !IsOpen()) return false;
  const std::vector<uint8_t> bytes = EncodeX4Command(command);
  return port_->Write(bytes.data(), bytes.size());
}

bool DirectDevice::RequestDeviceInfo() { return SendX4(kX4CmdDeviceInfo); }
bool DirectDevice::RequestHealth() { return SendX4(kX4CmdHealth); }
bool DirectDevice::StartScan() { return SendX4(kX4CmdScan); }
bool DirectDevice::StopScan() { return SendX4(kX4CmdStop); }

void DirectDevice::OnBytes(const QByteArray& bytes) {
  const Time now = SteadyNow();
  const auto* data = reinterpret_cast<const uint8_t*>(bytes.constData());
  const size_t n = static_cast<size_t>(bytes.size());
  if (kind_ == Kind::kX4) {
    x4_.Feed(data, n, now);
    for (X4DeviceInfo& info : x4_.TakeDeviceInfos()) {
      device_info_ = info;
      emit deviceInfoReceived();
    }
    for (X4Health& health : x4_.TakeHealth()) {
      health_ = health;
      emit healthReceived();
    }
    for (X4Scan& scan : x4_.TakeScans()) {
      scans_.push_back(std::move(scan));
      ++scans_received_;
      emit scanReceived();
    }
  } else {
    hi219_.Feed(data, n, now);
    const std::vector<ImuSample> samples = hi219_.TakeSamples();
    if (!samples.empty()) {
      imu_.insert(imu_.end(), samples.begin(), samples.end());
      imu_samples_received_ += samples.size();
      emit imuSampleReceived();
    }
  }
}

std::vector<X4Scan> DirectDevice::TakeScans() { return std::exchange(scans_, {}); }
std::vector<ImuSample> DirectDevice::TakeImuSamples() { return std::exchange(imu_, {}); }

const DecoderStats& DirectDevice::stats() const {
  return kind_ == Kind::kX4 ? x4_.stats() : hi219_.stats();
}

}  // namespace hardware
}  // namespace sweepscan
