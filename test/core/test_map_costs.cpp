// Tests of what a planner reads (core/map_costs.h): the cost table and its safe defaults, the
// static layer's reading of it (nothing hazardous reads as free), the raw PGM of ~save against
// the live costs, the lethal cells of safety_obstacles, and ~save's directory check.
#include "stereo_safety_map/core/map_costs.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <limits>

namespace stereo_safety_map {
namespace {

namespace fs = std::filesystem;

constexpr double kThetaT = 3.0;     // 000 Alg. 2 step 28
constexpr double kThetaMax = 10.0;  // 000 Alg. 2 step 2

std::int8_t cost(const CostTable& t, SafetyLabel l, bool drop, double slope = 0.0) {
  return cellCost(t, l, drop, slope, kThetaT, kThetaMax);
}

TEST(CostTable, DefaultsAreTheDocumentedTable) {
  const CostTable t;
  EXPECT_EQ(t.validate(), "");
  EXPECT_EQ(cost(t, SafetyLabel::kLevel, false), 0);
  EXPECT_EQ(cost(t, SafetyLabel::kInclined, false, kThetaT), 10);
  EXPECT_EQ(cost(t, SafetyLabel::kInclined, false, 6.5), 30);
  EXPECT_EQ(cost(t, SafetyLabel::kInclined, false, kThetaMax), 50);
  EXPECT_EQ(cost(t, SafetyLabel::kInclined, false, 45.0), 50);  // clamped
  EXPECT_EQ(cost(t, SafetyLabel::kInclined, false, std::nan("")), 10);
  EXPECT_EQ(cost(t, SafetyLabel::kLevel, true), 100);     // drop-off edge: lethal
  EXPECT_EQ(cost(t, SafetyLabel::kInclined, true), 100);  // on an incline too
  EXPECT_EQ(cost(t, SafetyLabel::kNonGround, false), 100);
  EXPECT_EQ(cost(t, SafetyLabel::kNonGround, true), 100);
  EXPECT_EQ(cost(t, SafetyLabel::kUnknown, false), -1);
  EXPECT_EQ(cost(t, SafetyLabel::kUnknown, true), -1);  // an annotation never makes it known
  EXPECT_EQ(cost(t, SafetyLabel::kUnexamined, false), -1);
  EXPECT_EQ(cost(t, static_cast<SafetyLabel>(7), false), -1);
}

TEST(CostTable, ConfiguredRows) {
  CostTable t;
  t.level = 5;
  t.inclined_low = 20;
  t.inclined_high = 99;
  t.drop_off = 90;
  ASSERT_EQ(t.validate(), "");
  EXPECT_EQ(cost(t, SafetyLabel::kLevel, false), 5);
  EXPECT_EQ(cost(t, SafetyLabel::kInclined, false, kThetaT), 20);
  EXPECT_EQ(cost(t, SafetyLabel::kInclined, false, kThetaMax), 99);
  EXPECT_EQ(cost(t, SafetyLabel::kLevel, true), 90);
  EXPECT_EQ(cost(t, SafetyLabel::kNonGround, false), 100);  // not configurable
}

TEST(CostTable, ValidateNamesTheParameter) {
  auto refused = [](CostTable t, const char* name) {
    const std::string err = t.validate();
    EXPECT_NE(err.find(name), std::string::npos) << err;
  };
  CostTable t;
  t.level = -1;
  refused(t, "cost_level");
  t = CostTable();
  t.level = 100;  // Level lethal: nonsense
  refused(t, "cost_level");
  t = CostTable();
  t.inclined_high = 100;  // graded Inclined stays below lethal
  refused(t, "cost_inclined_high");
  t = CostTable();
  t.inclined_low = 60;  // above inclined_high
  refused(t, "cost_inclined_high");
  t = CostTable();
  t.level = 20;  // above inclined_low
  refused(t, "cost_inclined_low");
  t = CostTable();
  t.drop_off = 0;  // a drop-off edge free: never
  refused(t, "cost_drop_off");
  t = CostTable();
  t.drop_off = 101;
  refused(t, "cost_drop_off");
  t = CostTable();
  t.inclined_high = 99;
  t.drop_off = 1;
  EXPECT_EQ(t.validate(), "");
}

TEST(StaticLayer, InterpretsValuesAsCostmap2dDoes) {
  StaticLayerSettings s;  // trinary, lethal 100, unknown -1, track unknown
  EXPECT_EQ(staticLayerCost(0, s), kCostmapFreeSpace);
  EXPECT_EQ(staticLayerCost(99, s), kCostmapFreeSpace);  // trinary: all below lethal is free
  EXPECT_EQ(staticLayerCost(100, s), kCostmapLethal);
  EXPECT_EQ(staticLayerCost(-1, s), kCostmapNoInformation);
  s.track_unknown_space = false;
  EXPECT_EQ(staticLayerCost(-1, s), kCostmapFreeSpace);
  s = StaticLayerSettings();
  s.trinary_costmap = false;
  EXPECT_EQ(staticLayerCost(50, s), 127);
  EXPECT_EQ(staticLayerCost(90, s), 228);
  EXPECT_EQ(staticLayerCost(100, s), kCostmapLethal);
}

// The safe default: through the static layer (trinary true, lethal 100, unknown -1,
// track_unknown_space true, the README's costmap section) no drop-off edge and no Non-ground
// cell reads as free, whatever its slope; Level does, Unknown is unknown.
TEST(StaticLayer, NothingHazardousReadsAsFreeWithTheDefaults) {
  const CostTable t;
  const StaticLayerSettings s;
  for (double slope : {0.0, 2.0, 3.0, 5.0, 10.0, 30.0}) {
    for (SafetyLabel l : {SafetyLabel::kLevel, SafetyLabel::kInclined}) {
      EXPECT_EQ(staticLayerCost(cost(t, l, true, slope), s), kCostmapLethal);
    }
    EXPECT_EQ(staticLayerCost(cost(t, SafetyLabel::kNonGround, false, slope), s), kCostmapLethal);
    EXPECT_EQ(staticLayerCost(cost(t, SafetyLabel::kUnknown, false, slope), s),
              kCostmapNoInformation);
    EXPECT_EQ(staticLayerCost(cost(t, SafetyLabel::kUnexamined, false, slope), s),
              kCostmapNoInformation);
  }
  EXPECT_EQ(staticLayerCost(cost(t, SafetyLabel::kLevel, false), s), kCostmapFreeSpace);
  EXPECT_EQ(staticLayerCost(cost(t, SafetyLabel::kInclined, false, 5.0), s), kCostmapFreeSpace);
}

SafetyMap exampleMap() {
  SafetyMap m;
  m.min_u = -3;
  m.min_v = 2;
  m.width = 5;
  m.height = 4;
  m.resolution = 0.1;
  const std::size_t n = 20;
  m.labels.assign(n, SafetyLabel::kLevel);
  m.drop_off.assign(n, 0);
  m.segment.assign(n, -1);
  SegmentInfo ramp;
  ramp.plane.slope_deg = 8.0;
  ramp.label = SafetyLabel::kInclined;
  m.segments.push_back(ramp);
  m.labels[m.index(-3, 2)] = SafetyLabel::kNonGround;
  m.labels[m.index(1, 5)] = SafetyLabel::kUnknown;
  m.labels[m.index(0, 5)] = SafetyLabel::kUnexamined;
  m.labels[m.index(-1, 3)] = SafetyLabel::kInclined;
  m.segment[m.index(-1, 3)] = 0;
  m.labels[m.index(-2, 3)] = SafetyLabel::kInclined;
  m.segment[m.index(-2, 3)] = 0;
  m.drop_off[m.index(-2, 3)] = 1;
  m.drop_off[m.index(1, 2)] = 1;
  return m;
}

TEST(SafetyMapCosts, RowMajorCellByCell) {
  const SafetyMap m = exampleMap();
  std::vector<std::int8_t> c;
  safetyMapCosts(m, CostTable(), kThetaT, kThetaMax, &c);
  ASSERT_EQ(c.size(), 20u);
  EXPECT_EQ(c[m.index(-3, 2)], 100);
  EXPECT_EQ(c[m.index(1, 5)], -1);
  EXPECT_EQ(c[m.index(0, 5)], -1);
  EXPECT_EQ(c[m.index(-1, 3)], 39);  // 10 + (8 - 3) / 7 * 40 = 38.6
  EXPECT_EQ(c[m.index(-2, 3)], 100);
  EXPECT_EQ(c[m.index(1, 2)], 100);
  EXPECT_EQ(c[m.index(0, 2)], 0);
}

TEST(RawPgm, MapServerReadsBackTheLiveCosts) {
  const SafetyMap m = exampleMap();
  CostTable t;
  t.drop_off = 90;  // any table: the file carries the values, not a trinary reading of them
  std::vector<std::int8_t> live;
  safetyMapCosts(m, t, kThetaT, kThetaMax, &live);
  const std::string pgm = costsToRawPgm(live, m.width, m.height);
  ASSERT_FALSE(pgm.empty());
  std::vector<std::int8_t> read;
  int w = 0, h = 0;
  ASSERT_EQ(rawPgmToCosts(pgm, &read, &w, &h), "");
  EXPECT_EQ(w, m.width);
  EXPECT_EQ(h, m.height);
  EXPECT_EQ(read, live);
  // Image row 0 is the map's top: the Non-ground cell (-3, 2) is the bottom-left pixel, 100.
  EXPECT_EQ(static_cast<unsigned char>(pgm[pgm.size() - m.width]), 100);
  // Unknown is pixel 255 (map_server raw: int8 -1).
  const std::size_t top_row = pgm.size() - static_cast<std::size_t>(m.width) * m.height;
  EXPECT_EQ(static_cast<unsigned char>(pgm[top_row + 4]), 255);  // (1, 5)
  EXPECT_TRUE(costsToRawPgm(live, m.width + 1, m.height).empty());
  EXPECT_NE(rawPgmToCosts("P2\n1 1\n255\n0", &read, &w, &h), "");
  EXPECT_NE(rawPgmToCosts(pgm.substr(0, pgm.size() - 1), &read, &w, &h), "");
}

TEST(LethalCells, CentresOfTheLethalCells) {
  const SafetyMap m = exampleMap();
  std::vector<std::int8_t> c;
  safetyMapCosts(m, CostTable(), kThetaT, kThetaMax, &c);
  std::vector<Eigen::Vector3f> pts;
  lethalCellPoints(m, c, 0.25f, &pts);
  ASSERT_EQ(pts.size(), 3u);  // Non-ground and the two drop-off edges
  EXPECT_NEAR(pts[0].x(), -0.3f, 1e-6);
  EXPECT_NEAR(pts[0].y(), 0.2f, 1e-6);
  EXPECT_FLOAT_EQ(pts[0].z(), 0.25f);
  CostTable t;
  t.drop_off = 90;  // drop-off edges not lethal: not obstacles
  safetyMapCosts(m, t, kThetaT, kThetaMax, &c);
  lethalCellPoints(m, c, 0.0f, &pts);
  EXPECT_EQ(pts.size(), 1u);
  c.pop_back();  // inconsistent: nothing
  lethalCellPoints(m, c, 0.0f, &pts);
  EXPECT_TRUE(pts.empty());
}

class SavePrefix : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("ssm_save_prefix_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_ / "maps" / "sub");
    fs::create_directories(root_ / "elsewhere");
    fs::create_directory_symlink(root_ / "elsewhere", root_ / "maps" / "out");
    fs::create_directory_symlink(root_ / "maps" / "sub", root_ / "maps" / "in");
    dir_ = (root_ / "maps").string();
  }
  void TearDown() override { fs::remove_all(root_); }
  fs::path root_;
  std::string dir_;
};

TEST_F(SavePrefix, InsideIsAccepted) {
  std::string r;
  EXPECT_EQ(resolveSavePrefix(dir_, "map", &r), "");
  EXPECT_EQ(r, dir_ + "/map");
  EXPECT_EQ(resolveSavePrefix(dir_, "run1/new/map", &r), "");  // not there yet: created later
  EXPECT_EQ(r, dir_ + "/run1/new/map");
  EXPECT_EQ(resolveSavePrefix(dir_, dir_ + "/sub/map", &r), "");
  EXPECT_EQ(resolveSavePrefix(dir_, "sub/../map", &r), "");
  EXPECT_EQ(r, dir_ + "/map");
  EXPECT_EQ(resolveSavePrefix(dir_ + "/", "in/map", &r), "");  // a symlink that stays inside
  EXPECT_EQ(r, dir_ + "/sub/map");
}

TEST_F(SavePrefix, LeavingIsRefusedWithAMessage) {
  std::string r = "unchanged";
  for (const std::string& p :
       {std::string("../map"), std::string("sub/../../map"), std::string("/etc/map"),
        (root_ / "elsewhere" / "map").string(), std::string("out/map"),
        std::string("out/deeper/map"), (root_ / "maps2" / "map").string()}) {
    const std::string err = resolveSavePrefix(dir_, p, &r);
    EXPECT_NE(err.find("outside save_directory"), std::string::npos) << p << ": " << err;
  }
  EXPECT_EQ(r, "unchanged");
  EXPECT_NE(resolveSavePrefix(dir_, "", &r), "");
  EXPECT_NE(resolveSavePrefix(dir_, "sub/", &r).find("no file name"), std::string::npos);
  EXPECT_NE(resolveSavePrefix(dir_, "..", &r), "");
  EXPECT_NE(resolveSavePrefix("relative/dir", "map", &r).find("absolute"), std::string::npos);
  EXPECT_EQ(r, "unchanged");
}

}  // namespace
}  // namespace stereo_safety_map
