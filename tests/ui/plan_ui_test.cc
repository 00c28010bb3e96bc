// The plan view in the desktop app (docs/desktop-app.md, "Floor plan"),
// through the real widgets under a real display (xvfb-run in CI), on the
// office floor's drives (resources/scenarios/building_{a,b,c}.json)
// recorded by the CLI (pair picking: pair_picking_ui_test.cc):
//
// * View > Floor Plan of rooms a and b (b placed by the CLI): walls, doors
//   and room b's inner width 5.5 m from the dimensions; a new cut height;
//   Cancel; File > Export Floor Plan as SVG (read back as XML) and DXF (read
//   and audited by ezdxf through tests/tools/check_dxf.py); the event loop
//   never blocked while the plan is built.
// * A vertical section drawn on the plan with the mouse (Shift + drag; the
//   Section button's drag, which Esc drops) across rooms a and b: floor,
//   ceiling and walls where the office floor has them; rebuilt with a new
//   cut height; Export Section's SVG rendered by rsvg-convert. The dock is
//   grabbed to build/tests/plan_section_panel.png to look at.
// * Rooms of a hand-made plan drawn as a tinted fill with their names; plan_build.h's
//   vertical section of posed clouds against core/plan's.
// * Export… only with a plan; room names clear the dimensions and doors.
#include <gtest/gtest.h>

#include <QAction>
#include <QApplication>
#include <QCheckBox>
#include <QComboBox>
#include <QDockWidget>
#include <QDoubleSpinBox>
#include <QElapsedTimer>
#include <QFile>
#include <QFileDialog>
#include <QFileInfo>
#include <QImage>
#include <QJsonDocument>
#include <QJsonObject>
#include <QLabel>
#include <QLineEdit>
#include <QMenu>
#include <QMenuBar>
#include <QPolygonF>
#include <QPushButton>
#include <QSettings>
#include <QTest>
#include <QTimer>
#include <QToolButton>
#include <QTreeWidget>
#include <QUndoStack>
#include <QWheelEvent>
#include <QXmlStreamReader>
#include <algorithm>
#include <cmath>
#include <random>

#include "core/project/project.h"
#include "core/scenario/scenario.h"
#include "tests/testing/event_loop_turns.h"
#include "tests/ui/file_chooser.h"
#include "tests/ui/project_ui_fixture.h"
#include "ui/plan/plan_build.h"
#include "ui/plan/plan_canvas.h"
#include "ui/plan/plan_panel.h"
#include "ui/plan/section_canvas.h"
#include "ui/project/project_controller.h"
#include "ui/project/project_layer.h"
#include "ui/project/project_panel.h"
#include "ui/view/cloud_view.h"

namespace sweepscan::ui {
namespace {

using testing::kResources;
using testing::RunCommand;
using testing::StartOf;
using testing::WaitFor;

class PlanUiTest : public testing::ProjectUiFixture {
 protected:
  // The plan and section jobs built on the GUI thread would be one turn of hundreds of
  // ms of CPU (~570 for the rebuild of both); their turns are the panel's updates, 10-20
  // ms. The dock's first show renders the 3D view at its new size, a frame of the
  // project's clouds (96-155 ms of CPU alone, 260 in a CI run): judged apart.
  static void ExpectResponsive(const char* what, const testing::EventLoopTurns& t) {
    testing::ExpectResponsive(what, t, 250.0);
  }
  static void ExpectDockShown() {
    testing::ExpectResponsive("dock shown", testing::MeasureTurnsUntil([] { return false; }, 400),
                              500.0);
  }

  // View > Floor Plan on a and b (b placed by the CLI), its first plan built.
  PlanPanel* ShowPlanOfRoomsAB(const std::string& name) {
    OpenAndLoad(MakeProject(name, "project align --session b --to a"));
    PlanPanel* panel = window_->plan_panel();
    window_->findChild<QDockWidget*>("planDock")->toggleViewAction()->trigger();
    ExpectDockShown();
    ExpectResponsive("first plan",
                     Turns([&] { return panel->plans_built() == 1 && !panel->busy(); }, 60000));
    return panel;
  }
};

TEST_F(PlanUiTest, PlanOfTwoRoomsShowsWallsAndExports) {
  OpenAndLoad(MakeProject("plan", "project align --session b --to a"));
  PlanPanel* panel = window_->plan_panel();
  ASSERT_NE(panel, nullptr);
  EXPECT_FALSE(panel->isVisible());
  EXPECT_EQ(panel->plans_built(), 0u);  // Hidden: nothing built.
  // View > Floor Plan: the dock's action.
  auto* dock = window_->findChild<QDockWidget*>("planDock");
  ASSERT_NE(dock, nullptr);
  dock->toggleViewAction()->trigger();
  ASSERT_TRUE(panel->isVisible());
  EXPECT_DOUBLE_EQ(panel->height_box()->value(), 1.0);
  EXPECT_DOUBLE_EQ(panel->band_box()->value(), 0.05);
  ExpectDockShown();
  ExpectResponsive("plan",
                   Turns([&] { return panel->plans_built() == 1 && !panel->busy(); }, 60000));
  std::printf("%s\n", panel->summary_label()->text().toStdString().c_str());

  ASSERT_TRUE(panel->canvas()->plan().has_value());
  const plan::FloorPlan& p = *panel->canvas()->plan();
  EXPECT_DOUBLE_EQ(p.height_m, 1.0);
  EXPECT_GT(p.section.points_in, 500000u);  // Both sessions' points.
  EXPECT_GE(p.walls.size(), 4u);
  for (const plan::Wall& w : p.walls) EXPECT_NEAR(w.thickness_m, 0.10, 0.01);
  EXPECT_GE(p.openings.size(), 3u);
  // Room b's inner width: 5.5 m between its walls.
  double best = 1e9;
  for (const plan::Dimension& d : p.dimensions) best = std::min(best, std::abs(d.distance_m - 5.5));
  EXPECT_LT(best, 0.02);
  // The canvas fits the plan: its extent within the widget.
  const QPointF lo = panel->canvas()->ToWidget(p.min), hi = panel->canvas()->ToWidget(p.max);
  EXPECT_TRUE(panel->canvas()->rect().contains(lo.toPoint()) &&
              panel->canvas()->rect().contains(hi.toPoint()));

  // A new cut height: built again (after the edits settle), the view kept.
  panel->height_box()->setValue(1.5);
  ExpectResponsive("second plan",
                   Turns([&] { return panel->plans_built() == 2 && !panel->busy(); }, 60000));
  EXPECT_DOUBLE_EQ(panel->canvas()->plan()->height_m, 1.5);

  // Cancelled: the plan shown stays the last one built.
  panel->Rebuild();
  QTest::mouseClick(panel->cancel_button(), Qt::LeftButton);
  Turns([&] { return !panel->busy(); }, 60000);
  EXPECT_LE(panel->plans_built(), 3u);
  ASSERT_TRUE(panel->canvas()->plan().has_value());

  // File > Export Floor Plan: SVG and DXF by the suffix; anything else refused.
  const QString svg = tmp_.path() + "/floor.svg", dxf = tmp_.path() + "/floor.dxf";
  QString error;
  ASSERT_TRUE(panel->ExportPlan(svg, &error)) << error.toStdString();
  ASSERT_TRUE(panel->ExportPlan(dxf, &error)) << error.toStdString();
  EXPECT_FALSE(panel->ExportPlan(tmp_.path() + "/floor.pdf", &error));
  EXPECT_NE(error.indexOf(".svg or .dxf"), -1) << error.toStdString();
  EXPECT_FALSE(panel->ExportPlan("/nonexistent-dir/floor.svg", &error));
  QFile svg_file(svg);
  ASSERT_TRUE(svg_file.open(QIODevice::ReadOnly));
  QXmlStreamReader xml(&svg_file);
  int groups = 0, lines = 0;
  QString root;
  while (!xml.atEnd()) {
    if (xml.readNext() != QXmlStreamReader::StartElement) continue;
    if (root.isEmpty()) root = xml.name().toString();
    groups += xml.name() == QLatin1String("g");
    lines += xml.name() == QLatin1String("line");
  }
  EXPECT_FALSE(xml.hasError()) << xml.errorString().toStdString();
  EXPECT_EQ(root, "svg");
  EXPECT_GE(groups, 4);
  EXPECT_GT(lines, 10);
  const auto read = RunCommand("/usr/bin/python3 " + kResources.toStdString() +
                               "/../tests/tools/check_dxf.py " + dxf.toStdString() + " 2>&1");
  ASSERT_EQ(read.code, 0) << read.out;
  const QJsonObject dxf_json =
      QJsonDocument::fromJson(QByteArray::fromStdString(read.out)).object();
  EXPECT_EQ(dxf_json["dxfversion"].toString(), "AC1009");
  EXPECT_EQ(dxf_json["audit"].toObject()["errors"].toInt(), 0) << read.out.substr(0, 400);
  EXPECT_GT(dxf_json["counts"].toObject()["LINE"].toObject()["WALLS"].toInt(), 0);
  EXPECT_GT(dxf_json["counts"].toObject()["TEXT"].toObject()["DIMENSIONS"].toInt(), 0);
}

// The office floor's world (x, y) in the project's frame: a's, where the
// scenario put the robot down.
Eigen::Vector2d ProjectXy(const Rigid3d& start_a, double x, double y) {
  return (start_a.inverse() * Eigen::Vector3d(x, y, 0.0)).head<2>();
}

// The section points with z in [z0, z1] and s in [s0, s1].
std::vector<Eigen::Vector2d> Within(const std::vector<Eigen::Vector2d>& s_z, double s0, double s1,
                                    double z0, double z1) {
  std::vector<Eigen::Vector2d> out;
  for (const Eigen::Vector2d& q : s_z) {
    if (q.x() >= s0 && q.x() <= s1 && q.y() >= z0 && q.y() <= z1) out.push_back(q);
  }
  return out;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

TEST_F(PlanUiTest, SectionDrawnOnThePlanShowsRoomsAsBuilt) {
  window_->resize(1600, 1000);  // As an operator's screen: room for both drawings.
  PlanPanel* panel = ShowPlanOfRoomsAB("section");
  PlanCanvas* canvas = panel->canvas();
  ASSERT_TRUE(canvas->plan().has_value());
  EXPECT_FALSE(panel->section_pane()->isVisible());  // No line yet.
  // Along world y = 4.5 from x = -0.3 (outside a's west wall) to 10.9 (past
  // b's east wall at 10.6): through rooms a and b, clear of their furniture.
  const Rigid3d start_a = StartOf("building_a.json");
  const Eigen::Vector2d a = ProjectXy(start_a, -0.3, 4.5), b = ProjectXy(start_a, 10.9, 4.5);
  const QPoint wa = canvas->ToWidget(a).toPoint(), wb = canvas->ToWidget(b).toPoint();
  ASSERT_TRUE(canvas->rect().contains(wa) && canvas->rect().contains(wb))
      << wa.x() << "," << wa.y();

  // The Section button's drag, dropped by Esc: no line, the mode kept for
  // another try, then left by a second Esc.
  QTest::mouseClick(panel->section_tool(), Qt::LeftButton);
  ASSERT_TRUE(canvas->section_mode());
  QTest::mousePress(canvas, Qt::LeftButton, Qt::NoModifier, wa);
  QTest::mouseMove(canvas, (wa + wb) / 2);
  EXPECT_TRUE(canvas->drawing_section());
  QTest::keyClick(canvas, Qt::Key_Escape);
  EXPECT_FALSE(canvas->drawing_section());
  QTest::mouseRelease(canvas, Qt::LeftButton, Qt::NoModifier, wb);
  EXPECT_FALSE(canvas->section_line().has_value());
  EXPECT_TRUE(canvas->section_mode());
  QTest::keyClick(canvas, Qt::Key_Escape);
  EXPECT_FALSE(canvas->section_mode());
  EXPECT_FALSE(panel->section_tool()->isChecked());
  EXPECT_FALSE(panel->busy());
  EXPECT_EQ(panel->sections_built(), 0u);
  const Eigen::Vector2d centre = canvas->centre();
  // A plain drag pans without the mode.
  QTest::mousePress(canvas, Qt::LeftButton, Qt::NoModifier, wa);
  QTest::mouseMove(canvas, wa + QPoint(30, 0));
  QTest::mouseRelease(canvas, Qt::LeftButton, Qt::NoModifier, wa + QPoint(30, 0));
  WaitFor([&] { return canvas->centre() != centre; }, 2000);
  EXPECT_FALSE(canvas->section_line().has_value());
  canvas->Fit();

  // Shift + drag draws the line; its section is built on the job thread.
  const QPoint fa = canvas->ToWidget(a).toPoint(), fb = canvas->ToWidget(b).toPoint();
  QTest::mousePress(canvas, Qt::LeftButton, Qt::ShiftModifier, fa);
  for (int k = 1; k <= 4; ++k) QTest::mouseMove(canvas, fa + (fb - fa) * k / 5);
  QTest::mouseRelease(canvas, Qt::LeftButton, Qt::ShiftModifier, fb);
  ASSERT_TRUE(canvas->section_line().has_value());
  // The line where the mouse put it: within a pixel's plan metres.
  EXPECT_LT((canvas->section_line()->a - a).norm(), 1.5 / canvas->scale());
  EXPECT_LT((canvas->section_line()->b - b).norm(), 1.5 / canvas->scale());
  ExpectResponsive("section",
                   Turns([&] { return panel->sections_built() == 1 && !panel->busy(); }, 60000));
  std::printf("%s\n", panel->section_summary_label()->text().toStdString().c_str());
  EXPECT_TRUE(panel->section_pane()->isVisible());
  EXPECT_EQ(QSettings().value("plan/section_line").toList().size(), 4);
  ASSERT_TRUE(panel->section_canvas()->section().has_value());
  const SectionOf& section = *panel->section_canvas()->section();
  EXPECT_EQ(section.options.band_m, panel->band_box()->value());
  EXPECT_GT(section.stats.points_in, 500000u);
  ASSERT_GT(section.s_z.size(), 1000u);
  const SectionLine line = *canvas->section_line();
  EXPECT_EQ(section.options.a, line.a);
  EXPECT_EQ(section.options.b, line.b);
  EXPECT_NEAR(panel->section_canvas()->length(), 11.2, 3.0 / canvas->scale());
  // s of a world x on the line drawn (where the mouse's pixels put its ends):
  // u . (p - A), core/plan/section.h.
  const Eigen::Vector2d u = (line.b - line.a).normalized();
  const auto s_of = [&](double x) { return u.dot(ProjectXy(start_a, x, 4.5) - line.a); };
  // Inside room a (x 0.5 .. 4.5) and b (5.6 .. 10.1): the floor at z 0,
  // the ceiling at 2.7 (the storey), nothing between.
  for (const auto& [x0, x1] : {std::pair{0.5, 4.5}, std::pair{5.6, 10.1}}) {
    std::vector<double> z;
    for (const Eigen::Vector2d& q : Within(section.s_z, s_of(x0), s_of(x1), -1.0, 4.0))
      z.push_back(q.y());
    ASSERT_GT(z.size(), 200u) << x0;
    EXPECT_NEAR(Quantile(z, 0.02), 0.0, 0.03) << "floor, x " << x0 << ".." << x1;
    EXPECT_NEAR(Quantile(z, 0.98), 2.7, 0.03) << "ceiling, x " << x0 << ".." << x1;
    EXPECT_LT(Within(section.s_z, s_of(x0), s_of(x1), 0.3, 2.4).size(), z.size() / 50)
        << "clutter, x " << x0;
  }
  // The walls' faces: a's west wall x 0, a|b at 5.0 and 5.1, b's east wall
  // 10.6; each a column of points from floor to ceiling at its s.
  for (const double x : {0.0, 5.0, 5.1, 10.6}) {
    const std::vector<Eigen::Vector2d> wall =
        Within(section.s_z, s_of(x) - 0.04, s_of(x) + 0.04, 0.3, 2.4);
    ASSERT_GT(wall.size(), 100u) << "no wall at x " << x;
    std::vector<double> s;
    for (const Eigen::Vector2d& q : wall) s.push_back(q.x());
    EXPECT_NEAR(Quantile(s, 0.5), s_of(x), 0.02) << "wall at x " << x;
  }
  // What the operator sees: the dock with its plan, line and section.
  const QString shot = QCoreApplication::applicationDirPath() + "/plan_section_panel.png";
  EXPECT_TRUE(panel->grab().save(shot));
  std::printf("dock grabbed to %s\n", shot.toStdString().c_str());
  // Its labels apart from one another (the plan's cut sat on the z ticks),
  // the last tick of each axis with its unit.
  const std::vector<SectionCanvas::Label>& labels = panel->section_canvas()->labels();
  int cut_labels = 0, units = 0;
  for (size_t i = 0; i < labels.size(); ++i) {
    cut_labels += labels[i].text.startsWith(QStringLiteral("plan cut "));
    units += labels[i].text.endsWith(QStringLiteral(" m")) &&
             !labels[i].text.startsWith(QStringLiteral("plan cut"));
    for (size_t k = i + 1; k < labels.size(); ++k) {
      EXPECT_FALSE(ConvexOverlap(labels[i].plate, labels[k].plate))
          << labels[i].text.toStdString() << " over " << labels[k].text.toStdString();
    }
  }
  EXPECT_EQ(cut_labels, 1);
  EXPECT_EQ(units, 2);

  // A new cut height: the plan and its section built again, the line kept.
  panel->height_box()->setValue(1.5);
  QElapsedTimer rebuild;
  rebuild.start();
  const testing::EventLoopTurns rebuild_turns = Turns(
      [&] { return panel->plans_built() == 2 && panel->sections_built() == 2 && !panel->busy(); },
      60000);
  std::printf("rebuild at 1.5 m: %lld ms\n", static_cast<long long>(rebuild.elapsed()));
  ExpectResponsive("rebuild", rebuild_turns);
  EXPECT_DOUBLE_EQ(canvas->plan()->height_m, 1.5);
  EXPECT_EQ(panel->section_canvas()->section()->options.a, canvas->section_line()->a);

  // Export Section: SVG, rendered by rsvg-convert with ink; DXF, read by
  // ezdxf with a POINT per section point; not another suffix.
  const QString svg = tmp_.path() + "/section.svg";
  QString error;
  ASSERT_TRUE(panel->ExportSection(svg, &error)) << error.toStdString();
  const QString dxf = tmp_.path() + "/section.dxf";
  ASSERT_TRUE(panel->ExportSection(dxf, &error)) << error.toStdString();
  const auto read = RunCommand("/usr/bin/python3 " + kResources.toStdString() +
                               "/../tests/tools/check_dxf.py '" + dxf.toStdString() + "' 2>&1");
  ASSERT_EQ(read.code, 0) << read.out;
  const QJsonObject dxf_json =
      QJsonDocument::fromJson(QByteArray::fromStdString(read.out)).object();
  EXPECT_EQ(dxf_json["counts"].toObject()["POINT"].toObject()["SECTION"].toInt(),
            static_cast<int>(panel->section_canvas()->section()->s_z.size()));
  EXPECT_EQ(dxf_json["audit"].toObject()["errors"].toInt(), 0) << read.out;
  EXPECT_FALSE(panel->ExportSection(tmp_.path() + "/section.pdf", &error));
  EXPECT_NE(error.indexOf(".dxf"), -1) << error.toStdString();
  EXPECT_FALSE(panel->ExportSection("/nonexistent-dir/section.svg", &error));
  const std::string png = tmp_.path().toStdString() + "/section.png";
  const auto render = RunCommand("rsvg-convert -o '" + png + "' '" + svg.toStdString() + "' 2>&1");
  ASSERT_EQ(render.code, 0) << render.out;
  const auto ink = RunCommand("/usr/bin/python3 " + kResources.toStdString() +
                              "/../tests/tools/png_ink.py '" + png + "' 2>&1");
  ASSERT_EQ(ink.code, 0) << ink.out;
  const QJsonObject ink_json = QJsonDocument::fromJson(QByteArray::fromStdString(ink.out)).object();
  EXPECT_GT(ink_json["width"].toInt(), ink_json["height"].toInt());  // 11.2 m long, 2.7 m high
  EXPECT_GT(ink_json["ink"].toInt(), 5000) << ink.out;

  // Removed: the pane hidden, the setting gone.
  panel->SetSectionLine(std::nullopt);
  EXPECT_FALSE(panel->section_pane()->isVisible());
  EXPECT_FALSE(QSettings().contains("plan/section_line"));
}

// A plan with one room, drawn by a canvas of its own: the room's tint fills
// its outline away from the label, its name is written at the label point;
// the same plan without the room leaves both white.
TEST_F(PlanUiTest, RoomsAreFilledAndNamed) {
  plan::FloorPlan plan;
  plan.min = {0.0, 0.0};
  plan.max = {10.0, 8.0};
  plan::Room room;
  room.outline = {{1.0, 1.0}, {7.0, 1.0}, {7.0, 6.0}, {1.0, 6.0}};
  room.area_m2 = 30.0;
  room.perimeter_m = 22.0;
  room.label = {4.0, 3.5};
  const auto draw = [&](bool with_room) {
    plan::FloorPlan p = plan;
    if (with_room) p.rooms.push_back(room);
    PlanCanvas canvas;
    canvas.resize(640, 480);
    canvas.SetPlan(p, true);
    return canvas.grab().toImage();
  };
  const QImage with = draw(true), without = draw(false);
  PlanCanvas probe;
  probe.resize(640, 480);
  probe.SetPlan(plan, true);
  // Inside the outline, off the 1 m grid, away from the label.
  const QPoint fill = probe.ToWidget({2.5, 5.5}).toPoint();
  EXPECT_EQ(without.pixelColor(fill), QColor(Qt::white));
  EXPECT_NE(with.pixelColor(fill), QColor(Qt::white));
  EXPECT_NE(with.pixelColor(fill), without.pixelColor(fill));
  // The name: dark pixels (text) around the label point.
  const QPoint label = probe.ToWidget(room.label).toPoint();
  const auto dark = [&](const QImage& image) {
    int n = 0;
    for (int y = label.y() - 20; y <= label.y() + 20; ++y) {
      for (int x = label.x() - 40; x <= label.x() + 40; ++x) n += qGray(image.pixel(x, y)) < 128;
    }
    return n;
  };
  EXPECT_GT(dark(with), 30);
  EXPECT_EQ(dark(without), 0);
  // Outside the outline: untouched.
  const QPoint out = probe.ToWidget({8.5, 7.5}).toPoint();
  EXPECT_EQ(with.pixelColor(out), without.pixelColor(out));
}

// plan_build.h's section of posed clouds, cut 64 k points at a time in the
// common frame: the points core/plan's VerticalSection finds in the clouds
// moved whole; cancel and a line of no length refused.
TEST(PlanBuildTest, SectionOfPosedCloudsIsCoreSectionOfTheMovedClouds) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> x(0.f, 10.f), y(0.f, 5.f), z(0.f, 3.f);
  auto cloud = std::make_shared<std::vector<Eigen::Vector3f>>();
  for (int i = 0; i < 150000; ++i) cloud->emplace_back(x(rng), y(rng), z(rng));
  const std::vector<PlanInput> inputs = {{cloud, Rigid3d::FromPose(2.0, 1.0, 0.0, 0.0, 0.0, 0.7)},
                                         {cloud, Rigid3d()}};
  plan::VerticalSectionOptions o;
  o.a = {1.0, 2.0};
  o.b = {8.0, 4.5};
  o.band_m = 0.05;
  SectionOf section;
  ASSERT_TRUE(BuildSectionOf(
                  inputs, o, [](double) { return true; }, &section)
                  .ok());
  std::vector<Eigen::Vector3f> moved;
  for (const PlanInput& in : inputs) {
    for (const Eigen::Vector3f& p : *in.positions) {
      moved.push_back((in.frame_from_cloud * p.cast<double>()).cast<float>());
    }
  }
  std::vector<Eigen::Vector2d> s_z;
  plan::SectionStats stats;
  ASSERT_TRUE(plan::VerticalSection(moved, o, &s_z, &stats).ok());
  EXPECT_EQ(section.stats.points_in, 300000u);
  EXPECT_GT(stats.points_out, 1000u);
  // float against double poses: a point on the slab's edge may go either way.
  EXPECT_NEAR(static_cast<double>(section.stats.points_out), static_cast<double>(stats.points_out),
              3.0);
  const std::vector<Eigen::Vector2d> drawn = plan::DecimateGrid(s_z, kSectionCellM);
  EXPECT_NEAR(static_cast<double>(section.s_z.size()), static_cast<double>(drawn.size()), 3.0);
  int calls = 0;
  EXPECT_EQ(BuildSectionOf(
                inputs, o, [&](double) { return ++calls < 3; }, &section)
                .message(),
            kPlanCancelled);
  o.b = o.a;
  EXPECT_FALSE(BuildSectionOf(
                   inputs, o, [](double) { return true; }, &section)
                   .ok());
}

// Export… (and File > Export Floor Plan…) only with a plan, the canvas's
// reason otherwise, its chooser beside the project and named after it;
// the section's buttons only with a section. Room names keep off the
// dimensions' and doors' figures and the section line's marks, and inside their rooms at every
// zoom, smaller or left out where they do not fit, along a corridor too narrow for them across; the
// figures keep off each other.
TEST_F(PlanUiTest, ExportsActWhenTheyCanAndRoomNamesClearTheFigures) {
  QAction* file_export = nullptr;
  for (QAction* a : window_->menuBar()->actions()) {
    if (a->menu() == nullptr) continue;
    for (QAction* b : a->menu()->actions()) {
      if (b->text() == "Export Floor P&lan…") file_export = b;
    }
  }
  ASSERT_NE(file_export, nullptr);
  EXPECT_FALSE(file_export->isEnabled());  // Nothing open.
  PlanPanel* panel = ShowPlanOfRoomsAB("exports");
  auto* export_button = panel->findChild<QPushButton*>("planExport");
  ASSERT_NE(export_button, nullptr);
  EXPECT_TRUE(export_button->isEnabled());
  EXPECT_TRUE(file_export->isEnabled());
  EXPECT_FALSE(panel->section_export_button()->isEnabled());  // No section line.
  // Export…'s chooser opens beside the project, named after it; a name
  // typed without a suffix is an SVG.
  QString opened_in, suggested;
  testing::AnswerFileChooser(QStringLiteral("drawing"), nullptr, &opened_in, &suggested);
  export_button->click();
  EXPECT_EQ(opened_in, QString::fromStdString(Dir()));
  EXPECT_EQ(suggested, QStringLiteral("exports-plan.svg"));
  EXPECT_TRUE(QFileInfo::exists(QString::fromStdString(Dir()) + "/drawing.svg"));
  const plan::FloorPlan plan = *panel->canvas()->plan();
  ASSERT_FALSE(plan.rooms.empty());
  ASSERT_FALSE(plan.dimensions.empty());

  PlanCanvas canvas;
  canvas.resize(900, 700);
  canvas.SetPlan(plan, true);
  canvas.Fit();
  const auto zoom = [&](int steps) {
    const QPointF at(450, 350);
    QWheelEvent wheel(at, canvas.mapToGlobal(at.toPoint()), QPoint(), QPoint(0, 120 * steps),
                      Qt::NoButton, Qt::NoModifier, Qt::NoScrollPhase, false);
    QApplication::sendEvent(&canvas, &wheel);
  };
  // Each name inside its room and clear of every figure; no figure over another.
  const auto check_labels = [&] {
    // No figure covers another (two rooms' dimensions cross at their middles).
    const std::vector<QPolygonF>& plates = canvas.label_plates();
    for (const QPolygonF& plate : plates) {
      // Along a vertical line the figure reads bottom to top, as on paper
      // (the text's top-left corner, the plate's first, is below its
      // centre); near-vertical walls' figures once read top to bottom.
      const QRectF bounds = plate.boundingRect();
      if (bounds.height() > 1.5 * bounds.width()) {
        EXPECT_GT(plate.front().y(), bounds.center().y()) << canvas.scale() << " px/m";
      }
    }
    for (size_t i = 0; i < plates.size(); ++i) {
      for (size_t j = i + 1; j < plates.size(); ++j) {
        EXPECT_FALSE(plates[i].intersected(plates[j]).boundingRect().width() > 1.0 &&
                     plates[i].intersected(plates[j]).boundingRect().height() > 1.0)
            << "figures " << i << " and " << j << " at " << canvas.scale() << " px/m";
      }
    }
    for (const PlanCanvas::RoomLabel& label : canvas.room_labels()) {
      for (const QPolygonF& figure : canvas.figures()) {
        EXPECT_FALSE(QPolygonF(label.block).intersects(figure))
            << label.name.toStdString() << " at " << canvas.scale() << " px/m";
      }
      const int room = label.name.mid(5).toInt() - 1;
      QPolygonF outline;
      for (const Eigen::Vector2d& v : plan.rooms[room].outline) outline << canvas.ToWidget(v);
      EXPECT_TRUE(outline.containsPoint(label.block.topLeft(), Qt::OddEvenFill) &&
                  outline.containsPoint(label.block.bottomRight(), Qt::OddEvenFill))
          << label.name.toStdString() << " at " << canvas.scale() << " px/m";
    }
  };
  std::vector<PlanCanvas::RoomLabel> at_fit;
  for (int steps : {0, -4, -4, -4, 14, 3, 3}) {
    zoom(steps);
    (void)canvas.grab();
    if (steps == 0) {
      at_fit = canvas.room_labels();
      if (qEnvironmentVariableIsSet("SWEEPSCAN_TEST_SHOTS")) {
        canvas.grab().save(qEnvironmentVariable("SWEEPSCAN_TEST_SHOTS") + "/room-names-fit.png");
      }
    }
    check_labels();
    if (steps == -4 && canvas.scale() < 8.0) {
      EXPECT_TRUE(canvas.room_labels().empty()) << canvas.scale();
    }
  }
  // Fitted, every room has its name beside its dimensions' crossing, the
  // corridor along its length (2 m, 37 px wide here: across, its name
  // would not fit beside the length's dimension line at any size), the
  // rooms across.
  size_t corridor = 0;
  double longest = 0.0;
  for (size_t i = 0; i < plan.rooms.size(); ++i) {
    Eigen::Vector2d lo = plan.rooms[i].outline.front(), hi = lo;
    for (const Eigen::Vector2d& v : plan.rooms[i].outline) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
    const Eigen::Vector2d size = hi - lo;
    if (size.maxCoeff() / size.minCoeff() > longest) {
      longest = size.maxCoeff() / size.minCoeff();
      corridor = i;
    }
  }
  ASSERT_GT(longest, 3.0);
  ASSERT_EQ(at_fit.size(), plan.rooms.size());
  for (const PlanCanvas::RoomLabel& label : at_fit) {
    const bool along = label.block.height() > label.block.width();
    EXPECT_EQ(along, label.name == QStringLiteral("Room %1").arg(corridor + 1))
        << label.name.toStdString();
  }
  canvas.Fit();
  (void)canvas.grab();
  if (qEnvironmentVariableIsSet("SWEEPSCAN_TEST_SHOTS")) {
    canvas.grab().save(qEnvironmentVariable("SWEEPSCAN_TEST_SHOTS") + "/room-names.png");
  }
  // A section line whose "A" (drawn 14 px before its start) falls where
  // the first room's name was: the name moves off it (the "A" once covered
  // "31.2 m²"), still inside its room.
  const PlanCanvas::RoomLabel first = at_fit.front();
  const QPointF a_mark = first.block.center();
  const double px = 1.0 / canvas.scale();
  const Eigen::Vector2d start = canvas.ToModel(a_mark + QPointF(14.0, 0.0));
  canvas.SetSectionLine(SectionLine{start, start + Eigen::Vector2d(60.0 * px, 0.0)});
  (void)canvas.grab();
  check_labels();
  const QRectF a_plate(a_mark - QPointF(8.0, 9.0), QSizeF(16.0, 18.0));
  bool named = false;
  for (const PlanCanvas::RoomLabel& label : canvas.room_labels()) {
    EXPECT_FALSE(label.block.intersects(a_plate)) << label.name.toStdString();
    named = named || label.name == first.name;
  }
  EXPECT_TRUE(named) << first.name.toStdString() << " left out";
  if (qEnvironmentVariableIsSet("SWEEPSCAN_TEST_SHOTS")) {
    canvas.grab().save(qEnvironmentVariable("SWEEPSCAN_TEST_SHOTS") + "/room-names-section.png");
  }
  canvas.SetSectionLine(std::nullopt);
  // In the app's dock (560 x 430 px, the plan about 22 px/m), the corridor
  // (2 m, 44 px between its walls, a dimension line along its middle) has
  // room for neither its name's two lines across nor along it: they come
  // on one line along it ("Room 2 · 32.00 m²"), where it had none.
  canvas.resize(560, 430);
  canvas.Fit();
  (void)canvas.grab();
  check_labels();
  EXPECT_EQ(canvas.room_labels().size(), plan.rooms.size()) << canvas.scale() << " px/m";
  if (qEnvironmentVariableIsSet("SWEEPSCAN_TEST_SHOTS")) {
    canvas.grab().save(qEnvironmentVariable("SWEEPSCAN_TEST_SHOTS") + "/room-names-dock.png");
  }

  // A cut in the ceiling's slab (2.7 m) is said under the plan, as the CLI
  // warns; a cut above the ceiling: no plan, and Export says why.
  uint64_t built = panel->plans_built();
  panel->height_box()->setValue(2.69);
  Turns([&] { return !panel->busy() && panel->plans_built() > built; }, 60000);
  EXPECT_NE(panel->summary_label()->text().indexOf("level surface at 2.70 m"), -1)
      << panel->summary_label()->text().toStdString();
  built = panel->plans_built();
  panel->height_box()->setValue(5.0);
  Turns([&] { return !panel->busy() && !panel->canvas()->plan(); }, 60000);
  EXPECT_EQ(panel->plans_built(), built);
  EXPECT_FALSE(export_button->isEnabled());
  EXPECT_NE(export_button->toolTip().indexOf(panel->canvas()->empty_text()), -1)
      << export_button->toolTip().toStdString();
  QString error;
  EXPECT_FALSE(panel->ExportPlan(QString::fromStdString(Dir()) + "/x.svg", &error));
  EXPECT_EQ(error.indexOf("View > Floor Plan draws one"), -1) << error.toStdString();
  EXPECT_FALSE(file_export->isEnabled());
}

}  // namespace
}  // namespace sweepscan::ui

int main(int argc, char** argv) { return sweepscan::testing::RunUiTests(argc, argv); }
