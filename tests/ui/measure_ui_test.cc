// The distance tool through real Shift + clicks on a replayed session, and
// where a click's point goes: its point comes back from the view's pick
// thread after the click, and goes to the mode the click was made in (the
// distance tool or the calibration's picks), not to whatever is on by then.
#include <gtest/gtest.h>

#include <QAction>
#include <QImage>
#include <QTest>
#include <QUndoStack>
#include <cmath>
#include <vector>

#include "core/cloud/cloud.h"
#include "tests/ui/app_fixture.h"
#include "tests/ui/pick_truth.h"
#include "ui/panels/calibration_panel.h"
#include "ui/view/cloud_view.h"
#include "ui/workspace/workspace.h"

namespace sweepscan::ui {
namespace {

using testing::WaitFor;

class MeasureTest : public testing::AppFixture {
 protected:
  // The lab session replayed and seen from above with everything over
  // 10 cm hidden: the floor. Its points, and the floor's two points
  // farthest apart along x and one halfway between.
  void SetUpFloor() {
    ASSERT_NO_FATAL_FAILURE(SimulateLabSession());
    ASSERT_NO_FATAL_FAILURE(OpenAndReplay(tmp_.path() + "/lab.sweepscan"));
    cloud_ = workspace_->CloudSnapshot().Flatten();
    view_ = window_->view();
    ASSERT_TRUE(WaitFor([&] { return view_->point_count() == cloud_.size(); }, 10000));
    view_->SetClipHeight(0.10);
    view_->ViewTop();
    view_->RenderNow();
    const CloudPoint* a = nullptr;
    const CloudPoint* b = nullptr;
    for (const CloudPoint& p : cloud_) {
      if (p.z > 0.02) continue;
      if (a == nullptr || p.x < a->x) a = &p;
      if (b == nullptr || p.x > b->x) b = &p;
    }
    ASSERT_TRUE(a != nullptr && b != nullptr);
    a_ = *a;
    b_ = *b;
    const CloudPoint* mid = nullptr;
    const double mid_x = 0.5 * (a_.x + b_.x);
    for (const CloudPoint& p : cloud_) {
      if (p.z <= 0.02 && (mid == nullptr || std::abs(p.x - mid_x) < std::abs(mid->x - mid_x))) {
        mid = &p;
      }
    }
    mid_ = *mid;
  }
  QPoint At(const CloudPoint& p) const {
    return view_->WorldToWidget(Eigen::Vector3d(p.x, p.y, p.z)).toPoint();
  }

  std::vector<CloudPoint> cloud_;
  CloudView* view_ = nullptr;
  CloudPoint a_, b_, mid_;
};

// Two Shift + clicks on cloud points measure the distance between the
// points under the cursor.
TEST_F(MeasureTest, MeasuresTheDistanceBetweenTwoClickedPoints) {
  ASSERT_NO_FATAL_FAILURE(SetUpFloor());
  EXPECT_TRUE(view_->color_bar_drawn());  // a cloud coloured by height: its bar
  window_->measure_action()->setChecked(true);
  const int picks_before = window_->calibration_panel()->pair_count();
  Eigen::Vector3d picked[2];
  int k = 0;
  for (const CloudPoint* p : {&a_, &b_}) {
    ASSERT_TRUE(view_->PickPoint(At(*p), &picked[k]));
    ASSERT_TRUE(testing::ShiftClick(view_, At(*p)));
    ++k;
  }
  // The clicks measured; they did not add calibration picks.
  EXPECT_EQ(window_->calibration_panel()->pair_count(), picks_before);
  EXPECT_NEAR(window_->measured_distance(), (picked[1] - picked[0]).norm(), 1e-9);
  // A pixel or so from the wanted point (the top view is ~1 cm per pixel
  // here), or a wall's foot (below 10 cm) above it.
  const double truth = std::hypot(b_.x - a_.x, b_.y - a_.y);
  EXPECT_NEAR(window_->measured_distance(), truth, 0.15);
  EXPECT_GT(truth, 3.0);

  // The distance is written over the cloud at the segment's middle, in the
  // segment's magenta (the path is amber), whatever is in front of it.
  view_->ViewOblique();
  view_->RenderNow();
  const QRectF box = view_->measure_label_box();
  ASSERT_FALSE(box.isEmpty());
  const QPointF mid = view_->WorldToWidget(0.5 * (picked[0] + picked[1]));
  EXPECT_TRUE(box.adjusted(-2, -2, 2, 2).contains(mid)) << mid.x() << " " << mid.y();
  const QImage image = view_->GrabImage().convertToFormat(QImage::Format_RGB32);
  const double sx = image.width() / static_cast<double>(view_->width());
  int magenta = 0;
  for (int y = static_cast<int>(box.top() * sx); y < static_cast<int>(box.bottom() * sx); ++y) {
    for (int x = static_cast<int>(box.left() * sx); x < static_cast<int>(box.right() * sx); ++x) {
      const QRgb c = image.pixel(x, y);
      magenta += qRed(c) > 200 && qGreen(c) < 150 && qBlue(c) > 200 ? 1 : 0;
    }
  }
  EXPECT_GT(magenta, 20) << "the label's text";
  window_->measure_action()->setChecked(false);  // the tool off: the distance goes
  view_->RenderNow();
  EXPECT_TRUE(view_->measure_label_box().isEmpty());
}

// A click's point comes back after the click. The distance tool switched
// in between does not take a point clicked for the calibration, nor the
// calibration one clicked for the distance tool. The click's point is
// posted to the event loop, so nothing is delivered before the toggle
// below: the order is certain.
TEST_F(MeasureTest, AClickGoesToTheModeItWasMadeIn) {
  ASSERT_NO_FATAL_FAILURE(SetUpFloor());
  QUndoStack* calibration_undo = window_->session_undo_stack();
  const int edits = calibration_undo->count();

  // Clicked with the distance tool on, which is then switched off: the
  // point is no calibration pick (it was dropped: its mode ended).
  window_->measure_action()->setChecked(true);
  QTest::mouseClick(view_, Qt::LeftButton, Qt::ShiftModifier, At(mid_));
  ASSERT_EQ(view_->picks_in_flight(), 1);
  window_->measure_action()->setChecked(false);
  ASSERT_TRUE(WaitFor([&] { return view_->picks_in_flight() == 0; }, 30000));
  EXPECT_EQ(calibration_undo->count(), edits);
  EXPECT_EQ(window_->measured_distance(), 0.0);

  // Clicked for the calibration, the distance tool then switched on: a
  // calibration pick, not the first end of a distance.
  QTest::mouseClick(view_, Qt::LeftButton, Qt::ShiftModifier, At(mid_));
  window_->measure_action()->setChecked(true);
  ASSERT_TRUE(WaitFor([&] { return view_->picks_in_flight() == 0; }, 30000));
  EXPECT_EQ(calibration_undo->count(), edits + 1);
  // So the next two clicks measure between themselves (a stray end at the
  // middle would have made the distance from there to a_).
  Eigen::Vector3d picked[2];
  int k = 0;
  for (const CloudPoint* p : {&a_, &b_}) {
    ASSERT_TRUE(view_->PickPoint(At(*p), &picked[k++]));
    ASSERT_TRUE(testing::ShiftClick(view_, At(*p)));
  }
  EXPECT_NEAR(window_->measured_distance(), (picked[1] - picked[0]).norm(), 1e-9);
  EXPECT_EQ(calibration_undo->count(), edits + 1);
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
