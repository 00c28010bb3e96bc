// The cloud store and the view's level of detail through the real app
// (docs/cloud-store.md), under a real display (xvfb-run in CI): the rest
// level at full resolution draws exactly the cloud (what VTK is given
// through the draw batches too, with and without a pass filter) and within a
// budget only cloud points; a rest level larger than the LOD budget is drawn in passes
// of about that budget to the one-frame image; a cloud larger than the
// memory budget opens paged to disk,
// equals `sweepscan-cli reconstruct` point for point and picks the true
// point under the cursor (not a drawn representative); a pick is the cloud
// point nearest the camera under the cursor, checked against every point; an opened room is
// shown looking into it with its ceiling hidden; a large session is
// streamed and opens as its replay would; zoomed in at rest, every point in
// view is drawn; looking along the room, the near cubes denser than the far;
// under a software renderer the driver is waited for every draw pace of
// points, to the same image.
#include <gtest/gtest.h>

#include <QAction>
#include <QImage>
#include <QLabel>
#include <QStatusBar>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "core/cloud/cloud_io.h"
#include "core/cloud/cloud_pager.h"
#include "tests/ui/app_fixture.h"
#include "tests/ui/paced_frame.h"
#include "tests/ui/progressive_passes.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

using testing::WaitFor;

using Xyz = std::array<float, 3>;

std::vector<Xyz> Positions(const std::vector<CloudPoint>& cloud) {
  std::vector<Xyz> out;
  out.reserve(cloud.size());
  for (const CloudPoint& p : cloud) out.push_back({p.x, p.y, p.z});
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Xyz> Positions(const std::vector<Eigen::Vector3f>& drawn) {
  std::vector<Xyz> out;
  out.reserve(drawn.size());
  for (const Eigen::Vector3f& p : drawn) out.push_back({p.x(), p.y(), p.z()});
  std::sort(out.begin(), out.end());
  return out;
}

bool Contains(const std::vector<Xyz>& sorted, const Xyz& p) {
  return std::binary_search(sorted.begin(), sorted.end(), p);
}

// The rest level planned afresh for the view's camera: at most the budget
// (and the growing chunk), more than half of it, every point a cloud point.
std::vector<Xyz> RestLevelWithinBudget(CloudView* view, const std::vector<Xyz>& cloud,
                                       size_t budget) {
  view->RenderNow();  // The clipping range fitted to the camera.
  view->SetLodActive(true);
  view->SetLodActive(false);
  std::vector<Xyz> drawn = Positions(view->DrawnPoints());
  EXPECT_LE(drawn.size(), budget + CloudView::kChunkPoints);
  EXPECT_GT(drawn.size(), budget / 2);
  EXPECT_TRUE(
      std::all_of(drawn.begin(), drawn.end(), [&](const Xyz& p) { return Contains(cloud, p); }));
  return drawn;
}

class CloudStoreUiTest : public testing::AppFixture {
 protected:
  void TearDown() override {
    AppFixture::TearDown();
    CloudPager::Default().SetBudget(CloudPager::DefaultBudgetBytes());
    CloudPager::Default().SetUnpackedBudget(CloudPager::kDefaultUnpackedBudget);
  }
  // The lab drive opened and replayed; the view holds all of it.
  void OpenLab() {
    ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
    ASSERT_NO_FATAL_FAILURE(OpenAndReplay(tmp_.path() + "/lab.sweepscan"));
    const size_t n = workspace_->CloudSize();
    ASSERT_GT(n, 100000u);
    ASSERT_TRUE(WaitFor([&] { return window_->view()->point_count() == n; }, 10000));
  }
  void PicksAreTheNearestPointsUnderTheCursor();
};

TEST_F(CloudStoreUiTest, FullResolutionAtRestDrawsExactlyTheCloud) {
  ASSERT_NO_FATAL_FAILURE(OpenLab());
  CloudView* view = window_->view();
  const std::vector<Xyz> cloud = Positions(workspace_->CloudSnapshot().Flatten());
  if (window_->ceiling_action()->isChecked()) window_->ceiling_action()->trigger();
  ASSERT_TRUE(std::isnan(view->clip_height()));
  view->ViewOblique();  // The whole cloud in the frustum.

  // The rest level with the cloud within the budget: every point, once.
  view->SetRestBudget(cloud.size());
  view->SetLodActive(false);
  EXPECT_EQ(Positions(view->DrawnPoints()), cloud);
  // ... and VTK is given exactly those: the batches' concatenated arrays
  // (built before a frame) and the growing chunk's.
  view->RenderNow();
  EXPECT_EQ(Positions(view->BatchedPoints()), cloud);
  // With a pass filter the batches' cells are the pass's points alone.
  {
    const std::vector<CloudPoint> appended = workspace_->CloudSnapshot().Flatten();
    std::vector<float> pass(appended.size());
    std::vector<CloudPoint> pass_b;
    for (size_t i = 0; i < pass.size(); ++i) {
      pass[i] = i % 3 == 0 ? 0.0f : i % 3 == 1 ? 1.0f : std::numeric_limits<float>::quiet_NaN();
      if (i % 3 == 1) pass_b.push_back(appended[i]);
    }
    view->SetPointValues(CloudView::ColorMode::kPass, pass);
    view->SetPassFilter(1);
    view->RenderNow();
    EXPECT_EQ(Positions(view->BatchedPoints()), Positions(pass_b));
    view->SetPassFilter(-1);
    view->RenderNow();
    EXPECT_EQ(Positions(view->BatchedPoints()), cloud);
  }

  // Within a quarter of it: at most the budget (and the growing chunk),
  // every one a cloud point.
  const size_t budget = cloud.size() / 4;
  view->SetRestBudget(budget);
  std::vector<Xyz> drawn = RestLevelWithinBudget(view, cloud, budget);

  // The motion level within its budget, likewise, one point a cell of the
  // view's even sample (core/geometry/voxel_sample.h), every one a cloud
  // point; and the rest level (now every second point or sparser) draws each
  // of them too, so that the progressive passes draw over pass 0's points.
  view->SetLodBudget(20000);
  view->SetLodActive(true);
  EXPECT_GT(view->lod_level(), 10);  // The cell's longest side (mm).
  EXPECT_LE(Positions(view->DrawnPoints()).size(), 20000 + CloudView::kChunkPoints);
  const std::vector<Xyz> motion = Positions(view->MotionPoints());
  EXPECT_EQ(motion.size(), view->motion_point_count());
  EXPECT_LE(motion.size(), 20000u);
  EXPECT_GT(motion.size(), 20000u / 4);
  EXPECT_TRUE(std::all_of(motion.begin(), motion.end(), [&](const Xyz& p) { return Contains(cloud, p); }));
  const std::array<double, 3> cell = view->motion_cell();
  std::set<std::array<int64_t, 3>> cells;
  for (const Xyz& p : motion) {
    std::array<int64_t, 3> c;
    for (int a = 0; a < 3; ++a) c[a] = static_cast<int64_t>(std::floor(static_cast<double>(p[a]) * (1.0 / cell[a])));
    EXPECT_TRUE(cells.insert(c).second) << "two motion points in one cell";
  }
  view->SetLodActive(false);
  drawn = Positions(view->DrawnPoints());
  EXPECT_TRUE(std::includes(drawn.begin(), drawn.end(), motion.begin(), motion.end()));

  // A larger budget cannot split cells without the points they were not
  // given: every chunk is offered again, the rest level planned again
  // around the new sample, still holding it.
  view->SetLodBudget(60000);
  const std::vector<Xyz> finer = Positions(view->MotionPoints());
  EXPECT_GT(finer.size(), motion.size());
  EXPECT_LE(finer.size(), 60000u);
  EXPECT_LT(view->motion_cell()[0] * view->motion_cell()[1] * view->motion_cell()[2],
            cell[0] * cell[1] * cell[2]);
  drawn = Positions(view->DrawnPoints());
  EXPECT_TRUE(std::includes(drawn.begin(), drawn.end(), finer.begin(), finer.end()));
}

// Zoomed into one spot of the room at rest, with a rest budget far below
// the cloud: every cloud point in view is drawn. A chunk is 13 s of sweeps
// across the room, so its box meets nearly any view from inside it; the
// plan counts only the points of its census cubes (0.5 m) in the frustum,
// so the spot is drawn whole and not every n-th point of the room's chunks.
// Colour by time or range reads every sealed chunk's rest level again (a
// compressed chunk unpacked): not at once on the GUI thread (seconds at
// 100 M points) but as after a camera move, the motion level drawn while
// the rest level is rebuilt in slices. At rest again, every point is drawn
// with its own range.
TEST_F(CloudStoreUiTest, ColourByRangeRebuildsTheRestLevelInSlicesWithEachPointsRange) {
  ASSERT_NO_FATAL_FAILURE(OpenLab());
  CloudView* view = window_->view();
  const std::vector<CloudPoint> points = workspace_->CloudSnapshot().Flatten();
  if (window_->ceiling_action()->isChecked()) window_->ceiling_action()->trigger();
  view->ViewOblique();
  view->SetRestBudget(points.size());
  view->SetLodActive(false);
  ASSERT_FALSE(view->lod_active());

  view->SetColorMode(CloudView::ColorMode::kRange);
  EXPECT_TRUE(view->lod_active());  // the motion level, recoloured, meanwhile
  EXPECT_TRUE(view->refining());
  ASSERT_TRUE(WaitFor([&] { return !view->refining() && !view->lod_active(); }, 30000));
  // A few points share a position (the store keeps whole millimetres).
  std::map<Xyz, std::vector<float>> range;
  for (const CloudPoint& p : points) range[{p.x, p.y, p.z}].push_back(p.range_m);
  std::vector<float> scalars;
  const std::vector<Eigen::Vector3f> drawn = view->DrawnPoints(&scalars);
  ASSERT_EQ(drawn.size(), points.size());
  ASSERT_EQ(scalars.size(), drawn.size());
  size_t wrong = 0;
  for (size_t i = 0; i < drawn.size(); ++i) {
    const auto it = range.find({drawn[i].x(), drawn[i].y(), drawn[i].z()});
    wrong += it == range.end() ||
             std::find(it->second.begin(), it->second.end(), scalars[i]) == it->second.end();
  }
  EXPECT_EQ(wrong, 0u);
}

TEST_F(CloudStoreUiTest, ZoomedInAtRestEveryPointInViewIsDrawn) {
  ASSERT_NO_FATAL_FAILURE(OpenLab());
  CloudView* view = window_->view();
  const std::vector<Xyz> cloud = Positions(workspace_->CloudSnapshot().Flatten());
  if (window_->ceiling_action()->isChecked()) window_->ceiling_action()->trigger();
  const size_t budget = cloud.size() / 16;
  view->SetRestBudget(budget);

  // The densest 0.3 m cube between 0.5 and 1.5 m above the floor (a wall
  // along the robot's lane), looked at from 2 m towards the room's middle:
  // a sphere of 0.3 m about it is well inside the 30-degree view (2 sin 15
  // deg = 0.52 m).
  float lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<float>::max();
    hi[a] = -lo[a];
  }
  for (const Xyz& p : cloud) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
  std::map<std::array<int, 3>, std::vector<Xyz>> cubes;
  for (const Xyz& p : cloud) {
    if (p[2] < lo[2] + 0.5f || p[2] > lo[2] + 1.5f) continue;
    cubes[{static_cast<int>(std::floor(p[0] / 0.3f)), static_cast<int>(std::floor(p[1] / 0.3f)),
           static_cast<int>(std::floor(p[2] / 0.3f))}]
        .push_back(p);
  }
  const auto densest = std::max_element(
      cubes.begin(), cubes.end(),
      [](const auto& a, const auto& b) { return a.second.size() < b.second.size(); });
  ASSERT_NE(densest, cubes.end());
  const Xyz& f = densest->second[densest->second.size() / 2];
  const Eigen::Vector3f focal(f[0], f[1], f[2]);
  Eigen::Vector3f inward(0.5f * (lo[0] + hi[0]) - focal.x(), 0.5f * (lo[1] + hi[1]) - focal.y(),
                         0.0f);
  inward.normalize();
  std::vector<Xyz> spot;
  for (const Xyz& p : cloud) {
    if ((Eigen::Vector3f(p[0], p[1], p[2]) - focal).norm() < 0.3f) spot.push_back(p);
  }
  ASSERT_GT(spot.size(), 500u) << "of " << cloud.size();
  view->LookAt(focal.cast<double>(),
               (focal + 2.0f * inward + Eigen::Vector3f(0.0f, 0.0f, 0.2f)).cast<double>());
  view->RenderNow();  // The clipping range fitted to the new view.
  view->SetLodActive(true);
  view->SetLodActive(false);
  const std::vector<Xyz> drawn = Positions(view->DrawnPoints());
  EXPECT_LE(drawn.size(), budget + CloudView::kChunkPoints);
  const size_t missing = static_cast<size_t>(
      std::count_if(spot.begin(), spot.end(), [&](const Xyz& p) { return !Contains(drawn, p); }));
  EXPECT_EQ(missing, 0u) << "of " << spot.size() << " points about the spot looked at";

  // Back to the whole room: within the budget again, every one a cloud point.
  view->ViewOblique();
  RestLevelWithinBudget(view, cloud, budget);
}

// Standing in the robot's lane looking along it, with a rest budget far
// below the points in view: the budget goes to what is near, as on screen
// (core/cloud/cube_budget.h). The floor within 2.6 m is drawn several times
// denser than the floor and wall beyond 5 m, which are still drawn; within
// the budget, every one a cloud point. (With one stride a chunk, every chunk
// spanning the room, both were thinned alike.)
TEST_F(CloudStoreUiTest, AtRestTheNearestCubesAreDrawnDenserThanTheFarOnes) {
  ASSERT_NO_FATAL_FAILURE(OpenLab());
  CloudView* view = window_->view();
  const std::vector<CloudPoint> snapshot = workspace_->CloudSnapshot().Flatten();
  const std::vector<Xyz> cloud = Positions(snapshot);
  if (window_->ceiling_action()->isChecked()) window_->ceiling_action()->trigger();
  const size_t budget = cloud.size() / 16;
  view->SetRestBudget(budget);
  Eigen::Vector3d lo(1e9, 1e9, 1e9), hi = -lo;
  for (const CloudPoint& p : snapshot) {
    lo = lo.cwiseMin(Eigen::Vector3d(p.x, p.y, p.z));
    hi = hi.cwiseMax(Eigen::Vector3d(p.x, p.y, p.z));
  }
  const Eigen::Vector3d eye(lo.x() + 2.3, 0.5 * (lo.y() + hi.y()), lo.z() + 1.0);
  // Looking down at the floor 3.5 m ahead from 1 m above it: the
  // 30-degree view spans the floor from 1.7 m on and the far end's wall.
  const Eigen::Vector3d focal(eye.x() + 3.5, eye.y(), lo.z());
  ASSERT_GT(hi.x() - eye.x(), 6.0) << "the room is too short to look along";
  view->LookAt(focal, eye);
  const std::vector<Xyz> drawn = RestLevelWithinBudget(view, cloud, budget);
  // The cloud's points on screen, by their distance from the eye.
  const Eigen::Vector3d ahead = (focal - eye).normalized();
  size_t near = 0, near_drawn = 0, far = 0, far_drawn = 0;
  for (const CloudPoint& p : snapshot) {
    const Eigen::Vector3d q(p.x, p.y, p.z);
    if ((q - eye).dot(ahead) < 0.3) continue;
    const QPointF at = view->WorldToWidget(q);
    if (at.x() < 0 || at.y() < 0 || at.x() > view->width() || at.y() > view->height()) continue;
    const double d = (q - eye).norm();
    const bool shown = Contains(drawn, {p.x, p.y, p.z});
    if (d < 2.6) {
      ++near;
      near_drawn += shown;
    } else if (d > 5.0) {
      ++far;
      far_drawn += shown;
    }
  }
  ASSERT_GT(near, 2000u);
  ASSERT_GT(far, 2000u);
  const double near_share = static_cast<double>(near_drawn) / near;
  const double far_share = static_cast<double>(far_drawn) / far;
  std::printf(
      "[lod] %zu drawn of %zu (budget %zu): within 2.6 m %zu of %zu (%.3f), beyond 5 m %zu of "
      "%zu (%.3f)\n",
      drawn.size(), cloud.size(), budget, near_drawn, near, near_share, far_drawn, far, far_share);
  EXPECT_GT(near_share, 4.0 * far_share);
  EXPECT_GT(far_drawn, 0u);
}

// Against every point of the cloud: the pick reads only the pieces of the
// blocks its ray passes near (PackedChunk::block_bounds(), PieceBox), and
// no point within a pixel less than its tolerance of the cursor may be
// nearer the camera than the pick. An oblique camera over the room: rays
// pass over floor, walls and furniture, through many chunks' boxes. Every
// third pick has a tolerance of 2 pixels, not 6; every other pick tests
// its blocks a chunk at a time from the start (on this small cloud the
// first waves in entry order nearly always find the point).
void CloudStoreUiTest::PicksAreTheNearestPointsUnderTheCursor() {
  ASSERT_NO_FATAL_FAILURE(OpenLab());
  CloudView* view = window_->view();
  const std::vector<CloudPoint> snapshot = workspace_->CloudSnapshot().Flatten();
  Eigen::Vector3d lo(1e9, 1e9, 1e9), hi = -lo;
  for (const CloudPoint& p : snapshot) {
    lo = lo.cwiseMin(Eigen::Vector3d(p.x, p.y, p.z));
    hi = hi.cwiseMax(Eigen::Vector3d(p.x, p.y, p.z));
  }
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const Eigen::Vector3d eye = centre + Eigen::Vector3d(-0.4, -0.7, 0.5) * (hi - lo).norm();
  view->LookAt(centre, eye);
  view->RenderNow();
  const double clip = view->clip_height();
  std::vector<QPointF> at(snapshot.size());
  for (size_t i = 0; i < snapshot.size(); ++i) {
    at[i] = view->WorldToWidget(Eigen::Vector3d(snapshot[i].x, snapshot[i].y, snapshot[i].z));
  }
  std::mt19937 rng(11);
  std::uniform_int_distribution<size_t> any(0, snapshot.size() - 1);
  int picks = 0;
  size_t by_chunk = 0, in_order = 0;
  for (int tries = 0; picks < 30 && tries < 1000; ++tries) {
    const size_t k = any(rng);
    if (!std::isnan(clip) && snapshot[k].z > clip) continue;
    const QPoint cursor = at[k].toPoint();
    if (cursor.x() < 10 || cursor.y() < 10 || cursor.x() > view->width() - 10 ||
        cursor.y() > view->height() - 10) {
      continue;
    }
    const double tolerance = picks % 3 == 2 ? 2.0 : 6.0;
    view->SetPickBlocksInOrder(picks % 2 == 0 ? std::numeric_limits<size_t>::max() : 0);
    Eigen::Vector3d got;
    ASSERT_TRUE(view->PickPoint(cursor, &got, tolerance));
    double nearest = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < snapshot.size(); ++i) {
      const CloudPoint& p = snapshot[i];
      if ((!std::isnan(clip) && p.z > clip) ||
          std::hypot(at[i].x() - cursor.x(), at[i].y() - cursor.y()) > tolerance - 1.0) {
        continue;
      }
      nearest = std::min(nearest, (Eigen::Vector3d(p.x, p.y, p.z) - eye).norm());
    }
    EXPECT_LE((got - eye).norm(), nearest + 1e-3) << "pick " << picks << " at " << cursor.x() << ", " << cursor.y();
    ++picks;
    by_chunk += view->last_pick_counts().blocks_by_chunk;
    in_order += view->last_pick_counts().blocks_in_order;
  }
  EXPECT_EQ(picks, 30);
  // Both paths were taken: blocks in entry order, and blocks a chunk at a time.
  EXPECT_GT(in_order, 0u);
  EXPECT_GT(by_chunk, 0u);
}

TEST_F(CloudStoreUiTest, APickIsTheCloudPointNearestTheCameraUnderTheCursor) {
  PicksAreTheNearestPointsUnderTheCursor();
}

// The same with every sealed chunk compressed (an unpacked budget of one
// byte keeps only the newest unpacked): each block a pick tests is decoded
// alone, on every core, in waves of blocks (cloud_view_picking.cc).
TEST_F(CloudStoreUiTest, APickOnCompressedChunksIsTheNearestPointUnderTheCursor) {
  CloudPager& pager = CloudPager::Default();
  pager.SetUnpackedBudget(1);
  PicksAreTheNearestPointsUnderTheCursor();
  EXPECT_GE(pager.packed_chunks(), 3u);
}

// The same with the cloud paged out to the cache file (a budget of 192
// KiB): the blocks beyond the first waves are tested a chunk at a time, each
// chunk read back once a pick, not once a block.
TEST_F(CloudStoreUiTest, APickOnPagedChunksIsTheNearestPointUnderTheCursor) {
  CloudPager& pager = CloudPager::Default();
  pager.SetBudget(size_t{192} << 10);
  PicksAreTheNearestPointsUnderTheCursor();
  EXPECT_GE(pager.paged_out_chunks(), 2u);
}

TEST_F(CloudStoreUiTest, TheRestLevelIsDrawnInPassesOfTheLodBudgetToTheOneFrameImage) {
  ASSERT_NO_FATAL_FAILURE(OpenLab());
  CloudView* view = window_->view();
  view->ViewOblique();
  const size_t budget = 20000;
  view->SetLodBudget(budget);
  view->SetRestBudget(view->point_count());  // Every point at rest.
  view->SetLodActive(false);
  const size_t rest = view->DrawnPoints().size();
  const QImage whole = view->GrabImage();  // In one frame.

  // As the GUI's timer draws it: pass 0 (the scene in motion), then the
  // rest level a LOD budget (and at most one batch more) a pass, to the
  // same image but for the text's anti-aliased edges (the colour bar's and
  // the axes' labels, blended twice: in pass 0 and the last; 943 of 369 024
  // pixels, all there, when written). Preserving the colour but not the
  // depth between passes left 19 382: farther points over nearer.
  testing::PassesDrawn drawn;
  ASSERT_NO_FATAL_FAILURE(
      testing::DrawPassesToTheOneFrameImage(view, whole, budget + CloudView::kChunkPoints, &drawn));
  // Every sealed chunk's rest points once (the growing chunk is drawn in
  // pass 0, whole).
  EXPECT_LE(drawn.points, rest);
  EXPECT_GE(drawn.points + CloudView::kChunkPoints, rest);
  EXPECT_GE(drawn.passes, drawn.points / (budget + CloudView::kChunkPoints));

  // A new frame asked for midway starts again at pass 0; the camera
  // starting to move ends the passes.
  view->RequestRender();
  ASSERT_TRUE(view->RenderIfDirty());
  ASSERT_TRUE(view->RenderIfDirty());
  EXPECT_TRUE(view->drawing_passes());
  view->SetLodActive(true);
  EXPECT_FALSE(view->drawing_passes());

  // A robot standing still asks for no new frame (at rest, one every tick
  // would keep the passes at pass 0); one that moves a centimetre does.
  Pose2d pose;
  pose.x = 1.0;
  pose.y = 2.0;
  pose.yaw = 0.3;
  view->SetRobotPose(pose);
  EXPECT_TRUE(view->RenderIfDirty());
  view->SetRobotPose(pose);
  EXPECT_FALSE(view->RenderIfDirty());
  pose.x += 0.01;
  view->SetRobotPose(pose);
  EXPECT_TRUE(view->RenderIfDirty());
}

// Under a software renderer the view waits for the driver every "draw pace"
// of points (ui/view/paced_mapper.h: Mesa's llvmpipe otherwise holds a
// large frame's binned points after it), and waiting changes no pixel.
TEST_F(CloudStoreUiTest, ASoftwareRendererIsWaitedForEveryPaceOfPointsAndDrawsTheSameImage) {
  ASSERT_NO_FATAL_FAILURE(OpenLab());
  CloudView* view = window_->view();
  view->ViewOblique();
  view->SetRestBudget(view->point_count());  // Every point at rest, in one frame.
  view->SetLodActive(false);
  const size_t rest = view->DrawnPoints().size();
  view->RenderNow();
  if (!view->software_renderer()) GTEST_SKIP() << "a GPU: the view never waits";
  EXPECT_EQ(view->draw_pace(), CloudView::kSoftwareDrawPace);

  // An eighth of the frame a pace (a batch is at most a chunk).
  testing::ExpectPacedFrameWaitsAndMatches(view, rest, rest / 8, CloudView::kChunkPoints);
}

TEST_F(CloudStoreUiTest, ACloudLargerThanTheMemoryBudgetOpensAndPicksTheTruePoint) {
  // 192 KiB hold the newest chunk unpacked (up to half of it) and about
  // one chunk compressed (2-3 bytes a point): the lab drive's ~270 000
  // points go mostly to the cache file (as --memory-budget 0.19 would).
  CloudPager& pager = CloudPager::Default();
  pager.SetBudget(size_t{192} << 10);
  const uint64_t page_outs_before = pager.page_outs();
  ASSERT_NO_FATAL_FAILURE(OpenLab());
  EXPECT_GT(pager.page_outs(), page_outs_before);
  EXPECT_GE(pager.paged_out_chunks(), 2u);
  EXPECT_LE(pager.resident_bytes(), (size_t{192} << 10) + 20 * CloudView::kChunkPoints);

  // Paged out and read back, the cloud is the CLI's point for point.
  const std::string dir = tmp_.path().toStdString();
  const auto rec = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " reconstruct " + dir +
                              "/lab.sweepscan --out " + dir + "/cli.ply");
  ASSERT_EQ(rec.code, 0) << rec.out;
  std::vector<CloudPoint> expected;
  ASSERT_TRUE(LoadCloud(dir + "/cli.ply", &expected).ok());
  const std::vector<CloudPoint> snapshot = workspace_->CloudSnapshot().Flatten();
  const std::vector<Xyz> cloud = Positions(snapshot);
  ASSERT_EQ(cloud, Positions(expected));

  // The floor from above at the motion level (every 8th point or sparser):
  // a click on a floor point picks a point of the cloud under the cursor,
  // read from its (paged) chunk, often one the view does not draw.
  CloudView* view = window_->view();
  view->SetClipHeight(0.10);
  view->ViewTop();
  view->SetLodBudget(30000);
  view->SetLodActive(true);
  view->RenderNow();
  const std::vector<Xyz> drawn = Positions(view->DrawnPoints());
  ASSERT_LE(drawn.size() * 8, snapshot.size());
  const uint64_t page_ins_before = pager.page_ins();
  std::mt19937 rng(7);
  std::uniform_int_distribution<size_t> any(0, snapshot.size() - 1);
  int picks = 0, undrawn = 0;
  while (picks < 40) {
    const CloudPoint& p = snapshot[any(rng)];
    if (p.z > 0.02) continue;
    const QPointF px = view->WorldToWidget(Eigen::Vector3d(p.x, p.y, p.z));
    if (px.x() < 10 || px.y() < 10 || px.x() > view->width() - 10 || px.y() > view->height() - 10) {
      continue;
    }
    Eigen::Vector3d got;
    ASSERT_TRUE(view->PickPoint(px.toPoint(), &got)) << p.x << " " << p.y;
    const Xyz g{static_cast<float>(got.x()), static_cast<float>(got.y()),
                static_cast<float>(got.z())};
    ASSERT_TRUE(Contains(cloud, g)) << got.transpose();
    const QPointF at = view->WorldToWidget(got);
    EXPECT_LE(std::hypot(at.x() - px.toPoint().x(), at.y() - px.toPoint().y()), 6.5);
    // Under the clip: what is on screen (compared as the view does, in
    // float: a point at 0.1f is at the clip, not above it).
    EXPECT_LE(g[2], 0.10f);
    if (!Contains(drawn, g)) ++undrawn;
    ++picks;
  }
  // Representatives alone would never give an undrawn point.
  EXPECT_GE(undrawn, picks / 2);
  EXPECT_GT(pager.page_ins(), page_ins_before);
}

// A large session at full speed is streamed (workspace_stream.cc): two
// passes over frames.bin, the samples never held. The cloud is the CLI's
// point for point and in its order, the view draws all of it, the opened
// session keeps none of its records, and another pose source replays it as
// it reads it and gives the CLI's cloud.
// The threshold is lowered to 0 so that the lab drive counts as large.
TEST_F(CloudStoreUiTest, ALargeSessionIsStreamedAndOpensAsItsReplayWould) {
  ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
  workspace_->set_stream_open_above_bytes(0);
  const QString session = tmp_.path() + "/lab.sweepscan";
  ASSERT_NO_FATAL_FAILURE(OpenAndReplay(session));
  const hardware::Recording* opened = workspace_->recording_opened();
  ASSERT_NE(opened, nullptr);
  // Streamed: no samples held, nor the wheel and IMU records.
  EXPECT_TRUE(opened->log.scans.empty());
  EXPECT_TRUE(opened->log.imu.empty());
  EXPECT_TRUE(opened->log.wheels.empty());
  EXPECT_GT(opened->decode.telemetry.device_bytes[1], 0u);  // The IMU's were decoded, then let go.
  EXPECT_EQ(workspace_->session_dir(), session);

  const std::string dir = tmp_.path().toStdString();
  auto cli = [&](const std::string& source) {
    const auto rec = testing::RunCommand(std::string(SWEEPSCAN_CLI) + " reconstruct " + dir +
                                         "/lab.sweepscan --pose-source " + source + " --out " + dir + "/cli.ply");
    EXPECT_EQ(rec.code, 0) << rec.out;
    std::vector<CloudPoint> cloud;
    EXPECT_TRUE(LoadCloud(dir + "/cli.ply", &cloud).ok());
    return cloud;
  };
  auto same = [](const std::vector<CloudPoint>& got, const std::vector<CloudPoint>& expected) {
    if (got.size() != expected.size()) return false;
    for (size_t i = 0; i < got.size(); ++i) {
      if (got[i].x != expected[i].x || got[i].y != expected[i].y || got[i].z != expected[i].z ||
          got[i].time_ns != expected[i].time_ns || got[i].pose_source != expected[i].pose_source) {
        return false;
      }
    }
    return true;
  };
  const std::vector<CloudPoint> ekf = cli("ekf");
  ASSERT_GT(ekf.size(), 100000u);
  EXPECT_TRUE(same(workspace_->CloudSnapshot().Flatten(), ekf));
  ASSERT_TRUE(WaitFor([&] { return window_->view()->point_count() == ekf.size(); }, 10000));

  // The wheels alone: the session is replayed as it is read (its wheel and
  // IMU records loaded in a job, its scans decoded as the replay reaches
  // them), still holding no samples.
  bool replayed = false;
  const auto c = QObject::connect(workspace_.get(), &Workspace::replayFinished, [&] { replayed = true; });
  workspace_->SetPoseSource(PoseSource::kOdometry);
  ASSERT_TRUE(WaitFor([&] { return replayed; }, 120000));
  QObject::disconnect(c);
  EXPECT_TRUE(same(workspace_->CloudSnapshot().Flatten(), cli("odometry")));
  opened = workspace_->recording_opened();
  ASSERT_NE(opened, nullptr);
  EXPECT_TRUE(opened->log.scans.empty());
}

TEST_F(CloudStoreUiTest, ARoomOpensLookingIntoItWithTheCeilingHidden) {
  ASSERT_NO_FATAL_FAILURE(OpenLab());
  CloudView* view = window_->view();
  QAction* ceiling = window_->ceiling_action();
  // The lab's ceiling is at 2.5 m: hidden just under it, and said so.
  ASSERT_TRUE(WaitFor([&] { return ceiling->isChecked(); }, 5000));
  EXPECT_NEAR(view->clip_height(), 2.45, 0.06);
  auto* label = window_->statusBar()->findChild<QLabel*>(QStringLiteral("statusClip"));
  ASSERT_NE(label, nullptr);
  EXPECT_EQ(label->text(), window_->clip_status());
  EXPECT_TRUE(label->text().startsWith(QStringLiteral("Ceiling hidden above 2.4")))
      << label->text().toStdString();
  view->RenderNow();

  // The middle of the floor, where the robot drove (y = 2.5 m): seen, not
  // hidden behind the ceiling.
  const std::vector<CloudPoint> cloud = workspace_->CloudSnapshot().Flatten();
  const CloudPoint* floor = nullptr;
  for (const CloudPoint& p : cloud) {
    if (p.z < 0.02 && std::abs(p.x - 4.0) < 0.05 && std::abs(p.y - 2.0) < 0.05) floor = &p;
  }
  ASSERT_NE(floor, nullptr);
  const QPoint at = view->WorldToWidget(Eigen::Vector3d(floor->x, floor->y, floor->z)).toPoint();
  ASSERT_TRUE(view->rect().contains(at));
  Eigen::Vector3d picked;
  ASSERT_TRUE(view->PickPoint(at, &picked));
  EXPECT_LT(picked.z(), 0.3) << picked.transpose();

  // The operator's toggle (View > Hide Ceiling, C): the ceiling comes back
  // and is what the same pixel shows, then goes again.
  ceiling->trigger();
  EXPECT_TRUE(std::isnan(view->clip_height()));
  EXPECT_TRUE(label->text().isEmpty());
  ASSERT_TRUE(view->PickPoint(at, &picked));
  EXPECT_GT(picked.z(), 2.4) << picked.transpose();
  ceiling->trigger();
  EXPECT_NEAR(view->clip_height(), 2.45, 0.06);
  EXPECT_FALSE(label->text().isEmpty());
}

// FindCeiling on its own: a room's ceiling layer, and none in the open.
// A point with a NaN coordinate (a chunk may hold one) is never picked: it
// compared as nearer than anything, and a block without a hit then gave its
// unset (0, 0, 0). Two sealed chunks and a growing one over a 2 m plane,
// a NaN in a sealed chunk and one in the growing chunk.
TEST(CloudViewPickTest, APointWithANanCoordinateIsNeverPicked) {
  std::vector<CloudPoint> points;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 2.0f);
  for (int i = 0; i < 140000; ++i) {
    CloudPoint p{};
    p.x = 5.0f + u(rng), p.y = 5.0f + u(rng), p.z = 0.0f;
    p.range_m = 2.0f;
    p.scan = static_cast<uint32_t>(i / 1000);
    p.time_ns = int64_t{i} * 200000;
    points.push_back(p);
  }
  points[1023].z = std::numeric_limits<float>::quiet_NaN();
  points[139995].x = std::numeric_limits<float>::quiet_NaN();
  CloudView view;
  view.resize(400, 300);
  view.show();
  ASSERT_TRUE(QTest::qWaitForWindowExposed(&view));
  view.AppendPoints(points);
  view.LookAt(Eigen::Vector3d(6, 6, 0), Eigen::Vector3d(6, 5.999, 4));
  view.RenderNow();
  int picks = 0;
  for (int x = 60; x < 360; x += 30) {
    for (int y = 40; y < 280; y += 30) {
      Eigen::Vector3d got;
      if (!view.PickPoint(QPoint(x, y), &got)) continue;
      ++picks;
      ASSERT_TRUE(got.allFinite()) << x << ", " << y;
      EXPECT_GE(got.x(), 5.0) << x << ", " << y << ": " << got.transpose();
      EXPECT_LE(got.x(), 7.0) << x << ", " << y << ": " << got.transpose();
      EXPECT_GE(got.y(), 5.0) << x << ", " << y << ": " << got.transpose();
      EXPECT_EQ(got.z(), 0.0) << x << ", " << y << ": " << got.transpose();
    }
  }
  EXPECT_GE(picks, 20);
}

TEST(CloudViewRoomTest, FindsTheCeilingOfARoomAndNoneWithoutOne) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  enum Ceiling { kNone, kFlat, kSmeared };
  auto room = [&](Ceiling ceiling) {
    std::vector<CloudPoint> points;
    for (int i = 0; i < 200000; ++i) {
      CloudPoint p{};
      // At random: the view samples every n-th point, which a regular
      // pattern of faces would alias.
      const int face = static_cast<int>(4 * u(rng)) % 4;
      if (face == 0) {  // Floor.
        p.x = 6 * u(rng), p.y = 4 * u(rng), p.z = 0;
      } else if (face == 1 && ceiling == kFlat) {
        p.x = 6 * u(rng), p.y = 4 * u(rng), p.z = 2.7f;
      } else if (face == 1 && ceiling == kSmeared) {
        // An uncalibrated circle drive's: 2.30 to 2.65 m, thinner between
        // its two passes' layers (2.45 to 2.50 m, a quarter as dense).
        p.x = 6 * u(rng), p.y = 4 * u(rng);
        do {
          p.z = 2.3f + 0.35f * u(rng);
        } while (p.z >= 2.45f && p.z < 2.5f && u(rng) < 0.75f);
      } else {  // Walls, up to 2.7 m.
        const bool x_wall = u(rng) < 0.5f;
        p.x = x_wall ? (u(rng) < 0.5f ? 0.0f : 6.0f) : 6 * u(rng);
        p.y = x_wall ? 4 * u(rng) : (u(rng) < 0.5f ? 0.0f : 4.0f);
        p.z = 2.7f * u(rng);
      }
      p.range_m = 2.0f;
      p.scan = static_cast<uint32_t>(i / 1000);
      p.time_ns = int64_t{i} * 200000;
      points.push_back(p);
    }
    return points;
  };
  CloudView view;
  view.AppendPoints(room(kFlat));
  EXPECT_NEAR(view.FindCeiling(), 2.7, 0.051);
  // The smeared ceiling's lower edge, so that hiding it leaves no lid.
  view.Clear();
  view.AppendPoints(room(kSmeared));
  EXPECT_NEAR(view.FindCeiling(), 2.3, 0.051);
  view.Clear();
  view.AppendPoints(room(kNone));
  EXPECT_TRUE(std::isnan(view.FindCeiling()));
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
