// The floor plan against the office floor's truth (core/sim/scene.h): the
// three simulated drives (tests/testing/worlds.h BuildingConfig a, b, c)
// reconstructed with the true poses in the world frame and merged, cut at
// 1.0 m. The truth: OfficeFloorRooms() (every room's inner faces) and
// OfficeFloorDoors() (the doors' jambs on the walls' centre lines).
#include "core/plan/floor_plan.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/plan/rooms.h"
#include "core/plan/section.h"
#include "core/sim/scene.h"
#include "tests/testing/worlds.h"

namespace sweepscan::plan {
namespace {

constexpr double kFaceTolerance = 0.005;  // m, the brief's 5 mm
constexpr double kDoorTolerance = 0.02;   // m, door widths

// A truth wall face: the line x = offset (vertical) or y = offset, over [lo, hi].
struct TruthLine {
  bool vertical;  // x = offset
  double offset, lo, hi;
};

// Every room's four inner faces, collinear ones merged (y = 8 is one line for
// rooms A, B and C).
std::vector<TruthLine> TruthLines() {
  std::vector<TruthLine> lines;
  const auto add = [&](bool vertical, double offset, double lo, double hi) {
    for (TruthLine& l : lines) {
      if (l.vertical == vertical && std::abs(l.offset - offset) < 1e-9) {
        l.lo = std::min(l.lo, lo);
        l.hi = std::max(l.hi, hi);
        return;
      }
    }
    lines.push_back({vertical, offset, lo, hi});
  };
  for (const sim::RoomTruth& r : sim::OfficeFloorRooms()) {
    add(true, r.x0, r.y0, r.y1);
    add(true, r.x1, r.y0, r.y1);
    add(false, r.y0, r.x0, r.x1);
    add(false, r.y1, r.x0, r.x1);
  }
  return lines;
}

// The truth line a face lies on: both ends within `tolerance` of it, inside
// its extent (15 cm of slack: a face ends where its last point is), or null.
const TruthLine* Match(const std::vector<TruthLine>& truth, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                       double tolerance) {
  for (const TruthLine& l : truth) {
    const int across = l.vertical ? 0 : 1, along = 1 - across;
    if (std::abs(a[across] - l.offset) > tolerance || std::abs(b[across] - l.offset) > tolerance) continue;
    if (std::min(a[along], b[along]) < l.lo - 0.15 || std::max(a[along], b[along]) > l.hi + 0.15) continue;
    return &l;
  }
  return nullptr;
}

class OfficeFloorPlanTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    cloud_ = new std::vector<Eigen::Vector3f>();
    for (const char drive : {'a', 'b', 'c'}) {
      const ReconstructionResult r =
          testing::SimulateAndReconstruct(testing::BuildingConfig(drive), PoseSource::kTruth, /*deskew=*/true);
      for (const CloudPoint& p : r.points) cloud_->emplace_back(p.x, p.y, p.z);
    }
    plan_ = new FloorPlan();
    status_ = new Status(BuildFloorPlan(*cloud_, FloorPlanOptions(), plan_));
  }
  static void TearDownTestSuite() {
    delete cloud_;
    delete plan_;
    delete status_;
  }
  void SetUp() override { ASSERT_TRUE(status_->ok()) << status_->message(); }

  static std::vector<Eigen::Vector3f>* cloud_;
  static FloorPlan* plan_;
  static Status* status_;
};
std::vector<Eigen::Vector3f>* OfficeFloorPlanTest::cloud_ = nullptr;
FloorPlan* OfficeFloorPlanTest::plan_ = nullptr;
Status* OfficeFloorPlanTest::status_ = nullptr;

std::string Describe(const WallFace& f) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "face (%.4f, %.4f)-(%.4f, %.4f), %zu points, rms %.1f mm", f.a.x(), f.a.y(),
                f.b.x(), f.b.y(), f.points, 1e3 * f.rms_m);
  return buf;
}

TEST_F(OfficeFloorPlanTest, EveryWallFaceOnATruthFaceWithin5mm) {
  const std::vector<TruthLine> truth = TruthLines();
  std::vector<int> seen(truth.size(), 0);
  int structural = 0;
  double worst = 0.0;
  for (const WallFace& f : plan_->faces) {
    if (!f.structural) continue;  // furniture: checked below not to be a wall
    ++structural;
    const TruthLine* l = Match(truth, f.a, f.b, kFaceTolerance);
    EXPECT_NE(l, nullptr) << "a wall face where the truth has none: " << Describe(f);
    if (l != nullptr) {
      seen[l - truth.data()] = 1;
      const int across = l->vertical ? 0 : 1;
      worst = std::max({worst, std::abs(f.a[across] - l->offset), std::abs(f.b[across] - l->offset)});
    }
  }
  std::printf("%d wall faces, largest distance of an end from its truth face %.2f mm\n", structural, 1e3 * worst);
  // Every truth line is seen by these drives (the corridor from both
  // sides, every room from inside).
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_TRUE(seen[i]) << (truth[i].vertical ? "x = " : "y = ") << truth[i].offset << " not found";
  }
  EXPECT_GE(structural, static_cast<int>(truth.size()));
}

TEST_F(OfficeFloorPlanTest, FurnitureIsNotAWall) {
  // The cabinets and shelves cut at 1 m are faces but not walls'.
  const std::vector<TruthLine> truth = TruthLines();
  for (const WallFace& f : plan_->faces) {
    if (f.structural) continue;
    EXPECT_EQ(Match(truth, f.a, f.b, 0.03), nullptr) << "a wall face taken for furniture: " << Describe(f);
  }
  for (const Wall& w : plan_->walls) {
    EXPECT_TRUE(plan_->faces[w.face_a].structural && plan_->faces[w.face_b].structural);
  }
}

TEST_F(OfficeFloorPlanTest, WallsAreTheTenCentimetreWalls) {
  // The inner walls' centre lines: corridor y = 2.05, A|B x = 5.05, B|C x = 10.65.
  const std::vector<TruthLine> centres = {{false, 2.05, 0.0, 16.0}, {true, 5.05, 2.1, 8.0}, {true, 10.65, 2.1, 8.0}};
  std::vector<int> seen(centres.size(), 0);
  for (const Wall& w : plan_->walls) {
    const TruthLine* l = Match(centres, w.a, w.b, kFaceTolerance);
    EXPECT_NE(l, nullptr) << "a wall where the truth has none: (" << w.a.transpose() << ")-(" << w.b.transpose()
                          << ")";
    if (l != nullptr) seen[l - centres.data()] = 1;
    EXPECT_NEAR(w.thickness_m, 0.1, kFaceTolerance);
  }
  for (size_t i = 0; i < centres.size(); ++i) EXPECT_TRUE(seen[i]) << "wall " << i << " not found";
}

TEST_F(OfficeFloorPlanTest, DoorsFoundWithTheirWidths) {
  const std::vector<sim::DoorTruth> doors = sim::OfficeFloorDoors();
  std::vector<int> found(doors.size(), 0);
  for (const Opening& o : plan_->openings) {
    const Eigen::Vector2d mid = 0.5 * (o.a + o.b);
    int match = -1;
    for (size_t d = 0; d < doors.size(); ++d) {
      if ((mid - 0.5 * (doors[d].a + doors[d].b)).norm() < 0.1) match = static_cast<int>(d);
    }
    ASSERT_GE(match, 0) << "an opening where there is no door: (" << o.a.transpose() << ")-(" << o.b.transpose()
                        << ")";
    ++found[match];
    const double width = (doors[match].b - doors[match].a).norm();
    EXPECT_NEAR(o.width_m, width, kDoorTolerance) << doors[match].label;
    EXPECT_GE(o.wall, 0) << doors[match].label << " should be an opening of a wall (both faces)";
    std::printf("%s: width %.4f m (truth %.3f)\n", doors[match].label.c_str(), o.width_m, width);
  }
  for (size_t d = 0; d < doors.size(); ++d) EXPECT_EQ(found[d], 1) << doors[d].label;
}

TEST_F(OfficeFloorPlanTest, RoomInnerDimensionsWithin5mm) {
  int checked = 0;
  for (const sim::RoomTruth& room : sim::OfficeFloorRooms()) {
    for (const bool along_x : {true, false}) {
      const double truth = along_x ? room.x1 - room.x0 : room.y1 - room.y0;
      const Dimension* found = nullptr;
      for (const Dimension& d : plan_->dimensions) {
        const Eigen::Vector2d m = 0.5 * (d.a + d.b), u = (d.b - d.a).normalized();
        const bool inside = m.x() > room.x0 && m.x() < room.x1 && m.y() > room.y0 && m.y() < room.y1;
        if (inside && std::abs(along_x ? u.x() : u.y()) > 0.99) found = &d;
      }
      ASSERT_NE(found, nullptr) << room.label << (along_x ? " x" : " y") << " dimension missing";
      EXPECT_NEAR(found->distance_m, truth, kFaceTolerance) << room.label << (along_x ? " x" : " y");
      std::printf("%s %s: %.4f m (truth %.3f)\n", room.label.c_str(), along_x ? "x" : "y", found->distance_m, truth);
      ++checked;
    }
  }
  EXPECT_EQ(checked, 8);
  // No dimension that is not a room's: each is one of the eight.
  for (const Dimension& d : plan_->dimensions) {
    bool known = false;
    for (const sim::RoomTruth& room : sim::OfficeFloorRooms()) {
      known = known || std::abs(d.distance_m - (room.x1 - room.x0)) < 0.01 ||
              std::abs(d.distance_m - (room.y1 - room.y0)) < 0.01;
    }
    EXPECT_TRUE(known) << "dimension " << d.distance_m << " m at (" << d.a.transpose() << ")";
  }
}

TEST_F(OfficeFloorPlanTest, VerticalSectionAlongTheCorridor) {
  // Along the corridor's middle: the floor at z = 0, the ceiling at 2.7 m,
  // the end walls at s = 0 and 16 m.
  VerticalSectionOptions o;
  o.a = {0.0, 1.0};
  o.b = {16.0, 1.0};
  std::vector<Eigen::Vector2d> s_z;
  ASSERT_TRUE(VerticalSection(*cloud_, o, &s_z).ok());
  ASSERT_GT(s_z.size(), 1000u);
  Eigen::Vector2d lo = s_z.front(), hi = s_z.front();
  for (const Eigen::Vector2d& p : s_z) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  EXPECT_NEAR(lo.y(), 0.0, 0.03);
  EXPECT_NEAR(hi.y(), 2.7, 0.03);  // the storey's height (OfficeFloorScene)
  EXPECT_GE(lo.x(), 0.0);
  EXPECT_LE(hi.x(), 16.0);
  EXPECT_LT(lo.x(), 0.05);
  EXPECT_GT(hi.x(), 15.95);
}

// The corner of `outline` nearest to p, and its distance.
double NearestCorner(const std::vector<Eigen::Vector2d>& outline, const Eigen::Vector2d& p) {
  double best = INFINITY;
  for (const Eigen::Vector2d& q : outline) best = std::min(best, (q - p).norm());
  return best;
}

bool InsidePolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool inside = false;  // crossings of a ray towards +x
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    if ((poly[i].y() > p.y()) != (poly[j].y() > p.y()) &&
        p.x() < (poly[j].x() - poly[i].x()) * (p.y() - poly[i].y()) / (poly[j].y() - poly[i].y()) + poly[i].x()) {
      inside = !inside;
    }
  }
  return inside;
}

TEST_F(OfficeFloorPlanTest, RoomOutlinesAreTheRoomsInnerFacesWithin5mm) {
  // Every room of the truth is one outline: four corners, each within 5 mm
  // of the room's inner corner, the doors closed flush with its walls; the
  // area within the corners' error; the label inside; nothing else.
  const std::vector<sim::RoomTruth> truth = sim::OfficeFloorRooms();
  ASSERT_EQ(plan_->rooms.size(), truth.size());
  std::vector<int> found(truth.size(), 0);
  for (const Room& room : plan_->rooms) {
    std::printf("room: %zu corners, %.3f m2, label (%.2f, %.2f), %zu faces, %zu openings\n", room.outline.size(),
                room.area_m2, room.label.x(), room.label.y(), room.faces.size(), room.openings.size());
    size_t match = truth.size();
    for (size_t t = 0; t < truth.size(); ++t) {
      const sim::RoomTruth& r = truth[t];
      if (room.label.x() > r.x0 && room.label.x() < r.x1 && room.label.y() > r.y0 && room.label.y() < r.y1) match = t;
    }
    ASSERT_LT(match, truth.size()) << "a room whose label is in no room of the truth";
    const sim::RoomTruth& r = truth[match];
    ++found[match];
    EXPECT_TRUE(InsidePolygon(room.outline, room.label)) << r.label;
    // The label (name over area, about 0.66 x 0.4 m at the default text
    // height) clear of every dimension's line and its value beside it
    // (0.05 m off the line, 0.125 m high): once it sat on "15.999".
    for (const Dimension& dim : plan_->dimensions) {
      for (int k = 0; k <= 1000; ++k) {
        const Eigen::Vector2d q = dim.a + (dim.b - dim.a) * (k / 1000.0);
        const Eigen::Vector2d off = (q - room.label).cwiseAbs() - Eigen::Vector2d(0.33, 0.2);
        EXPECT_GT(off.cwiseMax(0.0).norm(), 0.18)
            << r.label << ": label at " << room.label.transpose() << ", dimension at "
            << q.transpose();
        if (off.cwiseMax(0.0).norm() <= 0.18) break;
      }
    }
    ASSERT_EQ(room.outline.size(), 4u) << r.label;
    for (const Eigen::Vector2d& corner : {Eigen::Vector2d(r.x0, r.y0), Eigen::Vector2d(r.x1, r.y0),
                                          Eigen::Vector2d(r.x1, r.y1), Eigen::Vector2d(r.x0, r.y1)}) {
      const double d = NearestCorner(room.outline, corner);
      EXPECT_LT(d, kFaceTolerance) << r.label << " corner (" << corner.transpose() << ")";
      std::printf("  %s corner (%.1f, %.1f): %.2f mm\n", r.label.c_str(), corner.x(), corner.y(), 1e3 * d);
    }
    const double area = (r.x1 - r.x0) * (r.y1 - r.y0), perimeter = 2 * (r.x1 - r.x0 + r.y1 - r.y0);
    EXPECT_NEAR(room.area_m2, area, kFaceTolerance * perimeter) << r.label;
    EXPECT_NEAR(room.perimeter_m, perimeter, 8 * kFaceTolerance) << r.label;
    // Counter-clockwise, as documented.
    double twice = 0.0;
    for (size_t k = 0; k < room.outline.size(); ++k) {
      const Eigen::Vector2d& p = room.outline[k];
      const Eigen::Vector2d& q = room.outline[(k + 1) % room.outline.size()];
      twice += p.x() * q.y() - q.x() * p.y();
    }
    EXPECT_GT(twice, 0.0) << r.label;
  }
  for (size_t t = 0; t < truth.size(); ++t) EXPECT_EQ(found[t], 1) << truth[t].label;
  // The reading order: the corridor (south) first, then A, B, C west to east.
  EXPECT_LT(plan_->rooms.front().label.y(), 2.0);
  for (size_t k = 2; k < plan_->rooms.size(); ++k) {
    EXPECT_LT(plan_->rooms[k - 1].label.x(), plan_->rooms[k].label.x());
  }
  // The doors: the corridor reaches three, room A two (the corridor's, A|B).
  for (const Room& room : plan_->rooms) {
    if (room.label.y() < 2.0) {
      EXPECT_EQ(room.openings.size(), 3u);
    }
    if (room.label.x() < 5.0 && room.label.y() > 2.1) {
      EXPECT_EQ(room.openings.size(), 2u);
    }
  }
}

// A section drawn by hand: the points of an L-shaped room's walls, 1 cm
// apart with +-2 mm of deterministic noise, nothing else.
std::vector<Eigen::Vector2d> LShapedRoom() {
  const std::vector<Eigen::Vector2d> corners = {{0, 0}, {6, 0}, {6, 3}, {3, 3}, {3, 5}, {0, 5}};
  std::vector<Eigen::Vector2d> pts;
  int k = 0;
  for (size_t c = 0; c < corners.size(); ++c) {
    const Eigen::Vector2d a = corners[c], b = corners[(c + 1) % corners.size()];
    const Eigen::Vector2d u = (b - a).normalized(), n(-u.y(), u.x());
    for (double t = 0.0; t < (b - a).norm(); t += 0.01) pts.push_back(a + t * u + n * (0.002 * ((k++ * 7) % 5 - 2) / 2));
  }
  return pts;
}

// A cut through the floor (z = 0) or the office floor's 2.7 m ceiling draws
// the slab's extent as "walls" (219 diagonal ones at 2.69 m): it is found,
// at its height; cuts clear of both are not flagged.
TEST_F(OfficeFloorPlanTest, ACutInTheFloorOrCeilingSlabIsFound) {
  const auto level = [&](double height, double* z) {
    HorizontalSectionOptions o;
    o.height_m = height;
    return LevelSurfaceNearCut(*cloud_, o, 0.03, z);
  };
  double z = -1.0;
  ASSERT_TRUE(level(2.69, &z));
  EXPECT_NEAR(z, 2.7, 0.01);
  ASSERT_TRUE(level(2.63, &z));
  EXPECT_NEAR(z, 2.7, 0.01);
  ASSERT_TRUE(level(0.02, &z));
  EXPECT_NEAR(z, 0.0, 0.01);
  for (const double clear : {0.2, 1.0, 2.05, 2.55}) EXPECT_FALSE(level(clear, &z)) << clear;
}

TEST(FloorPlanRoomsTest, AnLShapedRoomIsOneOutlineWithItsSixCorners) {
  FloorPlan plan;
  ASSERT_TRUE(BuildFloorPlanFromSection(LShapedRoom(), FloorPlanOptions(), &plan).ok());
  ASSERT_EQ(plan.rooms.size(), 1u);
  const Room& room = plan.rooms.front();
  EXPECT_EQ(room.outline.size(), 6u);
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(6, 0), Eigen::Vector2d(6, 3), Eigen::Vector2d(3, 3),
        Eigen::Vector2d(3, 5), Eigen::Vector2d(0, 5)}) {
    EXPECT_LT(NearestCorner(room.outline, corner), 0.003) << corner.transpose();
  }
  EXPECT_NEAR(room.area_m2, 24.0, 0.05);
  EXPECT_NEAR(room.perimeter_m, 22.0, 0.02);
  // The label where it fits: inside the L, not at its centroid's corner.
  EXPECT_TRUE(InsidePolygon(room.outline, room.label)) << room.label.transpose();
  EXPECT_EQ(room.faces.size(), 6u);
}

TEST(FloorPlanRoomsTest, AnOpenSectionHasNoRoom) {
  // Three walls of a room (the fourth side never seen): the free space runs
  // out of the raster, so no outline is claimed.
  std::vector<Eigen::Vector2d> pts;
  for (double t = 0.0; t < 4.0; t += 0.01) {
    pts.emplace_back(t, 0.0);
    pts.emplace_back(0.0, t);
    pts.emplace_back(4.0, t);
  }
  FloorPlan plan;
  ASSERT_TRUE(BuildFloorPlanFromSection(pts, FloorPlanOptions(), &plan).ok());
  EXPECT_GE(plan.faces.size(), 3u);
  EXPECT_TRUE(plan.rooms.empty());
  // Said so, with what to do; a closed room has nothing to say, a section
  // of no walls says that.
  EXPECT_NE(NoRoomsReason(plan).find("do not close around any free floor"), std::string::npos)
      << NoRoomsReason(plan);
  FloorPlan closed;
  ASSERT_TRUE(BuildFloorPlanFromSection(LShapedRoom(), FloorPlanOptions(), &closed).ok());
  EXPECT_EQ(NoRoomsReason(closed), "");
  plan.faces.clear();
  EXPECT_EQ(NoRoomsReason(plan), "no room: no wall faces at this cut");
}

TEST(FloorPlanRefusalTest, BadInputIsRefusedWithAReason) {
  FloorPlan plan;
  FloorPlanOptions o;
  Status s = BuildFloorPlan({}, o, &plan);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("empty"), std::string::npos) << s.message();
  const std::vector<Eigen::Vector3f> cloud = {{0, 0, 1}, {1, 0, 1}, {2, 0, 1}};
  for (const double band : {0.0, -0.1, std::nan("")}) {
    o.section.band_m = band;
    s = BuildFloorPlan(cloud, o, &plan);
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find("band"), std::string::npos) << s.message();
  }
  o = FloorPlanOptions();
  o.section.height_m = INFINITY;
  EXPECT_FALSE(BuildFloorPlan(cloud, o, &plan).ok());
  o = FloorPlanOptions();
  s = BuildFloorPlan(cloud, o, &plan);  // three points: the cut misses the cloud
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("holds 3 points"), std::string::npos) << s.message();
  const std::vector<Eigen::Vector3f> nan_cloud = {{NAN, 0, 1}};
  s = BuildFloorPlan(nan_cloud, FloorPlanOptions(), &plan);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("no finite point"), std::string::npos) << s.message();
  std::vector<Eigen::Vector2d> s_z;
  VerticalSectionOptions v;
  v.b = v.a;
  EXPECT_FALSE(VerticalSection(cloud, v, &s_z).ok());
}

}  // namespace
}  // namespace sweepscan::plan
