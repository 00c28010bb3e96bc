// The cloud view's colour bar laid out before each frame (CloudView::
// LayoutColorBar, ui/view/cloud_view_overlays.cc): its texts are measured
// only when something they depend on changed (the view's size, the colour
// mode's title and categories), and the layout is then the one a view
// drawn afresh in that state has. A standalone CloudView under a real
// display (xvfb-run in CI).
#include <gtest/gtest.h>

#include <QApplication>
#include <QTest>
#include <cmath>
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

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
