// Workspace, by concern: ROS recordings (docs/ros-bags.md). A bag is
// inspected and imported on the job thread, exactly as `sweepscan-cli info
// BAG` and `import` do it (core/io/ros/import.h), and the imported session
// then opens like any other.
#include <malloc.h>

#include <QMetaObject>
#include <limits>
#include <memory>

#include "core/io/ros/ros_bag.h"
#include "ui/workspace/background_priority.h"
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
      [this, summary, warnings, path, what](std::atomic<bool>* cancel) -> QString {
        // A bag's summary comes from its index or summary section (the bar
        // shows it is busy), or (an MCAP without one) from a scan of the
        // file, which shows how far it is and stops at a Cancel.
        QMetaObject::invokeMethod(this, [this, what] { emit jobProgress(what, -1.0); });
        const Status s =
            io::SummarizeRosBag(path, summary.get(), warnings.get(), JobProgress(what, cancel));
        // Not kept open while the operator chooses (or cancels and
        // unplugs the drive): the import opens it again.
        io::ReleaseRosBags();
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
  const QString what = tr("Importing %1").arg(bag);
  // The import opens its session in place of the one shown: not of one
  // being recorded (started while the bag was being read, before its
  // chooser, modal to the window, was shown).
  if (recording_) {
    emit jobFinished(
        what, false,
        tr("Stop the recording first: the import opens its session in place of the one "
           "being recorded."));
    return;
  }
  auto report = std::make_shared<io::RosImportReport>();
  const std::string bag_path = bag.toStdString(), out = session_dir.toStdString();
  RunJob(
      what,
      [this, report, bag_path, out, options, what](std::atomic<bool>* cancel) -> QString {
        io::RosImportOptions o = options;
        // A cancel stops the reader within a thousand messages and removes
        // the session.
        o.progress = JobProgress(what, cancel);
        const Status s = io::ImportRosBag(bag_path, out, o, report.get());
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, report, session_dir, speed, session = session_generation_] {
        for (const std::string& w : report->warnings) {
          emit message(tr("%1: %2").arg(session_dir, QString::fromStdString(w)));
        }
        if (recording_ || session != session_generation_) {
          // A recording started (or another session was shown) while the
          // bag was read: the import does not replace it.
          emit message(tr("Imported %1; not opened, as the session shown changed meanwhile: "
                          "open it from File > Open Session.")
                           .arg(session_dir));
          return;
        }
        OpenSession(session_dir, speed);
      });
}

bool Workspace::MapIntensities(const SensorLog& log, const CloudSnapshotRef& cloud,
                               const std::atomic<bool>& cancel, QuantizedValues* out) {
  bool any = false;
  for (const LidarScan& scan : log.scans) {
    if (cancel || any) break;  // a session change waits for this thread
    for (size_t i = 0; !any && i < scan.samples.size(); ++i)
      any = scan.samples[i].intensity != 0.0f;
  }
  if (!any || cancel) return false;
  const ScansByIndex scans(log.scans);
  // Chunk by chunk (a 10 M-point cloud decoded whole would be 320 MB more).
  // Points come scan by scan: one beam table a scan.
  std::vector<float> values;
  values.reserve(cloud.size());
  std::vector<float> beam(65536, 0.0f);
  uint32_t table = std::numeric_limits<uint32_t>::max();
  const LidarScan* scan = nullptr;  // table's
  const auto map = [&](const CloudPoint& p) {
    if (p.scan != table) {
      table = p.scan;
      scan = scans.Find(p.scan);
      if (scan != nullptr)
        for (const LidarSample& s : scan->samples) beam[s.beam] = s.intensity;
    }
    if (scan == nullptr) {
      values.push_back(std::numeric_limits<float>::quiet_NaN());
      return;
    }
    values.push_back(beam[p.beam]);
  };
  std::vector<CloudPoint> points;
  for (const auto& chunk : cloud.sealed) {
    if (cancel) return false;
    points.clear();
    chunk->Decode(&points);
    for (const CloudPoint& p : points) map(p);
  }
  for (const CloudPoint& p : cloud.open) map(p);
  *out = Quantize(values);
  return !cancel;
}

void Workspace::StartIntensityMapping() {
  StopIntensityMapping();
  if (opened_ == nullptr || opened_samples_released_) return;
  // The recording and the snapshot are shared: the samples outlive their
  // release (ReleaseOpenedSamples swaps in a copy without them) until done.
  std::shared_ptr<const hardware::Recording> recording = opened_;
  CloudSnapshotRef cloud = CloudSnapshot();
  const uint64_t generation = intensity_generation_;
  intensity_thread_ = std::make_unique<std::thread>([this, recording, cloud, generation]() mutable {
    LowerThisThreadsPriority();
    auto values = std::make_shared<QuantizedValues>();
    const bool mapped = MapIntensities(recording->log, cloud, intensity_cancel_, values.get());
    // This may be the last hold on the samples (the replay's let go as it
    // ended): gigabytes for hours, which glibc keeps unless trimmed after
    // they are freed (ReleaseOpenedSamples' trim may have run already).
    recording.reset();
    cloud = CloudSnapshotRef();
    malloc_trim(0);
    if (!mapped) return;
    QMetaObject::invokeMethod(this, [this, values, generation] {
      if (generation == intensity_generation_) emit intensitiesMapped(values);
    });
  });
}

void Workspace::StopIntensityMapping() {
  ++intensity_generation_;
  if (intensity_thread_ == nullptr) return;
  intensity_cancel_ = true;  // seen between chunks: the join is short
  intensity_thread_->join();
  intensity_thread_.reset();
  intensity_cancel_ = false;
}

}  // namespace sweepscan::ui
