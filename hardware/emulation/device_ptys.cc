#include "hardware/emulation/device_ptys.h"

#include <QTimer>
#include <algorithm>

namespace sweepscan {
namespace hardware {
namespace {

constexpr std::array<LinkDevice, 3> kDevices = {LinkDevice::kLidar, LinkDevice::kImu,
                                                LinkDevice::kMotorBoard};
// The simulated world's time at the start (sim::SimWorld::kStartTimeS), as
// RobotAgentConfig::sim_clock_origin.
constexpr Duration kClockOrigin = std::chrono::seconds(1);
constexpr int kStepMs = 5;  // As RobotAgentConfig::sim_step_ms.

}  // namespace

DevicePtys::DevicePtys(std::unique_ptr<SimDevices> devices, int copies, QObject* parent)
    : QObject(parent), devices_(std::move(devices)), copies_(std::max(1, copies)) {}

DevicePtys::~DevicePtys() = default;

bool DevicePtys::Open(QString* error) {
  ptys_.assign(copies_, {});
  lidar_heard_.assign(copies_, false);
  for (int copy = 0; copy < copies_; ++copy) {
    for (size_t i = 0; i < kDevices.size(); ++i) {
      // A device does not wait for its host (PtyMasterStream).
      auto* pty = new PtyMasterStream(this, /*max_queued=*/0);
      if (!pty->Open(error)) return false;
      ptys_[copy][i] = pty;
      const LinkDevice device = kDevices[i];
      connect(pty, &ByteStream::bytesReceived, this,
              [this, copy, device](const QByteArray& bytes) { OnHostBytes(copy, device, bytes); });
    }
  }
  step_timer_ = new QTimer(this);
  step_timer_->setTimerType(Qt::PreciseTimer);
  connect(step_timer_, &QTimer::timeout, this, &DevicePtys::OnStep);
  return true;
}

std::array<QString, 3> DevicePtys::SlavePaths(int copy) const {
  std::array<QString, 3> paths;
  for (size_t i = 0; i < paths.size(); ++i) paths[i] = ptys_[copy][i]->SlavePath();
  return paths;
}

uint64_t DevicePtys::bytes_dropped() const {
  uint64_t n = 0;
  for (const auto& set : ptys_) {
    for (const PtyMasterStream* pty : set) n += pty->bytes_dropped();
  }
  return n;
}

Time DevicePtys::Now() const {
  return Time(kClockOrigin) + std::chrono::milliseconds(clock_.elapsed());
}

void DevicePtys::OnHostBytes(int copy, LinkDevice device, const QByteArray& bytes) {
  if (device == LinkDevice::kLidar && !lidar_heard_[copy]) {
    lidar_heard_[copy] = true;
    if (!started_ && std::all_of(lidar_heard_.begin(), lidar_heard_.end(), [](bool b) { return b; })) {
      started_ = true;
      clock_.start();
      step_timer_->start(kStepMs);
      emit worldStarted();
    }
  }
  emit hostBytes(copy, static_cast<int>(device), bytes);
  if (copy != 0) return;  // The mirrors' commands are not the robot's.
  devices_->WriteToDevice(device, reinterpret_cast<const uint8_t*>(bytes.constData()),
                          static_cast<size_t>(bytes.size()), started_ ? Now() : Time(kClockOrigin));
}

void DevicePtys::OnStep() {
  chunks_.clear();
  devices_->AdvanceTo(Now(), &chunks_);
  for (const TimedBytes& chunk : chunks_) {
    const size_t index = static_cast<size_t>(chunk.device) - 1;
    for (auto& set : ptys_) set[index]->Write(chunk.bytes.data(), chunk.bytes.size());
  }
}

}  // namespace hardware
}  // namespace sweepscan
