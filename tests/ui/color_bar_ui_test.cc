// The cloud view's colour bar laid out before each frame (CloudView::
// LayoutColorBar, ui/view/cloud_view_overlays.cc): its texts are measured
// only when something they depend on changed (the view's size, the colour
// mode's title and categories), and the layout is then the one a view
// drawn afresh in that state has. A standalone CloudView under a real
// display (xvfb-run in CI).
#include <gtest/gtest.h>

#include <QApplication>
#include <QTest>
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "tests/ui/app_fixture.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

// A 4 m x 3 m room's floor and walls, 2.5 m high.
std::vector<CloudPoint> Room() {
  std::vector<CloudPoint> points;
  for (int i = 0; i < 40; ++i) {
    for (int k = 0; k < 25; ++k) {
      CloudPoint p;
      p.x = 0.1f * i;
      p.y = k % 2 == 0 ? 0.0f : 3.0f;
      p.z = 0.1f * k;
      p.range_m = 1.0f + 0.05f * i;
      p.time_ns = int64_t{1'000'000} * (i * 25 + k);
      points.push_back(p);
    }
  }
  return points;
}

// A view of the room in `mode`, `width` x 480, drawn.
std::unique_ptr<CloudView> Drawn(CloudView::ColorMode mode, int width) {
  auto view = std::make_unique<CloudView>();
  view->resize(width, 480);
  view->show();
  EXPECT_TRUE(QTest::qWaitForWindowExposed(view.get()));
  view->AppendPoints(Room());
  if (mode == CloudView::ColorMode::kPass) {
    std::vector<float> pass(view->point_count());
    for (size_t i = 0; i < pass.size(); ++i) pass[i] = static_cast<float>(i % 2);
    view->SetPointValues(mode, pass);
  }
  view->SetColorMode(mode);
  view->RenderNow();
  return view;
}

TEST(ColorBarTest, AFrameWithNothingChangedMeasuresNoText) {
  std::unique_ptr<CloudView> view = Drawn(CloudView::ColorMode::kHeight, 640);
  ASSERT_TRUE(view->color_bar_drawn());
  const uint64_t first = view->color_bar_measures();
  EXPECT_GT(first, 0u);
  const QRectF box = view->color_bar_box();
  for (int i = 0; i < 20; ++i) view->RenderNow();
  EXPECT_EQ(view->color_bar_measures(), first);
  EXPECT_EQ(view->color_bar_box(), box);

  // What the layout depends on, changed: measured again, and laid out as a
  // view drawn afresh in that state is.
  std::vector<float> pass(view->point_count());
  for (size_t i = 0; i < pass.size(); ++i) pass[i] = static_cast<float>(i % 2);
  view->SetPointValues(CloudView::ColorMode::kPass, pass);
  view->SetColorMode(CloudView::ColorMode::kPass);  // another title, two categories
  view->RenderNow();
  const uint64_t pass_measures = view->color_bar_measures();
  EXPECT_GT(pass_measures, first);
  EXPECT_EQ(view->color_bar_box(), Drawn(CloudView::ColorMode::kPass, 640)->color_bar_box());
  EXPECT_LT(view->color_bar_box().left(), box.left() - 20.0);  // the names left of the swatches
  view->RenderNow();
  EXPECT_EQ(view->color_bar_measures(), pass_measures);

  view->resize(260, 480);  // narrow: the title moves the bar left to fit
  QApplication::processEvents();
  view->RenderNow();
  EXPECT_GT(view->color_bar_measures(), pass_measures);
  EXPECT_EQ(view->color_bar_box(), Drawn(CloudView::ColorMode::kPass, 260)->color_bar_box());
  EXPECT_LE(view->color_bar_box().right(), 260.0);
}

// Key 1 on a long room in a view taller than wide (the app's, beside its
// panels): ResetCamera alone fits the room to the view's whole width, and
// its east end was under the bar (the review's Top view). Fitted into the
// part left of the bar instead, and filling it.
TEST(ColorBarTest, TopViewFitsTheCloudLeftOfTheBar) {
  auto view = std::make_unique<CloudView>();
  view->resize(480, 640);
  view->show();
  ASSERT_TRUE(QTest::qWaitForWindowExposed(view.get()));
  // A 12 m x 3 m room's floor and ceiling, 2.5 m high, every 0.1 m.
  std::vector<CloudPoint> points;
  for (int i = 0; i <= 120; ++i) {
    for (int k = 0; k <= 30; ++k) {
      for (float z : {0.0f, 2.5f}) {
        CloudPoint p;
        p.x = 0.1f * i;
        p.y = 0.1f * k;
        p.z = z;
        points.push_back(p);
      }
    }
  }
  view->AppendPoints(points);
  view->SetColorMode(CloudView::ColorMode::kHeight);
  // The room's extent across the view, its corners drawn where expected.
  auto across = [&](const QRectF& bar) {
    double left = HUGE_VAL, right = -HUGE_VAL;
    for (float x : {0.0f, 12.0f}) {
      for (float y : {0.0f, 3.0f}) {
        for (float z : {0.0f, 2.5f}) {  // the ceiling, nearer the eye, is drawn larger
          const QPointF at = view->WorldToWidget(Eigen::Vector3d(x, y, z));
          EXPECT_TRUE(QRectF(view->rect()).contains(at)) << x << " " << y << " " << z;
          if (!bar.isEmpty()) {
            EXPECT_LT(at.x(), bar.left()) << x << " " << y << " " << z;
          }
          left = std::min(left, at.x());
          right = std::max(right, at.x());
        }
      }
    }
    return std::make_pair(left, right);
  };

  view->ViewTop();
  view->RenderNow();
  const QRectF bar = view->color_bar_box();
  ASSERT_FALSE(bar.isEmpty());
  const auto [left, right] = across(bar);
  EXPECT_GT(right - left, 0.95 * (bar.left() - 16.0));  // the free part, less its margins

  // The bar hidden: the view's whole width, past where the bar was.
  view->SetColorBarVisible(false);
  view->ViewTop();
  view->RenderNow();
  EXPECT_GT(across(QRectF()).second, bar.left() + 20.0);
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
