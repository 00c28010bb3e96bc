// Sessions in the desktop app, driven through its window and workspace under
// a real display (xvfb-run in CI): save, close and open again point for
// point, Save Session As (moved, or copied on the job thread onto another
// disk or from an opened session), corrupt and truncated sessions refused
// with the app still working, and opening with progress and Cancel.
#include <sys/stat.h>

#include <QAction>
#include <QApplication>
#include <QDir>
#include <QFile>
#include <QFileDialog>
#include <QFileInfo>
#include <QLabel>
#include <QLineEdit>
#include <QMenu>
#include <QMessageBox>
#include <QPushButton>
#include <QSettings>
#include <QStatusBar>
#include <QTemporaryDir>
#include <QTest>
#include <QTimer>
#include <functional>
#include <vector>

#include "core/cloud/cloud_io.h"
#include "tests/ui/app_fixture.h"
#include "ui/main_window.h"
#include "ui/project/project_controller.h"
#include "ui/project/project_layer.h"
#include "ui/view/cloud_view.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

using testing::kResources;
using testing::WaitFor;

using AppTest = testing::AppFixture;

TEST_F(AppTest, SaveCloseAndOpenRestoreTheSameCloudPointForPoint) {
  ConnectToSimulator();
  QString error;
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  workspace_->Drive(0.25, 0.2);
  ASSERT_TRUE(WaitFor([&] { return workspace_->point_count() > 30000; }, 30000));
  workspace_->StopMotion();
  const QString saved = tmp_.path() + "/saved.sweepscan";
  // Saved under a new name, the session and its cloud are the same: what was
  // measured on the cloud stays (nothing listening to sessionChanged forgets).
  int changed = 0;
  QString renamed;
  QObject::connect(workspace_.get(), &Workspace::sessionChanged, [&] { ++changed; });
  QObject::connect(workspace_.get(), &Workspace::sessionRenamed,
                   [&](const QString& dir) { renamed = dir; });
  const QString recorded = workspace_->session_dir();
  // Listed in Open Recent from its start (a recording not saved stays in
  // its folder; this is where the operator finds it again) ...
  const auto recent = [] {
    return QSettings().value(QStringLiteral("sessions/recent")).toStringList();
  };
  EXPECT_EQ(recent().value(0), recorded);
  ASSERT_TRUE(window_->SaveSessionTo(saved)) << window_->last_error().toStdString();
  EXPECT_FALSE(QFileInfo::exists(recorded));  // a new recording is moved, not copied
  // ... and the listing follows it when it moves.
  EXPECT_EQ(recent().value(0), saved);
  EXPECT_FALSE(recent().contains(recorded));
  EXPECT_EQ(workspace_->session_dir(), saved);
  EXPECT_EQ(changed, 0);
  EXPECT_EQ(renamed, saved);
  EXPECT_TRUE(window_->windowTitle().contains("saved.sweepscan"))
      << window_->windowTitle().toStdString();
  workspace_->Disconnect();
  QTest::qWait(300);
  const std::vector<CloudPoint> before = workspace_->CloudSnapshot().Flatten();
  ASSERT_GT(before.size(), 30000u);

  // Close the window and start a fresh one (the app reopened next week).
  window_.reset();
  workspace_ = std::make_unique<Workspace>();
  window_ = std::make_unique<MainWindow>(workspace_.get(), kResources);
  window_->SetInteractive(false);
  window_->show();
  bool finished = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { finished = true; });
  window_->OpenSessionPath(saved);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 60000)) << window_->last_error().toStdString();
  const std::vector<CloudPoint> after = workspace_->CloudSnapshot().Flatten();
  ASSERT_EQ(after.size(), before.size());
  for (size_t i = 0; i < before.size(); ++i) {
    ASSERT_EQ(after[i].x, before[i].x) << i;
    ASSERT_EQ(after[i].y, before[i].y) << i;
    ASSERT_EQ(after[i].z, before[i].z) << i;
    ASSERT_EQ(after[i].time_ns, before[i].time_ns) << i;
  }
  ASSERT_TRUE(WaitFor([&] { return window_->view()->point_count() == before.size(); }, 5000));

  // Saved again under another name: an opened session is copied on the job
  // thread, then it is the session shown; the original stays.
  const QString copy = tmp_.path() + "/copy.sweepscan";
  QString copied_to;
  QObject::connect(workspace_.get(), &Workspace::sessionRenamed,
                   [&](const QString& dir) { copied_to = dir; });
  ASSERT_TRUE(window_->SaveSessionTo(copy)) << window_->last_error().toStdString();
  ASSERT_TRUE(WaitFor([&] { return copied_to == copy; }, 30000))
      << window_->last_error().toStdString();
  EXPECT_EQ(workspace_->session_dir(), copy);
  QFile original(saved + "/frames.bin"), copied(copy + "/frames.bin");
  ASSERT_TRUE(original.open(QIODevice::ReadOnly) && copied.open(QIODevice::ReadOnly));
  EXPECT_EQ(original.readAll(), copied.readAll());
  EXPECT_TRUE(QFileInfo::exists(copy + "/meta.json"));
  // A name that is taken is refused before anything is copied.
  EXPECT_FALSE(workspace_->SaveSessionAs(saved, &error));
  EXPECT_TRUE(error.contains("exists already")) << error.toStdString();
}

// Answers the app's modal dialogs as an operator would: Save in the
// "Unsaved session" question, then `name` in the file chooser.
void AnswerSaveThenName(const QString& name, int* answered) {
  QTimer::singleShot(50, [name, answered] {
    QWidget* modal = QApplication::activeModalWidget();
    if (auto* box = qobject_cast<QMessageBox*>(modal)) {
      box->button(QMessageBox::Save)->click();
      ++*answered;
    } else if (auto* chooser = qobject_cast<QFileDialog*>(modal)) {
      // Typed into its name field, as an operator would.
      auto* field = chooser->findChild<QLineEdit*>(QStringLiteral("fileNameEdit"));
      if (field == nullptr) {
        ADD_FAILURE() << "the file chooser has no name field";
        chooser->reject();
        return;
      }
      field->setText(name);
      QMetaObject::invokeMethod(chooser, "accept", Qt::QueuedConnection);
      ++*answered;
      return;
    }
    AnswerSaveThenName(name, answered);
  });
}

// A new recording saved onto another disk (no rename there) is copied on
// the job thread, not on the GUI thread; opening another session, which
// asked to save it first, goes on once it is saved.
TEST_F(AppTest, ANewRecordingSavedOntoAnotherDiskIsCopiedOnTheJobThreadThenTheOpenGoesOn) {
  QTemporaryDir other_disk(QStringLiteral("/dev/shm/sweepscan-test-XXXXXX"));
  ASSERT_TRUE(other_disk.isValid());
  struct stat here {
  }, there{};
  ASSERT_EQ(stat(qPrintable(tmp_.path()), &here), 0);
  ASSERT_EQ(stat(qPrintable(other_disk.path()), &there), 0);
  if (here.st_dev == there.st_dev)
    GTEST_SKIP() << "/dev/shm is on the same file system as " << qPrintable(tmp_.path());
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());  // tmp/lab.sweepscan, the session to open next
  ConnectToSimulator();
  QString error;
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  workspace_->Drive(0.25, 0.2);
  ASSERT_TRUE(WaitFor([&] { return workspace_->point_count() > 10000; }, 30000));
  ASSERT_TRUE(workspace_->StopRecording(&error)) << error.toStdString();
  workspace_->Disconnect();
  const QString recorded = workspace_->session_dir();
  ASSERT_TRUE(workspace_->unsaved());

  const QString saved = other_disk.path() + "/kept.sweepscan";
  QString opened;
  QObject::connect(workspace_.get(), &Workspace::sessionChanged,
                   [&](const QString& dir) { opened = dir; });
  int answered = 0;
  window_->SetInteractive(true);
  AnswerSaveThenName(saved, &answered);
  window_->OpenSessionPath(tmp_.path() + "/lab.sweepscan");
  window_->SetInteractive(false);
  EXPECT_EQ(answered, 2);
  // Being copied: still unsaved, the job running, the open waiting.
  EXPECT_TRUE(workspace_->unsaved());
  EXPECT_TRUE(workspace_->job_running());
  EXPECT_TRUE(opened.isEmpty());
  ASSERT_TRUE(WaitFor([&] { return opened == tmp_.path() + "/lab.sweepscan"; }, 60000))
      << window_->last_error().toStdString();
  QFile original(recorded + "/frames.bin"), copied(saved + "/frames.bin");
  ASSERT_TRUE(original.open(QIODevice::ReadOnly) && copied.open(QIODevice::ReadOnly));
  EXPECT_GT(original.size(), 50000);
  EXPECT_EQ(original.readAll(), copied.readAll());
  EXPECT_TRUE(QFileInfo::exists(saved + "/meta.json"));
}

TEST_F(AppTest, CorruptOrTruncatedSessionsAreRefusedAndTheAppKeepsWorking) {
  // Record a short session through the real bytes with the CLI.
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  const QString good = tmp_.path() + "/lab.sweepscan";
  ASSERT_TRUE(QFileInfo::exists(good + "/meta.json"));

  // 1. A meta.json that is not JSON.
  const QString bad_meta = tmp_.path() + "/bad_meta.sweepscan";
  QDir().mkpath(bad_meta);
  QFile::copy(good + "/frames.bin", bad_meta + "/frames.bin");
  {
    QFile f(bad_meta + "/meta.json");
    ASSERT_TRUE(f.open(QIODevice::WriteOnly));
    f.write("{\"format_version\": 1, \"geometry\": ");
  }
  QString failed;
  QObject::connect(workspace_.get(), &Workspace::jobFinished,
                   [&](const QString&, bool ok, const QString& m) { failed = ok ? "" : m; });
  window_->OpenSessionPath(bad_meta);
  ASSERT_TRUE(WaitFor([&] { return !failed.isEmpty(); }, 20000));
  EXPECT_NE(failed.indexOf("meta.json"), -1) << failed.toStdString();
  EXPECT_EQ(window_->last_error(), failed);
  // Said plainly first, the reader's words after; the status bar has the
  // plain line.
  EXPECT_TRUE(
      failed.startsWith("bad_meta.sweepscan cannot be opened; nothing in it was changed.\n\n"))
      << failed.toStdString();
  EXPECT_TRUE(window_->statusBar()->currentMessage().endsWith(
      "bad_meta.sweepscan cannot be opened; nothing in it was changed."))
      << window_->statusBar()->currentMessage().toStdString();

  // 2. A frames.bin with a broken header.
  const QString bad_frames = tmp_.path() + "/bad_frames.sweepscan";
  QDir().mkpath(bad_frames);
  QFile::copy(good + "/meta.json", bad_frames + "/meta.json");
  {
    QFile f(bad_frames + "/frames.bin");
    ASSERT_TRUE(f.open(QIODevice::WriteOnly));
    f.write("not a session");
  }
  failed.clear();
  window_->OpenSessionPath(bad_frames);
  ASSERT_TRUE(WaitFor([&] { return !failed.isEmpty(); }, 20000));
  EXPECT_NE(failed.indexOf("frames.bin"), -1) << failed.toStdString();
  EXPECT_TRUE(failed.startsWith("bad_frames.sweepscan cannot be opened;")) << failed.toStdString();

  // 3. A truncated frames.bin (a crash mid-write) opens with what was recorded.
  // A copy of the good session whose frames.bin `harm` damages.
  const auto copy_of_good = [&](const char* name, const std::function<bool(QFile*)>& harm) {
    const QString dir = tmp_.path() + "/" + name + ".sweepscan";
    QDir().mkpath(dir);
    QFile::copy(good + "/meta.json", dir + "/meta.json");
    QFile::copy(good + "/frames.bin", dir + "/frames.bin");
    QFile f(dir + "/frames.bin");
    EXPECT_TRUE(f.open(QIODevice::ReadWrite) && harm(&f)) << name;
    return dir;
  };
  const QString truncated =
      copy_of_good("truncated", [](QFile* f) { return f->resize(f->size() / 2 + 7); });
  bool finished = false;
  QString said;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { finished = true; });
  QObject::connect(workspace_.get(), &Workspace::message, [&](const QString& m) {
    if (m.contains(QStringLiteral("ends early"))) said = m;
  });
  failed.clear();
  window_->OpenSessionPath(truncated);
  ASSERT_TRUE(WaitFor([&] { return finished || !failed.isEmpty(); }, 60000));
  EXPECT_TRUE(finished) << failed.toStdString();
  EXPECT_GT(workspace_->CloudSnapshot().size(), 1000u);
  // ... and says that it ends early, where and why (it replayed to its cut
  // as if that were the end of the drive).
  EXPECT_TRUE(said.startsWith(truncated + QStringLiteral(": the recording ends early")))
      << said.toStdString();
  EXPECT_NE(said.indexOf(QStringLiteral(" bytes left out: record ")), -1) << said.toStdString();
  // The replay panel keeps saying it while the session is open, and stops
  // for a whole one.
  auto* damage = window_->findChild<QLabel*>(QStringLiteral("replayDamage"));
  ASSERT_NE(damage, nullptr);
  EXPECT_TRUE(damage->isVisible());
  EXPECT_EQ(damage->text(), QStringLiteral("ends early: cut off while recording"));
  EXPECT_NE(damage->toolTip().indexOf(QStringLiteral("bytes left out")), -1);
  // A stretch of damage inside (a bad sector, a copy gone wrong): skipped,
  // counted and said beside the name too.
  const QString damaged = copy_of_good("damaged", [](QFile* f) {
    return f->seek(f->size() * 2 / 5) && f->write(QByteArray(64, '\xA5')) == 64;
  });
  finished = false;
  window_->OpenSessionPath(damaged);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 60000));
  EXPECT_TRUE(damage->isVisible());
  EXPECT_TRUE(damage->text().endsWith(QStringLiteral(" damaged records skipped")) ||
              damage->text() == QStringLiteral("1 damaged record skipped"))
      << damage->text().toStdString();
  EXPECT_NE(damage->toolTip().indexOf(QStringLiteral("of data lost")), -1)
      << damage->toolTip().toStdString();
  finished = false;
  window_->OpenSessionPath(good);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 60000));
  EXPECT_FALSE(damage->isVisible()) << damage->text().toStdString();

  // 4. A folder that is no session, and a recent session since deleted:
  // said plainly (it was "DIR/meta.json: cannot open for reading"), and the
  // deleted one leaves Open Recent.
  const QString plain = tmp_.path() + "/photos";
  QDir().mkpath(plain);
  window_->OpenSessionPath(plain);
  EXPECT_NE(window_->last_error().indexOf("is not a sweepscan session"), -1)
      << window_->last_error().toStdString();
  const QString gone = tmp_.path() + "/gone.sweepscan";
  QSettings().setValue(QStringLiteral("sessions/recent"), QStringList{gone, truncated});
  window_->OpenSessionPath(gone);
  EXPECT_NE(window_->last_error().indexOf("does not exist"), -1)
      << window_->last_error().toStdString();
  EXPECT_EQ(QSettings().value(QStringLiteral("sessions/recent")).toStringList(),
            QStringList{truncated});

  // The app still works: the simulator connects and streams.
  ConnectToSimulator();
}

// A session opened beside an open project is drawn in its own frame, the
// project's sessions in the anchor's: the same room can show twice, apart,
// and the status bar says why (it was left for the operator to puzzle over).
TEST_F(AppTest, ASessionOpenedBesideAProjectSaysItIsInItsOwnFrame) {
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  const QString session = tmp_.path() + "/lab.sweepscan";
  const QString file = tmp_.path() + "/lab.sweepscan-project";
  const auto made = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " project new " +
                                        file.toStdString() + " " + session.toStdString());
  ASSERT_EQ(made.code, 0) << made.out;
  ASSERT_TRUE(window_->project()->OpenProject(file)) << window_->last_error().toStdString();
  ASSERT_TRUE(WaitFor([&] { return window_->project()->layer()->shown_points() > 0; }, 60000));
  OpenAndReplay(session);
  EXPECT_TRUE(window_->statusBar()->currentMessage().contains(
      "lab.sweepscan is drawn in its own frame beside the open project"))
      << window_->statusBar()->currentMessage().toStdString();
}

TEST_F(AppTest, OpeningShowsProgressAndCancelStopsIt) {
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  const QString session = tmp_.path() + "/lab.sweepscan";
  std::vector<double> fractions;
  QString finished_message;
  bool finished = false, finished_ok = false;
  QObject::connect(workspace_.get(), &Workspace::jobProgress,
                   [&](const QString&, double f) { fractions.push_back(f); });
  QObject::connect(workspace_.get(), &Workspace::jobFinished,
                   [&](const QString&, bool ok, const QString& m) {
                     finished = true;
                     finished_ok = ok;
                     finished_message = m;
                   });
  // Cancelled at once (Tools > Cancel Running Task, enabled only while a
  // job runs): the job ends without a session and says so.
  auto* cancel = window_->findChild<QAction*>(QStringLiteral("cancelTaskAction"));
  ASSERT_NE(cancel, nullptr);
  auto* tools = qobject_cast<QMenu*>(cancel->parent());
  ASSERT_NE(tools, nullptr);
  emit tools->aboutToShow();
  EXPECT_FALSE(cancel->isEnabled());
  workspace_->OpenSession(session);
  emit tools->aboutToShow();
  ASSERT_TRUE(cancel->isEnabled());
  cancel->trigger();
  ASSERT_TRUE(WaitFor([&] { return finished; }, 20000));
  emit tools->aboutToShow();
  EXPECT_FALSE(cancel->isEnabled());
  EXPECT_FALSE(finished_ok);
  EXPECT_NE(finished_message.indexOf("ancel"), -1) << finished_message.toStdString();
  EXPECT_TRUE(workspace_->session_dir().isEmpty());
  // Opened in full: progress is monotone and ends at 1.
  fractions.clear();
  finished = false;
  workspace_->OpenSession(session);
  ASSERT_TRUE(WaitFor([&] { return finished; }, 20000));
  EXPECT_TRUE(finished_ok) << finished_message.toStdString();
  ASSERT_GE(fractions.size(), 3u);
  EXPECT_EQ(fractions.front(), -1.0);  // The job starts indeterminate...
  for (size_t i = 2; i < fractions.size(); ++i) EXPECT_GE(fractions[i], fractions[i - 1]) << i;
  EXPECT_EQ(fractions.back(), 1.0);  // ...and reports its end.
  EXPECT_EQ(workspace_->session_dir(), session);
}

// Connected to a robot and not recording, the view previews its live
// cloud; a session opened then shows its own points alone (the robot's went
// on arriving into it), and New Session shows the robot's preview again.
TEST_F(AppTest, ASessionOpenedWhileConnectedShowsOnlyItsOwnPoints) {
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  const QString session = tmp_.path() + "/lab.sweepscan";
  ASSERT_NO_FATAL_FAILURE(ConnectToSimulator());
  ASSERT_TRUE(WaitFor([&] { return workspace_->point_count() > 2000; }, 20000));  // the preview
  ASSERT_NO_FATAL_FAILURE(OpenAndReplay(session));
  const std::vector<CloudPoint> opened = workspace_->CloudSnapshot().Flatten();
  QTest::qWait(1500);  // the simulated X4 makes ~5 000 points a second
  const std::vector<CloudPoint> later = workspace_->CloudSnapshot().Flatten();
  ASSERT_EQ(later.size(), opened.size());
  // The session's points exactly, as the CLI places them.
  const std::string dir = tmp_.path().toStdString();
  const auto cli = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " reconstruct " + dir +
                                       "/lab.sweepscan --out " + dir + "/cli.ply");
  ASSERT_EQ(cli.code, 0) << cli.out;
  std::vector<CloudPoint> expected;
  ASSERT_TRUE(LoadCloud(dir + "/cli.ply", &expected).ok());
  ASSERT_EQ(later.size(), expected.size());
  for (size_t i = 0; i < expected.size(); i += 97) {
    ASSERT_EQ(later[i].x, expected[i].x) << i;
    ASSERT_EQ(later[i].z, expected[i].z) << i;
  }
  workspace_->NewSession();
  EXPECT_TRUE(WaitFor([&] { return workspace_->point_count() > 2000; }, 20000));
}

// Record pressed while a session is being opened: the opening is cancelled
// and says why; the recording goes on (the opening's end used to replace
// the live cloud and stop the recording).
TEST_F(AppTest, StartingARecordingCancelsASessionBeingOpened) {
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  const QString session = tmp_.path() + "/lab.sweepscan";
  ASSERT_NO_FATAL_FAILURE(ConnectToSimulator());
  bool finished = false, finished_ok = true;
  QString finished_message;
  QObject::connect(workspace_.get(), &Workspace::jobFinished,
                   [&](const QString&, bool ok, const QString& m) {
                     finished = true;
                     finished_ok = ok;
                     finished_message = m;
                   });
  workspace_->OpenSession(session);
  ASSERT_TRUE(workspace_->job_running());
  QString error;
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  const QString recording = workspace_->session_dir();
  ASSERT_TRUE(WaitFor([&] { return finished; }, 20000));
  EXPECT_FALSE(finished_ok);
  EXPECT_TRUE(finished_message.contains("a recording started")) << finished_message.toStdString();
  // Said in the status bar, not as an error box over the recording.
  EXPECT_TRUE(window_->last_error().isEmpty()) << window_->last_error().toStdString();
  EXPECT_TRUE(window_->statusBar()->currentMessage().contains("a recording started"))
      << window_->statusBar()->currentMessage().toStdString();
  QTest::qWait(300);
  EXPECT_TRUE(workspace_->recording());
  EXPECT_EQ(workspace_->session_dir(), recording);
  ASSERT_TRUE(WaitFor([&] { return workspace_->point_count() > 2000; }, 20000));
  ASSERT_TRUE(workspace_->StopRecording(&error)) << error.toStdString();
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
