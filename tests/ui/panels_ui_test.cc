// The panels and menus as an operator meets them (docs/desktop-app.md):
// what they offer can be done, and what they show fits their docks.
//
// * The drive panel stays inside its dock while a scripted drive runs (the
//   command's "(scripted)" once pushed the emergency stop's edge out).
#include <gtest/gtest.h>

#include <QAbstractButton>
#include <QDockWidget>
#include <QPushButton>
#include <QTest>
#include <cmath>

#include "tests/ui/app_fixture.h"
#include "ui/panels/drive_panel.h"
#include "ui/workspace/sim_robot.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

using testing::WaitFor;

using PanelsTest = testing::AppFixture;

// Every visible button of `panel` ends inside `dock`'s width.
::testing::AssertionResult ButtonsInside(QWidget* panel, QDockWidget* dock) {
  for (QAbstractButton* b : panel->findChildren<QAbstractButton*>()) {
    if (!b->isVisible()) continue;
    const QPoint right = b->mapTo(dock, QPoint(b->width() - 1, 0));
    if (right.x() >= dock->width()) {
      return ::testing::AssertionFailure()
             << "'" << b->text().toStdString() << "' ends at x " << right.x() << " in a dock "
             << dock->width() << " px wide";
    }
  }
  return ::testing::AssertionSuccess();
}

TEST_F(PanelsTest, DrivePanelFitsItsDockWhileAScriptedDriveRuns) {
  ConnectToSimulator();
  DrivePanel* panel = window_->drive_panel();
  auto* dock = window_->findChild<QDockWidget*>(QStringLiteral("driveDock"));
  ASSERT_NE(dock, nullptr);
  QApplication::processEvents();
  EXPECT_TRUE(ButtonsInside(panel, dock));
  QPushButton* start = nullptr;
  for (QPushButton* b : panel->findChildren<QPushButton*>()) {
    if (b->text() == QStringLiteral("Start")) start = b;
  }
  ASSERT_NE(start, nullptr);
  ASSERT_TRUE(WaitFor([&] { return start->isEnabled(); }, 5000));
  QTest::mouseClick(start, Qt::LeftButton);
  ASSERT_TRUE(WaitFor([&] { return workspace_->scripted_drive_running(); }, 5000));
  // The panel shows the drive's commands as they come.
  ASSERT_TRUE(
      WaitFor([&] { return std::abs(workspace_->sim_robot()->TrueTwist().v) > 0.01; }, 10000));
  QTest::qWait(300);
  EXPECT_TRUE(ButtonsInside(panel, dock));
  workspace_->AbortScriptedDrive();
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
