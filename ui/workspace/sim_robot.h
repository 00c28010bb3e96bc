// The built-in simulated robot: the scenario's world behind the byte-exact
// device emulations (SimDevices) and the real robot agent (RobotAgent),
// listening on loopback TCP with a fresh random key, on a thread of its own.
// The workspace connects to it through RobotConnection exactly as to a robot
// (or to a `sweepscan-sim` process), so the app exercises the real link.
//
// Threading: created and destroyed on the GUI thread; the agent and the
// devices live on the robot thread. Queries (TrueTwist) block briefly on it.
#ifndef SWEEPSCAN_UI_WORKSPACE_SIM_ROBOT_H_
#define SWEEPSCAN_UI_WORKSPACE_SIM_ROBOT_H_

#include <QObject>
#include <QString>
#include <QThread>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/robot/robot_model.h"
#include "core/sim/world.h"

namespace sweepscan::hardware {
class RobotAgent;
}

namespace sweepscan::ui {

class SimRobot {
 public:
  SimRobot();
  ~SimRobot();
  SimRobot(const SimRobot&) = delete;
  SimRobot& operator=(const SimRobot&) = delete;

  // Starts the agent on 127.0.0.1 (any free port). False with a message.
  bool Start(const sim::SimConfig& scenario, QString* error);
  void Stop();
  bool running() const { return agent_ != nullptr; }

  QString address() const;  // "tcp:127.0.0.1:PORT"
  const std::vector<uint8_t>& key() const { return key_; }
  const sim::SimConfig& scenario() const { return scenario_; }
  // The simulated robot's actual motion now (the world's twist, not a
  // measurement): what an emergency stop must bring to zero.
  Twist2d TrueTwist() const;

 private:
  QThread thread_;
  hardware::RobotAgent* agent_ = nullptr;  // Lives on thread_.
  sim::SimConfig scenario_;
  std::vector<uint8_t> key_;
  uint16_t port_ = 0;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_WORKSPACE_SIM_ROBOT_H_
