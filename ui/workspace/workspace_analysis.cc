// Workspace, by concern: the calibration (picks, automatic, the pass
// split, loading a calibration file, showing the calibrated cloud) and the
// evaluation, each a job on the job thread.
#include <QBuffer>
#include <QDateTime>
#include <QDir>
#include <QFileInfo>
#include <QImage>
#include <QMetaObject>

#include "core/calibration/automatic.h"
#include "core/calibration/calibration_file.h"
#include "core/common/checked_file.h"
#include "core/evaluation/report.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

// The deviation map's band: a point farther than this from every fitted
// plane is on none (furniture, the robot's own clutter) and shows grey.
constexpr double kDeviationBandM = 0.05;

// The report's JSON (docs/evaluation-report.md).
std::string ReportJson(const QString& session, const QString& image_name,
                       const CloudEvaluation& evaluation, const MountingError& calibration,
                       const CloudEvaluation* previous, const MountingError& previous_calibration) {
  auto angles = [](const MountingError& c) {
    return nlohmann::json{{"alpha", c.alpha}, {"beta", c.beta}, {"gamma", c.gamma}};
  };
  nlohmann::json report = {
      {"format", "sweepscan-evaluation-report"},
      {"version", 1},
      {"session", session.toStdString()},
      {"created", QDateTime::currentDateTimeUtc().toString(Qt::ISODateWithMs).toStdString()},
      {"image", image_name.toStdString()},
      {"calibration_rad", angles(calibration)},
      {"evaluation", EvaluationToJson(evaluation)}};
  if (previous != nullptr) {
    report["previous"] = {{"calibration_rad", angles(previous_calibration)},
                          {"evaluation", EvaluationToJson(*previous)}};
  }
  return report.dump(2) + "\n";
}

}  // namespace

namespace {

// LM iterations to the GUI thread; the cancel flag back to the solver.
class JobCalibrationProgress : public CalibrationProgress {
 public:
  JobCalibrationProgress(Workspace* workspace, std::atomic<bool>* cancel)
      : workspace_(workspace), cancel_(cancel) {}
  bool OnIteration(int iteration, const MountingError&, double cost) override {
    Workspace* w = workspace_;
    QMetaObject::invokeMethod(
        w, [w, iteration, cost] { emit w->calibrationIteration(iteration, cost); });
    return !*cancel_;
  }

 private:
  Workspace* workspace_;
  std::atomic<bool>* cancel_;
};

// The poses both calibration buttons solve on, as `sweepscan-cli calibrate`
// makes them: the uncalibrated recording's EKF poses smoothed over the drive,
// the filter taking the IMU's measured tilt noise if above the data sheet's;
// an IMU far noisier than its data sheet is refused first, since it bends
// the EKF's tilt and so beta and gamma, unseen by the residuals (workflow.h).
Status CalibrationPoses(const hardware::Recording& recording, ReconstructionResult* poses) {
  const Status tilt = CheckImuTiltNoise(recording.log);
  if (!tilt.ok()) return tilt;
  ReconstructionOptions options;
  options.pose.smooth = true;
  UseMeasuredTiltNoise(recording.log, &options.pose.ekf);
  return hardware::ReconstructRecording(recording, options, poses);
}

}  // namespace

void Workspace::Calibrate(const std::vector<PickPair>& picks, bool refine,
                          double board_thickness_m, bool board_only) {
  if (opened_ == nullptr) {
    emit calibrationFinished(false, QStringLiteral("Open a calibration drive's session first."));
    return;
  }
  if (opened_samples_released_) {
    calibration_waiting_ = true;
    WithOpenedSamples([=] {
      calibration_waiting_ = false;
      Calibrate(picks, refine, board_thickness_m, board_only);
    });
    return;
  }
  std::shared_ptr<const hardware::Recording> recording = opened_;
  auto result = std::make_shared<PickCalibrationResult>();
  auto error = std::make_shared<QString>();
  RunJob(
      tr("Calibrating"),
      [this, recording, picks, refine, board_thickness_m, board_only, result,
       error](std::atomic<bool>* cancel) -> QString {
        // The picks snap to samples under these poses.
        ReconstructionResult poses;
        Status s = CalibrationPoses(*recording, &poses);
        if (!s.ok()) return *error = QString::fromStdString(s.message());
        if (*cancel) return QString();
        const SampleStore store(recording->log, poses.poses);
        JobCalibrationProgress progress(this, cancel);
        PickCalibrationOptions o;
        o.refine = refine;
        o.solver.board_thickness_m = board_thickness_m;
        o.path_scale_from_planes = true;  // as the CLI on EKF poses (workflow.h)
        o.combine_with_planes = !board_only;
        o.solver.progress = &progress;
        s = CalibrateFromPicks(store, recording->geometry, picks, o, result.get());
        if (!s.ok()) return *error = QString::fromStdString(s.message());
        return QString();
      },
      [this, result, session = session_generation_] {
        if (!StillTheSession(session)) return;
        calibration_ = result;
        const MountingError& a = result->summary.angles;
        emit calibrationFinished(true, tr("alpha %1, beta %2, gamma %3 mrad")
                                           .arg(a.alpha * 1e3, 0, 'f', 2)
                                           .arg(a.beta * 1e3, 0, 'f', 2)
                                           .arg(a.gamma * 1e3, 0, 'f', 2));
      });
}

bool Workspace::StillTheSession(uint64_t session) {
  // A calibration started on one session and finished after another was
  // opened (or New Session, Connect) would be shown, and offered to the
  // robot, as this one's.
  if (session == session_generation_) return true;
  emit calibrationFinished(false, tr("The session changed while it was calibrated: calibrate the "
                                     "session shown again."));
  return false;
}

void Workspace::CalibrateAutomatic() {
  if (opened_ == nullptr) {
    emit calibrationFinished(false, QStringLiteral("Open a calibration drive's session first."));
    return;
  }
  if (opened_samples_released_) {
    calibration_waiting_ = true;
    WithOpenedSamples([this] {
      calibration_waiting_ = false;
      CalibrateAutomatic();
    });
    return;
  }
  std::shared_ptr<const hardware::Recording> recording = opened_;
  auto result = std::make_shared<PickCalibrationResult>();
  RunJob(
      tr("Calibrating"),
      [this, recording, result](std::atomic<bool>* cancel) -> QString {
        // As `sweepscan-cli calibrate SESSION --auto`: SolveAutomatic with
        // its default options.
        ReconstructionResult poses;
        Status s = CalibrationPoses(*recording, &poses);
        if (!s.ok()) return QString::fromStdString(s.message());
        if (*cancel) return QString();
        const SampleStore store(recording->log, poses.poses);
        JobCalibrationProgress progress(this, cancel);
        AutoCalibrationOptions o;
        o.solver.progress = &progress;
        s = SolveAutomatic(store, recording->geometry, {}, o, &result->summary);
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, result, session = session_generation_] {
        if (!StillTheSession(session)) return;
        calibration_ = result;
        emit calibrationFinished(true, QString());
      });
}

bool Workspace::LoadCalibration(const QString& path, QString* error) {
  auto result = std::make_shared<PickCalibrationResult>();
  const Status s = LoadCalibrationFile(path.toStdString(), &result->summary.angles);
  if (!s.ok()) {
    *error = QString::fromStdString(s.message());
    return false;
  }
  result->summary.method = "file";
  result->summary.converged = true;
  result->summary.initial = result->summary.angles;
  calibration_ = result;
  emit calibrationFinished(true, tr("loaded %1").arg(path));
  return true;
}

void Workspace::SplitPasses() {
  if (opened_ == nullptr || !opened_circle_.ok) {
    emit passesSplit(false, opened_ == nullptr ? tr("Open a calibration drive's session first.")
                                               : tr("Not a circle drive: %1")
                                                     .arg(opened_circle_.note));
    return;
  }
  auto snapshot = std::make_shared<const CloudSnapshotRef>(CloudSnapshot());
  auto labels = std::make_shared<std::vector<float>>();
  auto quantized = std::make_shared<QuantizedValues>();
  const OpenedCircle circle = opened_circle_;
  RunJob(
      tr("Splitting the passes"),
      [snapshot, labels, quantized, circle](std::atomic<bool>*) -> QString {
        // A chunk at a time: the cloud is not decoded whole (32 bytes a point).
        labels->reserve(snapshot->size());
        size_t hint = 0;
        std::vector<uint8_t> pass;
        snapshot->ForEachChunk([&](const CloudPoint* points, size_t n) {
          pass.resize(n);
          LabelCirclePasses(points, n, *circle.poses, circle.circle, &hint, pass.data());
          for (const uint8_t p : pass) {
            labels->push_back(p == kNoPass ? std::numeric_limits<float>::quiet_NaN()
                                           : static_cast<float>(p));
          }
          return true;
        });
        *quantized = Quantize(*labels);  // as the view keeps them, off the GUI thread
        return QString();
      },
      [this, labels, quantized, generation = cloud_generation_] {
        // Labels of the points of a cloud no longer shown (another session,
        // Connect, New Session while it ran) would colour the next one.
        if (generation != cloud_generation_) {
          emit passesSplit(false, tr("The cloud shown changed while its passes were split."));
          return;
        }
        pass_labels_ = std::move(*labels);
        pass_values_ = quantized;
        size_t a = 0, b = 0;
        for (float v : pass_labels_) (v == 0.0f ? a : b) += (v == 0.0f || v == 1.0f) ? 1 : 0;
        emit passesSplit(true, tr("pass A (near side) %L1 points, pass B (far side) %L2 points")
                                   .arg(a)
                                   .arg(b));
      });
  // A refused job (another task running) reports through jobFinished.
}

void Workspace::Evaluate() {
  auto points = std::make_shared<std::vector<Eigen::Vector3f>>();
  auto snapshot = std::make_shared<const CloudSnapshotRef>(CloudSnapshot());
  if (snapshot->size() == 0) {
    // The workspace holds one session's cloud (or the live one); a
    // project's sessions are drawn as layers of the view, not evaluated.
    emit evaluationFinished(
        false, tr("No session's cloud to evaluate. The evaluation works on a single session's "
                  "cloud: open or record a session. A project's clouds are not evaluated "
                  "together: open one of its sessions (File > Open Session) to evaluate it."));
    return;
  }
  auto result = std::make_shared<CloudEvaluation>();
  auto deviations = std::make_shared<std::vector<float>>();
  auto quantized = std::make_shared<QuantizedValues>();
  const MountingError shown = shown_calibration_;
  const uint64_t generation = cloud_generation_;
  RunJob(
      tr("Evaluating"),
      [this, snapshot, points, result, deviations,
       quantized](std::atomic<bool>* cancel) -> QString {
        // Positions only (12 bytes a point), a chunk decoded at a time.
        points->reserve(snapshot->size());
        const bool read = snapshot->ForEachChunk([&](const CloudPoint* p, size_t n) {
          for (size_t i = 0; i < n; ++i) points->emplace_back(p[i].x, p[i].y, p[i].z);
          return !*cancel;
        });
        if (!read) return tr("Cancelled.");
        // Stage and fraction to the status bar (at most ~50 calls a second,
        // from the evaluation's threads); Cancel stops it within 100 ms.
        EvaluationControl control;
        control.cancel = cancel;
        control.progress = [this](const EvaluationProgress& p) {
          // The evaluation's "done" is not the job's: the deviation map of
          // every point comes after it.
          const bool done = p.stage == EvaluationStage::kDone;
          const QString what =
              done ? tr("Evaluating: deviation map")
                   : tr("Evaluating: %1").arg(QString::fromLatin1(EvaluationStageName(p.stage)));
          const double f = done ? -1.0 : p.fraction;
          QMetaObject::invokeMethod(this, [this, what, f] { emit jobProgress(what, f); });
          return true;
        };
        const Status s = EvaluateCloud(*points, EvaluationOptions(), result.get(), control);
        if (!s.ok()) return QString::fromStdString(s.message());
        // The deviation map over every point shown (outliers included: the
        // operator sees them grey or far off white).
        *deviations = DeviationMapMm(*points, result->planes, kDeviationBandM);
        *quantized = Quantize(*deviations);  // as the view keeps them, off the GUI thread
        return QString();
      },
      [this, result, shown, deviations, quantized, generation] {
        if (generation != cloud_generation_) {
          // Another session, live cloud, pose source or calibration since:
          // these figures describe a cloud no longer shown.
          emit evaluationFinished(
              false, tr("The cloud shown changed while it was evaluated: evaluate it again."));
          return;
        }
        // A re-evaluation of the same cloud: the last result is "before".
        // (After another pose source or calibration ForgetEvaluation has
        // made it the previous already.)
        if (evaluation_ != nullptr) {
          previous_evaluation_ = evaluation_;
          previous_calibration_ = evaluated_calibration_;
        }
        evaluation_ = result;
        deviation_map_ = std::move(*deviations);
        deviation_values_ = quantized;
        evaluated_calibration_ = shown;
        evaluated_session_ = session_dir_;
        emit evaluationFinished(true, QString());
      });
}

void Workspace::ForgetEvaluation(bool keep_as_previous) {
  ++cloud_generation_;
  deviation_map_.clear();
  deviation_values_.reset();
  if (keep_as_previous && evaluation_ != nullptr) {
    previous_evaluation_ = evaluation_;
    previous_calibration_ = evaluated_calibration_;
  } else if (!keep_as_previous) {
    previous_evaluation_.reset();
  }
  const bool had = evaluation_ != nullptr;
  evaluation_.reset();
  if (!keep_as_previous) evaluated_session_.clear();
  if (had) emit evaluationCleared();
}

void Workspace::ForgetSessionResults() {
  ++session_generation_;
  ForgetEvaluation(/*keep_as_previous=*/false);
  pass_labels_.clear();
  pass_values_.reset();
  calibration_.reset();
  calibration_waiting_ = false;
  opened_circle_ = OpenedCircle();
}

bool Workspace::SaveEvaluationReport(const QString& path, const QString& image_name,
                                     QString* error) const {
  if (evaluation_ == nullptr) {
    *error = tr("Evaluate first.");
    return false;
  }
  const Status s = WriteFileChecked(
      path.toStdString(),
      ReportJson(evaluated_session_, image_name, *evaluation_, evaluated_calibration_,
                 previous_evaluation_.get(), previous_calibration_));
  if (!s.ok()) {
    *error = QString::fromStdString(s.message());
    return false;
  }
  return true;
}

void Workspace::ExportEvaluationReport(const QString& path, const QImage& view) {
  const QString what = tr("Exporting the report %1").arg(path);
  if (evaluation_ == nullptr) {
    emit jobFinished(what, false, tr("Evaluate the cloud shown first."));
    return;
  }
  const QFileInfo info(path);
  const QString image_name = info.completeBaseName() + QStringLiteral(".png");
  const std::string image_path = info.dir().filePath(image_name).toStdString();
  // The figures as they are now (the cloud may change while the files are
  // written); the writing, and the image's encoding, on the job thread.
  const std::string json =
      ReportJson(evaluated_session_, image_name, *evaluation_, evaluated_calibration_,
                 previous_evaluation_.get(), previous_calibration_);
  const std::string file = path.toStdString();
  RunJob(
      what,
      [view, image_path, json, file](std::atomic<bool>*) -> QString {
        QByteArray png;
        QBuffer buffer(&png);
        buffer.open(QIODevice::WriteOnly);
        if (view.isNull() || !view.save(&buffer, "PNG")) {
          return tr("%1: cannot encode the view's image").arg(QString::fromStdString(image_path));
        }
        // Each file complete or absent (core/common/checked_file.h).
        Status s = WriteFileChecked(image_path, png.toStdString());
        if (s.ok()) s = WriteFileChecked(file, json);
        return s.ok() ? QString() : QString::fromStdString(s.message());
      },
      [this, path] { emit message(tr("Exported the evaluation report to %1").arg(path)); });
}

void Workspace::ShowCalibrated(const MountingError& calibration) {
  if (opened_ == nullptr) return;
  // With the poses shown: SfM places the scans under the calibration too,
  // so its poses are computed again (a job). The same points in the same
  // order: the pass labels stay valid.
  Reprocess(calibration, shown_pose_source_, true);
}


}  // namespace sweepscan::ui
