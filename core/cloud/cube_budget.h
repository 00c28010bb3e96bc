// A point budget spent over the census cubes in view (docs/cloud-store.md,
// "The rest level"): Potree's rule, the budget goes to what is nearest and
// largest on screen, on the 0.5 m cubes of the chunks' census
// (PackedChunk::cell_keys()) summed over the whole cloud.
//
// A cube at distance d covers about (L f / d)^2 pixels (L its side, f the
// focal length in pixels), so a screen evenly dense in points gives cube c
//
//     kept_c = min(n_c, lambda / d_c^2)                                 (1)
//
// of its n_c points, lambda the one number that makes the kept points sum to
// the budget. A chunk draws every stride-th point of each cube, the stride a
// power of two (so that a finer stride's points include a coarser one's and
// small camera moves leave a chunk's level as it is):
//
//     stride_c = 2^shift_c,  the least power of two >= n_c d_c^2 / lambda  (2)
//
// lambda is the largest for which sum_c n_c / stride_c fits the budget
// (bisection: the sum grows with lambda); the budget the rounding up of (2)
// leaves is then spent on the nearest cubes, halving their strides while it
// lasts. d_c is clamped below at one cube's side: a cube around the camera
// is not worth more than one filling the screen.
#ifndef SWEEPSCAN_CORE_CLOUD_CUBE_BUDGET_H_
#define SWEEPSCAN_CORE_CLOUD_CUBE_BUDGET_H_

#include <cstddef>
#include <cstdint>
#include <vector>

namespace sweepscan {

struct CubeDemand {
  double distance2 = 0.0;  // from the camera to the cube's nearest point, m^2
  uint32_t count = 0;      // the cloud's points in it
};

// Each cube's stride as a shift (stride = 1 << shift, at most kMaxCubeShift)
// under `budget` points; *kept (if given) the points n_c / stride_c summed.
// Every cube keeps a stride, however far: one point or more of it is drawn
// by whichever chunk's index falls on a multiple (the budget is a budget
// of points, and the cubes in view are far fewer).
inline constexpr int kMaxCubeShift = 24;
std::vector<uint8_t> CubeShifts(const std::vector<CubeDemand>& cubes, size_t budget,
                                double* kept = nullptr);

}  // namespace sweepscan

#endif  // SWEEPSCAN_CORE_CLOUD_CUBE_BUDGET_H_
