// Ground segmentation, Alg. 1 (000, Sec. V-A), on hand-made height maps.
#include "stereo_safety_map/core/ground_segmentation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <set>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace {

constexpr double kLv = 0.1;

// 000's Alg. 1 alone (no island segments): the tests below check the paper's behaviour.
GroundSegmentationConfig paperConfig() {
  GroundSegmentationConfig c;
  c.segment_islands = false;
  c.footprint_radius = 0.0;
  c.split_steps = false;
  return c;
}

// Height map from text: row i is v = i, column j is u = j; '.' no height, '0'-'9' heights 0..9,
// 'a'-'i' heights -1..-9.
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

HeightMap flat(int min_u, int min_v, int w, int h, int height) {
  HeightMap hm;
  hm.reset(min_u, min_v, w, h);
  for (int v = min_v; v < min_v + h; ++v)
    for (int u = min_u; u < min_u + w; ++u)
      hm.set(u, v, height);
  return hm;
}

// Every segment's cells carry its id and its height; ids cover all segment cells once.
void expectConsistent(const HeightMap& hm, const GroundSegments& s) {
  ASSERT_EQ(static_cast<int>(s.segment_begin.size()), s.numSegments() + 1);
  std::set<int> seen;
  for (int k = 0; k < s.numSegments(); ++k) {
    EXPECT_GT(s.segmentSize(k), 0);
    for (const int* c = s.cellsBegin(k); c != s.cellsEnd(k); ++c) {
      EXPECT_EQ(s.segment_of[*c], k);
      // A footprint cell has no observed height: it is ground at the robot's base height.
      EXPECT_EQ(s.footprint[*c] ? s.robot.w : hm.atIndex(*c), s.segment_height[k]);
      EXPECT_TRUE(s.examined[*c]);
      EXPECT_TRUE(seen.insert(*c).second);
    }
  }
  int in_segments = 0;
  for (int c = 0; c < s.numCells(); ++c)
    in_segments += s.segment_of[c] >= 0;
  EXPECT_EQ(in_segments, static_cast<int>(seen.size()));
  for (int c : s.non_traversable) {
    EXPECT_EQ(s.segment_of[c], -1);
    EXPECT_TRUE(s.examined[c]);
    EXPECT_NE(hm.atIndex(c), HeightMap::kNoHeight);
  }
}

TEST(GroundSegmentationConfig, Validate) {
  GroundSegmentationConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_DOUBLE_EQ(c.planning_radius, 4.0);
  EXPECT_EQ(c.height_tolerance, 1);
  EXPECT_EQ(c.connectivity, 8);
  c.connectivity = 6;
  EXPECT_NE(c.validate().find("connectivity"), std::string::npos);
  EXPECT_THROW(GroundSegmentation{c}, std::invalid_argument);
  c = GroundSegmentationConfig();
  c.planning_radius = -1.0;
  EXPECT_NE(c.validate().find("planning_radius"), std::string::npos);
  c = GroundSegmentationConfig();
  c.height_tolerance = -1;
  EXPECT_NE(c.validate().find("height_tolerance"), std::string::npos);
  c = GroundSegmentationConfig();
  c.island_max_span = -1;
  EXPECT_NE(c.validate().find("island_max_span"), std::string::npos);
  c = GroundSegmentationConfig();
  c.seed_radius = std::numeric_limits<double>::infinity();
  EXPECT_NE(c.validate().find("seed_radius"), std::string::npos);
  c = GroundSegmentationConfig();
  c.seed_support_max_offset = -0.01;
  EXPECT_NE(c.validate().find("seed_support_max_offset"), std::string::npos);
  c.seed_support_max_offset = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(c.validate().find("seed_support_max_offset"), std::string::npos);
}

TEST(GroundSegmentation, FlatFloorIsOneSegment) {
  const HeightMap hm = flat(-10, -10, 21, 21, 0);
  GroundSegmentation seg(paperConfig());
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.robot_segment, 0);
  EXPECT_EQ(s.seed_cell, s.index(0, 0));
  EXPECT_EQ(s.segmentSize(0), 21 * 21);
  EXPECT_TRUE(s.non_traversable.empty());
}

TEST(GroundSegmentation, PlanningRadiusLimitsTheExaminedCells) {
  const HeightMap hm = flat(-50, -50, 101, 101, 0);
  GroundSegmentation seg(paperConfig());  // R_max = 4 m = 40 cells
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  expectConsistent(hm, s);
  int examined = 0, expected = 0;
  for (int v = -50; v <= 50; ++v)
    for (int u = -50; u <= 50; ++u) {
      expected += u * u + v * v <= 1600;
      examined += s.examined[s.index(u, v)];
    }
  EXPECT_EQ(examined, expected);
  EXPECT_TRUE(s.examined[s.index(40, 0)]);
  EXPECT_TRUE(s.examined[s.index(0, -40)]);
  EXPECT_FALSE(s.examined[s.index(41, 0)]);
  EXPECT_FALSE(s.examined[s.index(29, 29)]);  // 4.10 m
  EXPECT_TRUE(s.examined[s.index(28, 28)]);   // 3.96 m
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.segmentSize(0), expected);
  EXPECT_EQ(s.segment_of[s.index(50, 50)], -1);
  EXPECT_TRUE(s.non_traversable.empty());  // unexamined cells are never non-traversable
}

TEST(GroundSegmentation, StepOfOneStartsANewSegmentAndLargerStepsAreNonTraversable) {
  const HeightMap hm = fromText({
      "0000111122",
      "0000111122",
      "0000111122",
      "0000111122",
  });
  GroundSegmentation seg(paperConfig());
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{1, 1, 0}, kLv, &s));
  expectConsistent(hm, s);
  // 0 -> 1 -> 2: each step is w_T = 1, so the chain reaches all three heights.
  ASSERT_EQ(s.numSegments(), 3);
  EXPECT_EQ(s.segment_height[0], 0);
  EXPECT_EQ(s.segment_height[1], 1);
  EXPECT_EQ(s.segment_height[2], 2);
  EXPECT_EQ(s.segmentSize(0), 16);
  EXPECT_EQ(s.segmentSize(1), 16);
  EXPECT_EQ(s.segmentSize(2), 8);

  const HeightMap jump = fromText({
      "0000222200",
      "0000222200",
      "0000222200",
  });
  ASSERT_TRUE(seg.segment(jump, VoxelIndex{0, 0, 0}, kLv, &s));
  expectConsistent(jump, s);
  ASSERT_EQ(s.numSegments(), 1);  // a 2-voxel step is not crossed: the far floor is cut off
  EXPECT_EQ(s.segmentSize(0), 12);
  EXPECT_EQ(s.non_traversable.size(), 18u);  // the 2s and the floor behind them
  EXPECT_EQ(s.segment_of[s.index(9, 0)], -1);
}

TEST(GroundSegmentation, ToleranceZeroKeepsOnlyTheRobotsHeight) {
  const HeightMap hm = fromText({"0011", "0011"});
  GroundSegmentationConfig c = paperConfig();
  c.height_tolerance = 0;
  GroundSegmentation seg(c);
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.non_traversable.size(), 4u);
}

TEST(GroundSegmentation, BoxIsNonTraversableAndFloorAroundItOneSegment) {
  const HeightMap hm = fromText({
      "00000000",
      "00000000",
      "00055000",
      "00055000",
      "00000000",
      "00000000",
  });
  GroundSegmentation seg(paperConfig());
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.segmentSize(0), 44);
  std::set<int> nt(s.non_traversable.begin(), s.non_traversable.end());
  EXPECT_EQ(nt, (std::set<int>{s.index(3, 2), s.index(4, 2), s.index(3, 3), s.index(4, 3)}));
}

TEST(GroundSegmentation, EnclosedFloorIsUnreachable) {
  // Floor inside a wall of height 5 is the same height as the robot's floor but cannot be
  // reached: it is in no segment.
  const HeightMap hm = fromText({
      "000000000",
      "005555500",
      "005000500",
      "005000500",
      "005555500",
      "000000000",
  });
  GroundSegmentation seg(paperConfig());
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.segment_of[s.index(4, 2)], -1);
  EXPECT_EQ(s.non_traversable.size(), 14u + 6u);
}

TEST(GroundSegmentation, UnobservedCellsSeparateSegments) {
  const HeightMap hm = fromText({
      "000..000",
      "000..000",
  });
  GroundSegmentation seg(paperConfig());
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.segmentSize(0), 6);
  EXPECT_EQ(s.non_traversable.size(), 6u);
}

TEST(GroundSegmentation, ConnectivityFourVersusEight) {
  // Two floors touching only diagonally, walled off otherwise.
  const HeightMap hm = fromText({
      "00055",
      "00055",
      "55500",
      "55500",
  });
  GroundSegmentation eight(paperConfig());
  GroundSegments s;
  ASSERT_TRUE(eight.segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.segmentSize(0), 10);
  GroundSegmentationConfig c = paperConfig();
  c.connectivity = 4;
  GroundSegmentation four(c);
  ASSERT_TRUE(four.segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.segmentSize(0), 6);
  EXPECT_EQ(s.segment_of[s.index(4, 3)], -1);
}

TEST(GroundSegmentation, EqualHeightsAlwaysShareASegment) {
  // The 1s on both sides of the 0-corridor are one connected region: they must be one segment
  // although they are first reached from different places.
  const HeightMap hm = fromText({
      "1111111",
      "1000001",
      "1111111",
  });
  GroundSegmentation seg(paperConfig());
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{3, 1, 0}, kLv, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.numSegments(), 2);
  EXPECT_EQ(s.segmentSize(0), 5);
  EXPECT_EQ(s.segmentSize(1), 16);
}

TEST(GroundSegmentation, SeedRuleWhenTheRobotsCellIsUnobserved) {
  // Robot at (4, 3): its cell has no height. Nearest observed cell at the base height is
  // (4, 5) (0.2 m, before (4, 0) at 0.3 m); (6, 3) is as near but one voxel higher, (2, 3) is as
  // near but three voxels higher.
  const HeightMap hm = fromText({
      "0000000000",
      "..........",
      "..........",
      "..3...1...",
      "..........",
      "0000000000",
  });
  GroundSegmentation seg(paperConfig());
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{4, 3, 0}, kLv, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.seed_cell, s.index(4, 5));
  EXPECT_EQ(s.segment_height[0], 0);
  EXPECT_EQ(s.segmentSize(0), 10);

  // Only a cell one voxel off the base height is near: it seeds.
  const HeightMap hm2 = fromText({
      "..........",
      "...11.....",
      "...11.....",
  });
  ASSERT_TRUE(seg.segment(hm2, VoxelIndex{1, 1, 0}, kLv, &s));
  EXPECT_EQ(s.seed_cell, s.index(3, 1));
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.segment_height[0], 1);
}

TEST(GroundSegmentation, NoSeedWithinTheSeedRadiusMeansNoSegments) {
  HeightMap hm = flat(-30, -30, 61, 61, 0);
  for (int v = -12; v <= 12; ++v)
    for (int u = -12; u <= 12; ++u)
      hm.set(u, v, HeightMap::kNoHeight);  // 1.2 m blind area
  GroundSegmentation seg(paperConfig());   // seed radius 1 m
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 0);
  EXPECT_EQ(s.robot_segment, -1);
  EXPECT_EQ(s.seed_cell, -1);
  int examined_with_height = 0;
  for (int c = 0; c < s.numCells(); ++c)
    examined_with_height += s.examined[c] && hm.atIndex(c) != HeightMap::kNoHeight;
  EXPECT_EQ(static_cast<int>(s.non_traversable.size()), examined_with_height);

  GroundSegmentationConfig c = paperConfig();
  c.seed_radius = 1.5;
  GroundSegmentation wide(c);
  ASSERT_TRUE(wide.segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_TRUE(s.non_traversable.empty());

  // A seed at the right height but far off the robot's base height is rejected.
  const HeightMap high = flat(-5, -5, 11, 11, 3);
  ASSERT_TRUE(seg.segment(high, VoxelIndex{0, 0, 0}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 0);
  EXPECT_EQ(s.non_traversable.size(), 121u);
}

TEST(GroundSegmentation, RobotOutsideTheWindowAndBadInput) {
  const HeightMap hm = flat(0, 0, 10, 10, 0);
  GroundSegmentation seg(paperConfig());
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{1000, -1000, 0}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 0);
  for (auto e : s.examined)
    EXPECT_EQ(e, 0);
  EXPECT_TRUE(s.non_traversable.empty());

  // Just outside: the seed radius reaches into the window.
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{-3, 5, 0}, kLv, &s));
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.seed_cell, s.index(0, 5));

  // Extreme robot indices do not overflow.
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{1 << 30, -(1 << 30), 1 << 30}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 0);

  EXPECT_FALSE(seg.segment(hm, VoxelIndex{0, 0, 0}, 0.0, &s));
  EXPECT_EQ(s.numSegments(), 0);
  EXPECT_FALSE(seg.segment(hm, VoxelIndex{0, 0, 0}, std::nan(""), &s));
  EXPECT_FALSE(seg.segment(hm, VoxelIndex{0, 0, 0}, kLv, nullptr));

  HeightMap empty;
  ASSERT_TRUE(seg.segment(empty, VoxelIndex{0, 0, 0}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 0);
  EXPECT_EQ(s.numCells(), 0);
}

TEST(GroundSegmentation, BuffersAreReusedAcrossCalls) {
  const HeightMap a = fromText({"0000", "0011", "0011"});
  const HeightMap b = flat(0, 0, 4, 3, 0);
  GroundSegmentation seg(paperConfig());
  GroundSegments s;
  ASSERT_TRUE(seg.segment(a, VoxelIndex{0, 0, 0}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 2);
  ASSERT_TRUE(seg.segment(b, VoxelIndex{0, 0, 0}, kLv, &s));
  expectConsistent(b, s);
  EXPECT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.segmentSize(0), 12);
}

// ---- Island segments (ours, GroundSegmentationConfig::segment_islands).

GroundSegmentationConfig islandConfig() {
  GroundSegmentationConfig c;
  c.segment_islands = true;
  return c;
}

TEST(GroundSegmentation, IslandsBecomeSegmentsInsteadOfNonTraversableColumns) {
  const HeightMap hm = fromText({
      "000..000",
      "000..000",
      "000..000",
  });
  GroundSegments s;
  ASSERT_TRUE(GroundSegmentation(paperConfig()).segment(hm, VoxelIndex{0, 1, 0}, kLv, &s));
  ASSERT_EQ(s.numSegments(), 1);
  EXPECT_EQ(s.non_traversable.size(), 9u);  // 000: the far floor is non-traversable
  ASSERT_TRUE(GroundSegmentation(islandConfig()).segment(hm, VoxelIndex{0, 1, 0}, kLv, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.numSegments(), 2);
  EXPECT_EQ(s.robot_segment, 0);
  EXPECT_EQ(s.segment_island[0], 0);
  EXPECT_EQ(s.segment_island[1], 1);
  EXPECT_EQ(s.segmentSize(1), 9);
  EXPECT_TRUE(s.non_traversable.empty());
}

TEST(GroundSegmentation, ColumnsAlg1ComparedAndLeftOutStayNonTraversable) {
  // A box (height 5) beside the robot's floor, and an island floor beyond it. The box columns
  // Alg. 1 compared with the floor stay non-traversable; the one it never reached, (4, 0) (the
  // box's unseen-around top), becomes a one-cell island (Alg. 2: small, Unknown).
  const HeightMap hm = fromText({
      "00055..00",
      "00055..00",
      "00000....",
  });
  GroundSegments s;
  ASSERT_TRUE(GroundSegmentation(islandConfig()).segment(hm, VoxelIndex{0, 0, 0}, kLv, &s));
  expectConsistent(hm, s);
  EXPECT_EQ(s.segment_of[s.index(3, 0)], -1);
  EXPECT_EQ(s.segment_of[s.index(3, 1)], -1);
  EXPECT_EQ(s.segment_of[s.index(4, 1)], -1);
  EXPECT_EQ(s.non_traversable.size(), 3u);
  const int top = s.segment_of[s.index(4, 0)];
  ASSERT_GE(top, 1);
  EXPECT_EQ(s.segmentSize(top), 1);  // did not absorb the locked (4, 1)
  EXPECT_GE(s.segment_of[s.index(7, 0)], 1);
}

TEST(GroundSegmentation, ObstacleLikeColumnsDoNotSeedIslands) {
  // A pole seen without the floor around it: its column's occupied voxels span 14 voxels, so
  // it is the face of an obstacle, not ground, and stays non-traversable (Non-ground).
  HeightMap hm = fromText({
      "000..........",
      "000..........",
      "000..........",
  });
  hm.set(6, 1, 14, 0);  // the pole: top at 14, lowest occupied voxel at 0
  hm.set(8, 1, 0, 0);   // a floor column away from it...
  hm.set(9, 1, 1, 0);   // ...and one spanning one voxel (noise): still ground-like
  hm.set(11, 1, 0, 0);  // floor right beside a tall column (a table's edge above it, say)
  hm.set(12, 1, 7, 7);
  GroundSegments s;
  ASSERT_TRUE(GroundSegmentation(islandConfig()).segment(hm, VoxelIndex{0, 1, 0}, kLv, &s));
  expectConsistent(hm, s);
  EXPECT_EQ(s.segment_of[s.index(6, 1)], -1);
  EXPECT_GE(s.segment_of[s.index(8, 1)], 1);
  EXPECT_GE(s.segment_of[s.index(9, 1)], 1);
  // Beside a height discontinuity 000 calls both columns non-traversable; islands keep that.
  EXPECT_EQ(s.segment_of[s.index(11, 1)], -1);
  EXPECT_EQ(s.segment_of[s.index(12, 1)], -1);
  EXPECT_EQ(s.non_traversable.size(), 3u);
  GroundSegmentationConfig c = islandConfig();
  c.island_max_span = 0;
  ASSERT_TRUE(GroundSegmentation(c).segment(hm, VoxelIndex{0, 1, 0}, kLv, &s));
  EXPECT_EQ(s.segment_of[s.index(9, 1)], -1);
}

}  // namespace
}  // namespace stereo_safety_map

namespace stereo_safety_map {
namespace {

// The robot stands on ground (GroundSegmentationConfig::footprint_radius): with nothing observed
// near it, its footprint is the robot's segment at the base's height; with the footprint off
// (000's seed rule) there is no robot segment.
TEST(GroundSegmentationFootprint, TheFootprintSeedsTheRobotsSegment) {
  // Observed floor from 1.2 m ahead: farther than the seed radius (1 m).
  HeightMap hm = fromText({"..............00000", "..............00000", "..............00000",
                           "..............00000", "..............00000"});
  GroundSegmentationConfig c;
  c.footprint_radius = 0.0;
  GroundSegmentation paper(c);
  GroundSegments s;
  ASSERT_TRUE(paper.segment(hm, VoxelIndex{2, 2, 0}, 0.1, &s));
  EXPECT_EQ(s.robot_segment, -1);
  c.footprint_radius = 0.2;  // two cells
  GroundSegmentation ours(c);
  ASSERT_TRUE(ours.segment(hm, VoxelIndex{2, 2, 0}, 0.1, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.robot_segment, 0);
  EXPECT_EQ(s.segment_of[s.index(2, 2)], 0);
  EXPECT_EQ(s.segment_height[0], 0);
  int footprint = 0;
  for (int cell = 0; cell < s.numCells(); ++cell) {
    footprint += s.footprint[cell];
    if (s.footprint[cell]) {
      EXPECT_EQ(s.segment_of[cell], 0);
      EXPECT_EQ(hm.atIndex(cell), HeightMap::kNoHeight);  // the height map is not changed
    }
  }
  EXPECT_EQ(footprint, 13);  // cells within 2 cells of (2, 2)
  // An observed column in the footprint keeps its height: it is not footprint.
  hm.set(3, 2, 0);
  ASSERT_TRUE(ours.segment(hm, VoxelIndex{2, 2, 0}, 0.1, &s));
  EXPECT_FALSE(s.footprint[s.index(3, 2)]);
  EXPECT_EQ(s.segment_of[s.index(3, 2)], 0);
}

// Observed ground at the base's height within seed_radius seeds the robot's segment as in 000,
// also when it is not connected to the footprint (the camera's blind zone between them): the
// footprint joins that segment. Observed ground one index off the base's height does not beat
// the footprint, which is at the base's height.
TEST(GroundSegmentationFootprint, ObservedGroundWithinTheSeedRadiusAndTheFootprintAreOneSegment) {
  // Observed floor from 0.7 m ahead, within the seed radius (1 m), beyond the footprint.
  HeightMap hm = fromText(
      {"........00000", "........00000", "........00000", "........00000", "........00000"});
  GroundSegmentationConfig c;
  c.footprint_radius = 0.2;
  c.seed_radius = 1.0;
  GroundSegmentation seg(c);
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{1, 2, 0}, 0.1, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.robot_segment, 0);
  EXPECT_FALSE(s.footprint[s.seed_cell]);      // seeded on observed ground
  EXPECT_EQ(s.segment_of[s.index(10, 2)], 0);  // the floor ahead
  EXPECT_EQ(s.segment_of[s.index(1, 2)], 0);   // the robot's own cell (footprint)
  EXPECT_EQ(s.numSegments(), 1);
  // The floor one index up: the footprint (at the base's height) seeds the robot's segment and
  // the floor is a segment of its own (a step the labelling judges).
  HeightMap up = fromText(
      {"........11111", "........11111", "........11111", "........11111", "........11111"});
  ASSERT_TRUE(seg.segment(up, VoxelIndex{1, 2, 0}, 0.1, &s));
  expectConsistent(up, s);
  ASSERT_EQ(s.robot_segment, 0);
  EXPECT_TRUE(s.footprint[s.seed_cell]);
  EXPECT_NE(s.segment_of[s.index(10, 2)], 0);
}

// The ground the robot stands on (GroundSegmentationConfig::seed_on_support): the floor around
// the base reads one index high (seen from afar with an unreported pitch) and two stray columns
// still sit at the base's height. The least-difference seed rule grows the robot's segment on
// those two columns and leaves the floor under the chair a segment of its own; with the rule on,
// the floor that fills the footprint disk is the robot's segment. A step beside the chair that
// holds a few of the disk's cells does not move the seed off the ground the chair stands on.
TEST(GroundSegmentationFootprint, TheSeedIsTheGroundThatFillsTheFootprint) {
  HeightMap hm = fromText({"1111111111", "1111111111", "1111111111", "1101111111", "1111111111",
                           "1111101111", "1111111111"});
  GroundSegmentationConfig c;
  c.footprint_radius = 0.25;  // 21 cells around (3, 3)
  c.seed_on_support = false;
  GroundSegments s;
  ASSERT_TRUE(GroundSegmentation(c).segment(hm, VoxelIndex{3, 3, 0}, 0.1, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.robot_segment, 0);
  EXPECT_EQ(s.segment_height[0], 0);
  EXPECT_EQ(s.segmentSize(0), 1);  // a stray column
  EXPECT_NE(s.segment_of[s.index(3, 3)], 0);

  // The floor's ground heights 6 cm, the base at 2 cm: within seed_support_max_offset (5 cm).
  auto setGround = [](HeightMap* m, float z) {
    for (int v = 0; v < m->height(); ++v)
      for (int u = 0; u < m->width(); ++u)
        if (m->at(u, v) == 1) m->setGroundHeight(u, v, z);
  };
  setGround(&hm, 0.06f);
  c.seed_on_support = true;
  ASSERT_TRUE(GroundSegmentation(c).segment(hm, VoxelIndex{3, 3, 0}, 0.1, &s, 0.02f));
  expectConsistent(hm, s);
  ASSERT_EQ(s.robot_segment, 0);
  EXPECT_EQ(s.segment_height[0], 1);
  EXPECT_EQ(s.segment_of[s.index(3, 3)], 0);
  EXPECT_EQ(s.segment_of[s.index(9, 6)], 0);
  EXPECT_GE(s.segmentSize(0), 68);
  // A floor that reads 8 cm above the wheels, or no base height given: the map's heights near
  // the robot cannot be trusted, and the seed rule alone applies (the floor unreachable).
  setGround(&hm, 0.10f);
  ASSERT_TRUE(GroundSegmentation(c).segment(hm, VoxelIndex{3, 3, 0}, 0.1, &s, 0.02f));
  EXPECT_EQ(s.segment_height[0], 0);
  EXPECT_EQ(s.segmentSize(0), 1);
  setGround(&hm, 0.06f);
  ASSERT_TRUE(GroundSegmentation(c).segment(hm, VoxelIndex{3, 3, 0}, 0.1, &s));
  EXPECT_EQ(s.segment_height[0], 0);
  c.seed_support_max_offset = 0.1;
  setGround(&hm, 0.10f);
  ASSERT_TRUE(GroundSegmentation(c).segment(hm, VoxelIndex{3, 3, 0}, 0.1, &s, 0.02f));
  EXPECT_EQ(s.segment_height[0], 1);
  c.seed_support_max_offset = 0.05;

  // The robot on the lower floor (w = 0) beside a step up (w = 1) two cells away: the disk's
  // majority is the lower floor, which stays the robot's segment.
  HeightMap step = fromText({"0000011111", "0000011111", "0000011111", "0000011111", "0000011111",
                             "0000011111", "0000011111"});
  ASSERT_TRUE(GroundSegmentation(c).segment(step, VoxelIndex{3, 3, 0}, 0.1, &s));
  expectConsistent(step, s);
  ASSERT_EQ(s.robot_segment, 0);
  EXPECT_EQ(s.segment_height[0], 0);
  EXPECT_EQ(s.segment_of[s.index(0, 0)], 0);
  EXPECT_NE(s.segment_of[s.index(9, 3)], 0);

  // Unobserved footprint cells count at the base's height: a floor one index up seen only
  // beyond the blind zone does not take the seed (as in the test above).
  HeightMap blind = fromText({"......1111", "......1111", "......1111", "......1111", "......1111",
                              "......1111", "......1111"});
  ASSERT_TRUE(GroundSegmentation(c).segment(blind, VoxelIndex{3, 3, 0}, 0.1, &s));
  ASSERT_EQ(s.robot_segment, 0);
  EXPECT_EQ(s.segment_height[0], 0);
  EXPECT_TRUE(s.footprint[s.seed_cell]);
}

// --- Steps inside a segment (GroundSegmentationConfig::split_steps) ---------------------------

// A band of one indexed height (w = 0), 30 x 20 cells, whose columns' ground heights are
// ground(u, v) plus a deterministic +-1 cm noise; the robot stands at u = 2, v = 10.
HeightMap bandWithGround(const std::function<double(int, int)>& ground) {
  HeightMap hm;
  hm.reset(0, 0, 30, 20);
  for (int v = 0; v < 20; ++v) {
    for (int u = 0; u < 30; ++u) {
      hm.set(u, v, 0);
      const double noise = 0.01 * (((u * 7 + v * 13) % 5) - 2) / 2.0;
      hm.setGroundHeight(u, v, static_cast<float>(ground(u, v) + noise));
    }
  }
  return hm;
}

GroundSegmentationConfig splitConfig(bool split) {
  GroundSegmentationConfig c = paperConfig();
  c.split_steps = split;
  return c;
}

TEST(GroundSegmentationSplit, ASixCentimetreStepInsideTheBandSplitsTheRobotsSegment) {
  // The upper floor's points stand at +2 cm, the sunken floor's (u >= 15) at -4 cm: one indexed
  // height, as when the lower floor's noise reaches into the upper floor's voxel.
  const HeightMap hm = bandWithGround([](int u, int) { return u < 15 ? 0.02 : -0.04; });
  GroundSegments s;
  GroundSegmentation off(splitConfig(false));
  ASSERT_TRUE(off.segment(hm, VoxelIndex{2, 10, 0}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 1);  // 000's Alg. 1: one segment over both levels

  GroundSegmentation on(splitConfig(true));
  ASSERT_TRUE(on.segment(hm, VoxelIndex{2, 10, 0}, kLv, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.numSegments(), 2);
  EXPECT_EQ(s.robot_segment, 0);
  EXPECT_EQ(s.segment_of[s.index(2, 10)], 0);
  const int lower = s.segment_of[s.index(25, 10)];
  EXPECT_EQ(lower, 1);
  EXPECT_EQ(s.segment_split_from[1], 0);
  EXPECT_EQ(s.segment_split_from[0], -1);
  EXPECT_TRUE(s.splitSiblings(0, 1));
  EXPECT_TRUE(s.splitSiblings(1, 0));
  EXPECT_EQ(s.segment_height[1], 0);
  for (int v = 0; v < 20; ++v) {
    for (int u = 0; u < 30; ++u)
      EXPECT_EQ(s.segment_of[s.index(u, v)], u < 15 ? 0 : 1) << u << ", " << v;
  }
  EXPECT_TRUE(s.non_traversable.empty());
}

TEST(GroundSegmentationSplit, AStepBelowSplitMinStepOrASmallPatchDoesNotSplit) {
  GroundSegmentation seg(splitConfig(true));
  GroundSegments s;
  // 3 cm: crossable, not split.
  ASSERT_TRUE(seg.segment(bandWithGround([](int u, int) { return u < 15 ? 0.02 : -0.01; }),
                          VoxelIndex{2, 10, 0}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 1);
  // A lower patch of 3 x 3 cells (fewer than split_min_cells) is noise, not a level.
  ASSERT_TRUE(seg.segment(bandWithGround([](int u, int v) {
                            return (u >= 20 && u < 23 && v >= 8 && v < 11) ? -0.05 : 0.02;
                          }),
                          VoxelIndex{2, 10, 0}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 1);
}

TEST(GroundSegmentationSplit, ARampInsideTheBandIsNotSplit) {
  // 5 deg up along u: 0.87 cm per 0.1 m cell, 26 cm over the band (its heights are set by hand),
  // and a level floor that bends into a 6 deg ramp at u = 12. Otsu splits them along a contour
  // line, where the two sides' planes agree.
  const double t5 = std::tan(5.0 * M_PI / 180.0), t6 = std::tan(6.0 * M_PI / 180.0);
  GroundSegmentation seg(splitConfig(true));
  GroundSegments s;
  ASSERT_TRUE(seg.segment(bandWithGround([&](int u, int) { return -0.05 + kLv * u * t5; }),
                          VoxelIndex{2, 10, 0}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 1);
  ASSERT_TRUE(
      seg.segment(bandWithGround([&](int u, int) { return u < 12 ? 0.0 : kLv * (u - 12) * t6; }),
                  VoxelIndex{2, 10, 0}, kLv, &s));
  EXPECT_EQ(s.numSegments(), 1);
}

TEST(GroundSegmentationSplit, TheSideWithTheRobotKeepsTheSegment) {
  // The robot stands on the lower level: the upper side leaves.
  const HeightMap hm = bandWithGround([](int u, int) { return u < 15 ? -0.04 : 0.02; });
  GroundSegmentation seg(splitConfig(true));
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{2, 10, 0}, kLv, &s));
  expectConsistent(hm, s);
  ASSERT_EQ(s.numSegments(), 2);
  EXPECT_EQ(s.segment_of[s.index(2, 10)], s.robot_segment);
  EXPECT_EQ(s.segment_of[s.index(25, 10)], 1);
  EXPECT_EQ(s.segment_split_from[1], s.robot_segment);
}

}  // namespace
}  // namespace stereo_safety_map
