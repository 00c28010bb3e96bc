// The panels and menus as an operator meets them (docs/desktop-app.md):
// what they offer can be done, and what they show fits their docks.
//
// * The drive panel stays inside its dock while a scripted drive runs (the
//   command's "(scripted)" once pushed the emergency stop's edge out).
// * The floor plan shown at start (`--floor-plan`: raised before the
//   window's first layout) leaves the 3D view a third of the window, and
//   hidden gives the view its width back, also after a restart.
// * Pause only while a replay runs, "Resume" while paused; the Robot menu's
//   Connect, Disconnect, Clear Emergency Stop and Abort Scripted Drive only
//   when the link and the drive allow them.
// * Colour by pass, deviation and intensity offered when the cloud has
//   those values; the colour bar only for colours that mean something, its
//   labels at round values.
// * View > Panels lists each panel once, as they are placed.
// * The wheel scrolls a panel; a spin box takes it only with the focus.
// * F1's help lists every menu shortcut (read from the menus) and the mouse.
// * View > Clip Height… sets the operator's own clip; C keeps it.
// * A panel never scrolls sideways.
// * The link's health in a few rounded lines, not a dump of every counter.
// * A live cloud's ceiling hidden within seconds, long before the room view
//   frames the cloud (at 200 000 points), and once: shown again, it stays.
#include <gtest/gtest.h>

#include <QAbstractButton>
#include <QAction>
#include <QComboBox>
#include <QApplication>
#include <QDialog>
#include <QDockWidget>
#include <QDoubleSpinBox>
#include <QInputDialog>
#include <QLabel>
#include <QMenu>
#include <QMenuBar>
#include <QPushButton>
#include <QRegularExpression>
#include <QScrollArea>
#include <QScrollBar>
#include <QStatusBar>
#include <QTest>
#include <QTextBrowser>
#include <QTimer>
#include <QWheelEvent>
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tests/ui/app_fixture.h"
#include "ui/main_window.h"
#include "ui/panels/connection_panel.h"
#include "ui/panels/drive_panel.h"
#include "ui/panels/evaluation_panel.h"
#include "ui/panels/replay_panel.h"
#include "ui/view/cloud_view.h"
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

TEST_F(PanelsTest, FloorPlanShownAtStartLeavesTheViewAThirdAndHiddenGivesItBack) {
  // Windows as the app makes them at start, larger than the fixture's.
  const auto start = [this](bool with_plan) {
    window_.reset();
    window_ = std::make_unique<MainWindow>(workspace_.get(), testing::kResources);
    window_->SetInteractive(false);
    window_->resize(1400, 860);
    window_->show();
    if (with_plan) window_->RaiseDock(QStringLiteral("planDock"));  // --floor-plan, at once
    ASSERT_TRUE(QTest::qWaitForWindowExposed(window_.get()));
    QTest::qWait(200);
  };
  ASSERT_NO_FATAL_FAILURE(start(false));
  const int first_start = window_->view()->width();
  ASSERT_NO_FATAL_FAILURE(start(true));
  auto* plan = window_->findChild<QDockWidget*>(QStringLiteral("planDock"));
  ASSERT_TRUE(plan->isVisible());
  const int w = window_->width();
  EXPECT_GE(window_->view()->width(), w / 3 - 8) << "window " << w << ", plan " << plan->width();
  EXPECT_GE(plan->width(), w / 3) << "the plan has room";

  // Hidden: the view gets its width back, as wide as a first start's.
  plan->toggleViewAction()->trigger();
  QTest::qWait(200);
  EXPECT_NEAR(window_->view()->width(), first_start, 8) << "window " << w;

  // Quit and start again: the layout saved is the one shown.
  window_->close();
  ASSERT_NO_FATAL_FAILURE(start(false));
  plan = window_->findChild<QDockWidget*>(QStringLiteral("planDock"));
  EXPECT_FALSE(plan->isVisible());
  EXPECT_NEAR(window_->view()->width(), first_start, 8);

  // View > Floor Plan on and off in a laid-out window: the same.
  plan->toggleViewAction()->trigger();
  QTest::qWait(200);
  EXPECT_GE(plan->width(), w / 3);
  EXPECT_GE(window_->view()->width(), w / 3 - 8);
  plan->toggleViewAction()->trigger();
  QTest::qWait(200);
  EXPECT_NEAR(window_->view()->width(), first_start, 8);
}

TEST_F(PanelsTest, PauseOnlyWhileAReplayRuns) {
  auto* pause = window_->findChild<QPushButton*>(QStringLiteral("replayPause"));
  ASSERT_NE(pause, nullptr);
  EXPECT_FALSE(pause->isEnabled());  // no session
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  window_->replay_panel()->SetSpeed(1.0);  // real time: it runs for a minute
  bool finished = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { finished = true; });
  window_->OpenSessionPath(tmp_.path() + "/lab.sweepscan");
  ASSERT_TRUE(WaitFor([&] { return pause->isEnabled(); }, 60000));
  EXPECT_EQ(pause->text(), "Pause");
  QTest::mouseClick(pause, Qt::LeftButton);
  EXPECT_TRUE(pause->isChecked());
  EXPECT_EQ(pause->text(), "Resume");
  // Paused, the cloud stops growing.
  QTest::qWait(300);
  const size_t points = window_->view()->point_count();
  QTest::qWait(600);
  EXPECT_EQ(window_->view()->point_count(), points);
  QTest::mouseClick(pause, Qt::LeftButton);
  EXPECT_EQ(pause->text(), "Pause");
  ASSERT_TRUE(WaitFor([&] { return window_->view()->point_count() > points; }, 10000));
  // At full speed to its end: nothing left to pause.
  window_->replay_panel()->SetSpeed(0.0);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 120000));
  EXPECT_FALSE(pause->isEnabled());
  EXPECT_EQ(pause->text(), "Pause");
}

// `--speed 3` was lost: the list had no 3x, so the panel stayed at "max" and
// a replay that restarted (a seek back) ran as fast as possible.
TEST_F(PanelsTest, ASpeedTheListLacksIsAddedInItsPlace) {
  auto* box = window_->findChild<QComboBox*>(QStringLiteral("replaySpeed"));
  ASSERT_NE(box, nullptr);
  const int offered = box->count();
  window_->replay_panel()->SetSpeed(3.0);
  EXPECT_EQ(box->currentText(), "3x");
  EXPECT_DOUBLE_EQ(window_->replay_panel()->speed(), 3.0);
  ASSERT_EQ(box->count(), offered + 1);
  for (int i = 1; i + 1 < box->count(); ++i)  // in order, "max" (0) last
    EXPECT_LT(box->itemData(i - 1).toDouble(), box->itemData(i).toDouble()) << i;
  EXPECT_EQ(box->itemText(box->count() - 1), "max");
  window_->replay_panel()->SetSpeed(0.0);
  EXPECT_EQ(box->currentText(), "max");
  window_->replay_panel()->SetSpeed(3.0);  // once in the list
  EXPECT_EQ(box->count(), offered + 1);
  window_->replay_panel()->SetSpeed(50.0);
  EXPECT_EQ(box->currentText(), "50x");
  EXPECT_EQ(box->currentIndex(), box->count() - 2);
  window_->replay_panel()->SetSpeed(-1.0);  // refused: unchanged
  EXPECT_EQ(box->currentText(), "50x");
}

TEST_F(PanelsTest, RobotMenuOffersWhatTheLinkAllows) {
  QMenu* robot = nullptr;
  for (QAction* a : window_->menuBar()->actions()) {
    if (a->text() == "&Robot") robot = a->menu();
  }
  ASSERT_NE(robot, nullptr);
  const auto action = [robot](const char* text) {
    for (QAction* a : robot->actions()) {
      if (a->text().startsWith(QString::fromUtf8(text))) return a;
    }
    ADD_FAILURE() << text;
    return static_cast<QAction*>(nullptr);
  };
  QAction* connect = action("&Connect");
  QAction* disconnect = action("&Disconnect");
  QAction* estop = action("&Emergency Stop");
  QAction* clear = action("C&lear Emergency Stop");
  QAction* abort = action("&Abort Scripted Drive");
  ASSERT_TRUE(connect && disconnect && estop && clear && abort);
  // No link: connect, and the emergency stop (which says there is no robot).
  EXPECT_TRUE(connect->isEnabled());
  EXPECT_FALSE(disconnect->isEnabled());
  EXPECT_TRUE(estop->isEnabled());
  EXPECT_FALSE(clear->isEnabled());
  EXPECT_FALSE(abort->isEnabled());

  ConnectToSimulator();
  EXPECT_FALSE(connect->isEnabled());
  EXPECT_TRUE(disconnect->isEnabled());
  EXPECT_TRUE(clear->isEnabled());
  EXPECT_FALSE(abort->isEnabled());
  workspace_->StartScriptedDrive(Workspace::CirclePath(1.0, 0.05, 1.0), "the calibration circle");
  emit robot->aboutToShow();  // the menu opened
  EXPECT_TRUE(abort->isEnabled());
  // The Drive panel names the drive that runs (the drive demo's is a
  // scenario's path, not a circle).
  auto* state = window_->findChild<QLabel*>("driveScriptState");
  ASSERT_NE(state, nullptr);
  EXPECT_TRUE(WaitFor([&] { return state->isVisibleTo(window_.get()); }, 2000));
  EXPECT_EQ(state->text(), "Driving the calibration circle: Abort ends it.");
  abort->trigger();
  EXPECT_FALSE(workspace_->scripted_drive_running());

  disconnect->trigger();
  ASSERT_TRUE(WaitFor([&] { return !workspace_->link_open(); }, 10000));
  EXPECT_TRUE(connect->isEnabled());
  EXPECT_FALSE(disconnect->isEnabled());
  EXPECT_FALSE(clear->isEnabled());
}

// View > Panels names each panel once, in the order a first start places
// them: the left column from the top, then the right. The floor plan is
// View > Floor Plan, and only there.
TEST_F(PanelsTest, PanelsMenuListsEachPanelOnceAsTheyArePlaced) {
  QMenu* view = nullptr;
  for (QAction* a : window_->menuBar()->actions()) {
    if (a->text() == "&View") view = a->menu();
  }
  ASSERT_NE(view, nullptr);
  auto* panels = view->findChild<QMenu*>("panelsMenu");
  ASSERT_NE(panels, nullptr);
  std::vector<QDockWidget*> listed;
  for (QAction* a : panels->actions()) {
    for (QDockWidget* dock : window_->findChildren<QDockWidget*>()) {
      if (dock->toggleViewAction() == a) listed.push_back(dock);
    }
  }
  QStringList names;
  for (QDockWidget* dock : listed) names << dock->windowTitle();
  EXPECT_EQ(names.join(", ").toStdString(),
            "Connection, Project, Drive, Session and replay, Calibration, Evaluation");
  // Each as it stands: the left column's, then the right's, each from the
  // top (of the tabs that share a place, the one in front).
  std::vector<QDockWidget*> in_front;
  QStringList front_names;
  for (QDockWidget* dock : listed) {
    if (dock->visibleRegion().isEmpty()) continue;
    in_front.push_back(dock);
    front_names << dock->windowTitle();
  }
  EXPECT_EQ(front_names.join(", ").toStdString(),
            "Connection, Drive, Session and replay, Calibration");
  for (size_t i = 1; i < in_front.size(); ++i) {
    QDockWidget* a = in_front[i - 1];
    QDockWidget* b = in_front[i];
    const bool left_a = window_->dockWidgetArea(a) == Qt::LeftDockWidgetArea;
    const bool left_b = window_->dockWidgetArea(b) == Qt::LeftDockWidgetArea;
    EXPECT_TRUE(left_a >= left_b) << front_names[i].toStdString();
    if (left_a == left_b) {
      EXPECT_LT(a->geometry().top(), b->geometry().top()) << front_names[i].toStdString();
    }
  }
  // The floor plan: once in all of View.
  auto* plan = window_->findChild<QDockWidget*>("planDock");
  ASSERT_NE(plan, nullptr);
  int entries = 0;
  for (QMenu* menu : view->findChildren<QMenu*>()) {
    entries += menu->actions().count(plan->toggleViewAction());
  }
  entries += view->actions().count(plan->toggleViewAction());
  EXPECT_EQ(entries, 1);
}

// A wheel turned over the board thickness while scrolling the Calibration
// panel scrolls the panel and leaves the thickness alone (it once set it
// to 0 mm, saved); a click into the box first, and the wheel steps it.
TEST_F(PanelsTest, TheWheelScrollsAPanelAndStepsABoxOnlyOnceItHasTheFocus) {
  auto* dock = window_->findChild<QDockWidget*>("calibrationDock");
  auto* thickness = window_->findChild<QDoubleSpinBox*>("boardThickness");
  ASSERT_TRUE(dock != nullptr && thickness != nullptr);
  auto* area = qobject_cast<QScrollArea*>(dock->widget());
  ASSERT_NE(area, nullptr);
  window_->resizeDocks({dock}, {260}, Qt::Vertical);  // short: its panel scrolls
  QApplication::processEvents();
  QScrollBar* bar = area->verticalScrollBar();
  ASSERT_GT(bar->maximum(), 0);
  EXPECT_EQ(thickness->focusPolicy(), Qt::StrongFocus);
  const double before = thickness->value();
  const auto turn = [&](int notches) {
    const QPointF at(thickness->width() / 2.0, thickness->height() / 2.0);
    QWheelEvent wheel(at, thickness->mapToGlobal(at.toPoint()), QPoint(), QPoint(0, 120 * notches),
                      Qt::NoButton, Qt::NoModifier, Qt::NoScrollPhase, false);
    QApplication::sendEvent(thickness, &wheel);
  };
  bar->setValue(0);
  turn(-2);  // down
  EXPECT_GT(bar->value(), 0);
  EXPECT_EQ(thickness->value(), before);

  QApplication::setActiveWindow(window_.get());
  thickness->setFocus(Qt::MouseFocusReason);
  ASSERT_TRUE(thickness->hasFocus());
  const int scrolled = bar->value();
  turn(1);
  EXPECT_GT(thickness->value(), before);
  EXPECT_EQ(bar->value(), scrolled);
  thickness->setValue(before);
}

// F1 opens Help > Keyboard and Mouse beside the window: every menu
// shortcut is listed with its menu and item (the old box, typed by hand,
// lacked Ctrl+N, Ctrl+K, Ctrl+Shift+P, Ctrl+Shift+W and more), and so are
// the mouse's gestures in the view, which it did not mention at all.
TEST_F(PanelsTest, F1ListsEveryShortcutOfTheMenusAndTheMouse) {
  QApplication::setActiveWindow(window_.get());
  ASSERT_TRUE(WaitFor([&] { return QApplication::activeWindow() == window_.get(); }, 2000));
  QTest::keyClick(window_.get(), Qt::Key_F1);
  QDialog* help = nullptr;
  ASSERT_TRUE(WaitFor(
      [&] { return (help = window_->findChild<QDialog*>(QStringLiteral("keyboardHelp"))); }, 2000));
  EXPECT_TRUE(help->isVisible());
  EXPECT_FALSE(help->isModal());
  auto* browser = help->findChild<QTextBrowser*>();
  ASSERT_NE(browser, nullptr);
  const QString text = browser->toPlainText();
  int listed = 0;
  for (QAction* top : window_->menuBar()->actions()) {
    std::function<void(QMenu*)> walk = [&](QMenu* menu) {
      for (QAction* a : menu->actions()) {
        if (a->menu() != nullptr) {
          walk(a->menu());
        } else if (!a->shortcut().isEmpty()) {
          QString item = a->text().remove('&');
          if (item.endsWith(QChar(0x2026))) item.chop(1);
          const QString key = a->shortcut().toString(QKeySequence::NativeText);
          EXPECT_NE(text.indexOf(key), -1) << key.toStdString();
          EXPECT_NE(text.indexOf(QStringLiteral(" > ") + item), -1) << item.toStdString();
          ++listed;
        }
      }
    };
    if (top->menu() != nullptr) walk(top->menu());
  }
  EXPECT_GE(listed, 25);
  if (qEnvironmentVariableIsSet("SWEEPSCAN_TEST_SHOTS")) {
    help->grab().save(qEnvironmentVariable("SWEEPSCAN_TEST_SHOTS") + "/keyboard-help.png");
  }
  for (const char* gesture : {"Left drag", "Middle drag", "Right drag or wheel", "Shift + click",
                              "Arrows or W A S D", "Space"}) {
    EXPECT_NE(text.indexOf(QString::fromLatin1(gesture)), -1) << gesture;
  }
  help->close();
}

// Answers the next QInputDialog with `value`, as an operator types it.
void AnswerInput(double value) {
  QTimer::singleShot(50, [value] {
    auto* dialog = qobject_cast<QInputDialog*>(QApplication::activeModalWidget());
    if (dialog == nullptr) return AnswerInput(value);
    dialog->setDoubleValue(value);
    dialog->accept();
  });
}

// View > Clip Height… (Shift+C): the operator's own height, said in the
// status bar, kept by C's toggling; the clip was only ever the ceiling's.
TEST_F(PanelsTest, ClipHeightIsTheOperatorsAndCKeepsIt) {
  QAction* clip = nullptr;
  for (QAction* a : window_->findChildren<QAction*>()) {
    if (a->text() == QStringLiteral("Clip &Height…")) clip = a;
  }
  ASSERT_NE(clip, nullptr);
  EXPECT_EQ(clip->shortcut(), QKeySequence(QStringLiteral("Shift+C")));
  auto* status = window_->statusBar()->findChild<QLabel*>(QStringLiteral("statusClip"));
  ASSERT_NE(status, nullptr);
  AnswerInput(1.25);
  clip->trigger();
  EXPECT_DOUBLE_EQ(window_->view()->clip_height(), 1.25);
  EXPECT_TRUE(window_->ceiling_action()->isChecked());
  EXPECT_EQ(status->text(), QStringLiteral("Hidden above 1.25 m (C)"));
  window_->ceiling_action()->toggle();
  EXPECT_TRUE(std::isnan(window_->view()->clip_height()));
  window_->ceiling_action()->toggle();
  EXPECT_DOUBLE_EQ(window_->view()->clip_height(), 1.25);
  AnswerInput(0.8);  // changed while on
  clip->trigger();
  EXPECT_DOUBLE_EQ(window_->view()->clip_height(), 0.8);
}

// A panel never scrolls sideways: its labels wrap instead. A button given
// the focus at the right edge of the Calibration panel (Solve, Cancel) had
// the panel scrolled left by a few pixels, its steps' titles cut
// (". Solve").
TEST_F(PanelsTest, APanelNeverScrollsSideways) {
  for (const char* name : {"calibrationDock", "evaluationDock", "connectionDock", "driveDock"}) {
    auto* dock = window_->findChild<QDockWidget*>(name);
    ASSERT_NE(dock, nullptr) << name;
    auto* area = qobject_cast<QScrollArea*>(dock->widget());
    ASSERT_NE(area, nullptr) << name;
    dock->show();
    dock->raise();
    window_->resizeDocks({dock}, {1}, Qt::Horizontal);  // as narrow as it goes
    QApplication::processEvents();
    for (QWidget* w : area->widget()->findChildren<QWidget*>()) {
      if (!w->isVisibleTo(area->widget()) || w->width() == 0) continue;
      area->ensureWidgetVisible(w);
      EXPECT_EQ(area->horizontalScrollBar()->value(), 0)
          << name << ": " << w->metaObject()->className();
    }
    // Nothing wider than the place it is shown in.
    EXPECT_LE(area->widget()->width(), area->viewport()->width()) << name;
  }
}

// Five evenly spaced labels over 0..3 m read 0.0, 0.8, 1.5, 2.2, 3.0;
// round ones, with the decimals their step needs.
TEST(ColorBarTicksTest, RoundValuesWithTheirDecimals) {
  int decimals = -1;
  EXPECT_EQ(CloudView::BarTicks(0.0, 3.0, &decimals),
            (std::vector<double>{0, 0.5, 1, 1.5, 2, 2.5, 3}));
  EXPECT_EQ(decimals, 1);
  EXPECT_EQ(CloudView::BarTicks(0.0, 60.0, &decimals),
            (std::vector<double>{0, 10, 20, 30, 40, 50, 60}));
  EXPECT_EQ(decimals, 0);
  EXPECT_EQ(CloudView::BarTicks(-30.0, 30.0, &decimals),
            (std::vector<double>{-30, -20, -10, 0, 10, 20, 30}));
  const std::vector<double> unit = CloudView::BarTicks(0.0, 1.0, &decimals);
  ASSERT_EQ(unit.size(), 6u);
  EXPECT_NEAR(unit[1], 0.2, 1e-12);
  EXPECT_EQ(decimals, 1);  // an intensity of 0..1: 0.0, 0.2 ... 1.0, not 0, 0, 0, 1, 1
  const std::vector<double> height = CloudView::BarTicks(-0.12, 2.63, &decimals);
  EXPECT_EQ(decimals, 1);
  ASSERT_FALSE(height.empty());
  EXPECT_GE(height.front(), -0.12);
  EXPECT_LE(height.back(), 2.63);
  EXPECT_NEAR(height[1] - height[0], 0.5, 1e-12);
  EXPECT_TRUE(CloudView::BarTicks(1.0, 1.0, &decimals).empty());
}

// The evaluation's planes in the view: a room of an alcove has more than
// four walls, and its fifth was drawn in the first one's colour. The first
// eight walls, the floor and the ceiling are all far apart (RGB distance),
// and no two of a dozen walls are the same.
TEST(PlaneColorTest, WallsOfARoomEachHaveTheirOwnColour) {
  auto distance = [](const QColor& a, const QColor& b) {
    return std::hypot(a.red() - b.red(), a.green() - b.green(), a.blue() - b.blue());
  };
  std::vector<QColor> distinct = {PlaneColor("floor", 0), PlaneColor("ceiling", 0)};
  for (int w = 0; w < 8; ++w) distinct.push_back(PlaneColor("wall", w));
  for (size_t i = 0; i < distinct.size(); ++i) {
    for (size_t j = i + 1; j < distinct.size(); ++j) {
      EXPECT_GT(distance(distinct[i], distinct[j]), 40.0) << i << " and " << j;
    }
  }
  for (int i = 0; i < 12; ++i) {
    for (int j = i + 1; j < 12; ++j)
      EXPECT_NE(PlaneColor("wall", i), PlaneColor("wall", j)) << i << ", " << j;
  }
}

TEST_F(PanelsTest, ColourModesOfferedWhenTheCloudHasThem) {
  QMenu* colour = nullptr;
  for (QAction* a : window_->menuBar()->actions()) {
    if (a->text() != "&View") continue;
    for (QAction* b : a->menu()->actions()) {
      if (b->text() == "&Colour by") colour = b->menu();
    }
  }
  ASSERT_NE(colour, nullptr);
  const QList<QAction*> modes = colour->actions();
  ASSERT_EQ(modes.size(), CloudView::kColorModes);
  const auto offered = [&] {
    std::string s;
    for (QAction* a : modes) s += a->isEnabled() ? '1' : '0';
    return s;
  };
  EXPECT_EQ(offered(), "111000");  // height, time, range; no pass, deviation, intensity
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  ASSERT_NO_FATAL_FAILURE(OpenAndReplay(tmp_.path() + "/lab.sweepscan"));
  // The lab drive is no circle drive, and the X4 reports no intensities.
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 60000));
  EXPECT_EQ(offered(), "111000");
  CloudView* view = window_->view();
  view->RenderNow();
  EXPECT_TRUE(view->color_bar_drawn());
  // Chosen anyway (by code: the menu does not offer it): grey, no legend.
  view->SetColorMode(CloudView::ColorMode::kIntensity);
  view->RenderNow();
  EXPECT_FALSE(view->color_bar_drawn());
  view->SetColorMode(CloudView::ColorMode::kHeight);

  // Evaluated: deviations.
  EvaluationPanel* evaluation = window_->evaluation_panel();
  bool evaluated = false;
  QObject::connect(evaluation, &EvaluationPanel::evaluated, [&](bool) { evaluated = true; });
  evaluation->Evaluate();
  ASSERT_TRUE(WaitFor([&] { return evaluated; }, 120000));
  EXPECT_EQ(offered(), "111010");
  modes[static_cast<int>(CloudView::ColorMode::kDeviation)]->trigger();
  EXPECT_EQ(view->color_mode(), CloudView::ColorMode::kDeviation);
  view->RenderNow();
  EXPECT_TRUE(view->color_bar_drawn());

  // Another cloud (File > New Session): its values go, and the offer with them.
  workspace_->NewSession();
  EXPECT_TRUE(WaitFor([&] { return offered() == "111000"; }, 5000)) << offered();
}

TEST_F(PanelsTest, LinkHealthReadsAtAGlance) {
  ConnectToSimulator();
  auto* health = window_->connection_panel()->findChild<QLabel*>(QStringLiteral("linkHealth"));
  ASSERT_NE(health, nullptr);
  ASSERT_TRUE(WaitFor([&] { return workspace_->health().devices[0].frames_per_s > 0.0; }, 10000));
  QTest::qWait(1200);  // the panel's next update
  const QString text = health->text();
  const QStringList lines = text.split(QLatin1Char('\n'));
  EXPECT_LE(lines.size(), 4) << text.toStdString();
  // The robot's battery first, in sight: it was the fourth line, below the
  // dock's fold.
  EXPECT_TRUE(lines[0].startsWith("robot: battery")) << text.toStdString();
  EXPECT_TRUE(lines[1].contains(QRegularExpression("lidar \\d+/s, IMU \\d+/s, motor \\d+/s")))
      << text.toStdString();
  EXPECT_TRUE(text.contains("errors: none")) << text.toStdString();
  EXPECT_FALSE(text.contains(QRegularExpression("\\d\\.\\d\\d")))
      << "rounded: " << text.toStdString();
  EXPECT_TRUE(text.contains("robot: battery")) << text.toStdString();
  // Every counter, unrounded, is still there for a bug report.
  EXPECT_EQ(health->toolTip().toStdString(), workspace_->health().ToString());
}

TEST_F(PanelsTest, LiveCeilingHiddenWithinSeconds) {
  ConnectToSimulator();
  CloudView* view = window_->view();
  QAction* ceiling = window_->ceiling_action();
  EXPECT_FALSE(ceiling->isChecked());
  const uint64_t camera = view->camera_generation();
  workspace_->StartScriptedDrive(Workspace::CirclePath(1.0, 0.1, 1.0), "the circle");
  // The lab's ceiling is at 2.5 m.
  ASSERT_TRUE(WaitFor([&] { return ceiling->isChecked(); }, 30000)) << view->point_count();
  EXPECT_LT(view->point_count(), 100'000u);
  EXPECT_NEAR(view->clip_height(), 2.45, 0.06);
  EXPECT_EQ(view->camera_generation(), camera);  // not yet framed: too few points
  // The operator shows it again: it is not hidden again behind their back.
  ceiling->trigger();
  const size_t points = view->point_count();
  ASSERT_TRUE(WaitFor([&] { return view->point_count() > points + 10'000; }, 30000));
  QTest::qWait(1100);  // a status tick
  EXPECT_FALSE(ceiling->isChecked());
  workspace_->AbortScriptedDrive();
}

TEST(LinkHealthTextTest, SaysWhatWentWrong) {
  hardware::LinkHealth h;
  h.frames_per_s = 333.333;
  h.bytes_per_s = 36356.4;
  h.devices[0].frames_per_s = 154.154;
  h.devices[1].frames_per_s = 100.1;
  h.devices[2].frames_per_s = 50.0501;
  h.crc_errors = 2;
  h.sequence_gaps = 1;
  h.frames_missing = 3;
  h.have_status = true;
  h.agent_status.battery_voltage_v = 12.06f;
  h.agent_status.emergency_stop_latched = true;
  h.outages = 1;
  h.outage_s = 2.34;
  h.reconnect_attempts = 3;
  h.outage_reason = "no data for 2 s";
  h.data_lost_s[1] = 0.5;
  h.reconnects = 1;
  EXPECT_EQ(ConnectionPanel::HealthText(h).toStdString(),
            "robot: battery 12.1 V, emergency stop latched\n"
            "333 frames/s, 36.4 kB/s: lidar 154/s, IMU 100/s, motor 50/s\n"
            "errors: 2 CRC, 3 frames lost in a gap\n"
            "1 outage (last 2.3 s, 3 attempts: no data for 2 s)\n"
            "IMU data lost: 0.5 s\n"
            "reconnected once");
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
