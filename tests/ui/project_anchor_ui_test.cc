// Editing a project's sessions in the desktop app through the Project
// panel's context menu (docs/desktop-app.md, "Projects"): Remove from
// Project offered only where core/project allows it, removing the anchor,
// and Make Anchor moving the project's frame (not the building, on screen
// either), undone and redone, and not overwritten by an alignment that ends after it. Driven
// through the real widgets under a real display (xvfb-run in CI) on the
// office floor's drives recorded by the CLI.
#include <gtest/gtest.h>
#include <vtkCamera.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>

#include <QAction>
#include <QApplication>
#include <QComboBox>
#include <QDir>
#include <QDockWidget>
#include <QElapsedTimer>
#include <QFile>
#include <QFileDialog>
#include <QFileInfo>
#include <QLabel>
#include <QLineEdit>
#include <QLocale>
#include <QMenu>
#include <QMenuBar>
#include <QMessageBox>
#include <QPushButton>
#include <QStatusBar>
#include <QTest>
#include <QTimer>
#include <QTreeWidget>
#include <QTreeWidgetItem>
#include <QUndoGroup>
#include <QUndoStack>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "core/project/project.h"
#include "core/scenario/scenario.h"
#include "tests/testing/event_loop_turns.h"
#include "tests/ui/app_fixture.h"
#include "tests/ui/project_ui_fixture.h"
#include "ui/project/pair_picking.h"
#include "ui/project/project_controller.h"
#include "ui/project/project_layer.h"
#include "ui/project/project_panel.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

using testing::kResources;
using testing::RunCommand;
using testing::WaitFor;
using ProjectUiTest = testing::ProjectUiFixture;
using testing::kFrameCpuBoundMs;

// The anchor removed while the others are unplaced: the first left is the
// anchor, and the status bar says so (the project kept no frame, and the
// next session added became the anchor without a word).
TEST_F(ProjectUiTest, RemovingTheAnchorSaysWhichSessionIsTheAnchorNow) {
  ASSERT_TRUE(project()->OpenProject(MakeProject("anchor")));
  TurnsWhileBusy(60000);
  QString said;
  const QMetaObject::Connection c =
      QObject::connect(project(), &ProjectController::message, [&](const QString& m) { said = m; });
  project()->RemoveSession("a");
  QObject::disconnect(c);
  const Project& p = project()->document()->project();
  ASSERT_EQ(p.sessions.size(), 2u);
  EXPECT_EQ(p.Anchor(), 0);
  EXPECT_EQ(p.sessions[0].id, "b");
  EXPECT_NE(said.indexOf("'b' is the anchor now"), -1) << said.toStdString();
}

// Remove from Project is disabled with core/project's reason where it would
// refuse (the anchor while others are placed against it), and says who
// becomes the anchor where it would not.
TEST_F(ProjectUiTest, RemoveIsOfferedOnlyWhereItCanAct) {
  const QString file = MakeProject("removal");
  const auto run = RunCommand(std::string(SWEEPSCAN_CLI) + " project align --session b --to a " +
                              file.toStdString());
  ASSERT_EQ(run.code, 0) << run.out;
  ASSERT_TRUE(project()->OpenProject(file));
  TurnsWhileBusy(60000);
  const auto remove_of = [&](const std::string& id) {
    QAction* remove = nullptr;
    for (QAction* a : project()->panel()->ContextMenu(id)->actions()) {
      if (a->text() == "Remove from Project") remove = a;
    }
    return remove;
  };
  QAction* anchor = remove_of("a");
  ASSERT_NE(anchor, nullptr);
  EXPECT_FALSE(anchor->isEnabled());
  EXPECT_NE(anchor->toolTip().indexOf("anchor"), -1) << anchor->toolTip().toStdString();
  EXPECT_TRUE(remove_of("c")->isEnabled());
  project()->RemoveSession("b");
  QAction* now = remove_of("a");
  EXPECT_TRUE(now->isEnabled());
  EXPECT_NE(now->toolTip().indexOf("'c' becomes the anchor"), -1) << now->toolTip().toStdString();
}

// Make Anchor in a session's context menu: offered where core/project can
// act (disabled with its reason elsewhere, and while pairs are picked), an
// undoable edit that moves the frame, not the building: b placed against a
// at a known pose, then made the anchor, every session is drawn where that
// pose seen from b puts it, and a is placed against b by the same pairs;
// undone, the first frame is back.
TEST_F(ProjectUiTest, MakeAnchorMovesTheFrameNotTheBuildingAndUndoes) {
  const QString file = MakeProject("make-anchor");
  Project p;
  ASSERT_TRUE(LoadProject(file.toStdString(), &p).ok());
  const Rigid3d a_from_b = Rigid3d::FromPose(4.0, -3.0, 0.02, 0.01, -0.02, 1.1);
  ProjectSession& b = p.sessions[1];
  b.project_from_session = a_from_b;
  b.registration.method = "pairs";
  b.registration.reference = "a";
  for (int i = 0; i < 6; ++i) b.registration.covariance[i * 7] = i < 3 ? 1e-8 : 1e-6;
  for (const Eigen::Vector3d& source :
       {Eigen::Vector3d(1, 0, 0.5), Eigen::Vector3d(0, 2, 1), Eigen::Vector3d(-1, 1, 2)}) {
    b.registration.pairs.push_back({source, a_from_b * source});
  }
  ASSERT_TRUE(SaveProject(file.toStdString(), p).ok());
  ASSERT_TRUE(project()->OpenProject(file));
  TurnsWhileBusy(60000);
  ProjectPanel* panel = project()->panel();
  const auto anchor_of = [&](const std::string& id) {
    QAction* anchor = nullptr;
    for (QAction* a : panel->ContextMenu(id)->actions()) {
      if (a->text() == "Make Anchor") anchor = a;
    }
    return anchor;
  };
  ASSERT_NE(anchor_of("a"), nullptr);
  EXPECT_FALSE(anchor_of("a")->isEnabled());
  EXPECT_NE(anchor_of("a")->toolTip().indexOf("'a' is the anchor"), -1)
      << anchor_of("a")->toolTip().toStdString();
  EXPECT_FALSE(anchor_of("c")->isEnabled());  // Not placed, and b is.
  EXPECT_NE(anchor_of("c")->toolTip().indexOf("'c' is not placed: align it first"), -1)
      << anchor_of("c")->toolTip().toStdString();
  EXPECT_TRUE(anchor_of("b")->isEnabled());
  // While pairs are picked the project holds still.
  ASSERT_TRUE(project()->pair_picking()->Start("c", "a"));
  EXPECT_FALSE(anchor_of("b")->isEnabled());
  EXPECT_NE(anchor_of("b")->toolTip().indexOf("Not while pairs are picked"), -1);
  project()->pair_picking()->Cancel();
  TurnsWhileBusy(60000);
  ASSERT_TRUE(anchor_of("b")->isEnabled());

  QString said;
  const QMetaObject::Connection c =
      QObject::connect(project(), &ProjectController::message, [&](const QString& m) { said = m; });
  const int commands = project()->undo_stack()->count();
  anchor_of("b")->trigger();
  QObject::disconnect(c);
  EXPECT_EQ(project()->undo_stack()->count(), commands + 1);
  EXPECT_NE(said.indexOf("'b' is the anchor now"), -1) << said.toStdString();
  EXPECT_NE(said.indexOf("placed the other way round now: 'a'"), -1) << said.toStdString();
  const auto expect_frame = [&](const std::string& anchor) {
    const Project& now = project()->document()->project();
    ASSERT_EQ(now.Anchor(), now.Find(anchor));
    const Rigid3d truth_a = anchor == "a" ? Rigid3d() : a_from_b.inverse();
    const Rigid3d truth_b = anchor == "a" ? a_from_b : Rigid3d();
    for (const auto& [id, truth] :
         {std::pair{std::string("a"), truth_a}, std::pair{std::string("b"), truth_b}}) {
      const ProjectSession& s = now.sessions[now.Find(id)];
      ASSERT_TRUE(s.project_from_session.has_value()) << id;
      EXPECT_LT((s.project_from_session->translation() - truth.translation()).norm(), 1e-9) << id;
      EXPECT_LT(s.project_from_session->rotation().angularDistance(truth.rotation()), 1e-9) << id;
      // Drawn there, too.
      ASSERT_TRUE(WaitFor([&] { return !project()->busy(); }, 60000));
      Rigid3d drawn;
      ASSERT_TRUE(project()->layer()->drawn_pose(id, &drawn)) << id;
      EXPECT_LT((drawn.translation() - truth.translation()).norm(), 1e-5) << id;
      EXPECT_LT(drawn.rotation().angularDistance(truth.rotation()), 1e-5) << id;
    }
    EXPECT_FALSE(now.sessions[2].project_from_session.has_value());
  };
  expect_frame("b");
  {
    const Project& now = project()->document()->project();
    const ProjectSession& a = now.sessions[0];
    EXPECT_EQ(a.registration.reference, "b");
    EXPECT_EQ(a.registration.method, "pairs");
    const Rigid3d b_from_a =
        now.sessions[1].project_from_session->inverse() * *a.project_from_session;
    ASSERT_EQ(a.registration.pairs.size(), 3u);
    for (const PickedPair& pair : a.registration.pairs) {
      EXPECT_LT((b_from_a * pair.source - pair.target).norm(), 1e-9);
    }
  }
  EXPECT_NE(panel->item("a")->text(1).indexOf("pairs to b"), -1)
      << panel->item("a")->text(1).toStdString();
  EXPECT_NE(panel->item("b")->text(1).indexOf("anchor"), -1)
      << panel->item("b")->text(1).toStdString();
  EXPECT_TRUE(window_->isWindowModified());
  // Now a can be the anchor again, and b cannot.
  EXPECT_TRUE(anchor_of("a")->isEnabled());
  EXPECT_FALSE(anchor_of("b")->isEnabled());

  window_->undo_group()->undo();
  expect_frame("a");
  EXPECT_EQ(project()->document()->project().sessions[1].registration.reference, "a");
  EXPECT_FALSE(window_->isWindowModified());  // Back to what the file holds.
  window_->undo_group()->redo();
  expect_frame("b");
  EXPECT_TRUE(window_->isWindowModified());
}

// Make Anchor moves the project's frame, not the building: on screen too.
// The camera moves with the frame, so that the sessions' origins and a
// point above them are drawn at the same pixels after the change and after
// its undo (the camera held still made the building jump by b's pose).
TEST_F(ProjectUiTest, MakeAnchorKeepsTheBuildingStillOnScreen) {
  const QString file = MakeProject("anchor-on-screen");
  Project p;
  ASSERT_TRUE(LoadProject(file.toStdString(), &p).ok());
  const Rigid3d a_from_b = Rigid3d::FromPose(4.0, -3.0, 0.02, 0.01, -0.02, 1.1);
  p.sessions[1].project_from_session = a_from_b;
  p.sessions[1].registration.method = "manual";
  ASSERT_TRUE(SaveProject(file.toStdString(), p).ok());
  ASSERT_TRUE(project()->OpenProject(file));
  TurnsWhileBusy(60000);
  CloudView* view = window_->view();
  view->ViewOblique();
  vtkRenderer* renderer = view->renderWindow()->GetRenderers()->GetFirstRenderer();
  // Where a point of the building (in the frame of `anchor`'s start pose)
  // is drawn, in display pixels.
  const auto on_screen = [&](const Eigen::Vector3d& in_a, const std::string& anchor) {
    view->RenderNow();
    const Eigen::Vector3d w = anchor == "a" ? in_a : a_from_b.inverse() * in_a;
    renderer->SetWorldPoint(w.x(), w.y(), w.z(), 1.0);
    renderer->WorldToDisplay();
    double d[3];
    renderer->GetDisplayPoint(d);
    return Eigen::Vector2d(d[0], d[1]);
  };
  const std::vector<Eigen::Vector3d> building = {Eigen::Vector3d::Zero(), a_from_b.translation(),
                                                 a_from_b * Eigen::Vector3d(1.0, 2.0, 2.5)};
  std::vector<Eigen::Vector2d> before;
  for (const Eigen::Vector3d& x : building) before.push_back(on_screen(x, "a"));
  // On screen and apart: a jump would show.
  const QRectF widget(0, 0, view->width(), view->height());
  for (const Eigen::Vector2d& d : before) ASSERT_TRUE(widget.contains(d.x(), d.y()));
  ASSERT_GT((before[0] - before[1]).norm(), 20.0);
  const uint64_t placements = view->camera_generation();
  // Hide Ceiling (on with the room view, or turned on here): the same cut
  // of the building in the new frame, exact at the point of it under the
  // camera's focal point (the frames' tilt, 22 mrad here, cannot keep a
  // level cut exact everywhere); the status says the new height, and
  // Hide Ceiling off and on again restores it, not the old frame's.
  QAction* ceiling = window_->ceiling_action();
  if (!ceiling->isChecked()) ceiling->trigger();
  const double clip_in_a = view->clip_height();
  ASSERT_FALSE(std::isnan(clip_in_a));
  auto* clip_label = window_->statusBar()->findChild<QLabel*>(QStringLiteral("statusClip"));
  ASSERT_NE(clip_label, nullptr);
  const auto cut_after = [&](const Rigid3d& new_from_old) {
    Eigen::Vector3d focal;
    renderer->GetActiveCamera()->GetFocalPoint(focal.data());
    return (new_from_old * Eigen::Vector3d(focal.x(), focal.y(), view->clip_height())).z();
  };
  const auto expect_clip = [&](double z) {
    EXPECT_NEAR(view->clip_height(), z, 1e-9);
    EXPECT_NE(clip_label->text().indexOf(QString::number(z, 'f', 2)), -1)
        << clip_label->text().toStdString() << " for " << z;
    ceiling->trigger();
    EXPECT_TRUE(std::isnan(view->clip_height()));
    ceiling->trigger();
    EXPECT_NEAR(view->clip_height(), z, 1e-9);
  };
  double cut = cut_after(a_from_b.inverse());
  ASSERT_GT(std::abs(cut - clip_in_a), 0.02);  // b's frame is another: a kept clip would show.

  project()->MakeAnchor("b");
  ASSERT_EQ(project()->document()->project().Anchor(), 1);
  ASSERT_TRUE(WaitFor([&] { return !project()->busy(); }, 60000));
  for (size_t k = 0; k < building.size(); ++k) {
    EXPECT_LT((on_screen(building[k], "b") - before[k]).norm(), 1.0)
        << k << ": " << on_screen(building[k], "b").transpose() << " was " << before[k].transpose();
  }
  expect_clip(cut);
  cut = cut_after(a_from_b);
  window_->undo_group()->undo();
  ASSERT_EQ(project()->document()->project().Anchor(), 0);
  ASSERT_TRUE(WaitFor([&] { return !project()->busy(); }, 60000));
  for (size_t k = 0; k < building.size(); ++k) {
    EXPECT_LT((on_screen(building[k], "a") - before[k]).norm(), 1.0) << k;
  }
  expect_clip(cut);
  EXPECT_NEAR(view->clip_height(), clip_in_a, 1e-3);  // The focal point hardly moved.
  cut = cut_after(a_from_b.inverse());
  window_->undo_group()->redo();
  for (size_t k = 0; k < building.size(); ++k) {
    EXPECT_LT((on_screen(building[k], "b") - before[k]).norm(), 1.0) << k;
  }
  expect_clip(cut);
  // Not a placement of the camera by the operator (the room view may still come).
  EXPECT_EQ(view->camera_generation(), placements);
}

// A session made the anchor while it is being aligned: the alignment's
// result is not applied over the anchor (the project was left without one).
TEST_F(ProjectUiTest, AnAlignmentDoesNotReplaceTheAnchorMadeMeanwhile) {
  const QString file = MakeProject("anchor-meanwhile");
  Project p;
  ASSERT_TRUE(LoadProject(file.toStdString(), &p).ok());
  // b held by hand near where the scenarios put it, on no reference.
  p.sessions[1].project_from_session = Rigid3d::FromPose(5.0, 1.0, 0, 0, 0, 0);
  p.sessions[1].registration.method = "manual";
  ASSERT_TRUE(SaveProject(file.toStdString(), p).ok());
  ASSERT_TRUE(project()->OpenProject(file));
  TurnsWhileBusy(60000);
  const auto align = WatchAlign();
  ASSERT_TRUE(project()->Align("b", "a"));
  project()->MakeAnchor("b");
  ASSERT_EQ(project()->document()->project().Anchor(), 1);
  TurnsWhileBusy(120000);
  ASSERT_TRUE(align->finished);
  EXPECT_FALSE(align->placed);
  EXPECT_NE(align->message.indexOf("the project changed meanwhile"), -1)
      << align->message.toStdString();
  const Project& now = project()->document()->project();
  ASSERT_EQ(now.Anchor(), 1);
  EXPECT_TRUE(now.sessions[1].project_from_session->translation().isZero());
  EXPECT_EQ(now.sessions[0].registration.method, "manual");
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
