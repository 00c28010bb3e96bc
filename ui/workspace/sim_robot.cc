#include "ui/workspace/sim_robot.h"

#include <QMetaObject>
#include <random>

#include "hardware/agent/robot_agent.h"
#include "hardware/emulation/sim_devices.h"
#include "ui/workspace/thread_call.h"

namespace sweepscan::ui {

using hardware::RobotAgent;
using hardware::RobotAgentConfig;
using hardware::SimDevices;
using hardware::SimDevicesAdapter;
using hardware::TimedBytes;

SimRobot::SimRobot() { thread_.setObjectName(QStringLiteral("sim robot")); }

SimRobot::~SimRobot() { Stop(); }

bool SimRobot::Start(const sim::SimConfig& scenario, QString* error) {
  Stop();
  scenario_ = scenario;
  // A fresh 32-byte key per start: only this process can drive its robot.
  std::random_device rd;
  key_.resize(32);
  for (auto& b : key_) b = static_cast<uint8_t>(rd());

  RobotAgentConfig config;
  config.agent.name = "sweepscan built-in simulator (" + scenario.name + ")";
  config.agent.key = key_;
  config.agent.devices = {{1, "YDLIDAR X4 (simulated) @128000"},
                          {2, "HiPNUC HI219 (simulated) @115200"},
                          {3, "motor board (simulated) @115200"}};
  config.link = RobotAgentConfig::LinkKind::kTcp;
  config.listen_address = QStringLiteral("127.0.0.1");
  config.listen_port = 0;
  if (!config.IsValid(error)) return false;

  thread_.start();
  bool ok = false;
  // The agent and its devices are created on the robot thread so that their
  // timers and sockets belong to it.
  CallOnThread(&thread_, [&] {
    auto devices = std::make_unique<SimDevices>(scenario, SimDevices::Mode::kCommanded);
    agent_ = new RobotAgent(
        config, std::make_unique<SimDevicesAdapter<SimDevices, TimedBytes>>(std::move(devices)));
    ok = agent_->Start(error);
    if (!ok) {
      delete agent_;
      agent_ = nullptr;
    } else {
      port_ = agent_->tcp_port();
    }
  });
  if (!ok) {
    thread_.quit();
    thread_.wait();
  }
  return ok;
}

void SimRobot::Stop() {
  if (!thread_.isRunning()) return;
  if (agent_ != nullptr) {
    RobotAgent* agent = agent_;
    QMetaObject::invokeMethod(
        agent,
        [agent] {
          agent->Shutdown();
          delete agent;
        },
        Qt::BlockingQueuedConnection);
    agent_ = nullptr;
  }
  thread_.quit();
  thread_.wait();
}

QString SimRobot::address() const { return QStringLiteral("tcp:127.0.0.1:%1").arg(port_); }

Twist2d SimRobot::TrueTwist() const {
  Twist2d twist;
  if (agent_ == nullptr) return twist;
  RobotAgent* agent = agent_;
  QMetaObject::invokeMethod(
      agent,
      [agent, &twist] {
        auto* adapter =
            static_cast<SimDevicesAdapter<SimDevices, TimedBytes>*>(agent->virtual_devices());
        if (adapter != nullptr) twist = adapter->sim()->CurrentTwist();
      },
      Qt::BlockingQueuedConnection);
  return twist;
}

}  // namespace sweepscan::ui
