#include "ui/panels/device_check_dialog.h"

#include <QComboBox>
#include <QDialogButtonBox>
#include <QFontDatabase>
#include <QFormLayout>
#include <QLabel>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QSerialPortInfo>
#include <QVBoxLayout>

namespace sweepscan::ui {

DeviceCheckDialog::DeviceCheckDialog(Workspace* workspace, QWidget* parent)
    : QDialog(parent), workspace_(workspace) {
  setWindowTitle(tr("Device check"));
  auto* layout = new QVBoxLayout(this);
  auto* form = new QFormLayout;
  port_ = new QComboBox;
  port_->setEditable(true);
  for (const QSerialPortInfo& info : QSerialPortInfo::availablePorts()) {
    port_->addItem(info.systemLocation() + QStringLiteral("  ") + info.description(),
                   info.systemLocation());
  }
  kind_ = new QComboBox;
  kind_->addItem(tr("YDLIDAR X4 (128000 baud)"),
                 static_cast<int>(hardware::DirectDevice::Kind::kX4));
  kind_->addItem(tr("HiPNUC HI219 (115200 baud)"),
                 static_cast<int>(hardware::DirectDevice::Kind::kHi219));
  form->addRow(tr("Serial port"), port_);
  form->addRow(tr("Device"), kind_);
  layout->addLayout(form);
  check_ = new QPushButton(tr("Check (3 s)"));
  layout->addWidget(check_);
  verdict_ = new QLabel;
  layout->addWidget(verdict_);
  report_ = new QPlainTextEdit;
  report_->setReadOnly(true);
  report_->setFont(QFontDatabase::systemFont(QFontDatabase::FixedFont));
  report_->setMinimumSize(460, 140);
  layout->addWidget(report_);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Close);
  connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);
  layout->addWidget(buttons);

  connect(check_, &QPushButton::clicked, this, &DeviceCheckDialog::StartCheck);
  connect(workspace_, &Workspace::deviceCheckFinished, this, [this](bool ok, const QString& text) {
    passed_ = ok;
    check_->setEnabled(true);
    verdict_->setText(ok ? tr("<b style='color:#2e7d32'>Device answers.</b>")
                         : tr("<b style='color:#c62828'>Check failed.</b>"));
    report_->setPlainText(text);
    emit finished(ok);
  });
}

void DeviceCheckDialog::SetPort(const QString& port) { port_->setEditText(port); }

void DeviceCheckDialog::SetKind(hardware::DirectDevice::Kind kind) {
  kind_->setCurrentIndex(kind_->findData(static_cast<int>(kind)));
}

QString DeviceCheckDialog::report() const { return report_->toPlainText(); }

void DeviceCheckDialog::StartCheck() {
  QString port = port_->currentData().toString();
  if (port.isEmpty() || port_->currentText() != port_->itemText(port_->currentIndex())) {
    port = port_->currentText().trimmed();
  }
  if (port.isEmpty()) {
    verdict_->setText(tr("Choose a serial port."));
    return;
  }
  check_->setEnabled(false);
  verdict_->setText(tr("Listening on %1…").arg(port));
  report_->clear();
  workspace_->CheckDevice(static_cast<hardware::DirectDevice::Kind>(kind_->currentData().toInt()),
                          port);
}

}  // namespace sweepscan::ui
