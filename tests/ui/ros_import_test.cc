// File > Import ROS Recording… driven through its real widgets (QTest)
// under a real display (xvfb-run in CI): the topic chooser filled from the
// bag, the import and replay equal to `sweepscan-cli import` +
// `reconstruct`, a bag without a mount refused with the reason and then
// imported with one, and a file that is no bag.
#include <QVTKOpenGLNativeWidget.h>
#include <gtest/gtest.h>

#include <QApplication>
#include <QCheckBox>
#include <QComboBox>
#include <QDialogButtonBox>
#include <QDir>
#include <QElapsedTimer>
#include <QFile>
#include <QLabel>
#include <QLineEdit>
#include <QPointer>
#include <QPushButton>
#include <QSettings>
#include <QSurfaceFormat>
#include <QTemporaryDir>
#include <QTest>
#include <QThread>
#include <algorithm>
#include <functional>

#include "core/cloud/cloud_io.h"
#include "tests/testing/run_command.h"
#include "tests/ui/app_fixture.h"
#include "ui/main_window.h"
#include "ui/panels/ros_import_dialog.h"
#include "ui/view/cloud_view.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

const std::string kData = SWEEPSCAN_SOURCE_DIR "/tests/data";
using testing::WaitFor;

class RosImportUiTest : public testing::AppFixture {
 protected:
  // Opens the chooser on `bag` and waits until the bag is read.
  QPointer<RosImportDialog> OpenChooser(const std::string& bag) {
    QPointer<RosImportDialog> dialog = window_->ImportRosRecordingPath(QString::fromStdString(bag));
    EXPECT_TRUE(dialog);
    EXPECT_TRUE(WaitFor([&] { return !dialog || dialog->ready(); }, 30000));
    return dialog;
  }
  void ClickImport(RosImportDialog* dialog) {
    QTest::mouseClick(dialog->buttons()->button(QDialogButtonBox::Ok), Qt::LeftButton);
  }

};

// A ROS 2 MCAP written by @mcap/core: the chooser shows its topics; the
// imported session replays to the cloud the CLI makes of the same bag.
TEST_F(RosImportUiTest, ChooserImportsAndReplaysLikeTheCli) {
  const std::string bag = kData + "/ros2/ros2_zstd.mcap";
  QPointer<RosImportDialog> dialog = OpenChooser(bag);
  ASSERT_TRUE(dialog && dialog->isVisible());
  // It blocks the window (nothing opened or recorded meanwhile that Import
  // would replace unasked).
  EXPECT_EQ(QApplication::activeModalWidget(), dialog.data());
  // Its fields show what they hold whole: the hints and the session's path
  // (the robot frame's hint was cut at "else base_fo").
  for (QLineEdit* field : dialog->findChildren<QLineEdit*>()) {
    const QString shown = field->text().isEmpty() ? field->placeholderText() : field->text();
    EXPECT_LE(field->fontMetrics().horizontalAdvance(shown), field->width() - 8)
        << shown.toStdString();
  }
  ASSERT_EQ(dialog->scan_topic()->count(), 1);  // one LaserScan: no "none" offered
  EXPECT_TRUE(dialog->scan_topic()->currentText().startsWith("/scan  (20 messages")) << dialog->scan_topic()->currentText().toStdString();
  EXPECT_EQ(dialog->odom_topic()->currentData().toString(), "/odom");
  EXPECT_EQ(dialog->odom_topic()->itemData(dialog->odom_topic()->count() - 1).toString(), "none");
  EXPECT_EQ(dialog->imu_topic()->currentData().toString(), "/imu");
  const QString session = tmp_.path() + "/imported.sweepscan";
  dialog->session_dir()->setText(session);

  bool replayed = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { replayed = true; });
  ClickImport(dialog);
  ASSERT_TRUE(WaitFor([&] { return replayed; }, 60000)) << window_->last_error().toStdString();
  EXPECT_EQ(workspace_->session_dir(), session);

  const std::string dir = tmp_.path().toStdString();
  const auto cli = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " import " + bag + " --out " + dir +
                                       "/cli.sweepscan && " + SWEEPSCAN_CLI + " reconstruct " + dir +
                                       "/cli.sweepscan --out " + dir + "/cli.ply");
  ASSERT_EQ(cli.code, 0) << cli.out;
  std::vector<CloudPoint> expected;
  ASSERT_TRUE(LoadCloud(dir + "/cli.ply", &expected).ok());
  const std::vector<CloudPoint> shown = workspace_->CloudSnapshot().Flatten();
  ASSERT_GT(expected.size(), 100u);
  ASSERT_EQ(shown.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    ASSERT_EQ(shown[i].x, expected[i].x) << i;
    ASSERT_EQ(shown[i].z, expected[i].z) << i;
  }
}

// The choosers offer only what the import can read: a topic in ROS 1's
// encoding inside an MCAP (which `mcap convert` keeps) and a topic without
// messages are left out, and a kind with several readable topics offers
// them all in the bag's order. (No test bag holds these, so the summary is
// given.)
TEST_F(RosImportUiTest, ChoosersOfferOnlyTopicsTheImportCanRead) {
  QPointer<RosImportDialog> dialog = OpenChooser(kData + "/ros2/ros2_zstd.mcap");
  ASSERT_TRUE(dialog && dialog->ready());
  io::RosBagSummary s;
  s.format = "mcap";
  s.topics = {{"/scan_converted", "sensor_msgs/LaserScan", "ros1", 50, 0, 0},
              {"/scan_rear", "sensor_msgs/msg/LaserScan", "cdr", 0, 0, 0},
              {"/scan_front", "sensor_msgs/msg/LaserScan", "cdr", 40, 0, 0},
              {"/imu", "sensor_msgs/msg/Imu", "cdr", 0, 0, 0},
              {"/imu/data", "sensor_msgs/msg/Imu", "cdr", 20, 0, 0},
              {"/odom_wheels", "nav_msgs/msg/Odometry", "cdr", 5, 0, 0},
              {"/odom_fused", "nav_msgs/msg/Odometry", "cdr", 5, 0, 0}};
  dialog->Fill(s);
  const auto items = [](QComboBox* c) {
    QStringList l;
    for (int i = 0; i < c->count(); ++i) l << c->itemData(i).toString();
    return l.join(' ').toStdString();
  };
  EXPECT_EQ(items(dialog->scan_topic()), "/scan_front");
  EXPECT_EQ(items(dialog->imu_topic()), "/imu/data none");
  EXPECT_EQ(items(dialog->odom_topic()), "/odom_wheels /odom_fused none");
  const auto says_no_cloud = [&] {
    for (const QLabel* l : dialog->findChildren<QLabel*>()) {
      if (l->text().contains("the session will hold the trajectory only, no cloud")) return true;
    }
    return false;
  };
  EXPECT_FALSE(says_no_cloud());
  // Only the ROS 1-encoded scan: nothing to make a cloud of, "none" alone,
  // and the dialog says so before the import (it made a 0-point session
  // without a word).
  s.topics.erase(s.topics.begin() + 1, s.topics.begin() + 3);
  dialog->Fill(s);
  EXPECT_EQ(items(dialog->scan_topic()), "none");
  EXPECT_TRUE(says_no_cloud());
  dialog->reject();
}

// An MCAP without a summary section is read whole for the chooser: the bar
// follows the read, and the topics are the file's.
TEST_F(RosImportUiTest, AnMcapReadWholeShowsHowFarItIs) {
  std::vector<double> fractions;
  QObject::connect(workspace_.get(), &Workspace::jobProgress, [&](const QString& what, double f) {
    if (what.startsWith("Reading")) fractions.push_back(f);
  });
  QPointer<RosImportDialog> dialog = OpenChooser(kData + "/ros2/ros2_lz4_nosummary.mcap");
  ASSERT_TRUE(dialog && dialog->isVisible());
  EXPECT_TRUE(dialog->scan_topic()->currentText().startsWith("/scan  (20 messages"));
  ASSERT_FALSE(fractions.empty());
  EXPECT_EQ(fractions.back(), 1.0);  // not only the busy bar (-1)
  dialog->reject();
}

// A real car's bag with no tf to its laser: the import is refused with the
// reason (and leaves nothing); with the mount given it imports.
TEST_F(RosImportUiTest, MissingMountIsRefusedThenGiven) {
  const std::string bag = kData + "/ros/datmo_parallel.bag";
  const QString session = tmp_.path() + "/car.sweepscan";
  QPointer<RosImportDialog> dialog = OpenChooser(bag);
  ASSERT_TRUE(dialog);
  EXPECT_EQ(dialog->odom_topic()->currentData().toString(), "none");  // the bag has no odometry
  dialog->session_dir()->setText(session);
  ClickImport(dialog);
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running() && !window_->last_error().isEmpty(); }, 30000));
  EXPECT_TRUE(window_->last_error().contains("tf has no path from base_link to laser")) << window_->last_error().toStdString();
  EXPECT_FALSE(QDir(session).exists());

  dialog = OpenChooser(bag);
  ASSERT_TRUE(dialog);
  dialog->use_lidar_mount()->setChecked(true);
  dialog->lidar_mount()->setText("-0.12, 0, 0.1, 0, 0, 0.5x");
  dialog->session_dir()->setText(session);
  ClickImport(dialog);
  EXPECT_TRUE(dialog->isVisible());  // a malformed mount keeps the dialog, with the reason
  EXPECT_TRUE(dialog->error_label()->text().contains("six numbers"));
  dialog->lidar_mount()->setText("-0.12, 0, 0.1, 0, 0, 0");
  bool replayed = false;
  QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { replayed = true; });
  ClickImport(dialog);
  ASSERT_TRUE(WaitFor([&] { return replayed; }, 60000)) << window_->last_error().toStdString();
  EXPECT_GT(workspace_->CloudSnapshot().size(), 37000u);
  // The RPLIDAR's intensities (0 or 47) reach View > Colour by > Intensity.
  // Mapped on a worker thread as the replay ends; the view takes them.
  ASSERT_TRUE(WaitFor([&] { return window_->view()->has_point_values(CloudView::ColorMode::kIntensity); }, 5000));
  QuantizedValues intensity;
  ASSERT_TRUE(Workspace::MapIntensities(workspace_->recording_opened()->log,
                                        workspace_->CloudSnapshot(), std::atomic<bool>(false),
                                        &intensity));
  ASSERT_EQ(intensity.q.size(), workspace_->CloudSnapshot().size());
  std::vector<double> values;
  for (uint16_t q : intensity.q)
    values.push_back(q == QuantizedValues::kNone ? -1.0 : intensity.Value(q));
  EXPECT_TRUE(
      std::all_of(values.begin(), values.end(), [](double v) { return v == 0.0 || v == 47.0; }));
  EXPECT_GT(std::count(values.begin(), values.end(), 47.0), 30000);
  EXPECT_FALSE(Workspace::MapIntensities(workspace_->recording_opened()->log,
                                         workspace_->CloudSnapshot(), std::atomic<bool>(true),
                                         &intensity));  // cancelled
  window_->view()->SetColorMode(CloudView::ColorMode::kIntensity);
}

TEST_F(RosImportUiTest, NotABagSaysSoAndTheAppGoesOn) {
  const QString text = tmp_.path() + "/notes.bag";
  QFile f(text);
  ASSERT_TRUE(f.open(QIODevice::WriteOnly));
  f.write("not a bag\n");
  f.close();
  bool inspected_ok = true;
  QPointer<RosImportDialog> dialog = window_->ImportRosRecordingPath(text);
  ASSERT_TRUE(dialog);
  QObject::connect(dialog, &RosImportDialog::inspected, [&](bool ok) { inspected_ok = ok; });
  ASSERT_TRUE(WaitFor([&] { return !dialog; }, 30000));  // it closes itself
  EXPECT_FALSE(inspected_ok);
  EXPECT_TRUE(window_->last_error().contains("not a ROS bag")) << window_->last_error().toStdString();
  EXPECT_FALSE(workspace_->job_running());
}

// A recording started while the bag was being read (the chooser is modal
// only once shown): Import does not replace it, and says why.
TEST_F(RosImportUiTest, ARecordingStartedMeanwhileIsNotReplaced) {
  ASSERT_NO_FATAL_FAILURE(ConnectToSimulator());
  QPointer<RosImportDialog> dialog = OpenChooser(kData + "/ros2/ros2_zstd.mcap");
  ASSERT_TRUE(dialog && dialog->isVisible());
  QString error;
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  const QString recording = workspace_->session_dir();
  const QString session = tmp_.path() + "/imported.sweepscan";
  dialog->session_dir()->setText(session);
  ClickImport(dialog);
  ASSERT_TRUE(
      WaitFor([&] { return window_->last_error().contains("Stop the recording first"); }, 10000))
      << window_->last_error().toStdString();
  EXPECT_TRUE(workspace_->recording());
  EXPECT_EQ(workspace_->session_dir(), recording);
  EXPECT_FALSE(QFileInfo::exists(session));
  ASSERT_TRUE(workspace_->StopRecording(&error)) << error.toStdString();
}

// A recording started while the import runs (the chooser has closed): the
// imported session is written but not opened over the recording, which
// goes on; the operator is told where it is.
TEST_F(RosImportUiTest, ARecordingStartedDuringTheImportGoesOn) {
  ASSERT_NO_FATAL_FAILURE(ConnectToSimulator());
  QPointer<RosImportDialog> dialog = OpenChooser(kData + "/ros2/ros2_zstd.mcap");
  ASSERT_TRUE(dialog && dialog->isVisible());
  const QString session = tmp_.path() + "/imported.sweepscan";
  dialog->session_dir()->setText(session);
  QStringList said;
  QObject::connect(workspace_.get(), &Workspace::message, [&](const QString& m) { said << m; });
  ClickImport(dialog);
  ASSERT_TRUE(workspace_->job_running());  // its end is queued at the earliest
  QString error;
  ASSERT_TRUE(workspace_->StartRecording(&error)) << error.toStdString();
  const QString recording = workspace_->session_dir();
  ASSERT_TRUE(WaitFor([&] { return !workspace_->job_running(); }, 30000));
  QTest::qWait(500);  // an opening it started would have ended by now
  EXPECT_FALSE(workspace_->job_running());
  EXPECT_TRUE(workspace_->recording());
  EXPECT_EQ(workspace_->session_dir(), recording);
  EXPECT_TRUE(QFileInfo::exists(session + "/frames.bin"));
  EXPECT_TRUE(said.filter("Imported " + session + "; not opened").size() == 1) << said.join('\n').toStdString();
  ASSERT_TRUE(workspace_->StopRecording(&error)) << error.toStdString();
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
