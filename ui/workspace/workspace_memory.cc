// Workspace's memory: what an opened session keeps of its samples once the
// cloud is built, and where the cloud store pages (docs/cloud-store.md).
#include <malloc.h>

#include <QDir>
#include <QFileInfo>
#include <QMetaObject>

#include "core/cloud/cloud_pager.h"
#include "ui/workspace/live_processor.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {

void Workspace::PageBeside(const QString& folder) {
  // The cloud's cache file (unnamed: nothing to clean up) on the disk that
  // holds the sessions, not in a /tmp that may be RAM (tmpfs).
  const QString dir = QFileInfo(folder).absolutePath();
  if (QDir(dir).exists()) CloudPager::Default().SetCacheDirectory(dir.toStdString());
}

void Workspace::ReleaseOpenedSamples() {
  if (opened_ == nullptr || opened_samples_released_ || recording_ || replaying_) return;
  size_t samples = 0;
  for (const LidarScan& scan : opened_->log.scans) samples += scan.samples.size();
  if (samples <= kKeepSamplesAtMost) return;
  // A copy without the records (the scans, and the wheels and IMU, ~20 MB
  // an hour): a replay (a seek, another calibration) reads the session as
  // it goes (WithReplaySource), what needs every scan opens it whole again
  // (WithOpenedSamples). The processor's replay lets go of the full one.
  auto light = std::make_shared<hardware::Recording>();
  light->name = opened_->name;
  light->session_dir = opened_->session_dir;
  light->geometry = opened_->geometry;
  light->start = opened_->start;
  light->decode = opened_->decode;
  opened_ = light;
  opened_samples_released_ = true;
  replay_loaded_ = false;
  LiveProcessor* p = processor_;
  QMetaObject::invokeMethod(p, [p] {
    p->StopReplay();
    // The samples (24 bytes each, gigabytes for hours) back to the system:
    // a free in the middle of glibc's heap returns nothing by itself.
    malloc_trim(0);
  });
}

void Workspace::WithOpenedSamples(std::function<void()> then) {
  if (!opened_samples_released_) {
    then();
    return;
  }
  auto recording = std::make_shared<hardware::Recording>();
  const std::string path = session_dir_.toStdString();
  const std::shared_ptr<hardware::Recording> light = opened_;
  RunJob(
      tr("Opening %1").arg(session_dir_),
      [this, recording, path](std::atomic<bool>* cancel) -> QString {
        const QString what = tr("Opening %1").arg(QString::fromStdString(path));
        const Status s = hardware::OpenRecording(path, recording.get(), JobProgress(what, cancel));
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, recording, light, then] {
        if (opened_ != light) return;  // Another session (or a recording) since.
        opened_ = recording;
        opened_samples_released_ = false;
        then();
      },
      OpenRefused(session_dir_));
}

size_t Workspace::CloudSize() const {
  size_t n = 0;
  LiveProcessor* p = processor_;
  QMetaObject::invokeMethod(
      p, [p, &n] { n = p->CloudSize(); }, Qt::BlockingQueuedConnection);
  return n;
}

}  // namespace sweepscan::ui
