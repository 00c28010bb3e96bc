// The workspace's core: construction, recording and sessions, replay,
// reprocessing and the job thread. By concern, the rest is in
// workspace_link.cc (the robot link),
// workspace_drive.cc (driving, scripted drives, the bench check),
// workspace_analysis.cc (calibration and evaluation jobs) and
// workspace_import.cc (ROS recordings).
#include "ui/workspace/workspace.h"

#include <QDateTime>
#include <QDir>
#include <QFileInfo>
#include <QMetaObject>
#include <QStandardPaths>
#include <QStringList>
#include <QTimer>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/calibration/automatic.h"
#include "core/calibration/calibration_file.h"
#include "core/cloud/cloud_io.h"
#include "core/common/checked_file.h"
#include "core/common/json_reader.h"
#include "core/evaluation/report.h"
#include "core/pose/pose_estimator.h"
#include "core/scenario/scenario.h"
#include "core/sfm/wheeled.h"
#include "hardware/link/qt_transport.h"
#include "ui/workspace/background_priority.h"
#include "ui/workspace/cloud_export.h"
#include "ui/workspace/live_processor.h"
#include "ui/workspace/sim_robot.h"
#include "ui/workspace/thread_call.h"

namespace sweepscan::ui {
namespace {

// "Recording stopped: 20261201-075115-420.sweepscan in /root/sweepscan-sessions":
// the session's name first, which a status bar cut at its right keeps.
QString RecordingMessage(const QString& what, const QString& dir) {
  const QFileInfo info(dir);
  return QStringLiteral("%1 %2 in %3").arg(what, info.fileName(), info.absolutePath());
}

// The job that computes SfM poses for the opened session (its failures
// give the pose source choice back to the cloud shown).
QString SfmJobName() { return QObject::tr("Structure from motion"); }

// The SfM poses of a loaded session exactly as `sweepscan-cli reconstruct
// --pose-source sfm` computes them (app/cli_session.cc): the EKF as the
// motion prior from the session's start, planes found on the way (no
// designated ones), the wheeled scanner's default options.
// `cancel` stops it within a frame of tracking or an iteration of the
// refinement (SequenceOptions::cancel).
Status ComputeSfmPoses(const hardware::Recording& recording, const MountingError& calibration,
                       const std::atomic<bool>* cancel, PoseBuffer* poses, QString* summary) {
  sfm::WheeledSfmResult result;
  sfm::WheeledSfmOptions options;
  options.sequence.cancel = cancel;
  const Status s = sfm::WheeledSfmFromLog(recording.log, recording.geometry, calibration,
                                          recording.start, PoseSource::kEkf, sfm::SequenceInit(),
                                          options, &result);
  if (!s.ok()) return s;
  *poses = std::move(result.poses);
  const sfm::SequenceResult& seq = result.sequence;
  *summary = QObject::tr("SfM: %1 scans placed, %2 of %3 lines on %4 planes")
                 .arg(seq.poses.size())
                 .arg(seq.lines_assigned)
                 .arg(seq.lines_total)
                 .arg(seq.planes.size());
  return Status::Ok();
}

}  // namespace

QString PoseSourceTitle(PoseSource source) {
  switch (source) {
    case PoseSource::kEkf:
      return QObject::tr("EKF");
    case PoseSource::kOdometry:
      return QObject::tr("Odometry");
    case PoseSource::kTruth:
      return QObject::tr("Truth");
    case PoseSource::kSfm:
      return QObject::tr("SfM");
  }
  return QString();
}

Workspace::Workspace(QObject* parent) : QObject(parent) {
  io_thread_.setObjectName(QStringLiteral("io"));
  processing_thread_.setObjectName(QStringLiteral("processing"));
  sessions_root_ = QDir::homePath() + QStringLiteral("/sweepscan-sessions");
  processor_ = new LiveProcessor(&mailbox_);
  processor_->moveToThread(&processing_thread_);
  connect(&processing_thread_, &QThread::finished, processor_, &QObject::deleteLater);
  connect(processor_, &LiveProcessor::replayProgress, this, &Workspace::replayProgress,
          Qt::QueuedConnection);
  connect(processor_, &LiveProcessor::replayFailed, this, &Workspace::message,
          Qt::QueuedConnection);
  connect(
      processor_, &LiveProcessor::replayFinished, this,
      [this](quint64 seeks) {
        // A seek sent since (the slider dropped as the replay ended) goes
        // on: its own finish comes later. Letting the samples go now would
        // stop it halfway.
        if (seeks < seeks_sent_) return;
        replaying_ = false;
        emit replayFinished();
        StartIntensityMapping();  // keeps the samples it reads
        ReleaseOpenedSamples();
      },
      Qt::QueuedConnection);
  // A calibration's failures (bad picks, solver) and cancels arrive as a
  // failed job; the calibration panel listens to calibrationFinished only.
  connect(this, &Workspace::sessionChanged, this, [this] { StopIntensityMapping(); });
  // Save As moves the session with its cloud: its evaluation now names it there.
  connect(this, &Workspace::sessionRenamed, this,
          [this](const QString& dir) { evaluated_session_ = dir; });
  connect(this, &Workspace::jobFinished, this,
          [this](const QString& what, bool ok, const QString& message) {
            if (what == tr("Calibrating") && !ok) emit calibrationFinished(false, message);
            // The session read again for a calibration (its samples were let
            // go) failed or was cancelled: the calibration never started,
            // and the panel waiting for it must hear so.
            if (calibration_waiting_ && !ok && !job_running()) {
              calibration_waiting_ = false;
              emit calibrationFinished(false, message);
            }
            if (what == tr("Evaluating") && !ok) emit evaluationFinished(false, message);
            // SfM (or the re-opening of a let-go session's samples or
            // replay source that comes before a re-processing) failed, was
            // cancelled or refused: the cloud keeps its poses, and the
            // choice shows them again. A pose source differs from the shown
            // one only while such a chain runs.
            if (!ok && !job_running() && pose_source_ != shown_pose_source_) {
              pose_source_ = shown_pose_source_;
              emit poseSourceChanged(static_cast<int>(pose_source_));
            }
          });
  io_thread_.start();
  processing_thread_.start();
}

Workspace::~Workspace() {
  StopIntensityMapping();
  CancelJob();
  if (job_thread_ != nullptr) job_thread_->join();
  Disconnect();
  processing_thread_.quit();
  processing_thread_.wait();
  io_thread_.quit();
  io_thread_.wait();
}

// ---------------------------------------------------------------------------
// Sessions

void Workspace::ResetCloud(const Pose2d& start, const RobotGeometry& geometry) {
  ReconstructionOptions options;
  options.pose.initial_pose = start;
  options.calibration = robot_calibration_;
  LiveProcessor* p = processor_;
  QMetaObject::invokeMethod(p, [p, options, geometry] {
    p->StopReplay();
    p->Reset(options, geometry);
  });
  replay_loaded_ = false;
  point_count_ = 0;
  scan_count_ = 0;
  SetShownPoseSource(PoseSource::kEkf);
}

bool Workspace::StartRecording(QString* error) {
  if (connection_ == nullptr) {
    *error = QStringLiteral("Connect to a robot (or the simulator) first.");
    return false;
  }
  if (recording_) return true;
  if (job_running() && job_reads_session_) {
    // Its end (TakeOpened) would replace the live cloud, and stop this
    // recording, with the session it read.
    job_cancel_reason_ = tr("Cancelled: a recording started, and its live cloud replaces the "
                            "session that was being opened.");
    CancelJob();
  }
  if (!QDir().mkpath(sessions_root_)) {
    *error = QStringLiteral("%1: cannot create the sessions folder").arg(sessions_root_);
    return false;
  }
  const QString name =
      QDateTime::currentDateTimeUtc().toString(QStringLiteral("yyyyMMdd-HHmmss-zzz"));
  const QString dir = sessions_root_ + QLatin1Char('/') + name + QStringLiteral(".sweepscan");
  PageBeside(dir);
  // The recorder, the live decoder and the cloud restart at the same frame:
  // what is shown is exactly what the session holds. The reset is posted
  // from the I/O thread, after every batch of earlier frames and before any
  // batch of the session's.
  bool ok = false;
  QString start_error;
  const SessionMeta meta = live_meta_;
  hardware::RobotConnection* connection = connection_;
  LiveProcessor* processor = processor_;
  ReconstructionOptions options;
  options.pose.initial_pose = live_start_;
  options.calibration = robot_calibration_;
  const RobotGeometry geometry = live_geometry_;
  std::shared_ptr<std::atomic<bool>> feed = live_feed_;
  QMetaObject::invokeMethod(
      connection,
      [&] {
        ok = connection->StartRecording(dir, meta, &start_error);
        if (!ok) return;
        *feed = true;
        QMetaObject::invokeMethod(processor, [processor, options, geometry] {
          processor->StopReplay();
          processor->Reset(options, geometry);
        });
      },
      Qt::BlockingQueuedConnection);
  point_count_ = 0;
  scan_count_ = 0;
  if (!ok) {
    *error = start_error;
    return false;
  }
  recording_ = true;
  unsaved_ = true;
  session_dir_ = dir;
  ForgetSessionResults();
  opened_.reset();
  opened_samples_released_ = false;
  opened_source_.reset();
  replay_loaded_ = false;
  SetShownPoseSource(PoseSource::kEkf);  // Live: always the EKF.
  emit recordingChanged(true);
  emit sessionChanged(dir);
  emit message(RecordingMessage(QStringLiteral("Recording to"), dir));
  return true;
}

bool Workspace::StopRecording(QString* error) {
  if (!recording_) return true;
  Status closed;
  hardware::RobotConnection* connection = connection_;
  if (connection != nullptr) {
    // The cloud stops with the session (same frame on the I/O thread), so
    // that it stays equal to what the folder holds.
    std::shared_ptr<std::atomic<bool>> feed = live_feed_;
    QMetaObject::invokeMethod(
        connection,
        [&] {
          closed = connection->StopRecording();
          *feed = false;
        },
        Qt::BlockingQueuedConnection);
  }
  recording_ = false;
  QMetaObject::invokeMethod(processor_, [p = processor_] { p->Finish(); });
  emit recordingChanged(false);
  if (!closed.ok()) {
    *error = QString::fromStdString(closed.message());
    return false;
  }
  emit message(RecordingMessage(QStringLiteral("Recording stopped:"), session_dir_));
  return true;
}

void Workspace::StopRecordingOrSay() {
  if (!recording_) return;
  QString error;
  if (!StopRecording(&error)) emit recordingFailed(error);
}

void Workspace::NewSession() {
  StopRecordingOrSay();
  session_dir_.clear();
  unsaved_ = false;
  ForgetSessionResults();
  opened_.reset();
  opened_samples_released_ = false;
  opened_source_.reset();
  replay_loaded_ = false;
  replaying_ = false;
  ResetCloud(live_start_, live_geometry_);
  if (connection_ != nullptr) SetLiveFeed(true);  // after the reset, posted above
  emit sessionChanged(QString());
}

void Workspace::SetLiveFeed(bool on) {
  std::shared_ptr<std::atomic<bool>> feed = live_feed_;
  if (on || connection_ == nullptr) {
    *feed = on;
    return;
  }
  // Not recording (TakeOpened, StopRecording's own switch is on the I/O
  // thread too): the I/O thread is between frames, so this is quick.
  QMetaObject::invokeMethod(
      connection_, [feed] { *feed = false; }, Qt::BlockingQueuedConnection);
}

void Workspace::OpenSession(const QString& dir, double speed) {
  if (StreamsSession(dir, pose_source_)) {
    if (speed == 0.0) {
      OpenSessionStreamed(dir);
    } else {
      OpenSessionForReplay(dir, speed);
    }
    return;
  }
  PageBeside(dir);
  auto recording = std::make_shared<hardware::Recording>();
  auto circle = std::make_shared<OpenedCircle>();
  // SfM: its poses, what it found, or why it could not place the scans.
  const PoseSource source = pose_source_;
  auto sfm_poses = std::make_shared<PoseBuffer>();
  auto sfm_summary = std::make_shared<QString>();
  auto sfm_error = std::make_shared<QString>();
  const std::string path = dir.toStdString();
  RunJob(
      QStringLiteral("Opening %1").arg(dir),
      [this, recording, circle, path, source, sfm_poses, sfm_summary,
       sfm_error](std::atomic<bool>* cancel) -> QString {
        // A cancel stops the decoder.
        const QString what = QStringLiteral("Opening %1").arg(QString::fromStdString(path));
        const Status s = hardware::OpenRecording(path, recording.get(), JobProgress(what, cancel));
        if (!s.ok()) return QString::fromStdString(s.message());
        *circle = FindCircle(recording->log, recording->start, recording->geometry);
        if (source == PoseSource::kSfm && !*cancel) {
          // The batch over the whole log, now that it is loaded (a cancel
          // stops it within a frame or a refinement iteration).
          const QString name = QFileInfo(QString::fromStdString(path)).fileName();
          QMetaObject::invokeMethod(
              this, [this, name] { emit jobProgress(tr("%1: %2").arg(SfmJobName(), name), -1.0); });
          const Status sfm = ComputeSfmPoses(*recording, recording->decode.meta.calibration, cancel,
                                             sfm_poses.get(), sfm_summary.get());
          if (!sfm.ok()) *sfm_error = QString::fromStdString(sfm.message());
        }
        return QString();
      },
      [this, recording, circle, dir, speed, source, sfm_poses, sfm_summary, sfm_error] {
        TakeOpened(recording, *circle, dir, /*samples_released=*/false);
        PoseSource shown = source;
        if (source == PoseSource::kSfm && !sfm_error->isEmpty()) {
          // The session is fine; only SfM cannot place it (too few planes,
          // say): open it with the EKF and say why.
          shown = PoseSource::kEkf;
          if (pose_source_ == PoseSource::kSfm) {
            pose_source_ = shown;
            emit poseSourceChanged(static_cast<int>(shown));
          }
          emit poseSourceFailed(
              tr("SfM cannot place %1: %2. Showing the EKF poses.").arg(dir, *sfm_error));
        }
        sfm_summary_ = shown == PoseSource::kSfm ? *sfm_summary : QString();
        ReplayOpened(recording->decode.meta.calibration, shown,
                     shown == PoseSource::kSfm ? sfm_poses : nullptr, speed);
        emit sessionChanged(dir);
      },
      OpenRefused(dir));
}

Workspace::OpenedCircle Workspace::FindCircle(const SensorLog& log, const Pose2d& start,
                                              const RobotGeometry& geometry,
                                              std::shared_ptr<const PoseBuffer> ekf_poses) {
  // Is it a calibration drive? The EKF poses (a few ms per minute of
  // drive; Calibrate smooths them, which moves the circle by mm) and the
  // circle through them.
  OpenedCircle circle;
  std::shared_ptr<const PoseBuffer> poses = std::move(ekf_poses);
  if (!poses) {
    PoseEstimatorOptions pose;
    pose.initial_pose = start;
    PoseEstimator estimated = EstimatePoses(log, pose, geometry);
    poses =
        std::make_shared<const PoseBuffer>(std::move(*estimated.mutable_poses()));  // not copied
  }
  std::string why;
  circle.ok = FitCircleDrive(*poses, &circle.circle, &why);
  circle.note = circle.ok ? tr("a circle drive: radius %1 m").arg(circle.circle.radius_m, 0, 'f', 2)
                          : QString::fromStdString(why);
  // Kept for splitting a circle drive's passes (SplitPasses); any other
  // drive's poses go (a pose a wheel or IMU record: ~200 MB for the
  // 5.7-hour drive of docs/performance.md).
  if (circle.ok) circle.poses = poses;
  return circle;
}

void Workspace::TakeOpened(std::shared_ptr<hardware::Recording> recording, const OpenedCircle& circle,
                           const QString& dir, bool samples_released) {
  StopRecordingOrSay();  // (StartRecording cancels an opening: not expected)
  // A connected robot's live preview stops: the cloud is the session's alone.
  SetLiveFeed(false);
  // A damaged recording opens without its damaged records; say what was
  // lost (how many records and seconds, where). One cut off as it was
  // written opens with what was recorded before the cut, which a replay
  // that simply stops early would not tell.
  const FramesLoadReport& frames = recording->decode.frames;
  QStringList said;
  if (frames.damaged()) said << QString::fromStdString(frames.DamageSummary());
  if (frames.truncated_tail) {
    said << tr("the recording ends early: its last record was cut off as it was written (a crash "
               "or power loss?), and everything recorded before it is shown (%1 bytes left out: "
               "%2)")
                .arg(frames.tail_bytes_dropped)
                .arg(QString::fromStdString(frames.tail_reason));
  }
  if (!said.isEmpty()) emit message(tr("%1: %2").arg(dir, said.join(QStringLiteral("; "))));
  ForgetSessionResults();
  opened_ = std::move(recording);
  opened_samples_released_ = samples_released;
  opened_source_.reset();
  replay_loaded_ = false;
  opened_circle_ = circle;
  session_dir_ = dir;
  unsaved_ = false;
}

void Workspace::SetPoseSource(PoseSource source) {
  if (source == PoseSource::kTruth) source = PoseSource::kEkf;  // Sessions have no truth.
  if (opened_ == nullptr || recording_) {
    // Nothing opened to re-process: the next session opened uses it.
    if (source != pose_source_) {
      pose_source_ = source;
      emit poseSourceChanged(static_cast<int>(source));
    }
    return;
  }
  if (job_running()) {
    // One job at a time (and an opening session already chose its poses).
    emit poseSourceChanged(static_cast<int>(pose_source_));
    emit jobFinished(tr("Pose source"), false,
                     tr("%1 is still running: let it finish (or cancel it), then choose the pose "
                        "source again.")
                         .arg(job_what_));
    return;
  }
  const bool changed = source != pose_source_;
  pose_source_ = source;
  if (changed) emit poseSourceChanged(static_cast<int>(source));
  if (source != shown_pose_source_) Reprocess(shown_calibration_, source, false);
}

void Workspace::Reprocess(const MountingError& calibration, PoseSource source,
                          bool same_points) {
  if (opened_ == nullptr) return;
  if (opened_samples_released_) {
    // SfM needs every scan at once; the EKF and the wheels replay the
    // session as it is read.
    auto again = [this, calibration, source, same_points] {
      Reprocess(calibration, source, same_points);
    };
    if (source == PoseSource::kSfm) {
      WithOpenedSamples(again);
      return;
    }
    if (opened_source_ == nullptr) {
      WithReplaySource(again);
      return;
    }
  }
  // Deviations belong to the points they were measured on, pass labels to
  // the points in their order, the evaluation to the cloud; they go when the
  // new cloud comes (a failed SfM keeps the cloud and them). The evaluation
  // stays as the previous one: before / after a calibration or a pose source.
  auto forget = [this, same_points] {
    if (!same_points) {
      pass_labels_.clear();
      pass_values_.reset();
    }
    ForgetEvaluation(/*keep_as_previous=*/true);
  };
  if (source != PoseSource::kSfm) {
    forget();
    ReplayOpened(calibration, source, nullptr, 0.0);
    return;
  }
  std::shared_ptr<const hardware::Recording> recording = opened_;
  auto poses = std::make_shared<PoseBuffer>();
  auto summary = std::make_shared<QString>();
  RunJob(
      SfmJobName(),
      [recording, calibration, poses, summary](std::atomic<bool>* cancel) -> QString {
        const Status s = ComputeSfmPoses(*recording, calibration, cancel, poses.get(), summary.get());
        return s.ok() ? QString()
                      : tr("SfM cannot place this session: %1")
                            .arg(QString::fromStdString(s.message()));
      },
      [this, recording, calibration, poses, summary, forget] {
        if (opened_ != recording) return;  // Another session (or a recording) since.
        forget();
        sfm_summary_ = *summary;
        emit message(*summary);
        ReplayOpened(calibration, PoseSource::kSfm, poses, 0.0);
      });
}

void Workspace::SetShownPoseSource(PoseSource source) {
  if (source != PoseSource::kSfm) sfm_summary_.clear();
  shown_pose_source_ = source;
  emit shownPoseSourceChanged(static_cast<int>(source));
}

CloudSnapshotRef Workspace::CloudSnapshot() const {
  CloudSnapshotRef snapshot;
  LiveProcessor* p = processor_;
  QMetaObject::invokeMethod(
      p, [p, &snapshot] { snapshot = p->Snapshot(); }, Qt::BlockingQueuedConnection);
  return snapshot;
}

void Workspace::ExportCloud(const QString& path) {
  auto snapshot = std::make_shared<const CloudSnapshotRef>(CloudSnapshot());
  const size_t count = snapshot->size();
  const std::string file = path.toStdString();
  const std::string session = session_dir_.toStdString();
  const SessionMeta live = live_meta_;
  auto note = std::make_shared<std::string>();
  RunJob(
      QStringLiteral("Exporting %1").arg(path),
      [snapshot, file, session, live, note](std::atomic<bool>* cancel) -> QString {
        if (snapshot->size() == 0) return QStringLiteral("The cloud is empty: nothing to export.");
        // Streamed a chunk at a time (the cloud is not decoded whole; the
        // file appears whole or not at all).
        const Status s = ExportCloudFile(file, *snapshot, session, live, cancel, note.get());
        if (*cancel) return QStringLiteral("Cancelled.");
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, path, count, note] {
        QString said = QStringLiteral("Exported %1 points to %2").arg(count).arg(path);
        if (!note->empty()) said += QStringLiteral(" (%1)").arg(QString::fromStdString(*note));
        emit message(said);
      });
}

Status Workspace::ExportCloudNow(const QString& path, std::string* note) {
  return ExportCloudFile(path.toStdString(), CloudSnapshot(), session_dir_.toStdString(),
                         live_meta_, nullptr, note);
}

QString Workspace::OpenRefused(const QString& dir) {
  return tr("%1 cannot be opened; nothing in it was changed.").arg(QFileInfo(dir).fileName());
}

void Workspace::RunJob(const QString& what, std::function<QString(std::atomic<bool>*)> work,
                       std::function<void()> on_success, const QString& refused) {
  if (job_thread_ != nullptr) {
    // Name the task in the way, so the operator knows what to wait for.
    emit jobFinished(what, false,
                     tr("%1 is still running: let it finish (or cancel it), then try again.")
                         .arg(job_what_));
    return;
  }
  job_what_ = what;
  job_cancel_ = false;
  job_reads_session_ = !refused.isEmpty();
  job_cancel_reason_.clear();
  emit jobProgress(what, -1.0);  // Indeterminate until the job reports a fraction.
  job_thread_ = std::make_unique<std::thread>([this, what, work, on_success, refused] {
    LowerThisThreadsPriority();
    QString error = work(&job_cancel_);
    if (!error.isEmpty() && !refused.isEmpty()) error = refused + QStringLiteral("\n\n") + error;
    QMetaObject::invokeMethod(this, [this, what, error, on_success] {
      if (job_thread_ != nullptr) {
        job_thread_->join();
        job_thread_.reset();
      }
      if (job_cancel_) {
        emit jobFinished(what, false,
                         job_cancel_reason_.isEmpty() ? QStringLiteral("Cancelled.")
                                                      : job_cancel_reason_);
      } else if (!error.isEmpty()) {
        emit jobFinished(what, false, error);
      } else {
        on_success();
        emit jobFinished(what, true, QString());
      }
    });
  });
}

std::function<bool(double)> Workspace::JobProgress(const QString& what, std::atomic<bool>* cancel) {
  auto last = std::make_shared<double>(-1.0);
  return [this, what, cancel, last](double f) {
    if (f - *last >= 0.02 || (f >= 1.0 && *last < 1.0)) {
      *last = f;
      QMetaObject::invokeMethod(this, [this, what, f] { emit jobProgress(what, f); });
    }
    return !*cancel;
  };
}

void Workspace::CancelJob() {
  if (job_thread_ == nullptr) return;
  // Opening stops within a few milliseconds (the decoder polls the flag);
  // an export finishes its file and then drops the result.
  job_cancel_ = true;
}

}  // namespace sweepscan::ui
