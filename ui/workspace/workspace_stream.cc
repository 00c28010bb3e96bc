// Workspace's streamed open: a large session at full speed is not decoded
// whole and replayed, but read twice record by record
// (hardware/station/session_stream.h) on a job thread: pass 1 the wheel and
// IMU records and the poses, pass 2 each scan placed as it is decoded into
// the cloud store (PointChunks, paged above the memory budget). The cloud is
// the replay's point for point (both are Reconstruct's), without the
// decoded samples (24 bytes each) ever in memory, and the decode does not
// compete with the view for the processing thread.
//
// The session then is as a replayed large session is left: its samples
// released (ReleaseOpenedSamples). A seek or another calibration replays it
// as it reads it (workspace_replay.cc, WithReplaySource); what needs every
// scan (SfM, a calibration) opens it whole first (WithOpenedSamples).
#include <QFileInfo>
#include <QMetaObject>

#include "core/cloud/cloud.h"
#include "core/session/session.h"
#include "hardware/station/session_stream.h"
#include "ui/workspace/live_processor.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {

bool Workspace::StreamsSession(const QString& dir, PoseSource source) const {
  // SfM needs every scan at once; an imported bag (its records decoded
  // together, docs/ros-bags.md) keeps its intensities from the samples.
  if (source != PoseSource::kEkf && source != PoseSource::kOdometry) return false;
  const QFileInfo frames(dir + QStringLiteral("/") + QString::fromLatin1(kSessionFramesFile));
  if (!frames.isFile() || frames.size() <= stream_open_above_bytes_) return false;
  SessionMeta meta;
  const std::string meta_path = (dir + QStringLiteral("/") + QString::fromLatin1(kSessionMetaFile)).toStdString();
  return ReadSessionMeta(meta_path, &meta).ok() && meta.content.empty();
}

void Workspace::OpenSessionStreamed(const QString& dir) {
  PageBeside(dir);
  const PoseSource source = pose_source_;
  const std::string path = dir.toStdString();
  auto stream = std::make_shared<hardware::SessionCloudStream>();
  auto light = std::make_shared<hardware::Recording>();
  auto circle = std::make_shared<OpenedCircle>();
  auto cloud = std::make_shared<std::unique_ptr<PointChunks>>();
  auto options = std::make_shared<ReconstructionOptions>();
  auto poses = std::make_shared<std::shared_ptr<const PoseBuffer>>();
  RunJob(
      QStringLiteral("Opening %1").arg(dir),
      [this, stream, light, circle, cloud, options, poses, source,
       path](std::atomic<bool>* cancel) -> QString {
        const QString what = QStringLiteral("Opening %1").arg(QString::fromStdString(path));
        // The first pass (the wheels and IMU decoded, the EKF) is about a
        // third of the work, the second (the lidar decoded, the points
        // placed) the rest.
        auto progress = [this, what, cancel](double from, double share) {
          auto last = std::make_shared<double>(-1.0);
          return [this, what, cancel, from, share, last](double f) {
            const double at = from + share * f;
            if (at - *last >= 0.02 || f >= 1.0) {
              *last = at;
              QMetaObject::invokeMethod(this, [this, what, at] { emit jobProgress(what, at); });
            }
            return !*cancel;
          };
        };
        SessionMeta meta;
        Status s = ReadSessionMeta(path + "/" + kSessionMetaFile, &meta);
        if (!s.ok()) return QString::fromStdString(s.message());
        options->pose.source = source;
        options->calibration = meta.calibration;
        options->pose.initial_pose = SessionStartPose(meta);
        stream->set_keep_motion(true);
        s = stream->EstimatePoses(path, hardware::DefaultSessionFramesOptions(), *options, nullptr, progress(0.0, 0.35));
        if (!s.ok()) return QString::fromStdString(s.message());
        // The wheel and IMU records, for the calibration circle's check
        // below (with the wheels' poses it runs the EKF on them).
        light->log = stream->TakeMotion();
        light->session_dir = path;
        light->geometry = stream->decode().meta.geometry;
        light->start = options->pose.initial_pose;
        light->name = "session " + path;
        auto chunks = std::make_unique<PointChunks>();
        s = stream->PlacePoints(
            [&chunks](const CloudPoint* p, size_t n) {
              for (size_t i = 0; i < n; ++i) chunks->Append(p[i]);
              return Status::Ok();
            },
            progress(0.35, 0.65));
        if (!s.ok()) return QString::fromStdString(s.message());
        light->decode = stream->decode();  // with pass 2's lidar counts
        *cloud = std::move(chunks);
        // The poses, moved (hundreds of MB on a long drive), not copied.
        *poses = std::make_shared<const PoseBuffer>(stream->TakePoses());
        // With the EKF, they are the ones FindCircle would estimate again
        // (the same log, options and start).
        *circle = FindCircle(light->log, light->start, light->geometry,
                             source == PoseSource::kEkf ? *poses : nullptr);
        // Then they go as ReleaseOpenedSamples lets a replayed session's
        // samples go (~20 MB an hour of drive: 115 MB for the 5.7-hour
        // drive of docs/performance.md): a replay reads them again
        // (WithReplaySource).
        light->log = SensorLog();
        return QString();
      },
      [this, stream, light, circle, cloud, options, poses, dir] {
        TakeOpened(light, *circle, dir, /*samples_released=*/true);
        shown_calibration_ = options->calibration;
        shown_given_ = nullptr;
        sfm_summary_.clear();
        replaying_ = true;  // until the processor's replayFinished
        LiveProcessor* p = processor_;
        const RobotGeometry geometry = light->geometry;
        const size_t scans = stream->scans();
        const ReconstructionOptions o = *options;
        // The poses moved on, not copied: this job's functions must not keep
        // the whole drive's poses (~200 MB for 5.7 hours) once adopted.
        QMetaObject::invokeMethod(p, [p, cloud, poses = std::move(*poses), o, geometry, scans] {
          p->AdoptCloud(cloud, poses, o, geometry, scans);
        });
        SetShownPoseSource(options->pose.source);
        emit sessionChanged(dir);
      },
      OpenRefused(dir));
}

}  // namespace sweepscan::ui
