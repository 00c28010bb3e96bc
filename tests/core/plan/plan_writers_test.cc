// The plan's drawings read by programs we did not write: the DXF by
// Debian's python3-ezdxf (tests/tools/check_dxf.py, with ezdxf's audit) and
// printed by LibreCAD (`librecad dxf2pdf` under xvfb-run, rasterised by
// pdftoppm), the SVG rendered by rsvg-convert; the PNGs must hold ink
// (tests/tools/png_ink.py). The tools are found at configure time
// (tests/core/plan/CMakeLists.txt).
#include "core/plan/plan_writers.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <clocale>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>

#include "core/plan/axis_ticks.h"
#include "core/plan/floor_plan.h"
#include "tests/testing/run_command.h"
#include "tests/testing/worlds.h"

namespace sweepscan::plan {
namespace {

using sweepscan::testing::RunCommand;

// One folder a process: ctest runs each test of this file as its own
// process, two at a time, and a shared folder would be emptied under the
// other's feet by the suite's set-up.
const std::string kDir =
    std::string(SWEEPSCAN_BINARY_DIR) + "/tests/core/plan/plan_writers_test_out_" + std::to_string(::getpid());
const std::string kTools = std::string(SWEEPSCAN_SOURCE_DIR) + "/tests/tools/";

class PlanWritersTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::vector<Eigen::Vector3f> cloud;
    for (const char drive : {'a', 'b'}) {
      const ReconstructionResult r =
          testing::SimulateAndReconstruct(testing::BuildingConfig(drive), PoseSource::kTruth, /*deskew=*/true);
      for (const CloudPoint& p : r.points) cloud.emplace_back(p.x, p.y, p.z);
    }
    plan_ = new FloorPlan();
    ASSERT_TRUE(BuildFloorPlan(cloud, FloorPlanOptions(), plan_).ok());
    ASSERT_EQ(RunCommand("rm -rf '" + kDir + "' && mkdir -p '" + kDir + "'").code, 0);
  }
  static void TearDownTestSuite() {
    delete plan_;
    RunCommand("rm -rf '" + kDir + "'");
  }
  static FloorPlan* plan_;
};
FloorPlan* PlanWritersTest::plan_ = nullptr;

nlohmann::json PngInk(const std::string& png) {
  const testing::CommandRun r = RunCommand(std::string(SWEEPSCAN_PYTHON3) + " " + kTools + "png_ink.py '" + png + "'");
  EXPECT_EQ(r.code, 0) << r.out;
  return r.code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json();
}

TEST_F(PlanWritersTest, DxfReadByEzdxfMatchesThePlan) {
  const std::string path = kDir + "/plan.dxf";
  ASSERT_TRUE(WritePlanDxf(path, *plan_, DxfOptions()).ok());
  const testing::CommandRun r = RunCommand(std::string(SWEEPSCAN_PYTHON3) + " " + kTools + "check_dxf.py '" + path + "'");
  ASSERT_EQ(r.code, 0) << r.out << "\n(python3-ezdxf missing? scripts/install-deps.sh)";
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["dxfversion"], "AC1009");
  EXPECT_EQ(j["insunits"], 6);
  EXPECT_EQ(j["audit"]["errors"], 0) << j["audit"].dump();
  for (const char* layer :
       {kDxfLayerWalls, kDxfLayerOpenings, kDxfLayerDimensions, kDxfLayerSection, kDxfLayerRooms}) {
    bool found = false;
    for (const auto& l : j["layers"]) found = found || l == layer;
    EXPECT_TRUE(found) << layer;
  }
  size_t walls = 0, furniture = 0;
  for (const WallFace& f : plan_->faces) (f.structural ? walls : furniture)++;
  const nlohmann::json& lines = j["counts"]["LINE"];
  EXPECT_EQ(lines.value(kDxfLayerWalls, 0), static_cast<int>(walls));
  EXPECT_EQ(lines.value(kDxfLayerSection, 0), static_cast<int>(furniture));
  EXPECT_EQ(lines.value(kDxfLayerOpenings, 0), static_cast<int>(plan_->openings.size()));
  EXPECT_EQ(lines.value(kDxfLayerDimensions, 0), static_cast<int>(plan_->dimensions.size()));
  EXPECT_EQ(j["counts"]["POINT"].value(kDxfLayerSection, 0), static_cast<int>(plan_->points.size()));
  // Lines in the plan's order: faces, then per opening and per dimension.
  size_t k = 0;
  const auto& list = j["lines"];
  ASSERT_EQ(list.size(), plan_->faces.size() + plan_->openings.size() + plan_->dimensions.size());
  for (const WallFace& f : plan_->faces) EXPECT_NEAR(list[k++]["length"].get<double>(), f.Length(), 2e-6);
  for (const Opening& o : plan_->openings) EXPECT_NEAR(list[k++]["length"].get<double>(), o.width_m, 2e-6);
  for (const Dimension& d : plan_->dimensions) EXPECT_NEAR(list[k++]["length"].get<double>(), (d.b - d.a).norm(), 2e-6);
  // The dimension texts are the values, in the plan's order.
  std::vector<std::string> texts;
  for (const auto& t : j["texts"]) {
    if (t["layer"] == kDxfLayerDimensions) texts.push_back(t["text"]);
  }
  ASSERT_EQ(texts.size(), plan_->dimensions.size());
  for (size_t i = 0; i < texts.size(); ++i) EXPECT_EQ(texts[i], FormatMetres(plan_->dimensions[i].distance_m));
  // Rooms: one closed polyline each, its corners and area those of the
  // plan's outline (6 decimals), its name and area as texts.
  ASSERT_GE(plan_->rooms.size(), 2u);
  const nlohmann::json& polylines = j["polylines"];
  ASSERT_EQ(polylines.size(), plan_->rooms.size());
  std::vector<std::string> room_texts;
  for (const auto& t : j["texts"]) {
    if (t["layer"] == kDxfLayerRooms) room_texts.push_back(t["text"]);
  }
  ASSERT_EQ(room_texts.size(), 2 * plan_->rooms.size());
  for (size_t r = 0; r < plan_->rooms.size(); ++r) {
    const Room& room = plan_->rooms[r];
    const nlohmann::json& pl = polylines[r];
    EXPECT_EQ(pl["layer"], kDxfLayerRooms);
    EXPECT_TRUE(pl["closed"].get<bool>());
    ASSERT_EQ(pl["vertices"].size(), room.outline.size());
    for (size_t k = 0; k < room.outline.size(); ++k) {
      EXPECT_NEAR(pl["vertices"][k][0].get<double>(), room.outline[k].x(), 1e-6);
      EXPECT_NEAR(pl["vertices"][k][1].get<double>(), room.outline[k].y(), 1e-6);
    }
    EXPECT_NEAR(pl["area"].get<double>(), room.area_m2, 1e-4);
    EXPECT_EQ(room_texts[2 * r], RoomName(r));
    EXPECT_EQ(room_texts[2 * r + 1], FormatArea(room.area_m2));
  }
  // The header's extent, written with 6 decimals (1 um).
  EXPECT_LE(j["extmin"][0].get<double>(), plan_->min.x() + 1e-6);
  EXPECT_GE(j["extmax"][1].get<double>(), plan_->max.y() - 1e-6);
}

TEST_F(PlanWritersTest, DxfPrintedByLibreCad) {
  const std::string path = kDir + "/librecad.dxf";
  ASSERT_TRUE(WritePlanDxf(path, *plan_, DxfOptions()).ok());
  // LibreCAD 2.2's dxf2pdf takes no option values (-o, -p are parsed as
  // flags): it prints FILE.dxf to FILE.pdf beside it. The paper size is
  // read in drawing units, so a drawing in metres gets an A4 page 210 m
  // wide: pdftoppm scales the page to 1200 pixels.
  testing::CommandRun r =
      RunCommand(std::string(SWEEPSCAN_XVFB_RUN) + " -a " + SWEEPSCAN_LIBRECAD + " dxf2pdf -a '" + path + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  r = RunCommand(std::string(SWEEPSCAN_PDFTOPPM) + " -png -singlefile -scale-to 1200 '" + kDir + "/librecad.pdf' '" +
                 kDir + "/librecad'");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json ink = PngInk(kDir + "/librecad.png");
  EXPECT_GT(ink.value("ink", 0), 2000) << ink.dump();
}

TEST_F(PlanWritersTest, SvgRenderedByRsvg) {
  const std::string path = kDir + "/plan.svg";
  SvgOptions o;
  o.title = "office floor, drives a and b";
  ASSERT_TRUE(WritePlanSvg(path, *plan_, o).ok());
  std::string svg;
  ASSERT_TRUE(PlanSvg(*plan_, o, &svg).ok());
  for (const char* group :
       {"<g id=\"rooms\"", "<g id=\"points\"", "<g id=\"walls\"", "<g id=\"openings\"", "<g id=\"dimensions\""}) {
    EXPECT_NE(svg.find(group), std::string::npos) << group;
  }
  // One filled polygon and a name per room.
  size_t polygons = 0;
  for (size_t at = svg.find("<polygon points="); at != std::string::npos; at = svg.find("<polygon points=", at + 1)) {
    ++polygons;
  }
  EXPECT_EQ(polygons, plan_->rooms.size());
  for (size_t r = 0; r < plan_->rooms.size(); ++r) EXPECT_NE(svg.find(">" + RoomName(r) + "<"), std::string::npos);
  // 1:50: a 16 m wide plan is 320 mm of paper plus two 15 mm margins.
  const double width_mm = (plan_->max.x() - plan_->min.x()) * 20.0 + 30.0;
  char expect[64];
  std::snprintf(expect, sizeof(expect), "width=\"%.0f", std::floor(width_mm));
  EXPECT_NE(svg.find(expect), std::string::npos) << expect;
  const testing::CommandRun r =
      RunCommand(std::string(SWEEPSCAN_RSVG_CONVERT) + " -o '" + kDir + "/plan.png' '" + path + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json ink = PngInk(kDir + "/plan.png");
  EXPECT_GT(ink.value("ink", 0), 5000) << ink.dump();
  EXPECT_GT(ink.value("width", 0), 1000);
}

TEST_F(PlanWritersTest, SectionDxfReadByEzdxf) {
  // A section drawn by hand: a 4 m floor and a 2.5 m wall at s = 4.
  std::vector<Eigen::Vector2d> s_z;
  for (double s = 0.0; s <= 4.0; s += 0.01) s_z.emplace_back(s, 0.0);
  for (double z = 0.0; z <= 2.5; z += 0.01) s_z.emplace_back(4.0, z);
  const std::string path = kDir + "/section.dxf";
  ASSERT_TRUE(WriteSectionDxf(path, s_z, DxfOptions()).ok());
  const testing::CommandRun r = RunCommand(std::string(SWEEPSCAN_PYTHON3) + " " + kTools + "check_dxf.py '" + path + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["dxfversion"], "AC1009");
  EXPECT_EQ(j["audit"]["errors"], 0) << j["audit"].dump();
  EXPECT_EQ(j["counts"]["POINT"].value(kDxfLayerSection, 0), static_cast<int>(s_z.size()));
  // The ground line (4 m) and a tick every metre along s (0..4) and up z (0..2).
  EXPECT_EQ(j["counts"]["LINE"].value(kDxfLayerAxes, 0), 1 + 5 + 3);
  EXPECT_NEAR(j["lines"][0]["length"].get<double>(), 4.0, 1e-6);
  std::vector<std::string> labels;
  for (const auto& t : j["texts"]) labels.push_back(t["text"]);
  EXPECT_EQ(labels, (std::vector<std::string>{"0", "1", "2", "3", "4", "0", "1", "2"}));
  EXPECT_NEAR(j["extmax"][1].get<double>(), 2.5, 0.011);
  std::string out;
  EXPECT_FALSE(SectionDxf({}, DxfOptions(), &out).ok());
  EXPECT_FALSE(SectionDxf({{0.0, NAN}}, DxfOptions(), &out).ok());
}

// Switches LC_NUMERIC to German (decimal comma) for its lifetime, made with
// localedef in a folder of its own when the system has not generated it
// (the desktop app runs under the user's locale: QApplication calls
// setlocale(LC_ALL, "")).
class CommaLocale {
 public:
  CommaLocale() {
    if (std::setlocale(LC_NUMERIC, "de_DE.UTF-8") == nullptr) {
      const testing::CommandRun made =
          RunCommand("mkdir -p '" + kDir + "/locale' && localedef -i de_DE -f UTF-8 '" + kDir +
                     "/locale/de_DE.UTF-8' 2>&1");
      EXPECT_EQ(made.code, 0) << "localedef (package locales): " << made.out;
      ::setenv("LOCPATH", (kDir + "/locale").c_str(), 1);
      std::setlocale(LC_NUMERIC, "de_DE.UTF-8");
    }
  }
  ~CommaLocale() { std::setlocale(LC_NUMERIC, "C"); }
  static bool Active() { return std::string(std::localeconv()->decimal_point) == ","; }
};

// The same drawings whatever the C locale: "1.500000", never "1,500000"
// (which makes a DXF unreadable and an SVG invalid).
TEST_F(PlanWritersTest, DrawingsDoNotFollowTheLocalesDecimalComma) {
  const std::vector<Eigen::Vector2d> s_z = {{0.25, 0.5}, {1.75, 2.125}, {3.5, 0.0625}};
  auto draw = [&](std::string* svg, std::string* dxf, std::string* section_svg,
                  std::string* section_dxf) {
    ASSERT_TRUE(PlanSvg(*plan_, SvgOptions(), svg).ok());
    ASSERT_TRUE(PlanDxf(*plan_, DxfOptions(), dxf).ok());
    ASSERT_TRUE(SectionSvg(s_z, SvgOptions(), section_svg).ok());
    ASSERT_TRUE(SectionDxf(s_z, DxfOptions(), section_dxf).ok());
  };
  std::string svg, dxf, section_svg, section_dxf;
  draw(&svg, &dxf, &section_svg, &section_dxf);
  ASSERT_NE(dxf.find(".000000\n"), std::string::npos);
  std::string svg_de, dxf_de, section_svg_de, section_dxf_de;
  {
    CommaLocale german;
    ASSERT_TRUE(CommaLocale::Active()) << "no comma-decimal locale to test with";
    char printed[16];
    std::snprintf(printed, sizeof(printed), "%.1f", 1.5);
    ASSERT_STREQ(printed, "1,5");  // What printf now writes.
    draw(&svg_de, &dxf_de, &section_svg_de, &section_dxf_de);
  }
  EXPECT_EQ(svg_de, svg);
  EXPECT_EQ(dxf_de, dxf);
  EXPECT_EQ(section_svg_de, section_svg);
  EXPECT_EQ(section_dxf_de, section_dxf);
}

TEST(PlanWritersRefusalTest, BadOptionsAndEmptySections) {
  FloorPlan plan;
  std::string out;
  SvgOptions svg;
  svg.scale = 0.0;
  EXPECT_FALSE(PlanSvg(plan, svg, &out).ok());
  EXPECT_FALSE(SectionSvg({}, SvgOptions(), &out).ok());
  DxfOptions dxf;
  dxf.text_height_m = NAN;
  EXPECT_FALSE(PlanDxf(plan, dxf, &out).ok());
  plan.faces.push_back(WallFace());
  plan.faces.back().b = {NAN, 0.0};
  EXPECT_FALSE(PlanDxf(plan, DxfOptions(), &out).ok());
  // A file that cannot be opened is an error (a write failing half-way:
  // CliRobustnessTest.FullDiskIsExitOneAndLeavesNoFileBehind).
  const std::string missing = kDir + "/no/such/folder/plan.dxf";
  EXPECT_FALSE(WritePlanDxf(missing, FloorPlan(), DxfOptions()).ok());
}

TEST(AxisTicksTest, EveryMetreOrACoarserStepNeverMinusZero) {
  // A floor just below zero: its tick is 0, not -0 (the DXF labelled it "-0").
  const std::vector<double> room = AxisTicks(-0.004, 2.6);
  ASSERT_EQ(room, (std::vector<double>{0.0, 1.0, 2.0}));
  EXPECT_FALSE(std::signbit(room[0]));
  EXPECT_EQ(AxisTicks(-2.5, -0.5), (std::vector<double>{-2.0, -1.0}));
  EXPECT_EQ(AxisTicks(0.2, 0.8), std::vector<double>{});
  EXPECT_EQ(AxisTicks(0.0, 49.0).size(), 50u);             // 50 ticks: still every metre
  const std::vector<double> fifty = AxisTicks(0.0, 50.0);  // 51 would be too many
  EXPECT_EQ(fifty, (std::vector<double>{0.0,  2.0,  4.0,  6.0,  8.0,  10.0, 12.0, 14.0, 16.0,
                                        18.0, 20.0, 22.0, 24.0, 26.0, 28.0, 30.0, 32.0, 34.0,
                                        36.0, 38.0, 40.0, 42.0, 44.0, 46.0, 48.0, 50.0}));
  // A stray point 100 km up: every 5 km (2 km would be 51 ticks).
  const std::vector<double> stray = AxisTicks(0.0, 1e5);
  ASSERT_EQ(stray.size(), 21u);
  EXPECT_EQ(stray[1], 5000.0);
  EXPECT_EQ(stray.back(), 1e5);
  // Where a metre is below the doubles' spacing: bounded, and it ends.
  EXPECT_LE(AxisTicks(1e17, 1e17 + 64).size(), static_cast<size_t>(kMaxAxisTicks));
  EXPECT_LE(AxisTicks(-1e300, 1e300).size(), static_cast<size_t>(kMaxAxisTicks));
  EXPECT_TRUE(AxisTicks(1.0, 0.0).empty());
  EXPECT_TRUE(AxisTicks(0.0, INFINITY).empty());
}

// The scales' labels, from the DXF's TEXT entities (code 1 after TEXT).
std::vector<std::string> DxfTexts(const std::string& dxf) {
  std::vector<std::string> texts;
  size_t at = 0;
  while ((at = dxf.find("\n  0\nTEXT\n", at)) != std::string::npos) {
    at += 10;
    const size_t code = dxf.find("\n  1\n", at);
    const size_t end = dxf.find('\n', code + 5);
    texts.push_back(dxf.substr(code + 5, end - code - 5));
  }
  return texts;
}

TEST(PlanWritersRefusalTest, ASectionWithAStrayPointKeepsItsScalesShort) {
  std::vector<Eigen::Vector2d> s_z;
  for (int i = 0; i <= 400; ++i) s_z.emplace_back(0.01 * i, -0.004);  // floor noise below zero
  for (int i = 0; i <= 250; ++i) s_z.emplace_back(4.0, 0.01 * i);     // a wall
  std::string dxf, svg;
  ASSERT_TRUE(SectionDxf(s_z, DxfOptions(), &dxf).ok());
  EXPECT_EQ(DxfTexts(dxf), (std::vector<std::string>{"0", "1", "2", "3", "4", "0", "1", "2"}));
  // One point 100 km up: a tick every 5 km up z, not one a metre (a 25 MB DXF).
  s_z.emplace_back(2.0, 1e5);
  ASSERT_TRUE(SectionDxf(s_z, DxfOptions(), &dxf).ok());
  const std::vector<std::string> texts = DxfTexts(dxf);
  EXPECT_EQ(texts.size(), 5u + 21u);
  EXPECT_EQ(texts[6], "5000");
  EXPECT_LT(dxf.size(), 200000u);
  SvgOptions options;
  options.scale = 1e6;  // a paper of sensible size for 100 km
  ASSERT_TRUE(SectionSvg(s_z, options, &svg).ok());
  EXPECT_LT(svg.size(), 200000u);
}

// The section's scale labels read as the DXF's ("1", not "1.00") and carry
// no stroke: the axes group's red one drew the z labels outlined, bold.
TEST(PlanWritersRefusalTest, SectionScaleLabelsAreTheDxfsAndUnstroked) {
  std::vector<Eigen::Vector2d> s_z;
  for (int i = 0; i <= 400; ++i) s_z.emplace_back(0.01 * i, 0.0);
  for (int i = 0; i <= 250; ++i) s_z.emplace_back(4.0, 0.01 * i);
  std::string svg, dxf;
  ASSERT_TRUE(SectionSvg(s_z, SvgOptions(), &svg).ok());
  ASSERT_TRUE(SectionDxf(s_z, DxfOptions(), &dxf).ok());
  const size_t axes = svg.find("<g id=\"axes\"");
  ASSERT_NE(axes, std::string::npos);
  std::vector<std::string> labels;
  for (size_t at = svg.find("<text", axes); at != std::string::npos && at < svg.find("</g>", axes);
       at = svg.find("<text", at + 1)) {
    const std::string element = svg.substr(at, svg.find("</text>", at) - at);
    EXPECT_NE(element.find("stroke=\"none\""), std::string::npos) << element;
    labels.push_back(element.substr(element.find('>') + 1));
  }
  EXPECT_EQ(labels, DxfTexts(dxf));
  EXPECT_EQ(labels, (std::vector<std::string>{"0", "1", "2", "3", "4", "0", "1", "2"}));
}

// Labels of lines within 5 degrees of vertical read bottom to top in both
// drawings, whichever way the line runs and however little it is off plumb
// (0.02 deg turned a value top to bottom); others along the line, left to
// right. The SVG's texts carry no stroke (the openings' dashed one
// outlined the glyphs).
TEST(PlanWritersRefusalTest, LabelsOfNearlyVerticalLinesReadBottomToTop) {
  FloorPlan plan;
  plan.max = Eigen::Vector2d(10.0, 10.0);
  const double kDeg = M_PI / 180.0;
  // World directions (y up): almost up, almost down, exactly down, 87 deg, 30 deg.
  const double directions_deg[] = {89.98, -89.98, -90.0, 87.0, 30.0, 120.0};
  for (const double d : directions_deg) {
    Dimension dim;
    dim.a = Eigen::Vector2d(5.0, 5.0);
    dim.b = dim.a + 3.0 * Eigen::Vector2d(std::cos(d * kDeg), std::sin(d * kDeg));
    dim.distance_m = 3.0;
    plan.dimensions.push_back(dim);
  }
  std::string svg, dxf;
  ASSERT_TRUE(PlanSvg(plan, SvgOptions(), &svg).ok());
  ASSERT_TRUE(PlanDxf(plan, DxfOptions(), &dxf).ok());
  // SVG (paper y down): rotate(A ...), -90 reads bottom to top.
  std::vector<double> svg_angles;
  for (size_t at = svg.find("<text"); at != std::string::npos; at = svg.find("<text", at + 1)) {
    const size_t end = svg.find('>', at);
    const std::string tag = svg.substr(at, end - at);
    const size_t r = tag.find("rotate(");
    if (r == std::string::npos) continue;
    EXPECT_NE(tag.find("stroke=\"none\""), std::string::npos) << tag;
    svg_angles.push_back(std::stod(tag.substr(r + 7)));
  }
  // DXF (y up): group 50 of each TEXT, +90 reads bottom to top.
  std::vector<double> dxf_angles;
  for (size_t at = dxf.find("\nTEXT\n"); at != std::string::npos;
       at = dxf.find("\nTEXT\n", at + 1)) {
    const size_t code = dxf.find("\n 50\n", at);
    ASSERT_NE(code, std::string::npos);
    dxf_angles.push_back(std::stod(dxf.substr(code + 5)));
  }
  ASSERT_EQ(svg_angles.size(), 6u) << svg;
  ASSERT_EQ(dxf_angles.size(), 6u);
  const double svg_want[] = {-89.98, -90.02, -90.0, -87.0, -30.0, 60.0};
  const double dxf_want[] = {89.98, 90.02, 90.0, 87.0, 30.0, -60.0};
  for (int k = 0; k < 6; ++k) {
    EXPECT_NEAR(svg_angles[k], svg_want[k], 1e-3) << directions_deg[k];
    EXPECT_NEAR(dxf_angles[k], dxf_want[k], 1e-3) << directions_deg[k];
  }
}

// One stray return 200 km out made the page kilometres wide (rsvg-convert
// refuses anything above 32 767 pixels): the page is the room's, the point
// is counted.
TEST(PlanWritersRefusalTest, AStrayPointKeepsThePageTheRoomsSize) {
  std::vector<Eigen::Vector2d> section;  // A 4 x 3 m room's walls, a point a centimetre.
  for (int i = 0; i <= 400; ++i) {
    section.emplace_back(0.01 * i, 0.0);
    section.emplace_back(0.01 * i, 3.0);
  }
  for (int i = 0; i <= 300; ++i) {
    section.emplace_back(0.0, 0.01 * i);
    section.emplace_back(4.0, 0.01 * i);
  }
  section.emplace_back(200000.0, 1.0);
  FloorPlan plan;
  ASSERT_TRUE(BuildFloorPlanFromSection(section, FloorPlanOptions(), &plan).ok());
  EXPECT_EQ(plan.stray_points, 1u);
  EXPECT_NEAR(plan.max.x(), 4.0, 1e-9);
  EXPECT_NEAR(plan.max.y(), 3.0, 1e-9);
  std::string svg;
  ASSERT_TRUE(PlanSvg(plan, SvgOptions(), &svg).ok());
  // 4 m at 1:50 is 80 mm, and 15 mm of margin each side.
  EXPECT_NE(svg.find("width=\"110.00mm\""), std::string::npos) << svg.substr(0, 300);
}

TEST(PlanWritersRefusalTest, AControlCharacterInATitleKeepsTheSvgWellFormed) {
  SvgOptions options;
  options.title = std::string("run\x01 <3> & \"more\"\tend");
  std::string svg;
  ASSERT_TRUE(SectionSvg({{0.0, 0.0}, {1.0, 1.0}}, options, &svg).ok());
  EXPECT_EQ(svg.find('\x01'), std::string::npos);
  EXPECT_NE(svg.find("run? &lt;3&gt; &amp; &quot;more&quot;\tend"), std::string::npos);
}

}  // namespace
}  // namespace sweepscan::plan
