// Safety labelling, Alg. 2, and the safety map with drop-off edges (000, Sec. VI), on hand-made
// height maps, segments and planes.
#include "stereo_safety_map/core/safety_labelling.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace {

constexpr double kLv = 0.1;
constexpr double kDeg = M_PI / 180.0;
using L = SafetyLabel;

// Row i is v = i, column j is u = j; '.' no height, '0'-'9' heights 0..9, 'a'-'i' -1..-9.
HeightMap fromText(const std::vector<std::string>& rows) {
  HeightMap hm;
  hm.reset(0, 0, static_cast<int>(rows[0].size()), static_cast<int>(rows.size()));
  for (int v = 0; v < static_cast<int>(rows.size()); ++v) {
    for (int u = 0; u < static_cast<int>(rows[v].size()); ++u) {
      const char ch = rows[v][u];
      if (ch >= '0' && ch <= '9') hm.set(u, v, ch - '0');
      if (ch >= 'a' && ch <= 'i') hm.set(u, v, -(ch - 'a' + 1));
    }
  }
  return hm;
}

GroundPlane horizontal(double z) {
  GroundPlane p;
  p.valid = true;
  p.c = z;
  p.num_points = 100;
  return p;
}

// Plane through (x0, y0, z0) rising at `deg` along +x.
GroundPlane inclined(double deg, double x0, double z0) {
  GroundPlane p = horizontal(0.0);
  p.a = std::tan(deg * kDeg);
  p.c = z0 - p.a * x0;
  p.normal = Eigen::Vector3d(-p.a, 0.0, 1.0).normalized();
  p.slope_deg = deg;
  return p;
}

// 000's Alg. 1 and Alg. 2 alone (no island segments, no neighbours across gaps, plane step test
// only): most tests below
// check the paper's behaviour.
GroundSegmentationConfig paperSegmentation() {
  GroundSegmentationConfig c;
  c.segment_islands = false;
  c.footprint_radius = 0.0;
  return c;
}
SafetyLabellingConfig paperLabelling() {
  SafetyLabellingConfig c;
  c.max_gap_cells = 0;
  c.measured_step_test = false;
  c.small_obstacles = false;
  c.footprint_bridge = 0.0;
  c.isolated_ground_unknown = false;
  c.step_height_margin = 0.0;
  return c;
}

// Segments the height map from the robot's cell and gives each segment a horizontal plane at
// its indexed height, unless `plane_of_height` says otherwise.
struct World {
  HeightMap hm;
  GroundSegments segs;
  std::vector<GroundPlane> planes;
  SafetyMap map;

  World(const std::vector<std::string>& rows, int ru, int rv, int rw = 0,
        const GroundSegmentationConfig& sc = paperSegmentation())
      : hm(fromText(rows)) {
    GroundSegmentation seg(sc);
    EXPECT_TRUE(seg.segment(hm, VoxelIndex{ru, rv, rw}, kLv, &segs));
    for (int k = 0; k < segs.numSegments(); ++k) {
      planes.push_back(horizontal(segs.segment_height[k] * kLv));
    }
  }
  int segAt(int u, int v) const { return segs.segment_of[segs.index(u, v)]; }
  GroundPlane& planeAt(int u, int v) { return planes.at(segAt(u, v)); }
  bool label(const SafetyLabellingConfig& c = paperLabelling()) {
    SafetyLabelling labelling(c);
    return labelling.label(hm, segs, planes, kLv, &map);
  }
  L at(int u, int v) const { return map.labelAt(u, v); }
  bool drop(int u, int v) const { return map.drop_off[map.index(u, v)] != 0; }
};

std::vector<std::string> block(int w, int h, char ch) {
  return std::vector<std::string>(h, std::string(w, ch));
}

TEST(SafetyLabellingConfig, DefaultsAreThePapersAndValidateNamesTheParameter) {
  SafetyLabellingConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_DOUBLE_EQ(c.max_slope_deg, 10.0);
  EXPECT_EQ(c.min_segment_cells, 6);
  EXPECT_DOUBLE_EQ(c.thin_ratio, 0.1);
  EXPECT_DOUBLE_EQ(c.max_step_height, 0.05);
  EXPECT_EQ(c.min_passage_cells, 5);
  EXPECT_DOUBLE_EQ(c.level_slope_deg, 3.0);
  EXPECT_TRUE(c.floor_fragments);          // ours, on
  EXPECT_FALSE(c.robot_fragment_passage);  // ours, off: the safe side
  auto bad = [](auto mutate, const char* name) {
    SafetyLabellingConfig b;
    mutate(b);
    EXPECT_NE(b.validate().find(name), std::string::npos) << name;
  };
  bad([](auto& b) { b.max_slope_deg = 90.0; }, "max_slope_deg");
  bad([](auto& b) { b.min_segment_cells = -1; }, "min_segment_cells");
  bad([](auto& b) { b.thin_ratio = std::nan(""); }, "thin_ratio");
  bad([](auto& b) { b.max_step_height = 0.0; }, "max_step_height");
  bad([](auto& b) { b.min_passage_cells = 0; }, "min_passage_cells");
  bad([](auto& b) { b.level_slope_deg = 12.0; }, "level_slope_deg");
  bad([](auto& b) { b.drop_off_radius = -0.1; }, "drop_off_radius");
  bad([](auto& b) { b.drop_off_min_drop = -1.0; }, "drop_off_min_drop");
  bad([](auto& b) { b.obstacle_face_min_rise = -1.0; }, "obstacle_face_min_rise");
  bad([](auto& b) { b.max_gap_cells = 11; }, "max_gap_cells");
  bad([](auto& b) { b.max_gap_cells = -1; }, "max_gap_cells");
  bad([](auto& b) { b.floor_fragment_tolerance = 1.5; }, "floor_fragment_tolerance");
  bad([](auto& b) { b.step_height_margin = -0.01; }, "step_height_margin");
  bad([](auto& b) { b.step_height_margin = 0.05; }, "step_height_margin");  // not below h_T
  EXPECT_DOUBLE_EQ(c.slope_margin_deg, 0.0);  // ours, off: 000's theta_max
  bad([](auto& b) { b.slope_margin_deg = -0.5; }, "slope_margin_deg");
  bad([](auto& b) { b.slope_margin_deg = 7.5; }, "slope_margin_deg");  // over theta_max - theta_T
  c.max_step_height = -1.0;
  EXPECT_THROW(SafetyLabelling{c}, std::invalid_argument);
}

TEST(SafetyLabelling, FlatFloorIsOneLevelSegment) {
  World w(block(12, 10, '0'), 5, 5);
  ASSERT_TRUE(w.label());
  ASSERT_EQ(w.map.segments.size(), 1u);
  const SegmentInfo& s = w.map.segments[0];
  EXPECT_EQ(s.label, L::kLevel);
  EXPECT_TRUE(s.reachable);
  EXPECT_EQ(s.cells.size(), 120u);
  EXPECT_EQ(s.num_interior, 10 * 8);  // cells on the map's edge have fewer than 8 neighbours
  EXPECT_EQ(s.num_boundary, 120 - 80);
  EXPECT_EQ(w.map.robot_segment, 0);
  EXPECT_EQ(w.map.robot_u, 5);
  for (auto l : w.map.labels)
    EXPECT_EQ(l, L::kLevel);
  for (auto d : w.map.drop_off)
    EXPECT_EQ(d, 0);
  EXPECT_EQ(w.map.column_height[w.map.index(3, 3)], 0);
  EXPECT_DOUBLE_EQ(w.map.resolution, kLv);
}

TEST(SafetyLabelling, SlopeDecidesLevelInclinedNonGround) {
  // Robot's floor 0, a big region 1 beyond it. The region's plane is made to meet the floor at
  // the border (x = 0.75) with various slopes.
  std::vector<std::string> rows(10, "000000001111111111");
  for (double deg : {2.0, 5.0, 12.0}) {
    World w(rows, 2, 5);
    ASSERT_EQ(w.segs.numSegments(), 2);
    w.planeAt(12, 5) = inclined(deg, 0.75, 0.0);
    ASSERT_TRUE(w.label());
    const L expect = deg <= 3.0 ? L::kLevel : deg <= 10.0 ? L::kInclined : L::kNonGround;
    EXPECT_EQ(w.at(12, 5), expect) << deg;
    EXPECT_EQ(w.at(2, 5), L::kLevel);
    EXPECT_EQ(w.map.segments[w.segAt(12, 5)].reachable, deg <= 10.0);
    // The normal of an Inclined cell is its segment's plane normal.
    EXPECT_NEAR(std::acos(w.map.segments[w.segAt(12, 5)].plane.normal.z()) / kDeg, deg, 1e-9);
  }
}

TEST(SafetyLabelling, APlaneWithinTheSlopeMarginOfThetaMaxIsNonGround) {
  // The region beyond the floor measured at 9 deg: Inclined and reachable under 000's theta_max
  // alone, Non-ground with a 1.5 deg margin (8.5 deg); 8 deg stays Inclined with it.
  std::vector<std::string> rows(10, "000000001111111111");
  for (double margin : {0.0, 1.5}) {
    for (double deg : {8.0, 9.0}) {
      World w(rows, 2, 5);
      SafetyLabellingConfig c = paperLabelling();
      c.slope_margin_deg = margin;
      w.planeAt(12, 5) = inclined(deg, 0.75, 0.0);
      ASSERT_TRUE(w.label(c));
      const bool safe = deg <= 10.0 - margin;
      EXPECT_EQ(w.at(12, 5), safe ? L::kInclined : L::kNonGround) << deg << " " << margin;
      EXPECT_EQ(w.map.segments[w.segAt(12, 5)].reachable, safe) << deg << " " << margin;
      EXPECT_EQ(w.at(2, 5), L::kLevel);
    }
  }
}

TEST(SafetyLabelling, RobotsSegmentIsSafeEvenWhenSteep) {
  // Alg. 2 step 6 labels the robot's segment Safe after step 2; step 28 then makes it Inclined.
  World w(block(10, 10, '0'), 5, 5);
  w.planes[0] = inclined(14.0, 0.5, 0.0);
  ASSERT_TRUE(w.label());
  EXPECT_EQ(w.map.segments[0].label, L::kInclined);
  EXPECT_TRUE(w.map.segments[0].reachable);
}

TEST(SafetyLabelling, StepHeightDecidesReachability) {
  std::vector<std::string> rows(10, "000000001111111111");
  for (double z : {0.04, 0.06}) {
    World w(rows, 2, 5);
    w.planeAt(12, 5) = horizontal(z);
    ASSERT_TRUE(w.label());
    EXPECT_EQ(w.at(12, 5), z < 0.05 ? L::kLevel : L::kNonGround) << z;
    EXPECT_EQ(w.map.segments[w.segAt(12, 5)].reachable, z < 0.05);
  }
}

TEST(SafetyLabelling, ReachabilityChainsThroughSafeSegments) {
  // 0 -> 1 -> 2, each plane 0.03 m above the previous one.
  std::vector<std::string> rows(10, "000000111111222222");
  World w(rows, 2, 5);
  ASSERT_EQ(w.segs.numSegments(), 3);
  w.planeAt(8, 5) = horizontal(0.03);
  w.planeAt(14, 5) = horizontal(0.06);
  ASSERT_TRUE(w.label());
  EXPECT_EQ(w.at(14, 5), L::kLevel);
  // Raise the last one out of reach of the middle one.
  w.planeAt(14, 5) = horizontal(0.09);
  ASSERT_TRUE(w.label());
  EXPECT_EQ(w.at(8, 5), L::kLevel);
  EXPECT_EQ(w.at(14, 5), L::kNonGround);
}

TEST(SafetyLabelling, PassageNarrowerThanTheRobotIsNotCrossed) {
  // Floor 0 left, region 1 right, separated by a wall (9) with a gap of `gap` cells in column 8.
  for (int gap : {4, 5}) {
    std::vector<std::string> rows(12, "00000000911111111");
    for (int v = 3; v < 3 + gap; ++v)
      rows[v][8] = '1';
    World w(rows, 2, 6);
    ASSERT_EQ(w.segs.numSegments(), 2);
    w.planeAt(12, 6) = horizontal(0.02);
    ASSERT_TRUE(w.label());
    // num_T = 5 cells of robot width: a 4-cell gap is too narrow.
    EXPECT_EQ(w.at(12, 6), gap >= 5 ? L::kLevel : L::kNonGround) << gap;
    EXPECT_EQ(w.at(8, 0), L::kNonGround);  // the wall
  }
}

TEST(SafetyLabelling, SmallAndThinSegmentsAreUnknown) {
  std::vector<std::string> rows = block(20, 14, '0');
  rows[2].replace(2, 2, "11");  // 2 x 2 = 4 cells: small
  rows[3].replace(2, 2, "11");
  rows[8].replace(2, 14, std::string(14, '1'));  // 2 x 14 = 28 cells, no interior: thin
  rows[9].replace(2, 14, std::string(14, '1'));
  for (int v = 2; v <= 6; ++v)
    rows[v].replace(12, 5, "11111");  // 5 x 5: interior 9, boundary 16
  World w(rows, 8, 12);
  ASSERT_EQ(w.segs.numSegments(), 4);
  for (auto& p : w.planes)
    p = horizontal(0.01);
  ASSERT_TRUE(w.label());
  EXPECT_EQ(w.at(2, 2), L::kUnknown);
  EXPECT_EQ(w.at(10, 9), L::kUnknown);
  EXPECT_EQ(w.at(14, 4), L::kLevel);
  EXPECT_EQ(w.map.segments[w.segAt(14, 4)].num_interior, 9);
  EXPECT_EQ(w.map.segments[w.segAt(14, 4)].num_boundary, 16);

  // Thin threshold: with r_thin = 0.6 the 5 x 5 square (9 < 0.6 * 16) is thin as well.
  SafetyLabellingConfig c = paperLabelling();
  c.thin_ratio = 0.6;
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(14, 4), L::kUnknown);
  // n_small = 30 makes the 28-cell strip and the square small.
  c = paperLabelling();
  c.min_segment_cells = 30;
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(14, 4), L::kUnknown);
  EXPECT_EQ(w.at(0, 0), L::kLevel);  // the robot's segment is exempt
}

TEST(SafetyLabelling, UnknownSegmentsDoNotPassOnReachability) {
  // Floor 0 | strip of 1s two cells wide (thin, Unknown) | floor 2 beyond, only touching the strip.
  std::vector<std::string> rows(10, "0000001122222222");
  World w(rows, 2, 5);
  ASSERT_EQ(w.segs.numSegments(), 3);
  w.planeAt(7, 5) = horizontal(0.0);
  w.planeAt(12, 5) = horizontal(0.0);
  ASSERT_TRUE(w.label());
  EXPECT_EQ(w.at(7, 5), L::kUnknown);
  EXPECT_EQ(w.at(12, 5), L::kNonGround);  // step 27: never reached
  EXPECT_FALSE(w.map.segments[w.segAt(12, 5)].reachable);
}

TEST(SafetyLabelling, InvalidPlanesAreUnknown) {
  std::vector<std::string> rows(10, "000000001111111111");
  World w(rows, 2, 5);
  w.planeAt(12, 5).valid = false;
  ASSERT_TRUE(w.label());
  EXPECT_EQ(w.at(12, 5), L::kUnknown);
  EXPECT_EQ(w.at(2, 5), L::kLevel);

  // The robot's segment without a plane: nothing can be compared with it, nothing is reached.
  World r(rows, 2, 5);
  r.planeAt(2, 5).valid = false;
  ASSERT_TRUE(r.label());
  EXPECT_EQ(r.at(2, 5), L::kUnknown);
  EXPECT_EQ(r.at(12, 5), L::kNonGround);

  // Fewer planes than segments: the missing ones are invalid.
  World m(rows, 2, 5);
  m.planes.resize(1);
  ASSERT_TRUE(m.label());
  EXPECT_EQ(m.at(2, 5), L::kLevel);
  EXPECT_EQ(m.at(12, 5), L::kUnknown);
}

TEST(SafetyLabelling, CellMapLabels) {
  // Robot at (5, 5) with R_max = 0.4 m: a 9-cell-diameter disc is examined.
  std::vector<std::string> rows = {
      "00000000000",  //
      "00000000000",  //
      "00000000000",  //
      "00000550000",  //
      "000..550000",  //
      "000..000000",  //
      "00000000000",  //
      "00000000000",  //
      "00000000000",  //
      "00000000000",  //
      "00000000000",  //
  };
  HeightMap hm = fromText(rows);
  GroundSegmentationConfig gc;
  gc.planning_radius = 0.4;
  gc.footprint_radius = 0.0;  // (3, 4) would be the robot's footprint: ground
  GroundSegmentation seg(gc);
  GroundSegments segs;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{5, 5, 0}, kLv, &segs));
  std::vector<GroundPlane> planes(segs.numSegments(), horizontal(0.0));
  SafetyMap map;
  ASSERT_TRUE(SafetyLabelling().label(hm, segs, planes, kLv, &map));
  EXPECT_EQ(map.labelAt(5, 5), L::kLevel);
  EXPECT_EQ(map.labelAt(5, 3), L::kNonGround);  // box, non-traversable
  EXPECT_EQ(map.labelAt(3, 4), L::kUnknown);    // no data inside R_max
  EXPECT_EQ(map.labelAt(0, 0), L::kUnexamined);
  EXPECT_EQ(map.labelAt(9, 5), L::kLevel);  // 0.4 m: inside
  EXPECT_EQ(map.labelAt(10, 5), L::kUnexamined);
  EXPECT_EQ(map.segment[map.index(5, 3)], -1);
  EXPECT_EQ(map.segment[map.index(5, 5)], 0);
  EXPECT_EQ(map.column_height[map.index(5, 3)], 5);
  EXPECT_EQ(map.column_height[map.index(3, 4)], SafetyMap::kNoHeight);
}

// Floor (0) with an unobserved shadow band and a lower level (-2) beyond it.
std::vector<std::string> dropWorld(int shadow, char beyond) {
  std::vector<std::string> rows;
  for (int v = 0; v < 16; ++v) {
    std::string r = std::string(12, '0') + std::string(shadow, '.');
    r += std::string(24 - r.size(), beyond);
    rows.push_back(r);
  }
  return rows;
}

TEST(SafetyLabelling, DropOffEdgesBesideUnknownCellsNearLowerCells) {
  World w(dropWorld(3, 'b'), 4, 8);
  ASSERT_TRUE(w.label());
  EXPECT_EQ(w.at(20, 8), L::kNonGround);  // lower level: unreachable
  EXPECT_EQ(w.at(12, 8), L::kUnknown);    // shadow
  for (int v = 0; v < 16; ++v) {
    EXPECT_TRUE(w.drop(11, v)) << v;  // the edge: next to the shadow, 0.4 m from lower cells
    EXPECT_FALSE(w.drop(10, v)) << v;
    EXPECT_FALSE(w.drop(16, v)) << v;  // not on a safe segment
  }

  // Shadow wider than the radius: the lower cells are not "close".
  World wide(dropWorld(6, 'b'), 4, 8);
  ASSERT_TRUE(wide.label());
  for (int v = 0; v < 16; ++v)
    EXPECT_FALSE(wide.drop(11, v));
  SafetyLabellingConfig c = paperLabelling();
  c.drop_off_radius = 0.7;
  ASSERT_TRUE(wide.label(c));
  EXPECT_TRUE(wide.drop(11, 8));

  // Higher cells beyond the shadow (a wall) are no drop.
  World wall(dropWorld(3, '9'), 4, 8);
  ASSERT_TRUE(wall.label());
  for (auto d : wall.map.drop_off)
    EXPECT_EQ(d, 0);

  // A drop smaller than drop_off_min_drop is no drop: lower level at -1 (0.1 m) with 0.15 m.
  World shallow(dropWorld(3, 'a'), 4, 8);
  c = paperLabelling();
  c.drop_off_min_drop = 0.15;
  ASSERT_TRUE(shallow.label(c));
  for (auto d : shallow.map.drop_off)
    EXPECT_EQ(d, 0);
  ASSERT_TRUE(shallow.label());
  EXPECT_TRUE(shallow.drop(11, 8));

  c = paperLabelling();
  c.mark_drop_offs = false;
  ASSERT_TRUE(w.label(c));
  for (auto d : w.map.drop_off)
    EXPECT_EQ(d, 0);
}

TEST(SafetyLabelling, DropOffNeedsAnUnknownNeighbour) {
  // Floor stepping straight down to -2 without a shadow: the lower cells are Non-ground, not
  // Unknown, so no potential drop-off edge (the drop is seen).
  std::vector<std::string> rows(10, "000000000000bbbbbbbb");
  World w(rows, 4, 5);
  ASSERT_TRUE(w.label());
  for (auto d : w.map.drop_off)
    EXPECT_EQ(d, 0);
}

TEST(SafetyLabelling, BadInputGivesAnUnknownMap) {
  World w(block(8, 8, '0'), 4, 4);
  SafetyLabelling labelling;
  SafetyMap map;
  HeightMap other = fromText(block(9, 8, '0'));
  EXPECT_FALSE(labelling.label(other, w.segs, w.planes, kLv, &map));
  EXPECT_EQ(map.width, 9);
  EXPECT_EQ(map.labels.size(), 72u);
  for (auto l : map.labels)
    EXPECT_EQ(l, L::kUnknown);
  EXPECT_TRUE(map.segments.empty());
  EXPECT_EQ(map.robot_segment, -1);

  EXPECT_FALSE(labelling.label(w.hm, w.segs, w.planes, 0.0, &map));
  EXPECT_FALSE(labelling.label(w.hm, w.segs, w.planes, std::nan(""), &map));
  EXPECT_FALSE(labelling.label(w.hm, w.segs, w.planes, kLv, nullptr));

  GroundSegments broken = w.segs;
  broken.segment_cells[3] = 100000;
  EXPECT_FALSE(labelling.label(w.hm, broken, w.planes, kLv, &map));
  broken = w.segs;
  broken.segment_begin.pop_back();
  EXPECT_FALSE(labelling.label(w.hm, broken, w.planes, kLv, &map));
  broken = w.segs;
  broken.robot_segment = 5;
  EXPECT_FALSE(labelling.label(w.hm, broken, w.planes, kLv, &map));

  // Still usable afterwards.
  EXPECT_TRUE(labelling.label(w.hm, w.segs, w.planes, kLv, &map));
  EXPECT_EQ(map.labelAt(1, 1), L::kLevel);

  // Empty height map and no segments.
  HeightMap empty;
  GroundSegments none;
  GroundSegmentation().segment(empty, VoxelIndex{0, 0, 0}, kLv, &none);
  EXPECT_TRUE(labelling.label(empty, none, {}, kLv, &map));
  EXPECT_TRUE(map.labels.empty());
}

TEST(SafetyLabelling, NoRobotSegmentLeavesNothingSafe) {
  // Robot far from any observed cell: every examined column is non-traversable.
  World w(block(30, 30, '0'), 29, 29);
  HeightMap hm = w.hm;
  for (int v = 15; v < 30; ++v)
    for (int u = 15; u < 30; ++u)
      hm.set(u, v, HeightMap::kNoHeight);
  GroundSegments segs;
  GroundSegmentation(paperSegmentation()).segment(hm, VoxelIndex{29, 29, 0}, kLv, &segs);
  ASSERT_EQ(segs.numSegments(), 0);
  SafetyMap map;
  ASSERT_TRUE(SafetyLabelling(paperLabelling()).label(hm, segs, {}, kLv, &map));
  EXPECT_EQ(map.robot_segment, -1);
  EXPECT_EQ(map.labelAt(10, 10), L::kNonGround);
  EXPECT_EQ(map.labelAt(20, 20), L::kUnknown);
}

// ---- Extensions (ours): island segments (GroundSegmentationConfig::segment_islands) and
// neighbours across unobserved cells (SafetyLabellingConfig::max_gap_cells).

GroundSegmentationConfig islandSegmentation() {
  GroundSegmentationConfig c;
  c.segment_islands = true;
  return c;
}

// A floor at height 0 with an unobserved stripe of `gap` columns at u = 10 .. 10 + gap - 1, the
// far side at `far` ('0' level, '2' 0.2 m higher).
std::vector<std::string> floorWithGap(int gap, char far) {
  std::vector<std::string> rows = block(30, 20, '0');
  for (std::string& r : rows) {
    for (int u = 10; u < 10 + gap; ++u)
      r[u] = '.';
    for (int u = 10 + gap; u < 30; ++u)
      r[u] = far;
  }
  return rows;
}

TEST(SafetyLabelling, PaperModeLeavesTheFloorBeyondAGapNonGround) {
  // 000: the far floor is never reached by Alg. 1: its columns are non-traversable.
  World w(floorWithGap(2, '0'), 2, 10);
  ASSERT_TRUE(w.label());
  EXPECT_EQ(w.at(5, 10), L::kLevel);
  EXPECT_EQ(w.at(11, 10), L::kUnknown);  // the gap
  EXPECT_EQ(w.at(20, 10), L::kNonGround);
}

TEST(SafetyLabelling, IslandAcrossASmallGapOfUnobservedCellsIsReachable) {
  World w(floorWithGap(2, '0'), 2, 10, 0, islandSegmentation());
  ASSERT_EQ(w.segs.numSegments(), 2);
  EXPECT_EQ(w.segs.segment_island[w.segAt(20, 10)], 1);
  SafetyLabellingConfig c;  // max_gap_cells = 2
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(5, 10), L::kLevel);
  EXPECT_EQ(w.at(11, 10), L::kUnknown);  // nothing was seen there: stays Unknown
  EXPECT_EQ(w.at(20, 10), L::kLevel);
  EXPECT_TRUE(w.map.segments[w.segAt(20, 10)].reachable);
  // Without the gap rule the island is a segment but unreachable: Non-ground, as in 000.
  ASSERT_TRUE(w.label(paperLabelling()));
  EXPECT_EQ(w.at(20, 10), L::kNonGround);
}

TEST(SafetyLabelling, GapWiderThanTheLimitIsNotBridged) {
  World w(floorWithGap(3, '0'), 2, 10, 0, islandSegmentation());
  SafetyLabellingConfig c;
  c.max_gap_cells = 2;
  ASSERT_TRUE(w.label(c));
  // Not reached, and within max_gap_cells + 2 cells of the safe floor: Non-ground, also with
  // isolated_ground_unknown.
  EXPECT_EQ(w.at(20, 10), L::kNonGround);
  c.max_gap_cells = 3;
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(20, 10), L::kLevel);
}

TEST(SafetyLabelling, DropAcrossAGapStaysNonGround) {
  // The far side is 0.2 m higher (or lower): the h_T test separates across gaps too.
  for (const char far : {'2', 'b'}) {
    World w(floorWithGap(2, far), 2, 10, 0, islandSegmentation());
    ASSERT_TRUE(w.label(SafetyLabellingConfig()));
    EXPECT_EQ(w.at(5, 10), L::kLevel);
    EXPECT_EQ(w.at(20, 10), L::kNonGround) << far;
  }
}

TEST(SafetyLabelling, IsolatedGroundIsUnknownOnlyWhereADrivableSlopeCouldReachIt) {
  // Far floors beyond gaps wider than max_gap_cells: no border to the safe floor at all.
  // Level far floor 0.7 m away: Unknown. 0.2 m higher 0.7 m away: 0.05 + 0.7 tan(10 deg) = 0.17
  // m < 0.2, no drivable slope gets there: Non-ground (an obstacle's top). 0.2 m higher 1.3 m
  // away: 0.05 + 0.23 > 0.2, a ramp could lead there: Unknown. The paper's rule: all Non-ground.
  struct Case {
    int gap;
    char far;
    L expected;
  };
  for (const Case& k : {Case{6, '0', L::kUnknown}, Case{6, '2', L::kNonGround},
                        Case{12, '2', L::kUnknown}, Case{6, 'b', L::kNonGround}}) {
    World w(floorWithGap(k.gap, k.far), 2, 10, 0, islandSegmentation());
    const int u = 10 + k.gap + 3;
    ASSERT_NE(w.segAt(u, 10), w.segs.robot_segment);
    SafetyLabellingConfig c;
    ASSERT_TRUE(w.label(c));
    EXPECT_EQ(w.at(5, 10), L::kLevel);
    EXPECT_EQ(w.at(u, 10), k.expected) << "gap " << k.gap << " far " << k.far;
    EXPECT_FALSE(w.map.segments[w.segAt(u, 10)].reachable);
    c.isolated_ground_unknown = false;
    ASSERT_TRUE(w.label(c));
    EXPECT_EQ(w.at(u, 10), L::kNonGround) << "gap " << k.gap << " far " << k.far;
  }
}

TEST(SafetyLabelling, GroundBehindAFailedStepStaysNonGround) {
  // Floor | a 0.2 m step up (touching: a measured discontinuity) | beyond it, crossable from
  // the step's top (0.21 m), ground never reached. The group borders safe ground across the
  // failed step: all of it Non-ground, also the part without a border of its own to the floor.
  std::vector<std::string> rows = block(30, 20, '0');
  for (std::string& r : rows) {
    for (int u = 10; u < 15; ++u)
      r[u] = '2';
    for (int u = 15; u < 30; ++u)
      r[u] = '3';
  }
  World w(rows, 2, 10, 0, islandSegmentation());
  ASSERT_NE(w.segAt(12, 10), w.segAt(20, 10));
  w.planeAt(20, 10) = horizontal(0.21);
  ASSERT_TRUE(w.label(SafetyLabellingConfig()));
  EXPECT_EQ(w.at(5, 10), L::kLevel);
  EXPECT_EQ(w.at(12, 10), L::kNonGround);
  EXPECT_EQ(w.at(20, 10), L::kNonGround);
}

TEST(SafetyLabelling, ObservedColumnsBetweenSegmentsAreNoGap) {
  // A wall of tall columns between the floors: the line between the boundary cells crosses
  // columns with a height, so the far floor is not a neighbour across a gap.
  std::vector<std::string> rows = floorWithGap(2, '0');
  for (std::string& r : rows)
    r[11] = '9';
  World w(rows, 2, 10, 0, islandSegmentation());
  // A wall's columns are occupied from the floor to the top (its face): not ground-like.
  for (int v = 0; v < 20; ++v)
    w.hm.set(11, v, 9, 0);
  GroundSegmentation(islandSegmentation()).segment(w.hm, VoxelIndex{2, 10, 0}, kLv, &w.segs);
  w.planes.clear();
  for (int k = 0; k < w.segs.numSegments(); ++k)
    w.planes.push_back(horizontal(w.segs.segment_height[k] * kLv));
  ASSERT_TRUE(w.label(SafetyLabellingConfig()));
  EXPECT_EQ(w.at(11, 10), L::kNonGround);  // the wall
  // Unreachable behind it (within max_gap_cells + 2 cells of the floor: not isolated).
  EXPECT_EQ(w.at(20, 10), L::kNonGround);
}

// A floor (z = 0) running into an 8.5 deg ramp at u = 6 (z = 0.015 per cell). The floor's band
// (indexed height 0) holds the ramp's first cells up to z = 0.045; the ramp's band starts at
// u = 10 (z = 0.06). Each cell gets its measured surface height.
World floorIntoRamp() {
  std::vector<std::string> rows(20, std::string(20, '.'));
  for (std::string& r : rows)
    for (int u = 0; u < 20; ++u) {
      const double z = u < 6 ? 0.0 : 0.015 * (u - 6);
      r[u] = static_cast<char>('0' + static_cast<int>(std::lround(z / kLv)));
    }
  World w(rows, 2, 10, 0, islandSegmentation());
  for (int v = 0; v < 20; ++v)
    for (int u = 0; u < 20; ++u)
      w.hm.setSurfaceHeight(u, v, static_cast<float>(u < 6 ? 0.0 : 0.015 * (u - 6)));
  const double deg = std::atan(0.15) / kDeg;
  for (int u = 10; u < 20; ++u)
    w.planeAt(u, 10) = inclined(deg, 0.6, 0.0);  // the ramp's bands: the ramp's own plane
  return w;
}

TEST(SafetyLabelling, PlanesAloneMissTheStartOfARampInTheFloorsBand) {
  World w = floorIntoRamp();
  SafetyLabellingConfig c = paperLabelling();
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(3, 10), L::kLevel);
  // At the ramp band's border cells the floor's level plane is 6 cm below the surface.
  EXPECT_EQ(w.at(11, 10), L::kNonGround);
}

TEST(SafetyLabelling, MeasuredStepTestReachesTheRamp) {
  World w = floorIntoRamp();
  SafetyLabellingConfig c = paperLabelling();
  c.measured_step_test = true;  // neighbouring cells' surfaces differ by 1.5 cm
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(3, 10), L::kLevel);
  EXPECT_EQ(w.at(11, 10), L::kInclined);
}

TEST(SafetyLabelling, MeasuredStepTestStillStopsAtAStep) {
  // A 10 cm platform: measured heights and planes both differ by 10 cm at the border.
  std::vector<std::string> rows = block(20, 20, '0');
  for (std::string& r : rows)
    for (int u = 10; u < 20; ++u)
      r[u] = '1';
  World w(rows, 2, 10, 0, islandSegmentation());
  for (int v = 0; v < 20; ++v)
    for (int u = 0; u < 20; ++u)
      w.hm.setSurfaceHeight(u, v, u < 10 ? 0.0f : 0.1f);
  SafetyLabellingConfig c;  // measured_step_test and max_gap_cells on
  ASSERT_TRUE(c.measured_step_test);
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(3, 10), L::kLevel);
  EXPECT_EQ(w.at(15, 10), L::kNonGround);
  // ... and a 3.5 cm one is crossed (h_T less step_height_margin: 4 cm).
  for (int v = 0; v < 20; ++v)
    for (int u = 10; u < 20; ++u)
      w.hm.setSurfaceHeight(u, v, 0.035f);
  w.planeAt(15, 10) = horizontal(0.035);
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(15, 10), L::kLevel);
}

TEST(SafetyLabelling, AStepMeasuredWithinTheMarginOfHtIsNotCrossed) {
  // A sunken floor (indexed height -1) measured 4.5 cm below the robot's: dev seed 49's 5.6 cm
  // drop reads so in stereo. 000 crosses it (4.5 < h_T); with step_height_margin = 1 cm it is a
  // drop, while a step measured 3.5 cm is still crossed. Planes and measured surfaces agree.
  const std::vector<std::string> rows(10, "000000000aaaaaaaaa");
  for (const double margin : {0.0, 0.01}) {
    for (const double z : {-0.035, -0.045}) {
      World w(rows, 2, 5, 0, islandSegmentation());
      ASSERT_EQ(w.segs.numSegments(), 2);
      for (int v = 0; v < 10; ++v)
        for (int u = 0; u < 18; ++u)
          w.hm.setSurfaceHeight(u, v, u < 9 ? 0.0f : static_cast<float>(z));
      w.planeAt(3, 5) = horizontal(0.0);
      w.planeAt(15, 5) = horizontal(z);
      SafetyLabellingConfig c;
      c.step_height_margin = margin;
      ASSERT_TRUE(w.label(c));
      const bool crossed = margin == 0.0 || z > -0.04;
      EXPECT_EQ(w.at(3, 5), L::kLevel);
      EXPECT_EQ(w.at(15, 5), crossed ? L::kLevel : L::kNonGround)
          << "margin " << margin << ", step " << z;
    }
  }
}

TEST(SafetyLabelling, MeasuredStepTestIsNotFooledByACurbsFace) {
  // A 15 cm curb down to a street (indexed height -1 here). The sidewalk's last column holds the
  // top of the curb's face (mean 2 cm down), the street's first one its lower part (6 cm down):
  // those two columns alone differ by 4 cm, the two surfaces around them by 12 cm.
  std::vector<std::string> rows = block(20, 20, '0');
  for (std::string& r : rows)
    for (int u = 10; u < 20; ++u)
      r[u] = 'a';
  World w(rows, 2, 10, 0, islandSegmentation());
  for (int v = 0; v < 20; ++v)
    for (int u = 0; u < 20; ++u)
      w.hm.setSurfaceHeight(u, v, u < 9 ? 0.0f : u == 9 ? -0.02f : u == 10 ? -0.06f : -0.15f);
  w.planeAt(15, 10) = horizontal(-0.15);
  ASSERT_TRUE(w.label(SafetyLabellingConfig()));
  EXPECT_EQ(w.at(3, 10), L::kLevel);
  EXPECT_EQ(w.at(15, 10), L::kNonGround);
}

}  // namespace
}  // namespace stereo_safety_map

namespace stereo_safety_map {
namespace {

// Sets the measured surface height of every column with a height to its indexed height times
// l_v plus `offset` (what the points of a level surface in that voxel would give).
void setSurfaces(HeightMap* hm, double offset = 0.02) {
  for (int v = hm->minV(); v < hm->minV() + hm->height(); ++v)
    for (int u = hm->minU(); u < hm->minU() + hm->width(); ++u)
      if (hm->at(u, v) != HeightMap::kNoHeight) {
        hm->setSurfaceHeight(u, v, static_cast<float>(hm->at(u, v) * kLv + offset));
      }
}

// The top of a pole (0.2 x 0.2 m, 0.5 m high) seen without the floor right around it: Alg. 1
// makes it an island segment of 4 cells, which Alg. 2 step 3 calls Unknown (000) and the
// small-obstacle rule Non-ground (it stands 0.5 m above the safe floor beside it).
TEST(SafetyLabellingSmallObstacles, APolesTopIsNonGroundNotUnknown) {
  const std::vector<std::string> rows = {"000000000000", "000000000000", "00000....000",
                                         "00000.55.000", "00000.55.000", "00000....000",
                                         "000000000000", "000000000000"};
  GroundSegmentationConfig sc;  // islands on (ours)
  sc.footprint_radius = 0.0;
  World w(rows, 1, 3, 0, sc);
  setSurfaces(&w.hm);
  ASSERT_GE(w.segAt(6, 3), 0);
  ASSERT_NE(w.segAt(6, 3), w.segAt(1, 3));
  SafetyLabellingConfig c;  // ours: max_gap_cells 2 reaches across the unobserved ring
  c.footprint_bridge = 0.0;
  c.small_obstacles = false;
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(6, 3), L::kUnknown);  // 000 Alg. 2 step 3
  EXPECT_EQ(w.at(1, 3), L::kLevel);
  c.small_obstacles = true;
  ASSERT_TRUE(w.label(c));
  for (int v = 3; v <= 4; ++v)
    for (int u = 6; u <= 7; ++u)
      EXPECT_EQ(w.at(u, v), L::kNonGround) << u << "," << v;
  EXPECT_TRUE(w.map.segments[w.segAt(6, 3)].obstacle);
  EXPECT_EQ(w.at(1, 3), L::kLevel);
  EXPECT_EQ(w.at(5, 3), L::kUnknown);  // the unobserved ring stays Unknown
}

// A small patch of ground one voxel up but measured only 3 cm higher (a voxel boundary in the
// noise) is a small patch of ground, not an obstacle: Unknown (000 Alg. 2 step 3), and with
// floor_fragments (ours) the floor around it.
TEST(SafetyLabellingSmallObstacles, ASmallPatchOfGroundIsNoObstacle) {
  const std::vector<std::string> rows = {"000000000000", "000000000000", "00000....000",
                                         "00000.11.000", "00000.11.000", "00000....000",
                                         "000000000000", "000000000000"};
  GroundSegmentationConfig sc;
  sc.footprint_radius = 0.0;
  World w(rows, 1, 3, 0, sc);
  setSurfaces(&w.hm, 0.04);
  w.hm.setSurfaceHeight(6, 3, 0.07f);
  w.hm.setSurfaceHeight(7, 3, 0.07f);
  w.hm.setSurfaceHeight(6, 4, 0.07f);
  w.hm.setSurfaceHeight(7, 4, 0.07f);
  SafetyLabellingConfig c;
  c.footprint_bridge = 0.0;
  c.floor_fragments = false;
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(6, 3), L::kUnknown);
  EXPECT_FALSE(w.map.segments[w.segAt(6, 3)].obstacle);
  c.floor_fragments = true;  // 3 cm: not within floor_fragment_tolerance (0.03 m)
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(6, 3), L::kUnknown);
  c.floor_fragment_tolerance = 0.04;
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(6, 3), L::kLevel);    // within 4 cm of the floor across the unobserved ring
  EXPECT_EQ(w.at(5, 3), L::kUnknown);  // the ring itself stays Unknown
  EXPECT_FALSE(w.map.segments[w.segAt(6, 3)].obstacle);
  EXPECT_EQ(w.map.segments[w.segAt(6, 3)].merged_into, w.segAt(1, 3));
}

// SafetyLabellingConfig::floor_fragments. A level floor (indexed height 0, measured 0.04 m)
// with one-voxel-high fragments of 2 cells (measured `bump` m) touching it on every side.
struct FragmentFloor {
  World w;
  explicit FragmentFloor(float bump,
                         const std::vector<std::string>& rows = {"0000000000000", "0000000000000",
                                                                 "0000001100000", "0000000000000",
                                                                 "0000000000000", "0000000000000"})
      : w(rows, 1, 1, 0, islands()) {
    setSurfaces(&w.hm, 0.04);
    for (int v = 0; v < w.hm.height(); ++v)
      for (int u = 0; u < w.hm.width(); ++u)
        if (w.hm.at(u, v) == 1) w.hm.setSurfaceHeight(u, v, bump);
  }
  static GroundSegmentationConfig islands() {
    GroundSegmentationConfig sc;
    sc.footprint_radius = 0.0;
    return sc;
  }
  static SafetyLabellingConfig config(bool on) {
    SafetyLabellingConfig c;
    c.footprint_bridge = 0.0;
    c.floor_fragments = on;
    c.robot_fragment_passage = on;
    return c;
  }
};

TEST(SafetyLabellingFloorFragments, AFragmentCloseToTheFloorIsTheFloor) {
  FragmentFloor f(0.06f);  // 2 cm above the floor's 0.04 m
  ASSERT_NE(f.w.segAt(6, 2), f.w.segAt(1, 1));
  ASSERT_TRUE(f.w.label(FragmentFloor::config(false)));
  EXPECT_EQ(f.w.at(6, 2), L::kUnknown);  // 000 Alg. 2 step 3: 2 cells < n_small
  // 000's potential drop-off edges ring the hole only where a lower column is near; here the
  // hole's cells are the floor once the rule is on.
  ASSERT_TRUE(f.w.label(FragmentFloor::config(true)));
  EXPECT_EQ(f.w.at(6, 2), L::kLevel);
  EXPECT_EQ(f.w.at(7, 2), L::kLevel);
  const SegmentInfo& frag = f.w.map.segments[f.w.segAt(6, 2)];
  EXPECT_EQ(frag.merged_into, f.w.segAt(1, 1));
  EXPECT_TRUE(frag.reachable);
  EXPECT_EQ(frag.plane.c, f.w.map.segments[f.w.segAt(1, 1)].plane.c);  // the host's plane
  EXPECT_EQ(f.w.map.segments[f.w.segAt(1, 1)].merged_into, -1);
}

TEST(SafetyLabellingFloorFragments, AFragmentFartherFromTheFloorStaysUnknown) {
  // 4 cm above: within h_T, but a small obstacle's top reads that low in stereo's noise.
  FragmentFloor up(0.08f);
  ASSERT_TRUE(up.w.label(FragmentFloor::config(true)));
  EXPECT_EQ(up.w.at(6, 2), L::kUnknown);
  EXPECT_EQ(up.w.map.segments[up.w.segAt(6, 2)].merged_into, -1);
  SafetyLabellingConfig loose = FragmentFloor::config(true);
  loose.floor_fragment_tolerance = 0.05;  // h_T
  ASSERT_TRUE(up.w.label(loose));
  EXPECT_EQ(up.w.at(6, 2), L::kLevel);
  // A pothole's bottom 6 cm below the floor (indexed one voxel down).
  FragmentFloor down(-0.02f, {"0000000000000", "0000000000000", "000000aa00000", "0000000000000",
                              "0000000000000", "0000000000000"});
  ASSERT_TRUE(down.w.label(FragmentFloor::config(true)));
  EXPECT_NE(down.w.at(6, 2), L::kLevel);
  EXPECT_NE(down.w.at(6, 2), L::kInclined);
}

// A one-cell fragment at the edge of a street 30 cm lower (indexed -3): the street's columns
// beside the floor are non-traversable (Alg. 1 compared them and left them out), no segment, so
// the fragment borders the floor alone and becomes floor; the drop-off margin then makes it
// Non-ground like any floor cell at that edge. Never safe.
TEST(SafetyLabellingFloorFragments, AFragmentAtADropIsNotSafe) {
  FragmentFloor f(0.06f, {"00000000ccccc", "00000000ccccc", "0000001cccccc", "00000000ccccc",
                          "00000000ccccc", "00000000ccccc"});
  for (int v = 0; v < f.w.hm.height(); ++v)
    for (int u = 0; u < f.w.hm.width(); ++u)
      if (f.w.hm.at(u, v) == -3) f.w.hm.setSurfaceHeight(u, v, -0.26f);
  SafetyLabellingConfig c = FragmentFloor::config(true);
  ASSERT_TRUE(c.drop_off_margin);
  ASSERT_TRUE(f.w.label(c));
  EXPECT_EQ(f.w.at(1, 1), L::kLevel);
  EXPECT_FALSE(isSafe(f.w.at(10, 2)));  // the street, below a failed step
  EXPECT_EQ(f.w.at(6, 2), L::kNonGround);
  EXPECT_EQ(f.w.at(7, 1), L::kNonGround);  // the floor's own edge cells alike
}

// A curb seen from the side whose street was never seen (dev seed 44): the sidewalk's last row
// of columns holds the street's upper noise tail in the sidewalk's voxel band and measures 3 cm
// below the sidewalk's plane; beyond it no column has a height. drop_off_sink makes that row
// Non-ground; a row 1.5 cm low (the floor's own noise at range) and the same row with the rule
// off stay Level, and so does a sunken row with observed ground beyond it.
TEST(SafetyLabellingDropOffMargin, AnEdgeSinkingIntoTheUnseenIsNonGround) {
  const std::vector<std::string> rows = {"000000000000", "000000000000", "000000000000",
                                         "000000000000", "000000000000", "000000000000",
                                         "............", "............"};
  for (const double edge_z : {-0.03, -0.015}) {
    for (const double sink : {0.0, 0.025}) {
      World w(rows, 2, 1, 0, islandSegmentation());
      for (int v = 0; v < 6; ++v)
        for (int u = 0; u < 12; ++u)
          w.hm.setSurfaceHeight(u, v, v == 5 ? static_cast<float>(edge_z) : 0.0f);
      SafetyLabellingConfig c;
      c.drop_off_sink = sink;
      ASSERT_TRUE(c.drop_off_margin);
      ASSERT_TRUE(w.label(c));
      EXPECT_EQ(w.at(6, 2), L::kLevel);
      EXPECT_EQ(w.at(6, 5), sink > 0.0 && edge_z < -0.025 ? L::kNonGround : L::kLevel)
          << "edge " << edge_z << ", sink " << sink;
      EXPECT_EQ(w.at(6, 6), L::kUnknown);
    }
  }
  // Sunken by 3 cm, but ground was seen beyond it: the rule is about edges into the unseen.
  std::vector<std::string> seen = rows;
  seen[6] = seen[7] = "000000000000";
  World w(seen, 2, 1, 0, islandSegmentation());
  for (int v = 0; v < 8; ++v)
    for (int u = 0; u < 12; ++u)
      w.hm.setSurfaceHeight(u, v, v == 5 ? -0.03f : 0.0f);
  ASSERT_TRUE(w.label(SafetyLabellingConfig()));
  EXPECT_EQ(w.at(6, 5), L::kLevel);
}

// A pole 0.5 m high (one column, indexed 5) and a bump measured 8 cm above a level floor (indexed
// 1: stereo's noise on a floor at range reads so): with obstacle_face_margin the floor's 8 cells
// around the pole are Non-ground (its face may stand inside them), the cells around the bump stay
// Level (a rise below obstacle_face_min_rise makes no face), and so does the floor two cells from
// the pole. Off, as in 000, the pole's neighbours are Level. With the rise at h_T the bump is
// ringed too.
TEST(SafetyLabellingObstacleFaceMargin, TheFloorCellsAroundAPoleAreNonGround) {
  const std::vector<std::string> rows = {"000000000000", "000000000000", "000000000000",
                                         "000000500000", "000000000000", "000000000000",
                                         "000000000100", "000000000000"};
  for (const bool face : {false, true}) {
    World w(rows, 2, 1, 0, islandSegmentation());
    for (int v = 0; v < w.hm.height(); ++v)
      for (int u = 0; u < w.hm.width(); ++u)
        w.hm.setSurfaceHeight(u, v,
                              static_cast<float>(w.hm.at(u, v) == 5   ? 0.48
                                                 : w.hm.at(u, v) == 1 ? 0.08
                                                                      : 0.0));
    SafetyLabellingConfig c;
    c.obstacle_face_margin = face;
    ASSERT_TRUE(w.label(c));
    EXPECT_EQ(w.at(6, 3), L::kNonGround);  // the pole's column
    for (int dv = -1; dv <= 1; ++dv) {
      for (int du = -1; du <= 1; ++du) {
        if (du == 0 && dv == 0) continue;
        EXPECT_EQ(w.at(6 + du, 3 + dv), face ? L::kNonGround : L::kLevel)
            << "face " << face << " at " << du << ", " << dv;
      }
    }
    EXPECT_EQ(w.at(8, 3), L::kLevel);
    EXPECT_EQ(w.at(4, 3), L::kLevel);
    EXPECT_EQ(w.at(6, 1), L::kLevel);
    EXPECT_EQ(w.at(8, 6), L::kLevel);  // beside the bump
    EXPECT_EQ(w.at(10, 7), L::kLevel);
    EXPECT_FALSE(w.drop(5, 3));
    c.obstacle_face_min_rise = c.max_step_height;
    ASSERT_TRUE(w.label(c));
    EXPECT_EQ(w.at(8, 6), face ? L::kNonGround : L::kLevel);
  }
}

// obstacle_face_reach: the same pole, its surface points at (0.63, 0.31) m in its column
// (u 6: x 0.55-0.65 m; v 3: y 0.25-0.35 m). At a reach of 5 cm only the cells whose shared
// border (or corner) lies within 5 cm of a point are ringed: (7, 3) (2 cm), (6, 4) (4 cm) and
// the corner cell (7, 4) (2 and 4 cm); (5, 3) is 8 cm away, (6, 2) 6 cm, the other corners
// farther. At a reach of l_v or more, or without a grid, all eight are.
TEST(SafetyLabellingObstacleFaceMargin, AFaceRingsOnlyTheCellsItsPointsReach) {
  const std::vector<std::string> rows = {"000000000000", "000000000000", "000000000000",
                                         "000000500000", "000000000000", "000000000000",
                                         "000000000000", "000000000000"};
  World w(rows, 2, 1, 0, islandSegmentation());
  for (int v = 0; v < w.hm.height(); ++v)
    for (int u = 0; u < w.hm.width(); ++u)
      w.hm.setSurfaceHeight(u, v, w.hm.at(u, v) == 5 ? 0.5f : 0.0f);
  VoxelGridConfig gc;
  gc.size_x = gc.size_y = 2.0;
  gc.size_z = 2.0;
  gc.z_below_robot = 0.5;
  VoxelGrid grid(gc);
  grid.recenter(Eigen::Vector3f(0.6f, 0.3f, 0.0f));
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.translation() = Eigen::Vector3f(0.6f, 0.3f, 1.5f);  // a camera above the pole
  const Eigen::Vector3f p(0.63f, 0.31f, 0.50f);
  ASSERT_EQ(grid.indexOf(p), (VoxelIndex{6, 3, 5}));
  grid.integrate({p - T.translation()}, T);
  ASSERT_EQ(grid.points(VoxelIndex{6, 3, 5}).size, 1u);

  // The pole's 8 neighbours that the margin made Non-ground, as (du, dv).
  auto ringedWith = [&](const SafetyLabellingConfig& c, bool with_grid) {
    SafetyLabelling labelling(c);
    if (with_grid) labelling.setVoxelGrid(&grid);
    EXPECT_TRUE(labelling.label(w.hm, w.segs, w.planes, kLv, &w.map));
    EXPECT_EQ(w.at(6, 3), L::kNonGround);
    EXPECT_EQ(w.at(4, 3), L::kLevel);
    std::vector<std::pair<int, int>> cells;
    for (int dv = -1; dv <= 1; ++dv)
      for (int du = -1; du <= 1; ++du)
        if ((du != 0 || dv != 0) && w.at(6 + du, 3 + dv) == L::kNonGround)
          cells.emplace_back(du, dv);
    return cells;
  };
  auto ringed = [&](double reach, bool with_grid) {
    SafetyLabellingConfig c;
    c.obstacle_face_reach = reach;
    c.obstacle_face_reach_sigmas = 0.0;
    return ringedWith(c, with_grid);
  };
  const std::vector<std::pair<int, int>> near = {{1, 0}, {0, 1}, {1, 1}};
  EXPECT_EQ(ringed(0.05, true), near);
  EXPECT_EQ(ringed(0.05, false).size(), 8u);
  EXPECT_EQ(ringed(kLv, true).size(), 8u);
  EXPECT_EQ(ringed(0.01, true).size(), 0u);  // every border more than 1 cm from the point
  // obstacle_face_reach_sigmas: 1 sigma_d / (f b) r^2 = 0.5 / 10 m at the point's range (1 m):
  // a 5 cm reach again; without f b the fixed 1 cm alone.
  auto ringedSigmas = [&](double fb) {
    grid.setStereoGeometry(fb);
    SafetyLabellingConfig c;
    c.obstacle_face_reach = 0.01;
    c.obstacle_face_reach_sigmas = 1.0;
    return ringedWith(c, true);
  };
  EXPECT_NEAR(grid.points(VoxelIndex{6, 3, 5}).data[0].range, 1.0, 0.01);
  EXPECT_EQ(ringedSigmas(10.0), near);
  EXPECT_EQ(ringedSigmas(0.0).size(), 0u);
  SafetyLabellingConfig bad;
  bad.obstacle_face_reach = -0.1;
  EXPECT_NE(bad.validate().find("obstacle_face_reach"), std::string::npos);
  bad = SafetyLabellingConfig();
  bad.obstacle_face_reach_sigmas = -1.0;
  EXPECT_NE(bad.validate().find("obstacle_face_reach_sigmas"), std::string::npos);
}

// The robot's own segment a fragment: the seed rule picks the two cells at the base's indexed
// height, and the floor around was seen a voxel higher (measured 3 cm above them).
TEST(SafetyLabellingRobotFragmentPassage, ARobotSegmentThatIsAFragmentStillReachesTheFloor) {
  const std::vector<std::string> rows = {"1111111111111", "1111111111111", "1100111111111",
                                         "1111111111111", "1111111111111", "1111111111111"};
  World w(rows, 2, 2, 0, FragmentFloor::islands());
  for (int v = 0; v < w.hm.height(); ++v)
    for (int u = 0; u < w.hm.width(); ++u)
      w.hm.setSurfaceHeight(u, v, w.hm.at(u, v) == 0 ? 0.04f : 0.07f);
  ASSERT_EQ(w.segAt(2, 2), w.segs.robot_segment);
  ASSERT_NE(w.segAt(8, 3), w.segs.robot_segment);
  ASSERT_TRUE(w.label(FragmentFloor::config(false)));
  EXPECT_FALSE(isSafe(w.at(8, 3)));  // num_T: the robot's two cells are no passage
  ASSERT_TRUE(w.label(FragmentFloor::config(true)));
  EXPECT_EQ(w.at(8, 3), L::kLevel);
  EXPECT_EQ(w.at(2, 2), L::kLevel);
  // The floor 10 cm above the robot's cells instead: a step, still not crossed.
  for (int v = 0; v < w.hm.height(); ++v)
    for (int u = 0; u < w.hm.width(); ++u)
      if (w.hm.at(u, v) == 1) w.hm.setSurfaceHeight(u, v, 0.14f);
  w.planes.assign(w.planes.size(), horizontal(0.14));
  w.planes[w.segs.robot_segment] = horizontal(0.04);
  ASSERT_TRUE(w.label(FragmentFloor::config(true)));
  EXPECT_FALSE(isSafe(w.at(8, 3)));
}

// The camera's blind zone: the robot's footprint (cells 0..5 around u = 2) and the floor the
// camera sees from u = 14 on, nothing observed between. Without the bridge the floor is cut off
// from the robot (Non-ground); with it the floor is reachable, a floor 20 cm lower is not, and a
// wall across the blind zone separates.
std::vector<std::string> blindZone(char floor, char wall = '.') {
  std::vector<std::string> rows(11, std::string(30, '.'));
  for (std::string& r : rows) {
    for (int u = 14; u < 30; ++u)
      r[u] = floor;
    r[9] = wall;
  }
  return rows;
}

TEST(SafetyLabellingFootprintBridge, TheFloorBeyondTheBlindZoneIsReachable) {
  GroundSegmentationConfig sc;  // footprint 0.35 m, islands on
  World w(blindZone('0'), 2, 5, 0, sc);
  setSurfaces(&w.hm);
  ASSERT_EQ(w.segAt(2, 5), w.segs.robot_segment);
  ASSERT_TRUE(w.segs.footprint[w.segs.index(2, 5)]);
  ASSERT_NE(w.segAt(20, 5), w.segs.robot_segment);
  SafetyLabellingConfig c;
  c.footprint_bridge = 0.0;
  c.isolated_ground_unknown = false;
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(2, 5), L::kLevel);  // the footprint
  EXPECT_EQ(w.at(20, 5), L::kNonGround);
  c.isolated_ground_unknown = true;  // no border to it at all: Unknown
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(20, 5), L::kUnknown);
  c.footprint_bridge = 1.5;
  ASSERT_TRUE(w.label(c));
  EXPECT_EQ(w.at(20, 5), L::kLevel);
  EXPECT_EQ(w.at(10, 5), L::kUnknown);  // the blind zone itself
}

TEST(SafetyLabellingFootprintBridge, AnUnreportedTiltIsAllowedForButAStepIsNot) {
  // The floor beyond the blind zone (1.2 m and farther from the robot) measured 6.5 cm above
  // the footprint's level plane, as an unreported 1 deg pitch and the top voxel's noise make it
  // read: beyond h_T, within h_T + 1.2 m tan(1 deg) = 7.1 cm. A 10 cm step is not.
  GroundSegmentationConfig sc;
  for (const double z : {0.065, 0.10}) {
    World w(blindZone('0'), 2, 5, 0, sc);
    setSurfaces(&w.hm);
    w.planeAt(20, 5) = horizontal(z);
    SafetyLabellingConfig c;
    c.bridge_tilt_deg = 0.0;
    ASSERT_TRUE(w.label(c));
    EXPECT_EQ(w.at(20, 5), L::kNonGround) << z;
    c.bridge_tilt_deg = 1.0;
    ASSERT_TRUE(w.label(c));
    EXPECT_EQ(w.at(20, 5), z < 0.07 ? L::kLevel : L::kNonGround) << z;
  }
}

TEST(SafetyLabellingFootprintBridge, ARampThatStartsInTheBlindZoneIsReachable) {
  // An 8 deg ramp rising from x = 0.8 m, in the blind zone: at its first observed cells (x =
  // 1.4 m) it is 8.4 cm up, beyond h_T + 1.2 m tan(1 deg); carried back to the footprint it
  // meets the floor. The planes meet on the line between them: the ground runs on, Inclined.
  // A platform 10 cm up whose plane is level never meets the floor (the tilt test above).
  GroundSegmentationConfig sc;
  World w(blindZone('0'), 2, 5, 0, sc);
  setSurfaces(&w.hm);
  w.planeAt(20, 5) = inclined(8.0, 0.8, 0.0);
  ASSERT_TRUE(w.label(SafetyLabellingConfig()));
  EXPECT_EQ(w.at(20, 5), L::kInclined);
  EXPECT_TRUE(w.map.segments[w.segAt(20, 5)].reachable);
  // The same ramp starting 20 cm up (a curb onto the ramp): not crossable.
  w.planeAt(20, 5) = inclined(8.0, 0.8, 0.20);
  ASSERT_TRUE(w.label(SafetyLabellingConfig()));
  EXPECT_EQ(w.at(20, 5), L::kNonGround);
}

TEST(SafetyLabellingFootprintBridge, ALowerFloorOrAWallInBetweenIsNotBridged) {
  GroundSegmentationConfig sc;
  {
    World w(blindZone('b'), 2, 5, 0, sc);  // 20 cm lower
    setSurfaces(&w.hm);
    ASSERT_TRUE(w.label(SafetyLabellingConfig()));
    EXPECT_EQ(w.at(20, 5), L::kNonGround);
  }
  {
    World w(blindZone('0', '9'), 2, 5, 0, sc);  // a wall across the blind zone at u = 9
    setSurfaces(&w.hm);
    ASSERT_TRUE(w.label(SafetyLabellingConfig()));
    // Not reached; seen only across the wall's columns: Non-ground also with
    // isolated_ground_unknown.
    EXPECT_EQ(w.at(20, 5), L::kNonGround);
    EXPECT_FALSE(isSafe(w.at(9, 5)));
  }
  {
    // Farther than the bridge: floor from u = 25 (2 m of blind zone).
    std::vector<std::string> rows = blindZone('0');
    for (std::string& r : rows)
      for (int u = 14; u < 25; ++u)
        r[u] = '.';
    World w(rows, 2, 5, 0, sc);
    setSurfaces(&w.hm);
    ASSERT_TRUE(w.label(SafetyLabellingConfig()));
    EXPECT_FALSE(isSafe(w.at(27, 5)));
    EXPECT_FALSE(w.map.segments[w.segAt(27, 5)].reachable);
  }
}

TEST(SafetyLabellingFootprintBridge, AFloorTheBridgeOnlyGrazesIsUnknownAStepBeyondItNonGround) {
  // The floor seen from u = 20 on: the bridge's reach (1.5 m from the footprint's boundary)
  // touches only its nearest cells, fewer than num_T, so it is not reached. Those contacts are
  // crossable: nothing measured a discontinuity, and a drivable slope could reach it: Unknown
  // (isolated_ground_unknown), not Non-ground. The same floor 10 cm up fails the bridge's step
  // test: a measured step, Non-ground.
  GroundSegmentationConfig sc;
  std::vector<std::string> rows = blindZone('0');
  for (std::string& r : rows)
    for (int u = 14; u < 20; ++u)
      r[u] = '.';
  for (const double z : {0.0, 0.10}) {
    World w(rows, 2, 5, 0, sc);
    setSurfaces(&w.hm);
    w.planeAt(22, 5) = horizontal(z);
    SafetyLabellingConfig c;
    ASSERT_TRUE(w.label(c));
    EXPECT_FALSE(w.map.segments[w.segAt(22, 5)].reachable) << z;
    EXPECT_EQ(w.at(22, 5), z == 0.0 ? L::kUnknown : L::kNonGround) << z;
    // Without the bridge there is no border at all: Unknown either way.
    c.footprint_bridge = 0.0;
    ASSERT_TRUE(w.label(c));
    EXPECT_EQ(w.at(22, 5), L::kUnknown) << z;
  }
}

}  // namespace
}  // namespace stereo_safety_map
