// The target board's corners (board_fit.cc) and the refined-corners solve
// (refined_corners.cc).
//
// Refined corners. A raw pick is the sample nearest a corner, which in the
// two passes are different physical points (scans ~5 cm apart on the board
// at 0.2 m/s, samples 0.5 deg apart), so a pick pair is only a corner pair to
// within centimetres. FitBoardCorners replaces each pass's picks by the board
// corners fitted from that pass's samples (plane, then a rectangle through
// the scan lines' end points). The corners move with c, so the solve is an
// outer loop: fit corners under c_k, freeze each corner as a virtual lidar
// point attached to the pose of its nearest sample, solve for c_{k+1},
// re-fit, until c stops changing (see docs/calibration.md for why that fixed
// point is the answer). An upright board's side edges run along the vertical
// scan lines and are located only to the line spacing; a thin board turned
// 45 deg (a diamond) on two slow turns gives millimetre corners and mrad
// angles (measured there).
//
// Pure functions, no globals; may run on any thread.
#ifndef SWEEPSCAN_CORE_CALIBRATION_BOARD_FIT_H_
#define SWEEPSCAN_CORE_CALIBRATION_BOARD_FIT_H_

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <vector>

#include "core/calibration/pairs_solver.h"
#include "core/calibration/passes.h"
#include "core/calibration/samples.h"
#include "core/common/status.h"
#include "core/geometry/plane.h"
#include "core/robot/robot_model.h"

namespace sweepscan {

// Board corners of one pass, from its samples under a calibration.
struct BoardCorners {
  Plane plane;
  // Corners in the board plane, clockwise seen from the front (the side the
  // samples came from), starting with the corner whose direction from the
  // centre is nearest 112.5 deg (u = 0 deg, v = 90 deg): top-left, top-right,
  // bottom-right, bottom-left for an upright board; top, right, bottom, left
  // for a diamond. u = normalize(z x n), n oriented so that u points along +x
  // (or +y if the board faces x); v = n x u points up.
  std::array<Eigen::Vector3d, 4> corners;
  // Index (into the input) of the sample nearest each corner: the corner is
  // attached to that sample's pose when the solver re-projects it.
  std::array<size_t, 4> nearest;
  Eigen::Vector2d size_m = Eigen::Vector2d::Zero();  // fitted rectangle: width, height
  double rotation_rad = 0.0;  // of the rectangle's first axis from u, in [-pi/4, pi/4)
  double edge_rms_m = 0.0;    // RMS of the edge-point residuals
  size_t points = 0;          // inliers used
  size_t scans = 0;
  size_t edge_points = 0;  // scan-line end points (and side points) in the rectangle fit
  // End points kept though further from their edge than half a spacing
  // plus noise: lines a sample short or long at the edge (mixed returns at
  // the board's depth edges). Their share per edge widens the covariance.
  size_t shifted_edge_points = 0;
  // End points rejected as further from their edge than a whole spacing
  // plus noise, which one mixed return does not make (dropouts beside the
  // edge, foreign returns).
  size_t rejected_edge_points = 0;
  // Samples beyond a line's end found to be mixed returns (a blend of the
  // board's and the background's ranges, LineEndPoints): not board samples,
  // but they place the edge within their beam's footprint.
  size_t mixed_edge_samples = 0;
  // Covariance of the four corners (world x, y, z of corner 0, then 1, ...)
  // from the rectangle fit: the edge points' variances (s^2/12 and the
  // range noise) through the fit's five parameters (centre, half sizes,
  // rotation), scaled up by the fit's chi^2 per degree of freedom when
  // that exceeds 1. In the board plane only (rank 5).
  Eigen::Matrix<double, 12, 12> covariance = Eigen::Matrix<double, 12, 12>::Zero();
};

// Fits the board from the samples of one pass (points near the target, all
// from one sighting), re-projected under `calibration`:
//  1. a plane (RANSAC, 1 cm band, then least squares on the board's runs);
//  2. per scan line the longest gap-free run of in-plane samples, kept if it
//     reaches the height of the longest line's middle (a convex board
//     always does; a run on the sill below does not);
//  3. edge points: where each line's top and bottom sample's beam and,
//     beyond each, the next beam of that scan cross the plane; the edge
//     lies between the two, so the midpoint is unbiased with error
//     U(-s/2, s/2), s the local spacing (variance s^2/12). A board of
//     thickness T (`board_thickness_m`) is also hit on the edge faces that
//     face the beams (its bottom edges, for a lidar below it), which moves
//     the boundary between hits and misses T tan(incidence) beyond those
//     edges; each point carries that shift and the fit removes it on the
//     edges it applies to. A sample just beyond a line's end that lies
//     between the board and the background is a mixed return (a
//     triangulation lidar's blend at the depth edge): the edge is then
//     at its own beam's crossing (counted in mixed_edge_samples);
//  4. a rectangle (centre, rotation, width, height) by weighted least
//     squares of the edge points' offsets along their scan line from the
//     rectangle's boundary. For a fixed rotation this is linear; the
//     rotation is found by golden-section search. An edge within 20 deg of
//     the scan lines is crossed by none: it is then placed half a line
//     spacing beyond the outermost line (the upright board's side edges,
//     located only to the scan spacing; mount the target as a diamond).
//     End points further than s/2 + 6 mm from their edge (a line a sample
//     short or long: a mixed return) are kept and counted
//     (shifted_edge_points), and each edge's share of them enters the
//     covariance as a possible one-sided shift of that edge; those further
//     than s + 6 mm are rejected once (rejected_edge_points).
Status FitBoardCorners(const std::vector<LidarObservation>& samples, const RobotGeometry& geometry,
                       const MountingError& calibration, double board_thickness_m,
                       BoardCorners* corners);

// The target's samples on a circle drive: every valid sample whose world
// position under `calibration` lies in `region` (a box around the target,
// generous enough for uncalibrated ghosts), split into sightings by time
// gaps (FindPassWindows, gap_s, min_count). Sightings alternate near / far,
// so the even ones (k = 0, 2, ...) form pass 1 and the odd ones pass 2; with
// several turns each pass gathers the lines of all its sightings.
struct TargetSightings {
  std::vector<PassWindow> windows;           // all sightings, in time order
  std::vector<LidarObservation> passes[2];   // their samples, pass 1 and pass 2
};
TargetSightings CollectTargetSightings(const SampleStore& store, const RobotGeometry& geometry,
                                       const MountingError& calibration,
                                       const Eigen::AlignedBox3d& region, double gap_s = 1.0,
                                       size_t min_count = 20);

// RMS distance between the corners of two passes.
double CornerRms(const BoardCorners& a, const BoardCorners& b);

// Refined corners: the two passes' board samples (e.g. from
// SplitRegionIntoPasses via SampleStore) and the outer loop described above.
Status SolveRefinedCorners(const std::vector<LidarObservation>& pass1,
                           const std::vector<LidarObservation>& pass2,
                           const RobotGeometry& geometry, const MountingError& initial,
                           const CalibrationOptions& options, CalibrationSummary* summary);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CALIBRATION_BOARD_FIT_H_
