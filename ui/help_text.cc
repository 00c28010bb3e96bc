#include "ui/help_text.h"

#include <vtkVersionMacros.h>

#include <Eigen/Core>
#include <QAction>
#include <QDialog>
#include <QDialogButtonBox>
#include <QKeySequence>
#include <QMenu>
#include <QMenuBar>
#include <QTextBrowser>
#include <QVBoxLayout>
#include <QtGlobal>

namespace sweepscan::ui {
namespace {

QString Row(const QString& keys, const QString& what) {
  return QStringLiteral("<tr><td style='padding-right:16px'><b>%1</b></td><td>%2</td></tr>")
      .arg(keys.toHtmlEscaped(), what.toHtmlEscaped());
}

// The menu's actions with a shortcut, as "Menu > Item", submenus too.
void MenuRows(const QMenu* menu, const QString& path, QString* rows) {
  for (QAction* a : menu->actions()) {
    QString name = path + QStringLiteral(" > ") + a->text().remove(QLatin1Char('&'));
    if (a->menu() != nullptr) {
      MenuRows(a->menu(), name, rows);
      continue;
    }
    if (a->isSeparator() || a->shortcuts().isEmpty()) continue;
    QStringList keys;
    for (const QKeySequence& k : a->shortcuts()) keys << k.toString(QKeySequence::NativeText);
    if (name.endsWith(QChar(0x2026))) name.chop(1);  // "Export Cloud…": the dialog's mark
    *rows += Row(keys.join(QStringLiteral(" or ")), name);
  }
}

}  // namespace

QString KeyboardAndMouseHelpHtml(const QMenuBar* menus) {
  QString html = QStringLiteral("<h3>%1</h3><table>").arg(QObject::tr("Driving"));
  html += Row(QObject::tr("Arrows or W A S D"),
              QObject::tr("drive while held; releasing stops (Drive panel's limits)"));
  html += Row(QObject::tr("Space"), QObject::tr("emergency stop, whatever has the focus"));
  html += QStringLiteral("</table><h3>%1</h3><table>").arg(QObject::tr("Mouse in the 3D view"));
  html += Row(QObject::tr("Left drag"), QObject::tr("orbit round the view's centre"));
  html += Row(QObject::tr("Ctrl + left drag"), QObject::tr("roll about the line of sight"));
  html += Row(QObject::tr("Middle drag"), QObject::tr("pan"));
  html += Row(QObject::tr("Right drag or wheel"), QObject::tr("zoom"));
  html += Row(QObject::tr("Shift + click"),
              QObject::tr("pick the point under the cursor: a calibration pair's corner, a "
                          "project's pair, or an end of the distance (M)"));
  html += Row(QObject::tr("Esc"), QObject::tr("leave a project's pair picking"));
  html += QStringLiteral("</table><h3>%1</h3><table>").arg(QObject::tr("Floor plan"));
  html += Row(QObject::tr("Left drag"), QObject::tr("pan"));
  html += Row(QObject::tr("Wheel"), QObject::tr("zoom about the cursor"));
  html += Row(QObject::tr("Double click"), QObject::tr("fit the plan"));
  html += Row(QObject::tr("Shift + drag"),
              QObject::tr("a vertical section along the line (Esc drops the drag)"));
  html += QStringLiteral("</table><h3>%1</h3><table>").arg(QObject::tr("Menus"));
  QString rows;
  if (menus != nullptr) {
    for (QAction* a : menus->actions()) {
      if (a->menu() != nullptr) MenuRows(a->menu(), a->text().remove(QLatin1Char('&')), &rows);
    }
  }
  html += rows + QStringLiteral("</table>");
  html += QObject::tr(
      "<p>In the Calibration panel's pair list, Delete removes the selected "
      "pair.</p>");
  return html;
}

void ShowKeyboardAndMouseHelp(QWidget* parent, const QMenuBar* menus) {
  auto* dialog = new QDialog(parent);
  dialog->setObjectName(QStringLiteral("keyboardHelp"));
  dialog->setAttribute(Qt::WA_DeleteOnClose);
  dialog->setWindowTitle(QObject::tr("Keyboard and Mouse"));
  auto* layout = new QVBoxLayout(dialog);
  auto* text = new QTextBrowser;
  text->setHtml(KeyboardAndMouseHelpHtml(menus));
  layout->addWidget(text);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Close);
  QObject::connect(buttons, &QDialogButtonBox::rejected, dialog, &QDialog::close);
  layout->addWidget(buttons);
  dialog->resize(560, 640);
  dialog->show();
}

QString AboutHtml() {
  return QObject::tr(
             "<b>sweepscan 0.1.0</b>"
             "<p>Operator workstation for mobile 3D lidar scanning with a vertical 2D lidar "
             "(YDLIDAR X4) on a differential-drive robot: drive, record, replay, calibrate "
             "the lidar's mounting, evaluate, align a building's sessions, draw its plan, "
             "export LAS, PLY, PCD, SVG and DXF.</p>"
             "<p>Methods: Miao et al. 2022, <i>Frontiers in Physics</i> 10:993297 (EKF, "
             "the Laser→Body→World chain, the three-angle Levenberg-Marquardt calibration, "
             "RANSAC plane checks); Choi et al. 2017, <i>Sensors</i> 17:242 (P3L and "
             "lidar-only structure from motion).</p>"
             "<p>Built with Qt %1 (running %2), VTK %3, Eigen %4.%5.%6, PCL, Ceres, oneTBB, "
             "nanoflann, zstd and OpenSSL.</p>"
             "<p>The command line, the robot's agent and every file format are described in "
             "the docs folder; <tt>sweepscan-cli help</tt> lists the commands.</p>")
      .arg(QStringLiteral(QT_VERSION_STR), QString::fromLatin1(qVersion()),
           QStringLiteral(VTK_VERSION))
      .arg(EIGEN_WORLD_VERSION)
      .arg(EIGEN_MAJOR_VERSION)
      .arg(EIGEN_MINOR_VERSION);
}

}  // namespace sweepscan::ui
