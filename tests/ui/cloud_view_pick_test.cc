// A Shift + click is picked on the view's pick thread, not the GUI thread:
// the click returns at once, the point comes back through pointPicked, the
// same point CloudView::PickPoint finds, clicks answered in the order they
// were made; a pick of a cloud cleared meanwhile reports nothing, and a view
// closed with a pick in flight goes quietly. Under a real display
// (xvfb-run in CI).
#include <gtest/gtest.h>
#include <vtkActor.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkSmartPointer.h>

#include <QThread>
#include <QtTest>
#include <memory>
#include <vector>

#include "tests/testing/qt_wait.h"
#include "tests/ui/app_fixture.h"
#include "tests/ui/random_floor.h"
#include "tests/ui/pick_truth.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

using testing::WaitFor;

// A 10 x 10 m floor of random points at z = 0, in time order: four sealed
// chunks and a growing one.
std::vector<CloudPoint> Floor(size_t n) { return testing::RandomFloor(n, 10.0f, 11); }

void ShowFloor(CloudView* view) {
  view->resize(400, 300);
  view->show();
  ASSERT_TRUE(QTest::qWaitForWindowExposed(view));
  view->AppendPoints(Floor(300'000));
  ASSERT_GE(view->chunk_count(), 5u);
  view->ViewTop();
  view->RenderNow();
}

TEST(ShiftClickPickTest, AShiftClickIsPickedOnThePickThreadAndReportedInOrder) {
  CloudView view;
  ASSERT_NO_FATAL_FAILURE(ShowFloor(&view));
  // A layer whose owner notes where its snapshot is taken and where the
  // search runs (an empty actor: the layer has no point to offer).
  auto actor = vtkSmartPointer<vtkActor>::New();
  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  mapper->SetInputData(vtkSmartPointer<vtkPolyData>::New());
  actor->SetMapper(mapper);
  view.AddLayer(actor);
  QThread* snapshot_thread = nullptr;
  std::vector<QThread*> search_threads;
  view.SetLayerPicker([&] {
    snapshot_thread = QThread::currentThread();
    return LayerPick([&](const PickRay&, double*, PickHit*) {
      search_threads.push_back(QThread::currentThread());
      return false;
    });
  });
  std::vector<PickHit> hits;
  QObject::connect(&view, &CloudView::pointPicked, [&](const PickHit& h) { hits.push_back(h); });

  const QPoint a = view.WorldToWidget(Eigen::Vector3d(2.5, 3.0, 0.0)).toPoint();
  const QPoint b = view.WorldToWidget(Eigen::Vector3d(7.0, 6.5, 0.0)).toPoint();
  Eigen::Vector3d want_a, want_b;
  ASSERT_TRUE(view.PickPoint(a, &want_a));
  ASSERT_TRUE(view.PickPoint(b, &want_b));
  ASSERT_NE(want_a, want_b);
  search_threads.clear();

  QTest::mouseClick(&view, Qt::LeftButton, Qt::ShiftModifier, a);
  QTest::mouseClick(&view, Qt::LeftButton, Qt::ShiftModifier, b);
  // The clicks returned before their points were reported: the results
  // come back through the event loop.
  EXPECT_TRUE(hits.empty());
  EXPECT_EQ(view.picks_in_flight(), 2);
  ASSERT_TRUE(WaitFor([&] { return view.picks_in_flight() == 0; }, 30000));
  ASSERT_EQ(hits.size(), 2u);
  EXPECT_EQ(hits[0].world, want_a);  // In the clicks' order, each the true point.
  EXPECT_EQ(hits[1].world, want_b);
  EXPECT_TRUE(hits[0].layer.isEmpty());
  EXPECT_EQ(snapshot_thread, QThread::currentThread());  // Taken at the click...
  ASSERT_EQ(search_threads.size(), 2u);                  // ... searched on the pick thread.
  for (QThread* t : search_threads) EXPECT_NE(t, QThread::currentThread());
}

TEST(ShiftClickPickTest, APickOfAClearedCloudIsDroppedAndAClosedViewGoesQuietly) {
  auto view = std::make_unique<CloudView>();
  ASSERT_NO_FATAL_FAILURE(ShowFloor(view.get()));
  std::vector<PickHit> hits;
  QObject::connect(view.get(), &CloudView::pointPicked,
                   [&](const PickHit& h) { hits.push_back(h); });
  const QPoint at = view->WorldToWidget(Eigen::Vector3d(5.0, 5.0, 0.0)).toPoint();
  Eigen::Vector3d want;
  ASSERT_TRUE(view->PickPoint(at, &want));

  // Cleared before the pick came back: a point of the cloud that was is
  // not reported on the new one.
  QTest::mouseClick(view.get(), Qt::LeftButton, Qt::ShiftModifier, at);
  view->Clear();
  ASSERT_TRUE(WaitFor([&] { return view->picks_in_flight() == 0; }, 30000));
  EXPECT_TRUE(hits.empty());

  // The same click on a cloud there: reported.
  view->AppendPoints(Floor(300'000));
  view->RenderNow();
  ASSERT_TRUE(testing::ShiftClick(view.get(), at));
  ASSERT_EQ(hits.size(), 1u);
  EXPECT_EQ(hits[0].world, want);

  // Closed with a pick still searching: the view waits for it, and its
  // posted result goes with the view.
  QTest::mouseClick(view.get(), Qt::LeftButton, Qt::ShiftModifier, at);
  view.reset();
  testing::Pump(100);
  EXPECT_EQ(hits.size(), 1u);
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
