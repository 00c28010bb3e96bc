// Connection panel: the built-in simulator (default, with a scenario chooser
// over resources/scenarios), TCP (host, port, key file) or serial (port
// list, baud); connect / disconnect; link state and health (LinkHealth).
// GUI thread. Calls only the Workspace.
#ifndef SWEEPSCAN_UI_PANELS_CONNECTION_PANEL_H_
#define SWEEPSCAN_UI_PANELS_CONNECTION_PANEL_H_

#include <QWidget>
#include <functional>

#include "ui/workspace/workspace.h"

class QComboBox;
class QLabel;
class QLineEdit;
class QPushButton;
class QSpinBox;
class QStackedWidget;

namespace sweepscan::ui {

class ConnectionPanel : public QWidget {
  Q_OBJECT
 public:
  ConnectionPanel(Workspace* workspace, const QString& scenarios_dir, QWidget* parent = nullptr);

  ConnectOptions options() const;
  void SetOptions(const ConnectOptions& options);
  // The link's health as the panel shows it, a few short lines an operator
  // reads at a glance: the rates, the round trip, the errors (or none),
  // the robot's battery and faults, the outages.
  static QString HealthText(const hardware::LinkHealth& h);
  // Connects with the panel's options; errors go to the caller as a message.
  bool ConnectNow(QString* error);
  // Asked before the Connect button connects (a connection replaces the
  // session shown): false holds it; `retry` connects once the question is
  // settled (an unsaved recording being copied first).
  void SetConfirm(std::function<bool(const std::function<void()>& retry)> confirm) {
    confirm_ = std::move(confirm);
  }
  // What Connect (the button, Robot > Connect) does: asks, then connects;
  // an error is errorOccurred.
  void RequestConnect();

 signals:
  void errorOccurred(const QString& message);

 private:
  void RefreshSerialPorts();
  void UpdateState();

  Workspace* workspace_;
  std::function<bool(const std::function<void()>&)> confirm_;
  QComboBox* kind_;
  QStackedWidget* pages_;
  QComboBox* scenario_;
  QLineEdit* host_;
  QSpinBox* port_;
  QLineEdit* key_file_;
  QComboBox* serial_port_;
  QComboBox* baud_;
  QPushButton* connect_;
  QPushButton* disconnect_;
  QLabel* state_;
  QLabel* health_;
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_PANELS_CONNECTION_PANEL_H_
