// Workspace, by concern: ROS recordings (docs/ros-bags.md). A bag is
// inspected and imported on the job thread, exactly as `sweepscan-cli info
// BAG` and `import` do it (core/io/ros/import.h), and the imported session
// then opens like any other.
#include <QMetaObject>
#include <limits>
#include <memory>

#include "core/io/ros/ros_bag.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {

void Workspace::InspectRosBag(const QString& bag) {
  auto summary = std::make_shared<io::RosBagSummary>();
  const std::string path = bag.toStdString();
  const QString what = tr("Reading %1").arg(bag);
  // A refusal or failure reaches the dialog's caller as rosBagInspected too.
  auto failed = std::make_shared<QMetaObject::Connection>();
  *failed = connect(this, &Workspace::jobFinished, this,
                    [this, what, bag, failed](const QString& job, bool ok, const QString& message) {
                      if (job != what) return;
                      disconnect(*failed);
                      if (!ok) emit rosBagInspected(bag, false, message);
                    });
  auto warnings = std::make_shared<std::vector<std::string>>();
  RunJob(
      what,
      [this, summary, warnings, path, what](std::atomic<bool>*) -> QString {
        // A bag's summary comes from its index or summary section, or (an
        // MCAP without one) from a scan of the file that reports no
        // fraction: the bar shows it is busy, and a Cancel drops the result.
        QMetaObject::invokeMethod(this, [this, what] { emit jobProgress(what, -1.0); });
        const Status s = io::SummarizeRosBag(path, summary.get(), warnings.get());
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, summary, warnings, bag] {
        ros_bag_summary_ = *summary;
        for (const std::string& w : *warnings) {
          emit message(tr("%1: %2").arg(bag, QString::fromStdString(w)));
        }
        emit rosBagInspected(bag, true, QString());
      });
}

void Workspace::ImportRosRecording(const QString& bag, const QString& session_dir,
                                   const io::RosImportOptions& options, double speed) {
  auto report = std::make_shared<io::RosImportReport>();
  const std::string bag_path = bag.toStdString(), out = session_dir.toStdString();
  const QString what = tr("Importing %1").arg(bag);
  RunJob(
      what,
      [this, report, bag_path, out, options, what](std::atomic<bool>* cancel) -> QString {
        io::RosImportOptions o = options;
        // Progress to the status bar at most every 2 %; a cancel stops the
        // reader within a thousand messages and removes the session.
        auto last = std::make_shared<double>(-1.0);
        o.progress = [this, cancel, last, what](double f) {
          if (f - *last >= 0.02 || f >= 1.0) {
            *last = f;
            QMetaObject::invokeMethod(this, [this, what, f] { emit jobProgress(what, f); });
          }
          return !*cancel;
        };
        const Status s = io::ImportRosBag(bag_path, out, o, report.get());
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, report, session_dir, speed] {
        for (const std::string& w : report->warnings) {
          emit message(tr("%1: %2").arg(session_dir, QString::fromStdString(w)));
        }
        OpenSession(session_dir, speed);
      });
}

std::vector<float> Workspace::IntensityValues() const {
  if (opened_ == nullptr) return {};
  const SensorLog& log = opened_->log;
  bool any = false;
  std::vector<const LidarScan*> scans;
  for (const LidarScan& scan : log.scans) {
    if (scan.index >= scans.size()) scans.resize(scan.index + 1, nullptr);
    scans[scan.index] = &scan;
    for (const LidarSample& s : scan.samples) any = any || s.intensity != 0.0f;
  }
  if (!any) return {};
  const std::vector<CloudPoint> points = CloudSnapshot().Flatten();
  std::vector<float> values(points.size(), std::numeric_limits<float>::quiet_NaN());
  // Points come scan by scan: one beam table a scan.
  std::vector<float> beam(65536, 0.0f);
  uint32_t table = std::numeric_limits<uint32_t>::max();
  for (size_t i = 0; i < points.size(); ++i) {
    const CloudPoint& p = points[i];
    if (p.scan >= scans.size() || scans[p.scan] == nullptr) continue;
    if (p.scan != table) {
      table = p.scan;
      for (const LidarSample& s : scans[p.scan]->samples) beam[s.beam] = s.intensity;
    }
    values[i] = beam[p.beam];
  }
  return values;
}

}  // namespace sweepscan::ui
