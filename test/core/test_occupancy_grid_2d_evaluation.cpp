// Tests of the 2D occupancy grid's evaluation helpers: grid -> safety labels with the paper's
// planning thresholds (002 Sec. 3.4), outcome counts on the safety map's cell indexing, the
// per-cause split of GT Non-ground cells, and the board-width coverage behind the latency.
#include "stereo_safety_map/core/occupancy_grid_2d_evaluation.h"

#include <gtest/gtest.h>

#include <cmath>

namespace stereo_safety_map {
namespace {

LabelGrid makeTruth(int min_u, int min_v, int w, int h, SafetyLabel fill) {
  LabelGrid g;
  g.min_u = min_u;
  g.min_v = min_v;
  g.width = w;
  g.height = h;
  g.resolution = 0.1;
  g.labels.assign(static_cast<std::size_t>(w) * h, fill);
  return g;
}

TEST(OccupancyGridAsSafetyMap, ThresholdsAndRadius) {
  OccupancyGrid2D grid;  // 20 x 20 m, 0.1 m, thresholds 50 / 150
  grid.setCell({10, 0}, 151);
  grid.setCell({11, 0}, 150);  // not above the occupied threshold: unknown
  grid.setCell({12, 0}, 50);   // not below the free threshold: unknown
  grid.setCell({13, 0}, 49);
  grid.setCell({50, 0}, 255);  // 5 m away
  SafetyMap map;
  occupancyGridAsSafetyMap(grid, Eigen::Vector2f(0.0f, 0.0f), 4.0, &map);
  ASSERT_EQ(map.width, grid.sizeU());
  ASSERT_EQ(map.height, grid.sizeV());
  EXPECT_EQ(map.min_u, grid.minIndex().u);
  EXPECT_EQ(map.min_v, grid.minIndex().v);
  EXPECT_DOUBLE_EQ(map.resolution, 0.1);
  EXPECT_EQ(map.labels.size(), static_cast<std::size_t>(map.width) * map.height);
  EXPECT_EQ(map.labelAt(10, 0), SafetyLabel::kNonGround);
  EXPECT_EQ(map.labelAt(11, 0), SafetyLabel::kUnknown);
  EXPECT_EQ(map.labelAt(12, 0), SafetyLabel::kUnknown);
  EXPECT_EQ(map.labelAt(13, 0), SafetyLabel::kLevel);
  EXPECT_EQ(map.labelAt(0, 0), SafetyLabel::kUnknown);  // never updated
  EXPECT_EQ(map.labelAt(50, 0), SafetyLabel::kUnexamined);
  EXPECT_EQ(map.labelAt(40, 0), SafetyLabel::kUnknown);  // exactly 4 m: inside
  EXPECT_EQ(map.labelAt(29, 29), SafetyLabel::kUnexamined);

  // No radius: everything in the window is examined.
  occupancyGridAsSafetyMap(grid, Eigen::Vector2f(0.0f, 0.0f), 0.0, &map);
  EXPECT_EQ(map.labelAt(50, 0), SafetyLabel::kNonGround);
}

TEST(OccupancyGridAsSafetyMap, CountsOnTheSafetyMapsCellIndexing) {
  OccupancyGrid2D grid;
  // GT: a strip of Non-ground at u = 20 and Level elsewhere in u 10..29, v -2..2.
  LabelGrid truth = makeTruth(10, -2, 20, 5, SafetyLabel::kLevel);
  for (int v = -2; v <= 2; ++v)
    truth.labels[truth.index(20, v)] = SafetyLabel::kNonGround;
  grid.setCell({20, 0}, 200);  // TP
  grid.setCell({20, 1}, 10);   // FN: the grid calls an obstacle cell free
  grid.setCell({15, 0}, 200);  // FP
  grid.setCell({15, 1}, 10);   // TN
  grid.setCell({16, 1}, 10);   // TN
  grid.setCell({60, 0}, 200);  // outside the GT: unclassified in the GT
  SafetyMap map;
  occupancyGridAsSafetyMap(grid, Eigen::Vector2f(0.0f, 0.0f), 0.0, &map);
  ConfusionCounts c;
  std::vector<CellOutcome> outcomes;
  ASSERT_EQ(countConfusion(map, truth, &c, &outcomes), "");
  EXPECT_EQ(c.tp, 1u);
  EXPECT_EQ(c.fn, 1u);
  EXPECT_EQ(c.fp, 1u);
  EXPECT_EQ(c.tn, 2u);
  EXPECT_EQ(c.unclassified_in_gt, 1u);
  EXPECT_EQ(c.unclassified_in_map, 100u - 5u);
  EXPECT_EQ(outcomes[map.index(20, 0)], CellOutcome::kTruePositive);
  EXPECT_EQ(outcomes[map.index(20, 1)], CellOutcome::kFalseNegative);

  // Causes: the obstacle cell is seen, the drop-off cell is called free, the rest unknown.
  std::vector<UnsafeCause> causes(truth.labels.size(), UnsafeCause::kNotUnsafe);
  causes[truth.index(20, 0)] = UnsafeCause::kObstacle;
  causes[truth.index(20, 1)] = UnsafeCause::kLowerGround;
  causes[truth.index(20, 2)] = UnsafeCause::kTooSteep;
  causes[truth.index(20, -1)] = UnsafeCause::kObstacle;
  causes[truth.index(20, -2)] = UnsafeCause::kRaisedGround;
  UnsafeCauseCounts by;
  ASSERT_EQ(countUnsafeCauses(map, truth, causes, &by), "");
  const int obstacle = static_cast<int>(UnsafeCause::kObstacle);
  const int lower = static_cast<int>(UnsafeCause::kLowerGround);
  const int steep = static_cast<int>(UnsafeCause::kTooSteep);
  const int raised = static_cast<int>(UnsafeCause::kRaisedGround);
  EXPECT_EQ(by.occupied[obstacle], 1u);
  EXPECT_EQ(by.unclassified[obstacle], 1u);
  EXPECT_EQ(by.free[lower], 1u);
  EXPECT_EQ(by.unclassified[steep], 1u);
  EXPECT_EQ(by.unclassified[raised], 1u);
  EXPECT_EQ(by.free[obstacle], 0u);
  // Summed, the per-cause counts are the GT Non-ground cells' outcomes.
  std::uint64_t occ = 0, fr = 0;
  for (int k = 0; k < kNumUnsafeCauses; ++k) {
    occ += by.occupied[k];
    fr += by.free[k];
  }
  EXPECT_EQ(occ, c.tp);
  EXPECT_EQ(fr, c.fn);
  UnsafeCauseCounts twice = by;
  twice += by;
  EXPECT_EQ(twice.free[lower], 2u);

  // Cells outside the evaluated radius are not counted.
  SafetyMap near;
  occupancyGridAsSafetyMap(grid, Eigen::Vector2f(0.0f, 0.0f), 1.5, &near);
  UnsafeCauseCounts none;
  ASSERT_EQ(countUnsafeCauses(near, truth, causes, &none), "");
  for (int k = 0; k < kNumUnsafeCauses; ++k)
    EXPECT_EQ(none.occupied[k] + none.free[k] + none.unclassified[k], 0u);

  causes.pop_back();
  EXPECT_NE(countUnsafeCauses(map, truth, causes, &by), "");
  EXPECT_NE(countUnsafeCauses(map, truth, causes, nullptr), "");
}

TEST(DropOffEdges, MarkedFreeOccupiedOrUnknown) {
  LabelGrid truth = makeTruth(0, 0, 10, 1, SafetyLabel::kLevel);
  std::vector<std::uint8_t> edge(10, 0);
  for (int u = 2; u <= 6; ++u)
    edge[truth.index(u, 0)] = 1;
  SafetyMap map;
  map.min_u = 0;
  map.min_v = 0;
  map.width = 10;
  map.height = 1;
  map.resolution = 0.1;
  map.labels = {SafetyLabel::kLevel,      SafetyLabel::kLevel,     SafetyLabel::kLevel,
                SafetyLabel::kInclined,   SafetyLabel::kNonGround, SafetyLabel::kUnknown,
                SafetyLabel::kUnexamined, SafetyLabel::kLevel,     SafetyLabel::kLevel,
                SafetyLabel::kLevel};
  map.drop_off.assign(10, 0);
  map.drop_off[3] = 1;
  map.drop_off[0] = 1;  // not a GT edge: not counted
  DropOffEdgeCounts c;
  ASSERT_EQ(countDropOffEdges(map, truth, edge, &c), "");
  EXPECT_EQ(c.safe_unmarked, 1u);  // u = 2
  EXPECT_EQ(c.marked, 1u);         // u = 3
  EXPECT_EQ(c.unsafe, 1u);         // u = 4
  EXPECT_EQ(c.unclassified, 1u);   // u = 5; u = 6 Unexamined
  EXPECT_EQ(c.total(), 4u);
  // A map without marks (the 2D grid) can only call an edge free.
  map.drop_off.clear();
  DropOffEdgeCounts d;
  ASSERT_EQ(countDropOffEdges(map, truth, edge, &d), "");
  EXPECT_EQ(d.marked, 0u);
  EXPECT_EQ(d.safe_unmarked, 2u);
  d += c;
  EXPECT_EQ(d.total(), 8u);
  edge.pop_back();
  EXPECT_NE(countDropOffEdges(map, truth, edge, &d), "");
}

BoardBox boardAt(const Eigen::Vector3d& base, double yaw_deg) {
  // 0.03 m thick (x), 1.2 m wide (y), 1.0 m tall, standing on z = 0, as the latency scenes.
  BoardBox b;
  b.rotation =
      Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  b.half_size = Eigen::Vector3d(0.015, 0.6, 0.5);
  b.center = base + Eigen::Vector3d(0.0, 0.0, 0.5);
  return b;
}

TEST(BoardWidthCoverage2D, FractionOfTheWidthOccupied) {
  // Face at x = 5 (cell u = 50), y -0.575 .. 0.625: the 12 width samples at y = -0.525 + 0.1 i
  // fall into the cells v = -5 .. 6, one each.
  const BoardBox b = boardAt({5.0, 0.025, 0.0}, 0.0);
  OccupancyGrid2D grid;
  EXPECT_EQ(boardWidthCoverage2D(grid, b).bins, 12);
  EXPECT_EQ(boardWidthCoverage2D(grid, b).covered, 0);
  for (int v = 1; v <= 6; ++v)
    grid.setCell({50, v}, 200);
  BoardCoverage c = boardWidthCoverage2D(grid, b);
  EXPECT_EQ(c.covered, 6);
  EXPECT_DOUBLE_EQ(c.fraction(), 0.5);
  // One cell of slack across the board (stereo's depth error), not two.
  grid.setCell({49, -2}, 200);
  grid.setCell({51, -3}, 200);
  grid.setCell({48, -4}, 200);
  grid.setCell({52, -4}, 200);
  EXPECT_EQ(boardWidthCoverage2D(grid, b).covered, 8);
  // Unknown and free cells never count; cells beyond the width's end neither.
  grid.setCell({50, -5}, 140);
  grid.setCell({50, -1}, 10);
  grid.setCell({50, 8}, 255);
  grid.setCell({50, -7}, 255);
  EXPECT_EQ(boardWidthCoverage2D(grid, b).covered, 8);
  for (int v = -5; v <= 6; ++v)
    grid.setCell({50, v}, 200);
  EXPECT_DOUBLE_EQ(boardWidthCoverage2D(grid, b).fraction(), 1.0);
}

TEST(BoardWidthCoverage2D, RotatedBoard) {
  const BoardBox b = boardAt({3.0, 3.0, 0.0}, 45.0);  // width along (-1, 1) / sqrt(2)
  // Cells along one half of the board's face.
  OccupancyGrid2D grid;
  for (int i = 0; i <= 4; ++i)
    grid.setCell(grid.indexOf(Eigen::Vector2f(3.0f - 0.1f * i, 3.0f + 0.1f * i)), 200);
  BoardCoverage c = boardWidthCoverage2D(grid, b);
  EXPECT_EQ(c.bins, 12);
  EXPECT_GE(c.covered, 6);
  EXPECT_LE(c.covered, 8);
  for (int i = -4; i < 0; ++i)
    grid.setCell(grid.indexOf(Eigen::Vector2f(3.0f - 0.1f * i, 3.0f + 0.1f * i)), 200);
  EXPECT_EQ(boardWidthCoverage2D(grid, b).covered, 12);
  // The same cells shifted 0.5 m across the board do not count.
  OccupancyGrid2D off;
  for (int i = -4; i <= 4; ++i)
    off.setCell(off.indexOf(Eigen::Vector2f(3.35f - 0.1f * i, 3.35f + 0.1f * i)), 200);
  EXPECT_EQ(boardWidthCoverage2D(off, b).covered, 0);
  BoardBox bad = b;
  bad.half_size.x() = std::nan("");
  EXPECT_EQ(boardWidthCoverage2D(grid, bad).bins, 0);
}

}  // namespace
}  // namespace stereo_safety_map
