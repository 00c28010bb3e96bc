#include "ui/panels/connection_panel.h"

#include <QComboBox>
#include <QDir>
#include <QFileDialog>
#include <QFileInfo>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QSerialPortInfo>
#include <QSpinBox>
#include <QStackedWidget>
#include <QToolButton>
#include <QVBoxLayout>

namespace sweepscan::ui {

ConnectionPanel::ConnectionPanel(Workspace* workspace, const QString& scenarios_dir,
                                 QWidget* parent)
    : QWidget(parent), workspace_(workspace) {
  auto* layout = new QVBoxLayout(this);
  kind_ = new QComboBox;
  kind_->addItems({tr("Built-in simulator"), tr("Robot over TCP"), tr("Robot over serial")});
  kind_->setToolTip(tr("Where the robot link goes"));
  layout->addWidget(kind_);

  pages_ = new QStackedWidget;
  // Simulator.
  auto* sim_page = new QWidget;
  auto* sim_form = new QFormLayout(sim_page);
  scenario_ = new QComboBox;
  for (const QFileInfo& f :
       QDir(scenarios_dir).entryInfoList({QStringLiteral("*.json")}, QDir::Files, QDir::Name)) {
    scenario_->addItem(f.completeBaseName(), f.absoluteFilePath());
  }
  // Sized for about 20 characters, not the longest scenario's name: a long
  // name would widen the dock and take the width from the 3D view (the list
  // shows the names in full when opened).
  scenario_->setSizeAdjustPolicy(QComboBox::AdjustToMinimumContentsLengthWithIcon);
  scenario_->setMinimumContentsLength(20);
  scenario_->setToolTip(tr("The simulated world (resources/scenarios)"));
  sim_form->addRow(tr("Scenario"), scenario_);
  pages_->addWidget(sim_page);
  // TCP.
  auto* tcp_page = new QWidget;
  auto* tcp_form = new QFormLayout(tcp_page);
  host_ = new QLineEdit(QStringLiteral("127.0.0.1"));
  port_ = new QSpinBox;
  port_->setRange(1, 65535);
  port_->setValue(5600);
  auto* key_row = new QHBoxLayout;
  key_file_ = new QLineEdit;
  key_file_->setPlaceholderText(tr("the agent's --key-file"));
  auto* browse = new QToolButton;
  browse->setText(QStringLiteral("…"));
  connect(browse, &QToolButton::clicked, this, [this] {
    const QString f = QFileDialog::getOpenFileName(this, tr("Robot key file"));
    if (!f.isEmpty()) key_file_->setText(f);
  });
  key_row->addWidget(key_file_);
  key_row->addWidget(browse);
  tcp_form->addRow(tr("Host"), host_);
  tcp_form->addRow(tr("Port"), port_);
  tcp_form->addRow(tr("Key file"), key_row);
  pages_->addWidget(tcp_page);
  // Serial.
  auto* serial_page = new QWidget;
  auto* serial_form = new QFormLayout(serial_page);
  auto* port_row = new QHBoxLayout;
  serial_port_ = new QComboBox;
  serial_port_->setEditable(true);
  auto* refresh = new QToolButton;
  refresh->setText(tr("Refresh"));
  connect(refresh, &QToolButton::clicked, this, &ConnectionPanel::RefreshSerialPorts);
  port_row->addWidget(serial_port_, 1);
  port_row->addWidget(refresh);
  baud_ = new QComboBox;
  baud_->setEditable(true);
  baud_->addItems({QStringLiteral("921600"), QStringLiteral("460800"), QStringLiteral("230400"),
                   QStringLiteral("115200")});
  serial_form->addRow(tr("Port"), port_row);
  serial_form->addRow(tr("Baud"), baud_);
  pages_->addWidget(serial_page);
  layout->addWidget(pages_);
  connect(kind_, QOverload<int>::of(&QComboBox::currentIndexChanged), pages_,
          &QStackedWidget::setCurrentIndex);
  // The stack as tall as the page shown (a QStackedWidget takes its tallest
  // page's height: the TCP page left a blank gap under the simulator's).
  auto fit_pages = [this](int shown) {
    for (int i = 0; i < pages_->count(); ++i) {
      pages_->widget(i)->setSizePolicy(QSizePolicy::Preferred,
                                       i == shown ? QSizePolicy::Preferred : QSizePolicy::Ignored);
    }
    pages_->adjustSize();
  };
  connect(pages_, &QStackedWidget::currentChanged, this, fit_pages);
  fit_pages(pages_->currentIndex());
  RefreshSerialPorts();

  auto* buttons = new QHBoxLayout;
  connect_ = new QPushButton(tr("Connect"));
  disconnect_ = new QPushButton(tr("Disconnect"));
  buttons->addWidget(connect_);
  buttons->addWidget(disconnect_);
  layout->addLayout(buttons);
  connect(connect_, &QPushButton::clicked, this, &ConnectionPanel::RequestConnect);
  connect(disconnect_, &QPushButton::clicked, workspace_, &Workspace::Disconnect);

  state_ = new QLabel;
  state_->setObjectName(QStringLiteral("linkState"));
  layout->addWidget(state_);
  health_ = new QLabel;
  health_->setObjectName(QStringLiteral("linkHealth"));
  health_->setWordWrap(true);
  health_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  health_->setAlignment(Qt::AlignTop | Qt::AlignLeft);
  layout->addWidget(health_, 1);

  connect(workspace_, &Workspace::linkStateChanged, this, &ConnectionPanel::UpdateState);
  connect(workspace_, &Workspace::authenticatedChanged, this, &ConnectionPanel::UpdateState);
  connect(workspace_, &Workspace::healthUpdated, this, &ConnectionPanel::UpdateState);
  connect(workspace_, &Workspace::authenticationFailed, this,
          [this](const QString& reason) { state_->setText(tr("Refused: %1").arg(reason)); });
  UpdateState();
}

void ConnectionPanel::RefreshSerialPorts() {
  const QString current = serial_port_->currentText();
  serial_port_->clear();
  for (const QSerialPortInfo& info : QSerialPortInfo::availablePorts()) {
    serial_port_->addItem(info.systemLocation());
  }
  if (!current.isEmpty()) serial_port_->setEditText(current);
}

ConnectOptions ConnectionPanel::options() const {
  ConnectOptions o;
  o.kind = static_cast<LinkKind>(kind_->currentIndex());
  o.scenario_path = scenario_->currentData().toString();
  o.host = host_->text().trimmed();
  o.port = port_->value();
  o.key_file = key_file_->text().trimmed();
  o.serial_port = serial_port_->currentText().trimmed();
  o.baud = baud_->currentText().toInt();
  return o;
}

void ConnectionPanel::SetOptions(const ConnectOptions& o) {
  kind_->setCurrentIndex(static_cast<int>(o.kind));
  const int s = scenario_->findData(o.scenario_path);
  if (s >= 0)
    scenario_->setCurrentIndex(s);
  else if (!o.scenario_path.isEmpty()) {
    scenario_->addItem(QFileInfo(o.scenario_path).completeBaseName(), o.scenario_path);
    scenario_->setCurrentIndex(scenario_->count() - 1);
  }
  host_->setText(o.host);
  port_->setValue(o.port);
  key_file_->setText(o.key_file);
  serial_port_->setEditText(o.serial_port);
  baud_->setEditText(QString::number(o.baud));
}

void ConnectionPanel::RequestConnect() {
  // A connection replaces the session shown, as New Session does: an
  // unsaved recording is offered to be saved first.
  if (confirm_ && !confirm_([this] { RequestConnect(); })) return;
  QString error;
  if (!ConnectNow(&error)) emit errorOccurred(error);
}

bool ConnectionPanel::ConnectNow(QString* error) {
  const bool ok = workspace_->Connect(options(), error);
  UpdateState();
  return ok;
}

void ConnectionPanel::UpdateState() {
  const hardware::LinkHealth& h = workspace_->health();
  const bool open = workspace_->link_open();
  connect_->setEnabled(!open);
  disconnect_->setEnabled(open);
  kind_->setEnabled(!open);
  pages_->setEnabled(!open);
  QString state = QString::fromLatin1(hardware::LinkHealth::StateName(h.state));
  if (workspace_->authenticated()) state = tr("connected, authenticated");
  state_->setText(tr("Link: %1").arg(state));
  health_->setText(open ? HealthText(h) : QString());
  // Everything, unrounded, for a bug report.
  health_->setToolTip(open ? QString::fromStdString(h.ToString()) : QString());
}

QString ConnectionPanel::HealthText(const hardware::LinkHealth& h) {
  QStringList lines;
  // The robot's own state first: the battery and a latched emergency stop
  // are what an operator looks for, and as the fourth line they were below
  // the dock's fold while connected.
  if (h.have_status) {
    QString robot = tr("robot: battery %1 V").arg(h.agent_status.battery_voltage_v, 0, 'f', 1);
    if (h.agent_status.emergency_stop_latched) robot += tr(", emergency stop latched");
    if (h.agent_status.fault_bits != 0) {
      robot += tr(", faults 0x%1").arg(h.agent_status.fault_bits, 0, 16);
    }
    lines << robot;
  }
  lines << tr("%1 frames/s, %2 kB/s: lidar %3/s, IMU %4/s, motor %5/s")
               .arg(h.frames_per_s, 0, 'f', 0)
               .arg(h.bytes_per_s / 1000.0, 0, 'f', 1)
               .arg(h.devices[0].frames_per_s, 0, 'f', 0)
               .arg(h.devices[1].frames_per_s, 0, 'f', 0)
               .arg(h.devices[2].frames_per_s, 0, 'f', 0);
  if (h.latency_samples > 0) {
    lines << tr("round trip %1 ms (mean %2, max %3)")
                 .arg(h.latency_last_ms, 0, 'f', 1)
                 .arg(h.latency_mean_ms, 0, 'f', 1)
                 .arg(h.latency_max_ms, 0, 'f', 1);
  }
  QStringList errors;
  const auto count = [&errors](uint64_t n, const QString& what) {
    if (n > 0) errors << QStringLiteral("%L1 %2").arg(n).arg(what);
  };
  count(h.crc_errors, tr("CRC"));
  count(h.length_errors, tr("length"));
  count(h.framing_errors, tr("framing"));
  count(h.payload_errors, tr("payload"));
  count(h.input_floods, tr("floods"));
  count(h.acks_refused, tr("commands refused"));
  if (h.sequence_gaps > 0) {
    errors << (h.sequence_gaps == 1
                   ? tr("%L1 frames lost in a gap").arg(h.frames_missing)
                   : tr("%L1 frames lost in %L2 gaps").arg(h.frames_missing).arg(h.sequence_gaps));
  }
  lines << (errors.isEmpty() ? tr("errors: none") : tr("errors: %1").arg(errors.join(", ")));
  if (h.outages > 0) {
    lines << (h.outages == 1 ? tr("1 outage (%2 %3 s, %4 attempts: %5)")
                             : tr("%L1 outages (%2 %3 s, %4 attempts: %5)").arg(h.outages))
                 .arg(h.outage_open ? tr("now") : tr("last"))
                 .arg(h.outage_s, 0, 'f', 1)
                 .arg(h.reconnect_attempts)
                 .arg(h.outage_reason);
    static const char* kDevices[3] = {"lidar", "IMU", "motor"};
    for (int i = 0; i < 3; ++i) {
      if (h.data_lost_s[i] > 0.0) {
        lines << tr("%1 data lost: %2 s")
                     .arg(QLatin1String(kDevices[i]))
                     .arg(h.data_lost_s[i], 0, 'f', 1);
      }
    }
  }
  if (h.reconnects > 0) {
    lines << (h.reconnects == 1 ? tr("reconnected once")
                                : tr("reconnected %L1 times").arg(h.reconnects));
  }
  return lines.join(QLatin1Char('\n'));
}

}  // namespace sweepscan::ui
