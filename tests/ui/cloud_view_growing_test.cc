// The view's growing chunk as points stream in (CloudView::AppendPoints,
// the live path): batches of uneven sizes, one filling a chunk exactly and
// one crossing into the next, are drawn point for point with their colour
// scalars exact (height, time, range), VTK's cells the points the pass
// filter shows (new points not drawn while a filter is on, drawn again
// with it off), and a NaN first height leaves the colours' range finite,
// under a real display (xvfb-run in CI).
#include <gtest/gtest.h>

#include <QtTest>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "tests/ui/app_fixture.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

using Xyz = std::array<float, 3>;

std::vector<Xyz> Sorted(const std::vector<CloudPoint>& points) {
  std::vector<Xyz> out;
  for (const CloudPoint& p : points) out.push_back({p.x, p.y, p.z});
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Xyz> Sorted(const std::vector<Eigen::Vector3f>& points) {
  std::vector<Xyz> out;
  for (const Eigen::Vector3f& p : points) out.push_back({p.x(), p.y(), p.z()});
  std::sort(out.begin(), out.end());
  return out;
}

// Points of a 6 x 4 x 2.7 m room, each distinct, in time order from t0.
std::vector<CloudPoint> RoomPoints(size_t n, size_t first, std::mt19937* rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<CloudPoint> points(n);
  for (size_t i = 0; i < n; ++i) {
    CloudPoint& p = points[i];
    p.x = 6 * u(*rng), p.y = 4 * u(*rng), p.z = 2.7f * u(*rng);
    p.range_m = 0.5f + 5 * u(*rng);
    p.time_ns = 1'000'000'000'000 + static_cast<int64_t>(first + i) * 200'000;
    p.scan = static_cast<uint32_t>((first + i) / 720);
  }
  return points;
}

// Each drawn point's scalar is the value of the point at that position.
void ExpectScalars(const CloudView& view, const std::vector<CloudPoint>& cloud, int mode) {
  std::vector<float> scalars;
  const std::vector<Eigen::Vector3f> drawn = view.DrawnPoints(&scalars);
  ASSERT_EQ(drawn.size(), cloud.size());
  std::vector<std::pair<Xyz, float>> want, got;
  for (const CloudPoint& p : cloud) {
    const float t = static_cast<float>((p.time_ns - cloud.front().time_ns) * 1e-9);
    want.push_back({{p.x, p.y, p.z}, mode == 0 ? p.z : mode == 1 ? t : p.range_m});
  }
  for (size_t k = 0; k < drawn.size(); ++k) {
    got.push_back({{drawn[k].x(), drawn[k].y(), drawn[k].z()}, scalars[k]});
  }
  std::sort(want.begin(), want.end());
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, want) << "colour mode " << mode;
}

TEST(CloudViewGrowingTest, StreamedPointsAreDrawnExactlyWithTheirScalarsAndThePassFilter) {
  CloudView view;
  view.resize(400, 300);
  view.show();
  ASSERT_TRUE(QTest::qWaitForWindowExposed(&view));
  // Everything at full resolution: no motion level while points stream.
  view.SetLodBudget(10'000'000);
  view.SetRestBudget(10'000'000);
  std::mt19937 rng(11);
  std::vector<CloudPoint> cloud;
  // 1 + 7 + 1 000 + the rest of the first chunk: full exactly; then 3,
  // then 70 000 across the second chunk's end into a third.
  const size_t k = CloudView::kChunkPoints;
  for (size_t n : {size_t{1}, size_t{7}, size_t{1000}, k - 1008, size_t{3}, size_t{70000}}) {
    const std::vector<CloudPoint> batch = RoomPoints(n, cloud.size(), &rng);
    view.AppendPoints(batch);
    cloud.insert(cloud.end(), batch.begin(), batch.end());
    view.RenderNow();
    ASSERT_EQ(view.point_count(), cloud.size());
    ASSERT_EQ(Sorted(view.BatchedPoints()), Sorted(cloud)) << "after a batch of " << n;
  }
  EXPECT_EQ(view.chunk_count(), 3u);  // Two sealed, one growing.
  // The whole room in view (the rest level's plans draw what is in view),
  // planned for it.
  view.ViewOblique();
  view.RenderNow();
  view.SetLodActive(true);
  view.SetLodActive(false);
  ASSERT_EQ(Sorted(view.DrawnPoints()), Sorted(cloud));
  for (int mode : {1, 2, 0}) {
    view.SetColorMode(static_cast<CloudView::ColorMode>(mode));
    view.SetLodActive(false);  // Time and range: the rest level built again, at once.
    ExpectScalars(view, cloud, mode);
  }

  // Pass B alone: every third point from the first.
  std::vector<float> pass(cloud.size());
  std::vector<CloudPoint> pass_b;
  for (size_t i = 0; i < cloud.size(); ++i) {
    pass[i] = i % 3 == 0 ? 1.0f : i % 3 == 1 ? 0.0f : std::numeric_limits<float>::quiet_NaN();
    if (i % 3 == 0) pass_b.push_back(cloud[i]);
  }
  view.SetPointValues(CloudView::ColorMode::kPass, pass);
  view.SetColorMode(CloudView::ColorMode::kPass);
  EXPECT_EQ(view.color_bar_categories(), QStringList({"pass A (near side)", "pass B (far side)"}));
  const QColor cyan = view.ColorOfValue(0.0), magenta = view.ColorOfValue(1.0);
  EXPECT_EQ(cyan.rgb(), QColor::fromRgbF(0.0, 0.78, 1.0).rgb());  // 8 bits a channel, as drawn
  EXPECT_EQ(magenta.rgb(), QColor::fromRgbF(1.0, 0.24, 0.78).rgb());
  view.SetPassFilter(1);
  view.RenderNow();
  EXPECT_EQ(Sorted(view.BatchedPoints()), Sorted(pass_b));
  // The bar names the pass shown, not both beside one pass's points, and
  // the pass keeps its colour (pass B alone was drawn in pass A's cyan).
  EXPECT_EQ(view.color_bar_categories(), QStringList({"pass B (far side)"}));
  EXPECT_EQ(view.ColorOfValue(1.0).rgb(), magenta.rgb());
  view.SetPassFilter(0);
  EXPECT_EQ(view.color_bar_categories(), QStringList({"pass A (near side)"}));
  EXPECT_EQ(view.ColorOfValue(0.0).rgb(), cyan.rgb());
  view.SetPassFilter(1);
  view.RenderNow();
  // New points have no pass: not drawn while the filter is on ...
  std::vector<CloudPoint> batch = RoomPoints(500, cloud.size(), &rng);
  view.AppendPoints(batch);
  cloud.insert(cloud.end(), batch.begin(), batch.end());
  view.RenderNow();
  EXPECT_EQ(Sorted(view.BatchedPoints()), Sorted(pass_b));
  // ... and every point again with it off, the points streamed after too.
  view.SetPassFilter(-1);
  EXPECT_EQ(view.color_bar_categories().size(), 2);
  batch = RoomPoints(2000, cloud.size(), &rng);
  view.AppendPoints(batch);
  cloud.insert(cloud.end(), batch.begin(), batch.end());
  view.RenderNow();
  EXPECT_EQ(Sorted(view.BatchedPoints()), Sorted(cloud));
}

// A first batch whose first point has a NaN height (a chunk may hold one):
// the height colours span the other points' heights (the range started
// from the batch's first point, and a NaN start left it NaN for the
// session).
TEST(CloudViewGrowingTest, ANanFirstHeightLeavesTheColourRangeFinite) {
  CloudView view;
  std::mt19937 rng(7);
  std::vector<CloudPoint> points = RoomPoints(20000, 0, &rng);
  for (CloudPoint& p : points) p.z += 10.0f;  // A room on an upper floor: not the default span.
  points[0].z = std::numeric_limits<float>::quiet_NaN();
  view.AppendPoints(points);
  const std::array<double, 2> range = view.color_range();
  EXPECT_EQ(range[0], 10.0);  // The floor: the decimetre below the lowest point.
  EXPECT_TRUE(std::isfinite(range[1]));
  EXPECT_GE(range[1], 12.7);
}

// A room's floor a few millimetres below 0 (its noise) and its ceiling at
// 3.3 m: the height bar spans -0.1 to 3.5 m, not -1 to 6 m (whole metres
// down, doubling up), so the room's colours use the whole map.
TEST(CloudViewGrowingTest, HeightColoursSpanTheRoomToTheDecimetreAndHalfMetre) {
  CloudView view;
  std::mt19937 rng(8);
  std::vector<CloudPoint> points = RoomPoints(20000, 0, &rng);
  points[10].z = 3.3f;
  view.AppendPoints(points);
  points = RoomPoints(20000, points.size(), &rng);
  points[5].z = -0.004f;
  view.AppendPoints(points);
  const std::array<double, 2> range = view.color_range();
  EXPECT_DOUBLE_EQ(range[0], -0.1);
  EXPECT_DOUBLE_EQ(range[1], 3.5);
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
