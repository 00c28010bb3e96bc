// What the panels computed or showed for one session's cloud goes with it,
// driven through the real widgets under a real display (xvfb-run in CI):
// the evaluation (its tables, its report, its "before" column, its planes'
// names in the view kept off each other), the view's
// pass colouring, the replay panel's name and position, the calibration
// result; a failed report export is an error message; a calibration whose
// session cannot be read again ends instead of staying on "Solving…".
#include <gtest/gtest.h>

#include <QAction>
#include <QApplication>
#include <QFile>
#include <QFileDialog>
#include <QFileInfo>
#include <QFontMetrics>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QSettings>
#include <QSlider>
#include <QTableWidget>
#include <QTemporaryDir>
#include <QTest>
#include <QTimer>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/calibration/calibration_file.h"
#include "tests/testing/run_command.h"
#include "tests/ui/app_fixture.h"
#include "tests/ui/file_chooser.h"
#include "ui/main_window.h"
#include "ui/panels/calibration_panel.h"
#include "ui/panels/evaluation_panel.h"
#include "ui/panels/replay_panel.h"
#include "ui/view/cloud_view.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

using testing::AnswerFileChooser;
using testing::kResources;
using testing::WaitFor;

// Two sessions recorded once for the whole binary with the CLI: the lab
// drive (a straight drive, "A") and a one-turn circle drive in the same lab
// ("B", a calibration drive: its passes are split and coloured).
QString Simulated(const char* scenario, const char* name) {
  static QTemporaryDir dir;
  const QString session = dir.path() + "/" + name + ".sweepscan";
  if (!QFileInfo::exists(session)) {
    const auto sim = testing::RunCommand(
        std::string(SWEEPSCAN_CLI) + " simulate --scenario " + kResources.toStdString() +
        "/scenarios/" + scenario + " --out " + dir.path().toStdString() + "/" + name + ".ply");
    EXPECT_EQ(sim.code, 0) << sim.out;
  }
  return session;
}
QString LabSession() { return Simulated("lab.json", "lab"); }
QString CircleSession() { return Simulated("lab_circle.json", "circle"); }

template <typename W>
W* Named(QWidget* parent, const char* name) {
  W* w = parent->findChild<W*>(QString::fromLatin1(name));
  EXPECT_NE(w, nullptr) << name;
  return w;
}

class SessionResultsTest : public testing::AppFixture {
 protected:
  EvaluationPanel* evaluation() { return window_->evaluation_panel(); }

  // Clicks "Evaluate the cloud shown" and waits for the result.
  bool EvaluateByButton() {
    bool done = false, ok = false;
    QObject context;
    QObject::connect(evaluation(), &EvaluationPanel::evaluated, &context, [&](bool r) {
      done = true;
      ok = r;
    });
    QTest::mouseClick(Named<QPushButton>(evaluation(), "evaluate"), Qt::LeftButton);
    EXPECT_TRUE(WaitFor([&] { return done; }, 120000));
    return ok;
  }
  // Opens a session, waits for its replay and the view to hold every point.
  void Open(const QString& session) {
    ASSERT_NO_FATAL_FAILURE(OpenAndReplay(session));
    const size_t n = workspace_->CloudSize();
    ASSERT_TRUE(WaitFor([&] { return window_->view()->point_count() == n; }, 10000));
  }
  // Opens the circle drive and waits for the calibration panel to colour
  // its passes.
  void OpenCircle() {
    bool split = false;
    QObject context;
    QObject::connect(workspace_.get(), &Workspace::passesSplit, &context, [&] { split = true; });
    ASSERT_NO_FATAL_FAILURE(Open(CircleSession()));
    ASSERT_TRUE(workspace_->circle_drive()) << workspace_->circle_drive_note().toStdString();
    ASSERT_TRUE(WaitFor([&] { return split; }, 60000));
    ASSERT_TRUE(WaitFor(
        [&] { return window_->view()->color_mode() == CloudView::ColorMode::kPass; }, 10000));
  }
  QPushButton* export_button() { return Named<QPushButton>(evaluation(), "exportReport"); }
  QString summary() { return Named<QLabel>(evaluation(), "evaluationSummary")->text(); }
  QTableWidget* planes_table() { return Named<QTableWidget>(evaluation(), "evaluationPlanes"); }
  // File > Export Cloud… answered with `name` (and the file type `filter`
  // if given), as an operator would; true once the chooser was answered and
  // the export's job ended. Where the chooser opened, the name and type it
  // offered go to the last three.
  bool ExportCloudThrough(const QString& name, const QString& filter = QString(),
                          QString* opened_in = nullptr, QString* suggested = nullptr,
                          QString* suggested_filter = nullptr) {
    QAction* export_cloud = nullptr;
    for (QAction* a : window_->findChildren<QAction*>()) {
      if (a->text() == QStringLiteral("&Export Cloud…")) export_cloud = a;
    }
    if (export_cloud == nullptr) return false;
    bool answered = false, finished = false;
    QObject context;
    QObject::connect(workspace_.get(), &Workspace::jobFinished, &context,
                     [&](const QString& what, bool, const QString&) {
                       if (what.startsWith("Exporting")) finished = true;
                     });
    AnswerFileChooser(name, &answered, opened_in, suggested, filter, suggested_filter);
    export_cloud->trigger();
    return answered && WaitFor([&] { return finished; }, 60000);
  }
  QTableWidget* dimensions_table() {
    return Named<QTableWidget>(evaluation(), "evaluationDimensions");
  }
  // The "before" column of the planes table, row by row.
  QStringList before_column() {
    QStringList out;
    QTableWidget* t = planes_table();
    for (int r = 0; r < t->rowCount(); ++r) out << t->item(r, 4)->text();
    return out;
  }
};

// Session A evaluated, session B opened: the panel shows none of A's
// figures and cannot export them; B's evaluation has no "before" from A,
// and its report names B with B's numbers. Another pose source of B clears
// B's figures too but keeps them as B's "before".
TEST_F(SessionResultsTest, AnEvaluationGoesWithTheSessionItDescribes) {
  ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
  ASSERT_TRUE(EvaluateByButton()) << summary().toStdString();
  const size_t a_points = workspace_->evaluation()->points_in;
  ASSERT_GT(planes_table()->rowCount(), 0);
  EXPECT_TRUE(export_button()->isEnabled());

  ASSERT_NO_FATAL_FAILURE(OpenCircle());
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 60000));  // the pass split
  EXPECT_EQ(workspace_->evaluation(), nullptr);
  EXPECT_EQ(workspace_->previous_evaluation(), nullptr);
  EXPECT_EQ(planes_table()->rowCount(), 0);
  EXPECT_EQ(dimensions_table()->rowCount(), 0);
  EXPECT_FALSE(export_button()->isEnabled());
  EXPECT_EQ(summary().indexOf(QLocale().toString(qulonglong(a_points))), -1)
      << summary().toStdString();
  QString error;
  EXPECT_FALSE(evaluation()->ExportReport(tmp_.path() + "/stale.json", &error));

  ASSERT_TRUE(EvaluateByButton()) << summary().toStdString();
  const size_t b_points = workspace_->evaluation()->points_in;
  EXPECT_NE(b_points, a_points);
  EXPECT_EQ(workspace_->previous_evaluation(), nullptr);  // not A's
  EXPECT_EQ(summary().indexOf("previous evaluation"), -1) << summary().toStdString();
  for (const QString& b : before_column()) EXPECT_EQ(b, "-");
  EXPECT_TRUE(planes_table()->isColumnHidden(4));  // nothing to compare with
  EXPECT_TRUE(planes_table()->isColumnHidden(5));
  ASSERT_TRUE(evaluation()->ExportReport(tmp_.path() + "/b.json", &error)) << error.toStdString();
  std::ifstream in(tmp_.path().toStdString() + "/b.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report["session"], CircleSession().toStdString());
  EXPECT_EQ(report["evaluation"]["points"], b_points);
  EXPECT_FALSE(report.contains("previous"));

  // Another pose source: another cloud of the same session.
  bool replayed = false;
  QObject context;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, &context,
                   [&] { replayed = true; });
  workspace_->SetPoseSource(PoseSource::kOdometry);
  EXPECT_EQ(workspace_->evaluation(), nullptr);
  EXPECT_EQ(planes_table()->rowCount(), 0);
  EXPECT_FALSE(export_button()->isEnabled());
  ASSERT_NE(workspace_->previous_evaluation(), nullptr);  // B's, for before / after
  // Then the passes are split again (a job: one at a time).
  ASSERT_TRUE(WaitFor([&] { return replayed && !workspace_->job_running(); }, 60000));
  ASSERT_TRUE(EvaluateByButton()) << summary().toStdString();
  EXPECT_NE(summary().indexOf("previous evaluation"), -1) << summary().toStdString();
  EXPECT_FALSE(planes_table()->isColumnHidden(4));  // B's with the EKF, before
  EXPECT_FALSE(planes_table()->isColumnHidden(5));
  EXPECT_FALSE(dimensions_table()->isColumnHidden(2));

  // New Session and Connect: a live cloud, no evaluation.
  workspace_->NewSession();
  EXPECT_EQ(workspace_->evaluation(), nullptr);
  EXPECT_EQ(workspace_->previous_evaluation(), nullptr);
  EXPECT_EQ(planes_table()->rowCount(), 0);
  EXPECT_FALSE(export_button()->isEnabled());
}

// An evaluation still running when the cloud is replaced (New Session)
// describes a cloud no longer shown: it is dropped, not shown.
TEST_F(SessionResultsTest, AnEvaluationOfAReplacedCloudIsDropped) {
  ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
  bool done = false, ok = true;
  QObject context;
  QObject::connect(evaluation(), &EvaluationPanel::evaluated, &context, [&](bool r) {
    done = true;
    ok = r;
  });
  QTest::mouseClick(Named<QPushButton>(evaluation(), "evaluate"), Qt::LeftButton);
  ASSERT_TRUE(workspace_->job_running());
  workspace_->NewSession();
  ASSERT_TRUE(WaitFor([&] { return done; }, 120000));
  EXPECT_FALSE(ok);
  EXPECT_EQ(workspace_->evaluation(), nullptr);
  EXPECT_EQ(planes_table()->rowCount(), 0);
  EXPECT_FALSE(export_button()->isEnabled());
  EXPECT_NE(summary().indexOf("changed while it was evaluated"), -1) << summary().toStdString();
}

// The operator reads planes from 1 (the table's rows): the dimensions'
// planes and the progress say the same; "done" is said when it is.
TEST_F(SessionResultsTest, PlanesAreNumberedFromOneAndTheProgressNamesTheDeviationMap) {
  ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
  QStringList stages;
  QObject context;
  QObject::connect(workspace_.get(), &Workspace::jobProgress, &context,
                   [&](const QString& what, double) { stages << what; });
  ASSERT_TRUE(EvaluateByButton()) << summary().toStdString();
  EXPECT_FALSE(stages.contains("Evaluating: done")) << stages.join(", ").toStdString();
  EXPECT_TRUE(stages.contains("Evaluating: deviation map")) << stages.join(", ").toStdString();
  const CloudEvaluation* e = workspace_->evaluation();
  ASSERT_FALSE(e->dimensions.empty());
  QTableWidget* dims = dimensions_table();
  for (int r = 0; r < dims->rowCount(); ++r) {
    const RoomDimension& d = e->dimensions[r];
    EXPECT_EQ(dims->item(r, 0)->text(), QStringLiteral("%1 %2 \u2013 %3 %4")
                                            .arg(QString::fromStdString(e->planes[d.plane_a].kind))
                                            .arg(d.plane_a + 1)
                                            .arg(QString::fromStdString(e->planes[d.plane_b].kind))
                                            .arg(d.plane_b + 1));
  }
  // No previous evaluation of B: no "before" columns, and the names whole.
  EXPECT_TRUE(planes_table()->isColumnHidden(4));
  EXPECT_TRUE(dims->isColumnHidden(2));
  const QFontMetrics metrics(dims->font());
  for (int r = 0; r < dims->rowCount(); ++r) {
    EXPECT_LE(metrics.horizontalAdvance(dims->item(r, 0)->text()), dims->columnWidth(0))
        << dims->item(r, 0)->text().toStdString();
  }
}

// Selecting a plane in the table singles it out in the view: drawn more
// opaque than the others and outlined, its name bold and laid out first (nothing in the
// view said which rectangle the table's row was). The dimensions read to
// the millimetre (they read to a tenth of one, on a cloud of 1 mm steps
// and planes of several millimetres' RMS).
TEST_F(SessionResultsTest, TheSelectedPlaneStandsOutInTheView) {
  ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
  ASSERT_TRUE(EvaluateByButton()) << summary().toStdString();
  CloudView* view = window_->view();
  QTableWidget* planes = planes_table();
  ASSERT_GE(planes->rowCount(), 3);
  ASSERT_EQ(view->plane_count(), static_cast<size_t>(planes->rowCount()));
  EXPECT_EQ(view->selected_plane(), 0);  // the row selected after evaluating
  planes->selectRow(2);
  EXPECT_EQ(view->selected_plane(), 2);
  for (int i = 0; i < planes->rowCount(); ++i) {
    EXPECT_EQ(view->plane_opacity(i), i == 2 ? 0.6 : 0.2) << i;
  }
  // The others keep their faint edges (the selected one is outlined).
  EXPECT_EQ(view->plane_edges(), static_cast<size_t>(planes->rowCount() - 1));
  view->RenderNow();
  ASSERT_FALSE(view->plane_label_boxes().empty());
  EXPECT_EQ(view->plane_label_boxes().front().plane, 2);  // placed first: never pushed aside
  // Unselected (the table's selection cleared): all alike again.
  planes->clearSelection();
  planes->setCurrentCell(-1, -1);
  EXPECT_EQ(view->selected_plane(), -1);
  EXPECT_EQ(view->plane_opacity(0), 0.35);
  EXPECT_EQ(view->plane_edges(), static_cast<size_t>(planes->rowCount()));
  planes->selectRow(2);
  if (qEnvironmentVariableIsSet("SWEEPSCAN_TEST_SHOTS")) {
    window_->grab().save(qEnvironmentVariable("SWEEPSCAN_TEST_SHOTS") + "/selected-plane.png");
  }
  QTableWidget* dims = dimensions_table();
  ASSERT_GT(dims->rowCount(), 0);
  for (int r = 0; r < dims->rowCount(); ++r) {
    const QString figure = dims->item(r, 1)->text();
    EXPECT_EQ(figure.size() - figure.indexOf('.') - 1, 3) << figure.toStdString();
  }
}

// Evaluate with no session's cloud (a project's clouds are layers of the
// view, not a session's): the panel says what the evaluation works on.
TEST_F(SessionResultsTest, EvaluatingWithoutASessionsCloudSaysItWorksOnOneSession) {
  EXPECT_FALSE(EvaluateByButton());
  EXPECT_NE(summary().indexOf("single session"), -1) << summary().toStdString();
  EXPECT_NE(summary().indexOf("project"), -1) << summary().toStdString();
}

// File > Export Cloud…'s chooser: beside the session, named after it (it
// opened in the working folder with no name); a name typed without a
// suffix takes the filter's (.ply). Once used, its folder is remembered.
TEST_F(SessionResultsTest, ExportCloudOffersTheSessionsFolderAndName) {
  QSettings().remove(QStringLiteral("export/dir"));
  ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
  const QFileInfo session(LabSession());
  QString opened_in, suggested;
  const QString out = tmp_.path() + "/exported";
  ASSERT_TRUE(ExportCloudThrough(out, QString(), &opened_in, &suggested));
  EXPECT_EQ(opened_in, session.absolutePath());
  EXPECT_EQ(suggested, QStringLiteral("lab.ply"));
  EXPECT_TRUE(QFileInfo::exists(out + ".ply")) << window_->last_error().toStdString();
  // The next export starts where this one went.
  ASSERT_TRUE(ExportCloudThrough(tmp_.path() + "/again.ply", QString(), &opened_in, &suggested));
  EXPECT_EQ(opened_in, QFileInfo(tmp_.path()).absoluteFilePath());
  EXPECT_EQ(suggested, QStringLiteral("lab.ply"));
}

// LAS, which a surveyor's tools read, from the same chooser: a name typed
// without a suffix takes .las; the file holds every point of the cloud, its
// GPS times anchored on the session's start (meta.json's created_utc) and
// its System Identifier naming the simulation (as `sweepscan-cli export`
// writes; the format is read back by independent readers in
// las_writer_test). The next export offers LAS again.
TEST_F(SessionResultsTest, ExportCloudWritesLasAndOffersItNextTime) {
  QSettings().remove(QStringLiteral("export/dir"));
  QSettings().remove(QStringLiteral("export/suffix"));
  ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
  QString said, suggested, suggested_filter;
  QObject context;
  QObject::connect(workspace_.get(), &Workspace::message, &context,
                   [&](const QString& m) { said = m; });
  const QString out = tmp_.path() + "/survey";
  ASSERT_TRUE(ExportCloudThrough(out, QStringLiteral("LAS 1.4 (*.las)"), nullptr, &suggested,
                                 &suggested_filter));
  EXPECT_EQ(suggested, QStringLiteral("lab.ply"));
  EXPECT_EQ(suggested_filter, QStringLiteral("PLY (*.ply)"));
  QFile file(out + ".las");
  ASSERT_TRUE(file.open(QIODevice::ReadOnly)) << window_->last_error().toStdString();
  const QByteArray b = file.readAll();
  ASSERT_GE(b.size(), 375);
  const auto u16 = [&](int at) {
    uint16_t v;
    std::memcpy(&v, b.constData() + at, 2);
    return v;
  };
  uint64_t count;
  std::memcpy(&count, b.constData() + 247, 8);  // LAS 1.4 §2.4: Number of Point Records
  EXPECT_EQ(b.left(4), QByteArray("LASF"));
  EXPECT_EQ(b[24], 1);
  EXPECT_EQ(b[25], 4);
  EXPECT_EQ(u16(6) & 1, 1);  // Global Encoding bit 0: adjusted standard GPS time
  EXPECT_EQ(QByteArray(b.constData() + 26).left(32), QByteArray("sweepscan simulation"));
  EXPECT_EQ(count, workspace_->CloudSize());
  EXPECT_GT(count, 200000u);
  // The header's offset to the points plus the records fill the file
  // (§2.4: Offset to Point Data at 96, Point Data Record Length at 105).
  uint32_t offset;
  std::memcpy(&offset, b.constData() + 96, 4);
  EXPECT_EQ(static_cast<uint64_t>(b.size()), offset + count * u16(105));
  EXPECT_NE(said.indexOf(QStringLiteral("Exported %1 points").arg(count)), -1)
      << said.toStdString();
  EXPECT_EQ(said.indexOf(QStringLiteral("robot seconds")), -1) << said.toStdString();
  // The next export offers the same format, named after the session.
  ASSERT_TRUE(ExportCloudThrough(tmp_.path() + "/again.las", QString(), nullptr, &suggested,
                                 &suggested_filter));
  EXPECT_EQ(suggested, QStringLiteral("lab.las"));
  EXPECT_EQ(suggested_filter, QStringLiteral("LAS 1.4 (*.las)"));
  QSettings().remove(QStringLiteral("export/suffix"));
}

// Export report… into a folder that cannot be written: an error message as
// for any failed export (the main window's), the summary stays; into a
// writable one: the report and its image.
TEST_F(SessionResultsTest, AFailedReportExportIsAnErrorAndTheSummaryStays) {
  ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
  ASSERT_TRUE(EvaluateByButton()) << summary().toStdString();
  const QString evaluated = summary();
  // Not a folder (a file's name in its place): unwritable even for root.
  QFile blocker(tmp_.path() + "/not-a-folder");
  ASSERT_TRUE(blocker.open(QIODevice::WriteOnly));
  blocker.close();
  const QString bad = tmp_.path() + "/not-a-folder/report.json";
  const int errors = window_->errors_shown();
  bool answered = false, finished = false, ok = true;
  QObject context;
  QObject::connect(workspace_.get(), &Workspace::jobFinished, &context,
                   [&](const QString&, bool r, const QString&) {
                     finished = true;
                     ok = r;
                   });
  AnswerFileChooser(bad, &answered);
  QTest::mouseClick(export_button(), Qt::LeftButton);
  ASSERT_TRUE(answered);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 30000));
  EXPECT_FALSE(ok);
  EXPECT_EQ(window_->errors_shown(), errors + 1);
  EXPECT_NE(window_->last_error().indexOf("not-a-folder"), -1)
      << window_->last_error().toStdString();
  EXPECT_EQ(summary(), evaluated);
  EXPECT_TRUE(export_button()->isEnabled());

  const QString good = tmp_.path() + "/report.json";
  answered = finished = false;
  AnswerFileChooser(good, &answered);
  QTest::mouseClick(export_button(), Qt::LeftButton);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 30000));
  EXPECT_TRUE(ok) << window_->last_error().toStdString();
  EXPECT_EQ(window_->errors_shown(), errors + 1);
  std::ifstream in(good.toStdString());
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report["session"], LabSession().toStdString());
  EXPECT_EQ(report["image"], "report.png");
  EXPECT_TRUE(QImage(tmp_.path() + "/report.png").width() > 0);
}

// The calibration panel colours a calibration drive by pass; the next
// session (no passes) and the live cloud get the colouring from before
// back, unless the operator chose another meanwhile.
TEST_F(SessionResultsTest, ThePassColouringEndsWithTheCalibrationDrive) {
  CloudView* view = window_->view();
  ASSERT_EQ(view->color_mode(), CloudView::ColorMode::kHeight);
  ASSERT_NO_FATAL_FAILURE(OpenCircle());
  ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
  EXPECT_TRUE(WaitFor([&] { return view->color_mode() == CloudView::ColorMode::kHeight; }, 2000))
      << static_cast<int>(view->color_mode());

  // Coloured by deviation over the passes, then another session: neither.
  ASSERT_NO_FATAL_FAILURE(OpenCircle());
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 60000));
  ASSERT_TRUE(EvaluateByButton());
  evaluation()->ShowDeviations(true);
  ASSERT_EQ(view->color_mode(), CloudView::ColorMode::kDeviation);
  ConnectToSimulator();
  EXPECT_TRUE(WaitFor([&] { return view->color_mode() == CloudView::ColorMode::kHeight; }, 2000))
      << static_cast<int>(view->color_mode());
  workspace_->Disconnect();

  // The operator's own choice after the passes is kept.
  ASSERT_NO_FATAL_FAILURE(OpenCircle());
  QAction* time = nullptr;
  for (QAction* a : window_->findChildren<QAction*>()) {
    if (a->text() == "&Time") time = a;
  }
  ASSERT_NE(time, nullptr);
  time->trigger();
  ASSERT_EQ(view->color_mode(), CloudView::ColorMode::kTime);
  ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
  QTest::qWait(100);
  EXPECT_EQ(view->color_mode(), CloudView::ColorMode::kTime);
}

// New Session and Connect: the replay panel no longer names the session
// nor stands at its time; the calibration panel no longer shows its result.
TEST_F(SessionResultsTest, NewSessionAndConnectResetTheReplayAndCalibrationPanels) {
  ReplayPanel* replay = window_->replay_panel();
  CalibrationPanel* calibration = window_->calibration_panel();
  auto* name = Named<QLabel>(replay, "replaySession");
  auto* slider = Named<QSlider>(replay, "replaySlider");
  auto* position = Named<QLabel>(replay, "replayPosition");
  const std::string file = tmp_.path().toStdString() + "/calibration.json";
  ASSERT_TRUE(SaveCalibrationFile(file, MountingError{0.001, 0.002, 0.003}, nullptr).ok());

  for (const bool connect : {false, true}) {
    SCOPED_TRACE(connect ? "Connect" : "New Session");
    ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
    ASSERT_EQ(name->text(), "lab.sweepscan");
    ASSERT_GT(slider->value(), 900);
    ASSERT_NE(position->text().indexOf(" s"), -1) << position->text().toStdString();
    QString error;
    ASSERT_TRUE(calibration->LoadCalibration(QString::fromStdString(file), &error))
        << error.toStdString();
    ASSERT_NE(calibration->result_text().indexOf("Converged"), -1);

    if (connect) {
      ConnectToSimulator();
    } else {
      workspace_->NewSession();
    }
    QTest::qWait(200);  // what the replay had still queued, if anything
    EXPECT_EQ(name->text(), "No session");
    EXPECT_EQ(slider->value(), 0);
    EXPECT_FALSE(slider->isEnabled());
    EXPECT_EQ(position->text(), QString(QChar(0x2014)));  // no replay, no "0.0 / 0.0 s"
    EXPECT_EQ(calibration->result_text(), "");
    EXPECT_EQ(workspace_->calibration_result(), nullptr);
    EXPECT_TRUE(workspace_->session_dir().isEmpty());
    workspace_->Disconnect();
  }
}

// A session let go of its samples (opened streamed) is read whole again
// before a calibration; when that read fails the calibration ends with the
// reason instead of staying on "Solving…".
TEST_F(SessionResultsTest, ACalibrationWhoseSessionCannotBeReadAgainEnds) {
  // A copy of the circle drive, whose frames.bin is taken away once opened.
  const QString session = tmp_.path() + "/circle.sweepscan";
  const auto copy = testing::RunCommand("cp -r '" + CircleSession().toStdString() + "' '" +
                                        session.toStdString() + "'");
  ASSERT_EQ(copy.code, 0) << copy.out;
  workspace_->set_stream_open_above_bytes(0);  // every session streamed
  bool split = false;
  QObject context;
  QObject::connect(workspace_.get(), &Workspace::passesSplit, &context, [&] { split = true; });
  ASSERT_NO_FATAL_FAILURE(Open(session));
  ASSERT_TRUE(WaitFor([&] { return split && !workspace_->job_running(); }, 60000));
  ASSERT_TRUE(QFile::remove(session + "/frames.bin"));

  CalibrationPanel* panel = window_->calibration_panel();
  bool solved = false, ok = true;
  QObject::connect(panel, &CalibrationPanel::solved, &context, [&](bool r) {
    solved = true;
    ok = r;
  });
  panel->SolveAutomatic();
  ASSERT_TRUE(WaitFor([&] { return solved; }, 30000)) << panel->result_text().toStdString();
  EXPECT_FALSE(ok);
  EXPECT_FALSE(panel->solving());
  EXPECT_NE(panel->result_text().indexOf("Not solved"), -1) << panel->result_text().toStdString();
  EXPECT_NE(panel->result_text().indexOf("frames.bin"), -1) << panel->result_text().toStdString();
  EXPECT_FALSE(workspace_->job_running());
}

// A calibration (or a pass split) still running when another session
// takes its place ends without a result: it was shown, and offered to the
// robot, as the new session's (the review's case: Calibrate, then Connect).
TEST_F(SessionResultsTest, ACalibrationOfASessionNoLongerShownGivesNoResult) {
  ASSERT_NO_FATAL_FAILURE(OpenCircle());
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 60000));
  bool finished = false, ok = true;
  QString said;
  QObject context;
  QObject::connect(workspace_.get(), &Workspace::calibrationFinished, &context,
                   [&](bool r, const QString& m) {
                     finished = true;
                     ok = r;
                     said = m;
                   });
  workspace_->CalibrateAutomatic();
  ASSERT_TRUE(workspace_->job_running());
  workspace_->NewSession();
  ASSERT_TRUE(WaitFor([&] { return finished; }, 120000));
  EXPECT_FALSE(ok);
  EXPECT_NE(said.indexOf("The session changed while it was calibrated"), -1) << said.toStdString();
  EXPECT_EQ(workspace_->calibration_result(), nullptr);
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 60000));
}

// The evaluated planes' names in the view, on the simulated lab room (floor,
// ceiling, walls): each drawn at its own plane's centre or a few lines
// above or below it, never on another name, from above (where the floor's
// and the ceiling's centres meet), obliquely, from the front and the side.
// They used to be drawn each at its centre, on each other.
TEST_F(SessionResultsTest, PlaneNamesInTheViewStayOffEachOther) {
  ASSERT_NO_FATAL_FAILURE(Open(LabSession()));
  ASSERT_TRUE(EvaluateByButton()) << evaluation()->summary_text().toStdString();
  const CloudEvaluation* e = workspace_->evaluation();
  ASSERT_NE(e, nullptr);
  ASSERT_GE(e->planes.size(), 5u);  // the floor, the ceiling, walls
  CloudView* view = window_->view();
  view->SetClipHeight(std::numeric_limits<double>::quiet_NaN());  // the ceiling's name too
  const QRectF widget(0, 0, view->width(), view->height());
  for (int v = 0; v < 4; ++v) {
    SCOPED_TRACE(v);
    if (v == 0) view->ViewTop();
    if (v == 1) view->ViewOblique();
    if (v == 2) view->ViewFront();
    if (v == 3) view->ViewSide();
    view->RenderNow();
    const std::vector<CloudView::PlaneLabelBox> boxes = view->plane_label_boxes();
    // Most are named (a name is left out only where no place near its
    // plane is clear), the first (the floor) always.
    EXPECT_GE(boxes.size(), e->planes.size() * 2 / 3);
    ASSERT_FALSE(boxes.empty());
    EXPECT_EQ(boxes[0].plane, 0);
    for (size_t i = 0; i < boxes.size(); ++i) {
      const CloudView::PlaneLabelBox& b = boxes[i];
      ASSERT_LT(b.plane, static_cast<int>(e->planes.size()));
      // At its own plane's centre, or a few lines above or below it.
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (const Eigen::Vector3d& c : e->planes[b.plane].outline) centre += 0.25 * c;
      const QPointF at = view->WorldToWidget(centre);
      EXPECT_NEAR(b.box.center().x(), at.x(), 1.0) << b.plane;
      EXPECT_LE(std::abs(b.box.center().y() - at.y()), 4.5 * b.box.height()) << b.plane;
      EXPECT_TRUE(widget.contains(b.box)) << b.plane;
      for (size_t j = 0; j < i; ++j) {
        EXPECT_FALSE(b.box.intersects(boxes[j].box))
            << "plane " << b.plane + 1 << "'s name covers plane " << boxes[j].plane + 1 << "'s";
      }
    }
  }
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
