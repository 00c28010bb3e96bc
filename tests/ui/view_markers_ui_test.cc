// The cloud view's markers, as an operator finds them:
// * the picks' labels ("A1", "B1": a pair's number beside each marker),
//   drawn over the view beside their markers (CloudView::SetMarkers, placed
//   before each frame by LayoutOverlayLabels): as texts in the scene they
//   were cut by the walls in front of them;
// * the robot, a white chevron along its heading that a view of the whole
//   room shows at a glance (it was a thin arrow in the path's orange).
// * VTK's one-letter keys do nothing in the view: its style switch turned
//   the camera into a joystick ('j'), drew a red box round a pick ('p') and
//   reset the camera ('r') as an operator typed.
// A standalone CloudView under a real display (xvfb-run in CI).
#include <gtest/gtest.h>
#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCommand.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkInteractorStyle.h>
#include <vtkPropCollection.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>

#include <QApplication>
#include <QImage>
#include <QLineF>
#include <QMouseEvent>
#include <QTest>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <memory>
#include <vector>

#include "tests/ui/app_fixture.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

// Pixels of `color` (within 40 a channel) in `box` (widget pixels).
int PixelsOf(CloudView* view, const QRectF& box, const QColor& color) {
  const QImage image = view->GrabImage().convertToFormat(QImage::Format_RGB32);
  const double sx = image.width() / static_cast<double>(view->width());
  int count = 0;
  for (int y = static_cast<int>(box.top() * sx); y < static_cast<int>(box.bottom() * sx); ++y) {
    for (int x = static_cast<int>(box.left() * sx); x < static_cast<int>(box.right() * sx); ++x) {
      if (x < 0 || y < 0 || x >= image.width() || y >= image.height()) continue;
      const QRgb c = image.pixel(x, y);
      count += std::abs(qRed(c) - color.red()) < 40 && std::abs(qGreen(c) - color.green()) < 40 &&
                       std::abs(qBlue(c) - color.blue()) < 40
                   ? 1
                   : 0;
    }
  }
  return count;
}

// A 640 x 480 view, shown.
std::unique_ptr<CloudView> Shown() {
  auto view = std::make_unique<CloudView>();
  view->resize(640, 480);
  view->show();
  EXPECT_TRUE(QTest::qWaitForWindowExposed(view.get()));
  return view;
}

// 201 x 201 points, the (i, k)th at `at(i, k)`.
std::vector<CloudPoint> Grid(const std::function<Eigen::Vector3f(int, int)>& at) {
  std::vector<CloudPoint> points;
  for (int i = 0; i <= 200; ++i) {
    for (int k = 0; k <= 200; ++k) {
      const Eigen::Vector3f v = at(i, k);
      CloudPoint p;
      p.x = v.x();
      p.y = v.y();
      p.z = v.z();
      points.push_back(p);
    }
  }
  return points;
}

TEST(ViewMarkersTest, ALabelBehindAWallIsDrawnOverItBesideItsMarker) {
  std::unique_ptr<CloudView> view = Shown();
  // A wall across x = 2 m, 2 m wide and high, every centimetre: coloured
  // by height, blue to red, no white in it.
  view->AppendPoints(
      Grid([](int i, int k) { return Eigen::Vector3f(2.0f, -1.0f + 0.01f * i, 0.01f * k); }));
  view->SetColorBarVisible(false);
  // From x = 0 towards +x at 1 m: the wall fills the middle of the view,
  // and a pick 1 m behind it, in white, labelled.
  view->LookAt(Eigen::Vector3d(3, 0, 1), Eigen::Vector3d(0, 0, 1));
  const QColor white(255, 255, 255);
  const Eigen::Vector3d behind(3.0, -0.1, 0.9);
  view->SetMarkers({CloudView::Marker(behind, white, false, QStringLiteral("A1"))});
  view->RenderNow();

  ASSERT_EQ(view->marker_label_boxes().size(), 1u);
  const QRectF box = view->marker_label_boxes()[0];
  // Right of the marker and above it, a few pixels off the dot.
  const QPointF marker = view->WorldToWidget(behind);
  EXPECT_GT(box.left(), marker.x() + 4.0) << box.left() << " " << marker.x();
  EXPECT_LT(box.left(), marker.x() + 16.0) << box.left() << " " << marker.x();
  EXPECT_LT(box.bottom(), marker.y()) << box.bottom() << " " << marker.y();
  EXPECT_GT(box.bottom(), marker.y() - 16.0) << box.bottom() << " " << marker.y();
  // Its text in the marker's white, over the wall (in the scene, the wall
  // hid it all).
  EXPECT_GT(PixelsOf(view.get(), box, white), 15);

  // A marker behind the camera, or off the view: no label.
  view->SetMarkers({CloudView::Marker(Eigen::Vector3d(-1, 0, 1), white, false, "A1"),
                    CloudView::Marker(Eigen::Vector3d(3, 30, 1), white, false, "B1")});
  view->RenderNow();
  EXPECT_TRUE(view->marker_label_boxes().empty());
  view->SetMarkers({});
  view->RenderNow();
  EXPECT_TRUE(view->marker_label_boxes().empty());
  EXPECT_EQ(PixelsOf(view.get(), box, white), 0);
}

// The robot seen from above over a 4 m floor coloured by height: its
// chevron covers at least half its 0.10 m² in white pixels, its tip ahead
// of it along the heading and nothing white behind.
TEST(ViewMarkersTest, TheRobotIsAWhiteChevronAlongItsHeading) {
  std::unique_ptr<CloudView> view = Shown();
  view->AppendPoints(Grid([](int i, int k) {
    return Eigen::Vector3f(0.02f * i, 0.02f * k, 0.001f * ((i * 7 + k * 3) % 10));  // 1 cm of noise
  }));
  view->SetColorBarVisible(false);
  const QColor white(250, 250, 250);
  for (const double yaw : {0.0, M_PI / 2}) {
    view->SetRobotPose(Pose2d{2.0, 2.0, yaw});
    view->ViewTop();
    view->RenderNow();
    const Eigen::Vector3d at(2.0, 2.0, 0.1), heading(std::cos(yaw), std::sin(yaw), 0.0);
    const QPointF centre = view->WorldToWidget(at);
    const double px_per_m =
        QLineF(centre, view->WorldToWidget(at + Eigen::Vector3d::UnitX())).length();
    ASSERT_GT(px_per_m, 50.0);
    const QRectF around(centre - QPointF(0.5 * px_per_m, 0.5 * px_per_m),
                        QSizeF(px_per_m, px_per_m));
    EXPECT_GT(PixelsOf(view.get(), around, white), 0.5 * 0.103 * px_per_m * px_per_m) << yaw;
    const auto white_near = [&](const Eigen::Vector3d& p) {
      const QPointF q = view->WorldToWidget(p);
      return PixelsOf(view.get(), QRectF(q - QPointF(2, 2), QSizeF(4, 4)), white);
    };
    EXPECT_GT(white_near(at + 0.30 * heading), 0) << "the tip, at " << yaw;
    EXPECT_EQ(white_near(at - 0.45 * heading), 0) << "behind, at " << yaw;
  }
}

// Typed with the view focused and the cursor on the cloud, VTK's letters
// leave the scene and the camera as they were, and a drag still orbits.
TEST(ViewKeysTest, VtksOneLetterKeysLeaveTheViewAsItWas) {
  std::unique_ptr<CloudView> view = Shown();
  view->AppendPoints(
      Grid([](int i, int k) { return Eigen::Vector3f(2.0f, -1.0f + 0.01f * i, 0.01f * k); }));
  view->LookAt(Eigen::Vector3d(-1, -0.5, 1.5), Eigen::Vector3d(2, 0, 1));
  view->RenderNow();
  vtkRenderer* renderer = view->renderWindow()->GetRenderers()->GetFirstRenderer();
  vtkCamera* camera = renderer->GetActiveCamera();
  const int props = renderer->GetViewProps()->GetNumberOfItems();
  double before[3];
  camera->GetPosition(before);
  view->setFocus();
  QTest::mouseMove(view.get(), QPoint(320, 240));
  for (const char key : {'j', 'p', 'r', 'u', 'l', 't', 'e', 'q'}) QTest::keyClick(view.get(), key);
  view->RenderNow();
  EXPECT_EQ(renderer->GetViewProps()->GetNumberOfItems(), props);  // no pick box
  double after[3];
  camera->GetPosition(after);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(after[k], before[k]) << k;  // no reset
  EXPECT_TRUE(view->interactor()->GetInteractorStyle()->IsA("vtkInteractorStyleTrackballCamera"));
  // A left drag orbits: the camera moves round the focal point, as far
  // from it as before, and the interactor says an interaction started.
  const double distance = camera->GetDistance();
  int started = 0;
  auto count = vtkSmartPointer<vtkCallbackCommand>::New();
  count->SetClientData(&started);
  count->SetCallback([](vtkObject*, unsigned long, void* n, void*) { ++*static_cast<int*>(n); });
  view->interactor()->AddObserver(vtkCommand::StartInteractionEvent, count);
  QTest::mousePress(view.get(), Qt::LeftButton, Qt::NoModifier, QPoint(320, 240));
  for (int x = 325; x <= 400; x += 5) {
    QMouseEvent move(QEvent::MouseMove, QPointF(x, 240), Qt::LeftButton, Qt::LeftButton,
                     Qt::NoModifier);
    QApplication::sendEvent(view.get(), &move);
  }
  EXPECT_EQ(started, 1);  // the interaction the view's motion level follows
  QTest::mouseRelease(view.get(), Qt::LeftButton, Qt::NoModifier, QPoint(400, 240));
  camera->GetPosition(after);
  EXPECT_GT(std::hypot(after[0] - before[0], after[1] - before[1]), 0.3);
  EXPECT_NEAR(camera->GetDistance(), distance, 1e-6 * distance);
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
