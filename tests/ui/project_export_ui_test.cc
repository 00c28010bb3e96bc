// A building's cloud exported from the app (File > Export Project Cloud,
// and Export Cloud while the project is what the view shows): every point
// the view draws of the placed, shown sessions, where the view draws it,
// under each session's Point Source ID; cancel and refusals leave nothing.
// The truth is the app's own clouds of the sessions (built for the view,
// by another path: positions streamed and moved by the layer) and the
// placements in the project.
#include <gtest/gtest.h>

#include <QAction>
#include <QApplication>
#include <QDir>
#include <QFileInfo>
#include <QLabel>
#include <QProgressBar>
#include <QSettings>
#include <QTimer>
#include <QToolButton>

#include "tests/testing/las_records.h"
#include "tests/testing/qt_wait.h"
#include "tests/ui/file_chooser.h"
#include "tests/ui/project_ui_fixture.h"
#include "ui/project/project_panel.h"

namespace sweepscan::ui {
namespace {

using testing::WaitFor;

class ProjectExportUiTest : public testing::ProjectUiFixture {
 protected:
  QAction* Action(const QString& text) {
    for (QAction* a : window_->findChildren<QAction*>()) {
      if (a->text() == text) return a;
    }
    return nullptr;
  }
  // The project's next message (the status bar's), from this call on.
  std::shared_ptr<QString> WatchMessage() {
    auto said = std::make_shared<QString>();
    QObject::connect(project(), &ProjectController::message, window_.get(),
                     [said](const QString& m) { *said = m; });
    return said;
  }
};

// Ctrl+E with the office floor open and no session: the chooser offers the
// project's name beside it in the format last used; a and b (placed) are
// written, c (not placed) is left out and said so. Each record is a point
// of the view's cloud of its session, moved by its placement.
TEST_F(ProjectExportUiTest, ExportCloudWithTheProjectShownWritesTheBuilding) {
  QSettings().remove(QStringLiteral("export/dir"));
  QSettings().setValue(QStringLiteral("export/suffix"), QStringLiteral("las"));
  const QString file = MakeProject("export", "project align --session b --to a");
  ASSERT_NO_FATAL_FAILURE(OpenAndLoad(file));
  ASSERT_EQ(project()->clouds().size(), 2u);
  QAction* export_project = Action(QStringLiteral("Export Pro&ject Cloud…"));
  ASSERT_NE(export_project, nullptr);
  EXPECT_TRUE(export_project->isEnabled());

  const auto said = WatchMessage();
  const QString out = QDir(QString::fromStdString(Dir())).filePath(QStringLiteral("floor"));
  QString opened_in, suggested;
  bool answered = false;
  testing::AnswerFileChooser(out, &answered, &opened_in, &suggested);
  QAction* export_cloud = Action(QStringLiteral("&Export Cloud…"));
  ASSERT_NE(export_cloud, nullptr);
  export_cloud->trigger();
  ASSERT_TRUE(answered);
  ASSERT_TRUE(WaitFor([&] { return !project()->busy() && !said->isEmpty(); }, 60000))
      << said->toStdString();
  EXPECT_EQ(suggested, QStringLiteral("export.las"));
  EXPECT_EQ(opened_in, QFileInfo(file).absolutePath());
  EXPECT_TRUE(said->startsWith("Exported ")) << said->toStdString();
  EXPECT_TRUE(said->contains("of 2 session(s)")) << said->toStdString();
  EXPECT_TRUE(said->contains("not placed, left out: c")) << said->toStdString();
  EXPECT_TRUE(window_->last_error().isEmpty()) << window_->last_error().toStdString();

  testing::LasRecords las;
  ASSERT_TRUE(las.Read((out + ".las").toStdString()));
  const Project& p = project()->document()->project();
  size_t i = 0, wrong_source = 0;
  double worst = 0.0;
  for (const char* id : {"a", "b"}) {
    const ProjectCloud& cloud = *project()->clouds().at(id);
    const int k = p.Find(id);
    const Rigid3d placed = *p.sessions[k].project_from_session;
    ASSERT_LE(i + cloud.positions.size(), las.count);
    for (const Eigen::Vector3f& q : cloud.positions) {
      worst = std::max(worst, (las.Position(i) - placed * q.cast<double>()).cwiseAbs().maxCoeff());
      wrong_source += las.PointSourceId(i) != k + 1;
      ++i;
    }
  }
  EXPECT_EQ(i, las.count);
  EXPECT_EQ(wrong_source, 0u);
  // Float positions moved in double, then rounded to float by the export:
  // within a float's step at 20 m and half the 0.1 mm scale.
  EXPECT_LE(worst, 0.5 * las.scale[0] + 4e-6) << worst;
  EXPECT_TRUE(said->contains(QString::number(las.count))) << said->toStdString();
}

// Cancel in the panel while it writes leaves no file (nor the writer's
// temporary) and says so; with nothing placed and shown the export is
// refused with the reason before any chooser; the action follows the
// project's being open.
TEST_F(ProjectExportUiTest, CancelledOrNothingToExportLeavesNoFile) {
  const QString file = MakeProject("cancel", "project align --session b --to a");
  ASSERT_NO_FATAL_FAILURE(OpenAndLoad(file));
  const QString folder = QDir(QString::fromStdString(Dir())).filePath(QStringLiteral("cancelled"));
  ASSERT_TRUE(QDir().mkpath(folder));
  const auto said = WatchMessage();
  auto* cancel = window_->findChild<QToolButton*>(QStringLiteral("projectCancel"));
  ASSERT_NE(cancel, nullptr);
  // Clicked at the job's first progress, as it reaches the panel: the
  // export of two sessions takes some 100 times the event loop's turn.
  bool clicked = false;
  QObject context;
  QObject::connect(
      project()->jobs(), &ProjectJobs::progress, &context, [&](const QString& what, double) {
        if (clicked || !what.startsWith("Export: reading")) return;
        EXPECT_TRUE(cancel->isVisible());
        // The stage is said once, whole, in the line below the bar; the
        // bar shows its percentage (the stage in it was said twice and a
        // long one wrapped, cut off).
        auto* bar = window_->findChild<QProgressBar*>(QStringLiteral("projectProgress"));
        ASSERT_NE(bar, nullptr);
        EXPECT_TRUE(bar->text().endsWith(QStringLiteral(" %"))) << bar->text().toStdString();
        EXPECT_FALSE(bar->text().contains(QStringLiteral("Export")));
        EXPECT_EQ(bar->toolTip(), what);
        EXPECT_EQ(project()->panel()->status_label()->text(), what + QStringLiteral("…"));
        if (qEnvironmentVariableIsSet("SWEEPSCAN_TEST_SHOTS")) {
          window_->grab().save(qEnvironmentVariable("SWEEPSCAN_TEST_SHOTS") +
                               "/project-export-progress.png");
        }
        cancel->click();
        clicked = true;
      });
  ASSERT_TRUE(project()->ExportCloud(folder + "/floor.las"));
  ASSERT_TRUE(WaitFor([&] { return !project()->busy(); }, 60000));
  EXPECT_TRUE(clicked);
  EXPECT_TRUE(said->startsWith("Export cancelled")) << said->toStdString();
  EXPECT_TRUE(QDir(folder).isEmpty(QDir::AllEntries | QDir::NoDotAndDotDot | QDir::Hidden));

  project()->SetVisible("a", false);
  project()->SetVisible("b", false);
  EXPECT_FALSE(project()->ExportCloud(folder + "/floor.las"));
  EXPECT_TRUE(window_->last_error().contains("placed and shown"))
      << window_->last_error().toStdString();
  // Through the menu: said before any chooser opens (none is answered).
  QAction* export_project = Action(QStringLiteral("Export Pro&ject Cloud…"));
  ASSERT_NE(export_project, nullptr);
  const int errors = window_->errors_shown();
  bool chooser = false;  // A chooser would block trigger(): closed, and said.
  QObject watch;
  QTimer::singleShot(3000, &watch, [&chooser] {
    if (QWidget* modal = QApplication::activeModalWidget()) {
      chooser = true;
      modal->close();
    }
  });
  export_project->trigger();
  EXPECT_FALSE(chooser);
  EXPECT_EQ(window_->errors_shown(), errors + 1);
  EXPECT_TRUE(QDir(folder).isEmpty(QDir::AllEntries | QDir::NoDotAndDotDot | QDir::Hidden));

  ASSERT_TRUE(project()->CloseProject());
  EXPECT_FALSE(export_project->isEnabled());
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
