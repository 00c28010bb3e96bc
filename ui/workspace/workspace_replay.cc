// Workspace's replay of the opened session: where its records come from
// (hardware/station/replay_source.h), the open that replays a large session
// as it reads it, and the replay's controls (speed, pause, seek).
//
// A session whose samples are not held (a large one once its replay ended,
// or one opened streamed) is replayed from a SessionReplaySource: its wheel
// and IMU records decoded once and kept with the opened session (about
// 20 MB an hour of drive), its scans decoded from frames.bin as the replay
// reaches them. A replay, a seek across hours or another calibration then
// needs no more memory than the cloud it builds, where decoding the session
// whole held 24 bytes a lidar sample (3.1 GiB for 5.7 hours). What needs
// every scan at once (SfM, a calibration) still opens the session whole
// (WithOpenedSamples).
#include <QFileInfo>
#include <QMetaObject>

#include "ui/workspace/live_processor.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {

void Workspace::ReplayOpened(const MountingError& calibration, PoseSource source,
                             std::shared_ptr<const PoseBuffer> given, double speed) {
  if (opened_ == nullptr) return;
  std::shared_ptr<hardware::ReplaySource> from;
  if (!opened_samples_released_) {
    from = std::make_shared<hardware::LogReplaySource>(opened_);
  } else if (opened_source_ != nullptr) {
    from = opened_source_;
  } else {
    WithReplaySource([=] { ReplayOpened(calibration, source, given, speed); });
    return;
  }
  ReconstructionOptions options;
  options.calibration = calibration;
  options.pose.source = source;
  shown_calibration_ = calibration;
  shown_given_ = given;
  replaying_ = true;
  replay_loaded_ = true;
  LiveProcessor* p = processor_;
  QMetaObject::invokeMethod(
      p, [p, from, options, speed, given] { p->StartReplay(from, options, speed, given); });
  SetShownPoseSource(source);
}

void Workspace::WithReplaySource(std::function<void()> then) {
  if (!opened_samples_released_ || opened_source_ != nullptr) {
    then();
    return;
  }
  if (opened_->decode.measurements) {
    // An imported bag is decoded in one piece (docs/ros-bags.md), and its
    // intensities are mapped from the samples once it has replayed: whole.
    WithOpenedSamples(std::move(then));
    return;
  }
  auto source = std::make_shared<std::unique_ptr<hardware::SessionReplaySource>>();
  const std::string path = session_dir_.toStdString();
  const std::shared_ptr<hardware::Recording> light = opened_;
  RunJob(
      tr("Opening %1").arg(session_dir_),
      [this, source, path](std::atomic<bool>* cancel) -> QString {
        const QString what = tr("Opening %1").arg(QString::fromStdString(path));
        const Status s =
            hardware::SessionReplaySource::Open(path, JobProgress(what, cancel), source.get());
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, source, light, then] {
        if (opened_ != light) return;  // Another session (or a recording) since.
        opened_source_ = std::move(*source);
        then();
      },
      OpenRefused(session_dir_));
}

void Workspace::OpenSessionForReplay(const QString& dir, double speed) {
  PageBeside(dir);
  const PoseSource source = pose_source_;
  const std::string path = dir.toStdString();
  auto replay = std::make_shared<std::unique_ptr<hardware::SessionReplaySource>>();
  auto light = std::make_shared<hardware::Recording>();
  auto circle = std::make_shared<OpenedCircle>();
  RunJob(
      QStringLiteral("Opening %1").arg(dir),
      [this, replay, light, circle, path](std::atomic<bool>* cancel) -> QString {
        const QString what = QStringLiteral("Opening %1").arg(QString::fromStdString(path));
        const Status s =
            hardware::SessionReplaySource::Open(path, JobProgress(what, cancel), replay.get());
        if (!s.ok()) return QString::fromStdString(s.message());
        const hardware::SessionReplaySource& r = **replay;
        light->name = r.name();
        light->session_dir = path;
        light->geometry = r.geometry();
        light->start = r.start_pose();
        light->decode = r.decode();
        // Is it a calibration drive? The circle of the EKF over the wheel
        // and IMU records.
        *circle = FindCircle(r.motion(), r.start_pose(), r.geometry());
        return QString();
      },
      [this, replay, light, circle, dir, source, speed] {
        TakeOpened(light, *circle, dir, /*samples_released=*/true);
        opened_source_ = std::move(*replay);
        sfm_summary_.clear();
        ReplayOpened(light->decode.meta.calibration, source, nullptr, speed);
        emit sessionChanged(dir);
      },
      OpenRefused(dir));
}

void Workspace::SetReplaySpeed(double speed) {
  replay_speed_ = speed;
  LiveProcessor* p = processor_;
  QMetaObject::invokeMethod(p, [p, speed] { p->SetReplaySpeed(speed); });
}

void Workspace::SetReplayPaused(bool paused) {
  LiveProcessor* p = processor_;
  QMetaObject::invokeMethod(p, [p, paused] { p->SetReplayPaused(paused); });
}

void Workspace::SeekReplay(double position_s) {
  if (opened_ != nullptr && !recording_ && !replay_loaded_) {
    // Nothing to seek in (the session opened streamed, or its replay let
    // its samples go when it finished): replay again, then seek.
    WithReplaySource([this, position_s] {
      ReplayOpened(shown_calibration_, shown_pose_source_, shown_given_, replay_speed_);
      SeekReplay(position_s);
    });
    return;
  }
  if (opened_ != nullptr && !recording_)
    replaying_ = true;  // After the end: replays on from the target.
  ++seeks_sent_;
  LiveProcessor* p = processor_;
  QMetaObject::invokeMethod(p, [p, position_s] { p->SeekReplay(position_s); });
}

}  // namespace sweepscan::ui
