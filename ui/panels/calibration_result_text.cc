// The calibration panel's result text (calibration_result_text.h).
#include "ui/panels/calibration_result_text.h"

#include <QCoreApplication>

namespace sweepscan::ui {

namespace {

// The panel's translation context, so that its texts keep their
// translations where they moved from.
struct Text {
  Q_DECLARE_TR_FUNCTIONS(CalibrationPanel)
};

}  // namespace

QString CalibrationResultText(const PickCalibrationResult& r, const QString& message) {
  const CalibrationSummary& s = r.summary;
  auto angle = [](double v, double sigma) {
    return sigma >= 0
               ? QStringLiteral("%1 ± %2").arg(v * 1e3, 0, 'f', 2).arg(sigma * 1e3, 0, 'f', 2)
               : QStringLiteral("%1").arg(v * 1e3, 0, 'f', 2);
  };
  const bool automatic = s.method == "auto-planes";
  const QString ghost =
      automatic ? Text::tr("point-to-plane RMS: %1 mm -> %2 mm, %3 points on %4 planes")
                      .arg(s.initial_rms_m * 1e3, 0, 'f', 1)
                      .arg(s.final_rms_m * 1e3, 0, 'f', 2)
                      .arg(s.residual_blocks)
                      .arg(s.planes)
                : Text::tr("the ghost (RMS pair distance): %1 mm -> %2 mm, %3 pairs, %4 sightings")
                      .arg(s.initial_rms_m * 1e3, 0, 'f', 1)
                      .arg(s.final_rms_m * 1e3, 0, 'f', 2)
                      .arg(s.residual_blocks)
                      .arg(static_cast<int>(r.sightings.windows.size()));
  QString text = Text::tr("<b>%1</b> (%2)<br>alpha %3 mrad<br>beta %4 mrad<br>gamma %5 mrad<br>%6")
                     .arg(s.converged ? Text::tr("Converged") : Text::tr("Not converged"))
                     .arg(QString::fromStdString(s.method))
                     .arg(angle(s.angles.alpha, s.sigma_rad[0]))
                     .arg(angle(s.angles.beta, s.sigma_rad[1]))
                     .arg(angle(s.angles.gamma, s.sigma_rad[2]))
                     .arg(s.method == "file" ? message.toHtmlEscaped() : ghost);
  // Workspace::Calibrate and CalibrateAutomatic solve on the EKF's poses
  // smoothed over the drive (as `sweepscan-cli calibrate`), while the view
  // shows the forward filter's cloud: say which the angles rest on.
  if (s.method != "file") text += Text::tr("<br>poses: the EKF's, smoothed over the drive");
  // Refined picks: how the board's edges held (docs/calibration.md, "Mixed
  // returns"): lines a sample short or long at an edge (mixed returns) are
  // kept and their share widens the sigma above; lines further off are
  // rejected.
  if (s.rejected_edge_points >= 0) {
    text += Text::tr("<br>board edges: %1 edge points kept, %2 rejected, %3 a sample off (mixed returns), "
               "%4 mixed returns recognised beyond the lines")
                .arg(s.edge_points)
                .arg(s.rejected_edge_points)
                .arg(s.shifted_edge_points)
                .arg(s.mixed_edge_samples);
  }
  // Combined with the room's planes: both parts, so that the operator sees
  // what each said and how well they agreed.
  if (r.has_board_alone) {
    const CalibrationSummary& b = r.board_alone;
    const CalibrationSummary& p = r.planes;
    text += Text::tr("<br>combined with the room's planes (agreement chi² %1 of 3 angles):"
               "<br>&nbsp;&nbsp;board alone: %2, %3, %4 mrad"
               "<br>&nbsp;&nbsp;planes alone: %5, %6, %7 mrad")
                .arg(r.planes_chi2, 0, 'f', 1)
                .arg(angle(b.angles.alpha, b.sigma_rad[0]))
                .arg(angle(b.angles.beta, b.sigma_rad[1]))
                .arg(angle(b.angles.gamma, b.sigma_rad[2]))
                .arg(angle(p.angles.alpha, p.sigma_rad[0]))
                .arg(angle(p.angles.beta, p.sigma_rad[1]))
                .arg(angle(p.angles.gamma, p.sigma_rad[2]));
  }
  if (r.has_baseline) {
    text += Text::tr("<br>raw picks alone (the paper's method): %1 mm -> %2 mm")
                .arg(r.baseline.initial_rms_m * 1e3, 0, 'f', 1)
                .arg(r.baseline.final_rms_m * 1e3, 0, 'f', 1);
  }
  for (const std::string& w : s.warnings)
    text += Text::tr("<br>warning: %1").arg(QString::fromStdString(w));
  return text;
}

}  // namespace sweepscan::ui
