// Mounting-error calibration (Miao et al. 2022, section 4, Eq. 15-17) and an
// automatic variant, solved with Ceres' Levenberg-Marquardt. This header
// gathers the room; include the piece you use:
//   samples.h           the raw samples and their re-projection (the model)
//   picks.h             picks, pick pairs, the pairs file
//   pairs_solver.h      options, progress, summary; the pairs problem (Eq. 15-17)
//   board_fit.h         the target board's corners; the refined-corners solve
//   automatic.h         the automatic mode (planes seen in both passes)
//   calibration_file.h  calibration files
//   workflow.h          picks -> calibration, as the CLI and the app run it
//   combine.h           two calibrations of one recording made into one
//   passes.h            the passes of a circle drive
#ifndef SWEEPSCAN_CORE_CALIBRATION_CALIBRATION_H_
#define SWEEPSCAN_CORE_CALIBRATION_CALIBRATION_H_

#include "core/calibration/automatic.h"
#include "core/calibration/board_fit.h"
#include "core/calibration/calibration_file.h"
#include "core/calibration/combine.h"
#include "core/calibration/pairs_solver.h"
#include "core/calibration/passes.h"
#include "core/calibration/picks.h"
#include "core/calibration/samples.h"
#include "core/calibration/workflow.h"

#endif  // SWEEPSCAN_CORE_CALIBRATION_CALIBRATION_H_
