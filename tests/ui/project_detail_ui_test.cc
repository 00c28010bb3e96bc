// A project's sessions above the rest budget are drawn at rest as the
// session view draws its cloud: densest where the camera looks
// (ProjectLayer::PlanDetail, ui/project/project_detail.h). Before, they drew
// every k-th point whatever the camera: zoomed onto a corner of a floor
// eight times the budget, one point in eight of the corner. A 20 x 20 m
// floor of 800 000 points at a pose, the view's budgets made small (rest
// 100 000, motion 10 000), under a real display (xvfb-run in CI).
#include <gtest/gtest.h>

#include <QElapsedTimer>
#include <QTest>
#include <limits>
#include <random>
#include <vector>

#include "tests/ui/app_fixture.h"
#include "tests/ui/pick_truth.h"
#include "ui/main_window.h"
#include "ui/project/project_detail.h"
#include "ui/project/project_layer.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

class ProjectDetailTest : public testing::AppFixture {
 protected:
  void SetUp() override {
    testing::AppFixture::SetUp();
    view_ = window_->view();
    view_->SetLodBudget(10000);
    view_->SetRestBudget(kRest);
    auto cloud = std::make_shared<ProjectCloud>();
    cloud->id = "s";
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    // Sweeps across the floor in scan order, as a drive makes them.
    for (int sweep = 0; sweep < 400; ++sweep) {
      const float x = 0.05f * sweep;
      for (int k = 0; k < 2000; ++k)
        cloud->positions.emplace_back(x + 0.05f * u(rng), 0.01f * (k + u(rng)), 0.0f);
    }
    IndexForPicks(cloud.get());
    cloud_ = cloud;
    session_.id = "s";
    session_.project_from_session =
        Rigid3d(Eigen::Vector3d(2.0, -1.0, 0.1),
                Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ())));
    project_.sessions.push_back(session_);
    layer_ = std::make_unique<ProjectLayer>(view_);
    layer_->Sync(project_, {{"s", cloud_}});
    while (layer_->Pump()) {
    }
  }
  void TearDown() override {
    layer_.reset();
    testing::AppFixture::TearDown();
  }

  // The floor's point (u, v) of the session's frame, in the project's.
  Eigen::Vector3d At(double u, double v) const {
    return *session_.project_from_session * Eigen::Vector3d(u, v, 0.0);
  }
  // The cloud's points a picture of the view shows (in front of the camera,
  // inside the widget with a margin), in the project's frame.
  std::vector<Eigen::Vector3d> OnScreen() const {
    std::vector<Eigen::Vector3d> out;
    double planes[24], eye[3];
    view_->ViewFrustum(planes, eye);
    for (const Eigen::Vector3f& p : cloud_->positions) {
      const Eigen::Vector3d w = *session_.project_from_session * p.cast<double>();
      bool inside = true;
      for (int k = 0; k < 4 && inside; ++k) {  // The sides (the plan's)
        const double* n = planes + 4 * k;
        inside = n[0] * w.x() + n[1] * w.y() + n[2] * w.z() + n[3] >= 0.02;
      }
      if (inside) out.push_back(w);
    }
    return out;
  }
  // The layer's plan runs on its own thread: its result is shown by the
  // GUI thread's event loop.
  void WaitForDetail() {
    QElapsedTimer clock;
    clock.start();
    while (layer_->detail_pending() && clock.elapsed() < 20000) QTest::qWait(5);
    ASSERT_FALSE(layer_->detail_pending());
  }
  static size_t Near(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& c,
                     double r) {
    size_t n = 0;
    for (const Eigen::Vector3d& p : points) n += (p - c).norm() < r;
    return n;
  }

  static constexpr size_t kRest = 100000;
  CloudView* view_ = nullptr;
  std::shared_ptr<ProjectCloud> cloud_;
  ProjectSession session_;
  Project project_;
  std::unique_ptr<ProjectLayer> layer_;
};

TEST_F(ProjectDetailTest, ARestLevelPlannedForTheCameraDrawsWhatItLooksAtInFull) {
  // Thinned at rest: every 8th point (800 000 over the budget of 100 000).
  ASSERT_LE(layer_->drawn_points(), kRest + ProjectLayer::kPiecePoints);

  // Close over the session's corner (1, 1), looking down from 2 m.
  const Eigen::Vector3d corner = At(1.0, 1.0);
  view_->LookAt(corner, corner + Eigen::Vector3d(0.0, -0.01, 2.0));
  view_->SetLodActive(true);
  view_->SetLodActive(false);  // Plans the rest level, the view's and the layer's.
  WaitForDetail();
  const std::vector<Eigen::Vector3d> shown = OnScreen();
  ASSERT_GT(shown.size(), 1000u);
  ASSERT_LT(shown.size(), kRest / 2);  // All of it fits the budget...
  const std::vector<Eigen::Vector3d> detail = layer_->DetailPoints();
  EXPECT_LE(detail.size(), kRest);
  // ... so every point on screen is drawn (the detail holds the cloud's
  // own points, through the session's pose).
  std::vector<std::array<double, 3>> drawn;
  for (const Eigen::Vector3d& p : detail) drawn.push_back({p.x(), p.y(), p.z()});
  std::sort(drawn.begin(), drawn.end());
  size_t found = 0;
  for (const Eigen::Vector3d& p : shown) {
    const auto it = std::lower_bound(drawn.begin(), drawn.end(),
                                     std::array<double, 3>{p.x() - 1e-6, p.y(), p.z()});
    for (auto j = it; j != drawn.end() && (*j)[0] <= p.x() + 1e-6; ++j) {
      if ((Eigen::Vector3d((*j)[0], (*j)[1], (*j)[2]) - p).norm() < 1e-5) {
        ++found;
        break;
      }
    }
  }
  EXPECT_EQ(found, shown.size());
  // The frame draws the detail and the pieces' motion level, within the budget.
  EXPECT_LE(view_->layer_points_drawn(), kRest + ProjectLayer::kPiecePoints);
  EXPECT_GE(view_->layer_points_drawn(), detail.size());

  // Moving: the detail is not drawn, the motion level alone.
  view_->SetLodActive(true);
  EXPECT_LE(view_->layer_points_drawn(), 10000u + 16u);
  view_->SetLodActive(false);

  // View > Top through the app's tick (the view re-plans a placed camera):
  // the whole floor, the far corner (19, 19) as dense as the near one.
  view_->ViewTop();
  QElapsedTimer clock;
  clock.start();
  bool moved = false;
  while (clock.elapsed() < 20000) {
    QTest::qWait(20);
    moved = moved || view_->lod_active();
    if (moved && !view_->lod_active() && !view_->drawing_passes()) break;
  }
  ASSERT_TRUE(moved && !view_->lod_active());
  WaitForDetail();
  const std::vector<Eigen::Vector3d> top = layer_->DetailPoints();
  EXPECT_LE(top.size(), kRest);
  EXPECT_GE(top.size(), kRest / 2);
  const size_t near = Near(top, At(1.0, 1.0), 0.8), far = Near(top, At(19.0, 19.0), 0.8);
  EXPECT_GT(far, 0u);
  EXPECT_GT(far * 2, near) << far << " " << near;
  EXPECT_GT(near * 2, far) << far << " " << near;

  // Hidden: no detail; shown again: planned again.
  project_.sessions[0].visible = false;
  layer_->Sync(project_, {{"s", cloud_}});
  EXPECT_EQ(layer_->detail_points(), 0u);
  EXPECT_EQ(view_->layer_points_drawn(), 0u);
  project_.sessions[0].visible = true;
  layer_->Sync(project_, {{"s", cloud_}});
  WaitForDetail();
  EXPECT_EQ(layer_->DetailPoints().size(), top.size());
}

// A cloud made without IndexForPicks (no boxes, no cubes) is neither
// planned for the camera nor unpickable: its every-k-th points stay at
// rest, and a pick tests its points one by one (it found none before).
TEST_F(ProjectDetailTest, ACloudWithoutItsIndexIsDrawnThinnedAndPickedPointByPoint) {
  auto bare = std::make_shared<ProjectCloud>();
  bare->id = "s";
  bare->positions = cloud_->positions;
  bare->bounds = cloud_->bounds;
  ASSERT_FALSE(IndexedForPicks(*bare));
  layer_->Sync(project_, {{"s", bare}});
  while (layer_->Pump()) {
  }
  view_->SetLodActive(true);
  view_->SetLodActive(false);
  WaitForDetail();
  EXPECT_EQ(layer_->detail_points(), 0u);
  EXPECT_EQ(view_->layer_points_drawn(), layer_->drawn_points());  // the pieces' rest level
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> v(-1.0, 1.0);
  size_t hits = 0;
  for (int r = 0; r < 40; ++r) {
    CloudView::PickRay ray;
    ray.origin = Eigen::Vector3d(10.0 + 8.0 * v(rng), 10.0 + 8.0 * v(rng), 3.0);
    const Eigen::Vector3d target = *session_.project_from_session *
                                   bare->positions[rng() % bare->positions.size()].cast<double>();
    ray.direction = (target - ray.origin).normalized();
    ray.tolerance_per_t = 0.001;
    const double expected =
        testing::NearestAlongRay(bare->positions, *session_.project_from_session, ray);
    double t = std::numeric_limits<double>::infinity();
    PickHit hit;
    ASSERT_TRUE(layer_->Pick(ray, &t, &hit)) << r;
    EXPECT_NEAR(t, expected, 1e-9) << r;
    hits += hit.layer == "s";
  }
  EXPECT_EQ(hits, 40u);
}

// The plan itself: cubes out of view draw nothing, the clip in the
// project's frame hides what is above it through a tilted pose, and a
// budget above the points in view draws them all.
TEST(ProjectDetailPlanTest, CubesOutOfViewAndAboveTheClipDrawNothing) {
  ProjectCloud cloud;
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  // Pieces of 64 points a few centimetres across, anywhere in 10 x 10 x 3 m.
  for (int piece = 0; piece < 3200; ++piece) {
    const Eigen::Vector3f c(10.0f * u(rng), 10.0f * u(rng), 3.0f * u(rng));
    for (int k = 0; k < 64; ++k)
      cloud.positions.push_back(c + 0.04f * Eigen::Vector3f(u(rng), u(rng), u(rng)));
  }
  IndexForPicks(&cloud);
  DetailSession session{
      &cloud, Rigid3d(Eigen::Vector3d(5.0, 0.0, 1.0),
                      Eigen::Quaterniond(Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitX())))};
  // A box-shaped "frustum": x in [5, 10] of the project's frame, all y and z.
  DetailCamera camera;
  const double planes[24] = {1, 0,  0, -5,  -1, 0, 0, 10, 0, 1, 0, 1e3,
                             0, -1, 0, 1e3, 0,  0, 0, 0,  0, 0, 0, 0};
  std::copy(planes, planes + 24, camera.planes.begin());
  camera.eye = Eigen::Vector3d(7.5, 5.0, 20.0);
  camera.clip_z = 2.5;
  const std::vector<std::vector<uint32_t>> all = PlanDetail({session}, camera, 10'000'000);
  ASSERT_EQ(all.size(), 1u);
  size_t in_view = 0;
  for (const Eigen::Vector3f& p : cloud.positions) {
    const Eigen::Vector3d w = session.project_from_session * p.cast<double>();
    in_view += w.x() >= 5.0 && w.x() <= 10.0 && w.z() <= 2.5;
  }
  // Every point in view, and only whole cubes' worth beyond (a cube is
  // planned whole: at most a cube's side, 0.5 m, outside either bound).
  size_t inside = 0;
  for (uint32_t i : all[0]) {
    const Eigen::Vector3d w = session.project_from_session * cloud.positions[i].cast<double>();
    EXPECT_GT(w.x(), 5.0 - 0.9);
    EXPECT_LT(w.x(), 10.0 + 0.9);
    EXPECT_LT(w.z(), 2.5 + 0.9);
    inside += w.x() >= 5.0 && w.x() <= 10.0 && w.z() <= 2.5;
  }
  EXPECT_EQ(inside, in_view);
  EXPECT_TRUE(std::is_sorted(all[0].begin(), all[0].end()));
  // Under a budget: about the budget.
  const std::vector<std::vector<uint32_t>> some = PlanDetail({session}, camera, 20000);
  EXPECT_LE(some[0].size(), 20000u * 11 / 10);
  EXPECT_GE(some[0].size(), 20000u / 2);
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
