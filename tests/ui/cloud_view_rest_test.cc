// The view's rest level follows the camera and the clip however they are
// set: after a placement without the mouse (View > Top, LookAt, as the menus and the
// room view do) the app's render tick goes to the motion level and the
// settle timer plans the rest level again for the new camera, as after a
// drag. Before, the rest level kept the old camera's plan: zoomed into one
// corner and then View > Top, the far corner stayed at the handful of
// points the corner view gave it. Under a real display (xvfb-run in CI).
#include <gtest/gtest.h>

#include <QElapsedTimer>
#include <QtTest>
#include <limits>
#include <vector>

#include "tests/ui/app_fixture.h"
#include "tests/ui/random_floor.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

// A 20 x 20 m floor of random points (every chunk spans it), in time order.
std::vector<CloudPoint> Floor(size_t n) { return testing::RandomFloor(n, 20.0f, 5); }

// The app's render tick (MainWindow's timer) until the view is back at rest
// with its passes drawn.
void TickUntilRest(CloudView* view) {
  QElapsedTimer clock;
  clock.start();
  bool moved = false;
  while (clock.elapsed() < 20000) {
    QTest::qWait(20);
    view->RenderIfDirty();
    moved = moved || view->lod_active();
    if (moved && !view->lod_active() && !view->drawing_passes()) return;
  }
  FAIL() << "the view did not come back to rest";
}

// A small view on screen with small budgets: motion 20 000, rest 100 000.
void ShowSmall(CloudView* view) {
  view->resize(400, 300);
  view->show();
  ASSERT_TRUE(QTest::qWaitForWindowExposed(view));
  view->SetLodBudget(20000);
  view->SetRestBudget(100000);
}

size_t InCorner(const std::vector<Eigen::Vector3f>& points) {
  size_t n = 0;
  for (const Eigen::Vector3f& p : points) n += p.x() > 15.0f && p.y() > 15.0f;
  return n;
}

TEST(CloudViewRestTest, APlacementWithoutTheMousePlansTheRestLevelForTheNewCamera) {
  CloudView view;
  ASSERT_NO_FATAL_FAILURE(ShowSmall(&view));
  view.AppendPoints(Floor(1'500'000));
  TickUntilRest(&view);

  // Close over the opposite corner: the far corner gets few points.
  view.LookAt(Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(1, 0.99, 2));
  TickUntilRest(&view);
  const size_t corner_view = InCorner(view.DrawnPoints());

  // View > Top (the menu's slot): the whole floor planned afresh.
  view.ViewTop();
  TickUntilRest(&view);
  const std::vector<Eigen::Vector3f> top = view.DrawnPoints();
  // What planning at once for this camera draws (as Budget changes do).
  view.SetLodActive(true);
  view.SetLodActive(false);
  const std::vector<Eigen::Vector3f> planned = view.DrawnPoints();
  EXPECT_EQ(top.size(), planned.size());
  EXPECT_EQ(InCorner(top), InCorner(planned));
  // From above, the far corner holds its share: a sixteenth of the floor.
  EXPECT_GT(InCorner(top), planned.size() / 32);
  EXPECT_GT(InCorner(top), 2 * corner_view) << corner_view;
}

// Hide Ceiling off: the rest level planned under the clip left the cubes
// above it out; it is planned again without the clip, so the ceiling comes
// back at rest (it stayed away until the camera moved).
TEST(CloudViewRestTest, AClipTakenAwayPlansTheRestLevelAgain) {
  std::vector<CloudPoint> points = Floor(600'000);
  // Half of it a ceiling, in runs as scan lines cross it.
  for (size_t i = 0; i < points.size(); ++i) points[i].z = (i / 1000) % 2 == 0 ? 2.5f : 0.0f;
  CloudView view;
  ASSERT_NO_FATAL_FAILURE(ShowSmall(&view));
  view.SetClipHeight(2.0);
  view.AppendPoints(points);
  TickUntilRest(&view);
  const auto ceiling = [&] {
    size_t n = 0;
    for (const Eigen::Vector3f& p : view.DrawnPoints()) n += p.z() > 2.0f;
    return n;
  };
  // Above the clip, hardly more than the motion level's points (the rest
  // level holds them too; the clip hides them).
  const size_t clipped = ceiling();
  EXPECT_LE(clipped, 20000u);
  view.SetClipHeight(std::numeric_limits<double>::quiet_NaN());
  TickUntilRest(&view);
  EXPECT_GT(ceiling(), 2 * clipped + 10000) << clipped;  // Half the budget's, about 50 000.
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
