// The desktop app without its widgets: the current session, the robot link
// on an I/O thread, the live pipeline on a processing thread, the built-in
// simulated robot, replay, the pose source of opened sessions (EKF,
// odometry, SfM), and the long jobs (open, SfM, export) on worker threads
// with progress and cancel. Every button of the app calls a method
// here, and the UI tests drive the same methods (docs/architecture.md, "ui/").
//
// Threads (docs/architecture.md):
//   GUI thread         this object, every widget and VTK object;
//   I/O thread         RobotConnection (socket or serial port, session recorder,
//                      telemetry decoding); decoded records go to
//   processing thread  LiveProcessor (EKF, deskew, assembly), which posts
//                      immutable LiveBatches to mailbox(); the view drains it
//                      on a GUI timer;
//   robot thread       the built-in simulator's agent and devices (SimRobot);
//   job threads        open a session, SfM poses, export a cloud (one at
//                      a time).
//
// Lives on the GUI thread; not thread-safe.
#ifndef SWEEPSCAN_UI_WORKSPACE_WORKSPACE_H_
#define SWEEPSCAN_UI_WORKSPACE_WORKSPACE_H_

#include <QElapsedTimer>
#include <QObject>
#include <QString>
#include <QThread>
#include <atomic>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "core/calibration/passes.h"
#include "core/calibration/workflow.h"
#include "core/cloud/reconstruct.h"
#include "core/evaluation/evaluation.h"
#include "core/io/ros/import.h"
#include "core/sim/world.h"
#include "hardware/station/direct_device.h"
#include "hardware/station/drive_script.h"
#include "hardware/station/recording.h"
#include "hardware/station/replay_source.h"
#include "hardware/station/robot_connection.h"
#include "ui/view/point_values.h"
#include "ui/workspace/live_batch.h"

class QImage;
class QTimer;

namespace sweepscan::ui {

class LiveProcessor;
class SimRobot;

enum class LinkKind { kSimulator = 0, kTcp = 1, kSerial = 2 };

struct ConnectOptions {
  LinkKind kind = LinkKind::kSimulator;
  QString scenario_path;                       // kSimulator: the world (resources/scenarios/*.json)
  QString host = QStringLiteral("127.0.0.1");  // kTcp
  int port = 5600;
  QString key_file;     // kTcp: the robot's pre-shared key
  QString serial_port;  // kSerial: e.g. /dev/ttyUSB0
  int baud = 921600;
  // A robot's geometry is not sent over the link; a real robot uses the
  // paper's geometry unless settings say otherwise. The simulator's comes
  // from its scenario.
  RobotGeometry geometry;
};

// A pose source as the operator reads it: "EKF", "Odometry", "SfM", "Truth".
QString PoseSourceTitle(PoseSource source);

struct DriveLimits {
  double v_max_mps = 0.3;
  double w_max_radps = 0.8;
};

class Workspace : public QObject {
  Q_OBJECT
 public:
  explicit Workspace(QObject* parent = nullptr);
  ~Workspace() override;

  // ---- Robot link ---------------------------------------------------------
  // Starts the built-in simulator if asked, then connects (asynchronously:
  // watch linkStateChanged / authenticationFailed). False with a message for
  // options that cannot work (missing key file, bad scenario).
  bool Connect(const ConnectOptions& options, QString* error);
  void Disconnect();
  bool link_open() const { return connection_ != nullptr; }
  bool authenticated() const { return authenticated_; }
  hardware::LinkHealth::State link_state() const { return health_.state; }
  const hardware::LinkHealth& health() const { return health_; }
  const ConnectOptions& connect_options() const { return connect_options_; }
  SimRobot* sim_robot() const { return sim_.get(); }  // Null unless on the simulator.

  // ---- Bench check ------------------------------------------------------
  // A lidar or IMU plugged straight into this computer (DirectDevice, on the
  // I/O thread): opens `port`, asks an X4 for its info and health and
  // starts it scanning, listens for `seconds`, and reports what arrived and
  // the decoders' error counters (deviceCheckFinished).
  void CheckDevice(hardware::DirectDevice::Kind kind, const QString& port, double seconds = 3.0);

  // ---- Driving ------------------------------------------------------------
  // Drive commands, clamped to limits(); the agent applies its own limits too.
  void Drive(double v_mps, double w_radps);
  void StopMotion();
  void EmergencyStop();  // Sent at once, also while unauthenticated; latched by the agent.
  void ClearEmergencyStop();
  void SetLidarMotor(bool on);  // Remembered: applied again on every (re)connection.
  bool lidar_motor() const { return lidar_on_; }
  void SetLimits(const DriveLimits& limits) { limits_ = limits; }
  const DriveLimits& limits() const { return limits_; }
  Twist2d commanded() const { return commanded_; }
  // Scripted drive: the segments' (v, w) sent as drive commands at 10 Hz,
  // exactly what the keyboard sends. CirclePath is the calibration drive.
  // Aborted, with a message, when the robot stops on its own (a watchdog
  // trip, this process frozen or the computer asleep: hardware/station/drive_script.h).
  // `what` names the drive for the operator ("the circle").
  void StartScriptedDrive(const std::vector<sim::DriveSegment>& path, const QString& what);
  void AbortScriptedDrive();
  bool scripted_drive_running() const { return script_timer_ != nullptr; }
  const QString& scripted_drive_name() const { return script_name_; }
  static std::vector<sim::DriveSegment> CirclePath(double radius_m, double speed_mps, double turns);

  // ---- Sessions -----------------------------------------------------------
  // Records from now on into a new session folder under sessions_root()
  // (crash-safe from its first second; the cloud restarts with it). A
  // session being opened (or read again) is cancelled: it would replace the
  // live cloud when it finished.
  bool StartRecording(QString* error);
  bool StopRecording(QString* error);
  bool recording() const { return recording_; }
  // The session shown: being recorded, recorded and not saved yet, or opened.
  QString session_dir() const { return session_dir_; }
  bool unsaved() const { return unsaved_; }  // A new recording not saved elsewhere yet.
  // Saves the current session as `dir` (must not exist), which becomes the
  // current session (sessionRenamed). A new recording's folder is moved
  // before this returns when `dir` is on the same disk; otherwise, and for
  // an opened session, the folder is copied on the job thread (progress,
  // Cancel; a failure is a failed job) and unsaved() holds until it is done.
  // Not while recording. workspace_save.cc.
  bool SaveSessionAs(const QString& dir, QString* error);
  // A Save Session As copy is running (job_name() names it).
  bool saving() const { return job_running() && job_what_ == save_job_; }
  QString job_name() const { return job_running() ? job_what_ : QString(); }
  // Forgets the current session and cloud (the recording folder stays on
  // disk); a connected robot's live preview shows again.
  void NewSession();
  // Opens a session folder on a job thread (progress, cancel), then replays
  // it at `speed` (0 = as fast as possible). A corrupt session is refused:
  // jobFinished(false, "where and why").
  // At full speed with the EKF's or the wheels' poses, a session whose
  // frames.bin is above stream_open_above_bytes() (default 32 MiB, about 4 M
  // lidar samples) is streamed instead (workspace_stream.cc): its cloud is
  // built in two passes over the file, the samples never held, and it opens
  // as a replayed large session is left (its samples released). At a replay
  // speed such a session is replayed as it is read (workspace_replay.cc).
  void OpenSession(const QString& dir, double speed = 0.0);
  void set_stream_open_above_bytes(qint64 bytes) { stream_open_above_bytes_ = bytes; }
  qint64 stream_open_above_bytes() const { return stream_open_above_bytes_; }
  const hardware::Recording* recording_opened() const { return opened_.get(); }
  // Replay of the opened session.
  void SetReplaySpeed(double speed);
  void SetReplayPaused(bool paused);
  void SeekReplay(double position_s);
  bool replaying() const { return replaying_; }
  // Writes the cloud shown (LAS, PLY or PCD by extension; cloud_export.h)
  // on a job thread.
  void ExportCloud(const QString& path);
  // The same at once, on the calling thread (--export-cloud before quitting).
  Status ExportCloudNow(const QString& path, std::string* note);

  // ---- ROS recordings (docs/ros-bags.md; workspace_import.cc) -----------
  // Reads what a bag holds (topics, types, counts, tf) on a job thread: an
  // MCAP without a summary is read whole. rosBagInspected(bag, ok, why);
  // then ros_bag_summary() holds it.
  void InspectRosBag(const QString& bag);
  const io::RosBagSummary& ros_bag_summary() const { return ros_bag_summary_; }
  // Imports the bag into a new session folder on a job thread (progress,
  // cancel: nothing is left behind), then opens it at `speed` like any
  // session; the import's warnings go to message().
  void ImportRosRecording(const QString& bag, const QString& session_dir,
                          const io::RosImportOptions& options, double speed = 0.0);
  // Imports go under sessions_root() by default, beside the recordings.
  // The intensities of a session's cloud, one per point of `cloud` in order
  // (the sample each came from, by scan and beam; NaN for none), quantised as
  // the view keeps them; false when `log`'s lidar reports none (the X4) or
  // `cancel` was set. Any thread. An opened session's are mapped on a worker
  // thread once its replay finishes (intensitiesMapped): ~0.9 s for 10 M
  // points that the GUI thread used to spend at the end of the replay.
  static bool MapIntensities(const SensorLog& log, const CloudSnapshotRef& cloud,
                             const std::atomic<bool>& cancel, QuantizedValues* out);
  void CancelJob();
  bool job_running() const { return job_thread_ != nullptr; }

  // ---- Pose source of opened sessions (docs/desktop-app.md) -------------
  // Which poses place an opened session's scans: the EKF (wheels + IMU, the
  // default), wheel odometry alone, or SfM: the EKF's poses corrected by
  // the planes the scans cross (core/sfm/wheeled.h), the same as
  // `sweepscan-cli reconstruct --pose-source ekf|odometry|sfm`. SfM is a
  // batch method over the whole log, so it runs on a job thread after the
  // log is loaded (progress, cancel) and the session then replays with the
  // SfM poses given. Live clouds and recordings always use the EKF (SfM
  // needs the whole log); the choice applies to sessions opened, and
  // setting it re-processes the one shown. When SfM fails (or is
  // cancelled, or another job runs) the cloud keeps its poses and the
  // choice goes back to them (poseSourceChanged); a session opened with
  // SfM that SfM cannot place opens with the EKF instead and says why
  // (poseSourceFailed). kTruth is not offered (no truth in a session).
  void SetPoseSource(PoseSource source);
  PoseSource pose_source() const { return pose_source_; }
  // What the cloud shown is made with (kEkf for live clouds).
  PoseSource shown_pose_source() const { return shown_pose_source_; }
  // The SfM result of the cloud shown ("182 scans placed by 23 planes"),
  // empty for other sources.
  QString sfm_summary() const { return sfm_summary_; }

  // Where new recordings go (default: ~/sweepscan-sessions, QSettings).
  QString sessions_root() const { return sessions_root_; }
  void set_sessions_root(const QString& root) { sessions_root_ = root; }

  // ---- Calibration of the opened session (docs/calibration.md) ----------
  // Picks -> mounting error on a job thread (CalibrateFromPicks, the same
  // workflow as `sweepscan-cli calibrate --pairs`): poses by the EKF, the
  // target region from the picks, the pairs solve or, with refine, the
  // refined-corners solve (the board `board_thickness_m` thick) with the
  // raw picks as baseline, combined with the room's planes unless
  // `board_only` (PickCalibrationOptions::combine_with_planes). Progress per
  // LM iteration (calibrationIteration), cancel through CancelJob().
  void Calibrate(const std::vector<PickPair>& picks, bool refine, double board_thickness_m,
                 bool board_only = false);
  // The automatic mode (no picks): planes seen in both passes, the same
  // SolveAutomatic as `sweepscan-cli calibrate --auto` with EKF poses. The
  // result arrives like a picks solve (calibrationFinished), with method
  // "auto-planes" and no pair checks.
  void CalibrateAutomatic();
  // The last successful result (null before one).
  const PickCalibrationResult* calibration_result() const { return calibration_.get(); }
  // Loads a calibration file as the current result (as if solved), so that
  // it can be shown, used for the robot or saved again.
  bool LoadCalibration(const QString& path, QString* error);

  // ---- The passes of a circle drive (calibration panel, step 2) ---------
  // Opening a session also fits the circle of its drive (EKF poses,
  // FitCircleDrive); circle_drive() says whether it is one, and why not.
  bool circle_drive() const { return opened_circle_.ok; }
  QString circle_drive_note() const { return opened_circle_.note; }
  Eigen::Vector2d circle_centre() const { return opened_circle_.circle.centre; }
  // Labels every point of the cloud shown pass A (near side) or B (far side)
  // on a job thread (LabelCirclePasses); passesSplit(ok, message) when done.
  // The labels stay valid when the same session is shown under another
  // calibration (the same points in the same order).
  void SplitPasses();
  const std::vector<float>& pass_labels() const { return pass_labels_; }
  // The same quantised for the view (CloudView::SetPointValues), on the job
  // thread: null when there are none.
  std::shared_ptr<const QuantizedValues> pass_values() const { return pass_values_; }
  // Replays the opened session under `calibration` (as fast as possible):
  // the before / after view.
  void ShowCalibrated(const MountingError& calibration);
  const MountingError& shown_calibration() const { return shown_calibration_; }
  // The robot's mounting calibration: the live cloud is assembled under it
  // and every new recording carries it in meta.json (MainWindow keeps it in
  // QSettings). Takes effect at the next connection or recording.
  void SetRobotCalibration(const MountingError& calibration) { robot_calibration_ = calibration; }
  const MountingError& robot_calibration() const { return robot_calibration_; }

  // ---- Evaluation of the cloud shown (Miao et al. 2022, section 5) -------
  // Outlier removal, planes with deviation histograms, density (Eq. 18-19)
  // and room dimensions on a job thread, the same EvaluateCloud as
  // `sweepscan-cli evaluate`. The previous result is kept for before / after.
  // Evaluations describe one cloud: another session, a live cloud (Connect,
  // New Session, a recording) forgets both; another pose source or
  // calibration of the same session forgets the current one and keeps it as
  // the previous (evaluationCleared). A result for a cloud replaced while it
  // was computed is dropped (evaluationFinished(false)).
  void Evaluate();
  const CloudEvaluation* evaluation() const { return evaluation_.get(); }
  const CloudEvaluation* previous_evaluation() const { return previous_evaluation_.get(); }
  // The session the evaluation was made on (empty for a live cloud).
  QString evaluated_session() const { return evaluated_session_; }
  // What the evaluated cloud was assembled under.
  const MountingError& evaluated_calibration() const { return evaluated_calibration_; }
  // The deviation map of the last evaluation: each point of the cloud shown
  // (in order) in mm from its fitted plane, NaN off every plane
  // (DeviationMapMm with a 5 cm band), computed with the evaluation.
  const std::vector<float>& deviation_map() const { return deviation_map_; }
  std::shared_ptr<const QuantizedValues> deviation_values() const {
    return deviation_values_;
  }  // for the view
  // The report of the last evaluation (and the one before) as JSON
  // (docs/evaluation-report.md), written atomically to `path`.
  bool SaveEvaluationReport(const QString& path, const QString& image_name, QString* error) const;
  // The same on a job thread, with `view` (a screenshot of the view) written
  // beside it as PNG (same name, .png): Export report. A failure is a failed
  // job (jobFinished), which the main window shows as an error.
  void ExportEvaluationReport(const QString& path, const QImage& view);

  // ---- The cloud ----------------------------------------------------------
  BatchMailbox* mailbox() { return &mailbox_; }
  // Every point assembled since the last reset, as chunks to decode later
  // (CloudSnapshotRef::Flatten, on a job): taken on the processing thread,
  // which costs the GUI only the wait for its current batch and a copy of
  // the open chunk, not the unpacking or page-in of millions of points.
  CloudSnapshotRef CloudSnapshot() const;
  // Its number of points (without decoding them).
  size_t CloudSize() const;
  // Points and scans assembled, as of the last batch the view took.
  size_t point_count() const { return point_count_; }
  size_t scan_count() const { return scan_count_; }
  void NoteBatch(size_t points, size_t scans) {
    point_count_ = points;
    scan_count_ = scans;
  }

 signals:
  void linkStateChanged(int state);  // A LinkHealth::State.
  void authenticatedChanged(bool authenticated);
  void authenticationFailed(const QString& reason);
  void healthUpdated();
  // The authenticated link was lost (open: `text` says why) or is back
  // after `seconds` (`text`: what was resent, how the clock tie moved).
  void linkOutage(bool open, double seconds, const QString& text);
  void recordingChanged(bool recording);
  void sessionChanged(const QString& dir);
  // Save Session As: the same session and cloud, now in `dir`. What was
  // measured on the cloud (planes, passes, intensities, the camera) stays.
  void sessionRenamed(const QString& dir);
  void replayProgress(double position_s, double length_s);
  void replayFinished();
  // The opened session's intensities (MapIntensities), for View > Colour by
  // > Intensity; only for lidars that report them.
  void intensitiesMapped(std::shared_ptr<const sweepscan::ui::QuantizedValues> values);
  void jobProgress(const QString& what, double fraction);
  void jobFinished(const QString& what, bool ok, const QString& message);
  void message(const QString& text);  // For the status bar.
  void emergencyStopped();            // EmergencyStop() was called (any control).
  // Writing the recording failed (disk full, a pulled drive) or closing it
  // did: recording has stopped; `message` says why and what is kept.
  void recordingFailed(const QString& message);
  void deviceCheckFinished(bool ok, const QString& report);
  void calibrationIteration(int iteration, double cost);
  void calibrationFinished(bool ok, const QString& message);
  void evaluationFinished(bool ok, const QString& message);
  // evaluation() no longer describes the cloud shown and is null now.
  void evaluationCleared();
  void passesSplit(bool ok, const QString& message);
  void poseSourceChanged(int source);       // The choice (a PoseSource).
  void shownPoseSourceChanged(int source);  // A new cloud is on its way, made with this.
  void poseSourceFailed(const QString& message);
  void rosBagInspected(const QString& bag, bool ok, const QString& message);

 private:
  bool PrepareLink(const ConnectOptions& options, hardware::RobotConnectionOptions* link,
                   QString* error);
  void ResetCloud(const Pose2d& start, const RobotGeometry& geometry);
  // Replays the opened session under `calibration` with `source`'s poses
  // (`given` for SfM) at `speed`.
  void ReplayOpened(const MountingError& calibration, PoseSource source,
                    std::shared_ptr<const PoseBuffer> given, double speed);
  // Re-processes the opened session under `calibration` with `source`: a
  // job computing the SfM poses first, or at once for the EKF / odometry.
  // `same_points`: the new cloud has the old one's points in the same order
  // (another calibration only), so the pass labels stay.
  void Reprocess(const MountingError& calibration, PoseSource source, bool same_points);
  void SetShownPoseSource(PoseSource source);
  // Memory: a replayed session above kKeepSamplesAtMost lidar samples, or a
  // streamed one, keeps none of its records (the samples take 24 bytes
  // each, more than the cloud store's 14 a point; the wheel and IMU records
  // ~20 MB an hour of drive). A replay then reads the session as it goes
  // (WithReplaySource); what needs every scan (SfM, a calibration) opens
  // the session whole in a job first, then calls `then`.
  static constexpr size_t kKeepSamplesAtMost = 4'000'000;
  void ReleaseOpenedSamples();
  // Stops a recording that another action ends (disconnect, a new or opened
  // session); a failure to close it is said (recordingFailed).
  void StopRecordingOrSay();
  // Large sessions opened with the EKF's or the wheels' poses are read as
  // they are processed (StreamsSession): at full speed by the streamed open
  // (workspace_stream.cc), at a replay speed by OpenSessionForReplay
  // (workspace_replay.cc); either way the samples are never held whole.
  bool StreamsSession(const QString& dir, PoseSource source) const;
  void OpenSessionStreamed(const QString& dir);
  void OpenSessionForReplay(const QString& dir, double speed);
  void WithOpenedSamples(std::function<void()> then);
  // Calls `then` once the opened session can be replayed: at once when its
  // samples are held or its SessionReplaySource is loaded, otherwise after
  // a job that loads the source (its wheel and IMU records).
  void WithReplaySource(std::function<void()> then);
  // The cloud store pages beside `folder` (a session, the sessions folder).
  void PageBeside(const QString& folder);
  // What was computed on the cloud shown (calibration, evaluation, pass
  // labels, deviations) when another session or a live cloud replaces it
  // (workspace_analysis.cc).
  void ForgetSessionResults();
  // The evaluation when the cloud changes; `keep_as_previous`: the same
  // session under other poses or another calibration, kept for before / after.
  void ForgetEvaluation(bool keep_as_previous);
  // `refused`: said first, a line of its own, when the work fails (not
  // when cancelled): what failed in plain words before the reader's ones.
  // A job with a `refused` reads a session folder (OpenRefused): opening it,
  // or reading it again; StartRecording cancels those.
  void RunJob(const QString& what, std::function<QString(std::atomic<bool>*)> work,
              std::function<void()> on_success, const QString& refused = QString());
  // RunJob's `refused` for opening session folder `dir`.
  static QString OpenRefused(const QString& dir);
  // A job's progress callback (any thread): the fraction to the status bar
  // at most every 2 % and at the end; false once the job is cancelled.
  std::function<bool(double)> JobProgress(const QString& what, std::atomic<bool>* cancel);
  void OnScriptTick();
  void InvokeOnConnection(std::function<void(hardware::RobotConnection*)> call);

  io::RosBagSummary ros_bag_summary_;
  BatchMailbox mailbox_;
  QThread io_thread_;
  QThread processing_thread_;
  LiveProcessor* processor_ = nullptr;               // Lives on processing_thread_.
  hardware::RobotConnection* connection_ = nullptr;  // Lives on io_thread_.
  std::unique_ptr<SimRobot> sim_;
  ConnectOptions connect_options_;
  hardware::LinkHealth health_;
  bool authenticated_ = false;
  DriveLimits limits_;
  bool lidar_on_ = true;
  // Whether decoded telemetry reaches the cloud: on while connected, off
  // once a recording stops or a session is opened (the cloud is then the
  // session's), on again with New Session. I/O thread reads it.
  std::shared_ptr<std::atomic<bool>> live_feed_ = std::make_shared<std::atomic<bool>>(true);
  // Switches live_feed_; off, on the I/O thread (when connected), so that no
  // batch read before lands in the processor after what the caller posts next.
  void SetLiveFeed(bool on);
  Twist2d commanded_;
  RobotGeometry live_geometry_;
  Pose2d live_start_;
  SessionMeta live_meta_;

  QTimer* script_timer_ = nullptr;
  QString script_name_;
  std::optional<hardware::DriveScript> script_;

  bool recording_ = false;
  bool unsaved_ = false;
  QString session_dir_;
  QString sessions_root_;
  std::shared_ptr<hardware::Recording> opened_;
  bool opened_samples_released_ = false;
  // The opened session's records read as it replays, once a replay of it
  // without its samples needed them (kept for the next replay or seek).
  std::shared_ptr<hardware::SessionReplaySource> opened_source_;
  // The processor holds a replay of the opened session (a seek goes on in
  // it): false after a streamed open, or once the replay let go.
  bool replay_loaded_ = false;
  std::shared_ptr<const PoseBuffer> shown_given_;  // SfM's poses of the cloud shown.
  double replay_speed_ = 0.0;
  bool replaying_ = false;
  quint64 seeks_sent_ = 0;  // SeekReplay calls sent to the processor.
  std::shared_ptr<PickCalibrationResult> calibration_;
  MountingError shown_calibration_;
  PoseSource pose_source_ = PoseSource::kEkf;
  PoseSource shown_pose_source_ = PoseSource::kEkf;
  QString sfm_summary_;
  MountingError robot_calibration_;
  struct OpenedCircle {
    bool ok = false;
    QString note;
    CircleDrive circle;
    std::shared_ptr<const PoseBuffer> poses;
  };
  OpenedCircle opened_circle_;
  qint64 stream_open_above_bytes_ = qint64{32} << 20;
  // The circle of an opened session's EKF poses (is it a calibration drive?).
  // `ekf_poses`: the recording's EKF poses when already estimated.
  static OpenedCircle FindCircle(const SensorLog& log, const Pose2d& start,
                                 const RobotGeometry& geometry,
                                 std::shared_ptr<const PoseBuffer> ekf_poses = nullptr);
  // What opening a session sets, whichever way it was opened.
  void TakeOpened(std::shared_ptr<hardware::Recording> recording, const OpenedCircle& circle,
                  const QString& dir, bool samples_released);
  // False (and calibrationFinished(false, why)) when the session shown is no
  // longer the one a calibration job started on (`session`, its
  // session_generation_ then).
  bool StillTheSession(uint64_t session);
  uint64_t session_generation_ = 0;  // Bumped by ForgetSessionResults.
  std::vector<float> pass_labels_;
  std::vector<float> deviation_map_;
  std::shared_ptr<const QuantizedValues> pass_values_, deviation_values_;
  std::shared_ptr<CloudEvaluation> evaluation_, previous_evaluation_;
  MountingError evaluated_calibration_, previous_calibration_;
  QString evaluated_session_;
  // Bumped by every cloud that replaces the one shown (ForgetEvaluation):
  // an evaluation started on an older cloud is dropped when it ends.
  uint64_t cloud_generation_ = 0;
  // A calibration waits for the opened session's samples to be read again
  // (WithOpenedSamples): a failure of that job is the calibration's.
  bool calibration_waiting_ = false;
  size_t point_count_ = 0;
  size_t scan_count_ = 0;

  // The intensity mapping's worker (workspace_import.cc): started as a
  // replay finishes, stopped by the next session; a result from a stopped
  // one (its generation past) is dropped.
  void StartIntensityMapping();
  void StopIntensityMapping();
  std::unique_ptr<std::thread> intensity_thread_;
  std::atomic<bool> intensity_cancel_{false};
  uint64_t intensity_generation_ = 0;

  std::unique_ptr<std::thread> job_thread_;
  QString save_job_;  // The last Save Session As copy's job name.
  QString job_what_;  // the running (or last) job's name, as its progress shows it
  std::atomic<bool> job_cancel_{false};
  bool job_reads_session_ = false;  // RunJob's `refused` was given
  QString job_cancel_reason_;       // said for a cancel not the operator's
};

}  // namespace sweepscan::ui

#endif  // SWEEPSCAN_UI_WORKSPACE_WORKSPACE_H_
