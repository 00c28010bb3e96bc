// Connection panel: the built-in simulator (default, with a scenario chooser
// over resources/scenarios), TCP (host, port, key file) or serial (port
// list, baud); connect / disconnect; link state and health (LinkHealth).
// GUI thread. Calls only the Workspace.
#ifndef SWEEPSCAN_UI_PANELS_CONNECTION_PANEL_H_
#define SWEEPSCAN_UI_PANELS_CONNECTION_PANEL_H_

#include <QWidget>

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
  // Connects with the panel's options; errors go to the caller as a message.
  bool ConnectNow(QString* error);

 signals:
  void errorOccurred(const QString& message);

 private:
  void RefreshSerialPorts();
  void UpdateState();

  Workspace* workspace_;
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
