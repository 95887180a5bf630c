// Height map of the voxel grid (000, Sec. V-A, Alg. 1 step 1).
#include "stereo_safety_map/core/height_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace stereo_safety_map {
namespace {

VoxelGridConfig smallGrid() {
  VoxelGridConfig c;
  c.size_x = 2.0;
  c.size_y = 2.0;
  c.size_z = 3.0;
  c.z_below_robot = 1.0;
  return c;
}

void occupy(VoxelGrid* g, int u, int v, int w) {
  g->setLogOdds({u, v, w}, 200);
}

TEST(HeightMapConfig, Validate) {
  HeightMapConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_DOUBLE_EQ(c.robot_height, 1.5);
  c.robot_height = 0.0;
  EXPECT_NE(c.validate().find("robot_height"), std::string::npos);
  c.robot_height = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(c.validate(), "");
  EXPECT_THROW(HeightMap{c}, std::invalid_argument);
}

TEST(HeightMap, EmptyGridHasNoHeightsAndCoversTheWindow) {
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f(0.3f, -0.2f, 0.0f));
  HeightMap hm;
  ASSERT_TRUE(hm.build(g, 0.0f));
  EXPECT_EQ(hm.width(), g.sizeU());
  EXPECT_EQ(hm.height(), g.sizeV());
  EXPECT_EQ(hm.minU(), g.minIndex().u);
  EXPECT_EQ(hm.minV(), g.minIndex().v);
  for (auto w : hm.data())
    EXPECT_EQ(w, HeightMap::kNoHeight);
}

TEST(HeightMap, HighestOccupiedVoxelBelowTheRobotsTop) {
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  occupy(&g, 1, 1, 0);
  occupy(&g, 1, 1, 3);   // higher, counts
  occupy(&g, 2, 1, -4);  // below the base (a hole)
  occupy(&g, 3, 1, 0);
  occupy(&g, 3, 1, 15);  // centre 1.5 m: not below the 1.5 m top, the robot passes under it
  occupy(&g, 4, 1, 0);
  occupy(&g, 4, 1, 14);          // centre 1.4 m: below the top, an obstacle
  g.setLogOdds({5, 1, 2}, 99);   // below occ_t = 100: free
  g.setLogOdds({6, 1, 2}, 100);  // exactly occ_t: occupied
  HeightMap hm;
  ASSERT_TRUE(hm.build(g, 0.0f));
  EXPECT_EQ(hm.at(1, 1), 3);
  EXPECT_EQ(hm.at(2, 1), -4);
  EXPECT_EQ(hm.at(3, 1), 0);
  EXPECT_EQ(hm.at(4, 1), 14);
  EXPECT_EQ(hm.at(5, 1), HeightMap::kNoHeight);
  EXPECT_EQ(hm.at(6, 1), 2);
  EXPECT_EQ(hm.at(0, 0), HeightMap::kNoHeight);
  EXPECT_EQ(hm.topIndex(), 14);
}

TEST(HeightMap, TopFollowsTheRobotsBaseAndHeight) {
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f(0.0f, 0.0f, 0.5f));  // window w in [-5, 25)
  occupy(&g, 0, 0, 19);                           // centre 1.9 m
  HeightMap hm;
  ASSERT_TRUE(hm.build(g, 0.5f));  // top at 2.0 m
  EXPECT_EQ(hm.at(0, 0), 19);
  ASSERT_TRUE(hm.build(g, 0.4f));  // top at 1.9 m: the voxel's centre is not below it
  EXPECT_EQ(hm.at(0, 0), HeightMap::kNoHeight);

  HeightMapConfig low;
  low.robot_height = 0.5;
  HeightMap hm_low(low);
  ASSERT_TRUE(hm_low.build(g, 1.5f));  // top at 2.0 m again
  EXPECT_EQ(hm_low.at(0, 0), 19);
}

TEST(HeightMap, WindowEntirelyAboveTheTop) {
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  occupy(&g, 0, 0, -10);
  HeightMap hm;
  ASSERT_TRUE(hm.build(g, -5.0f));  // top at -3.5 m, below the window's bottom (-1.05 m)
  EXPECT_EQ(hm.at(0, 0), HeightMap::kNoHeight);
}

TEST(HeightMap, NonFiniteBaseGivesNoHeights) {
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  occupy(&g, 0, 0, 0);
  HeightMap hm;
  EXPECT_FALSE(hm.build(g, std::numeric_limits<float>::quiet_NaN()));
  EXPECT_EQ(hm.width(), g.sizeU());
  EXPECT_EQ(hm.at(0, 0), HeightMap::kNoHeight);
  EXPECT_FALSE(hm.build(g, std::numeric_limits<float>::infinity()));
  EXPECT_EQ(hm.at(0, 0), HeightMap::kNoHeight);
  EXPECT_TRUE(hm.build(g, 0.0f));
  EXPECT_EQ(hm.at(0, 0), 0);
}

TEST(HeightMap, LowestOccupiedVoxelAndMeasuredSurfaceHeight) {
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  // Points at z = 0.03 in column (1, 1), seen from a camera 2 m above; a second occupied voxel
  // at w = 4 above them (the face of an obstacle).
  const Eigen::Isometry3f T(Eigen::Translation3f(0.1f, 0.1f, 2.0f));
  std::vector<Eigen::Vector3f> one(1);
  for (int i = 0; i < 12; ++i) {
    one[0] = Eigen::Vector3f(0.08f + 0.003f * i, 0.1f, 0.03f) - T.translation();
    g.integrate(one, T);
  }
  ASSERT_TRUE(g.isOccupied({1, 1, 0}));
  HeightMap hm;
  ASSERT_TRUE(hm.build(g, 0.0f));
  const int c = hm.index(1, 1);
  EXPECT_EQ(hm.atIndex(c), 0);
  EXPECT_EQ(hm.lowestAtIndex(c), 0);
  EXPECT_NEAR(hm.surfaceHeightAtIndex(c), 0.03f, 1e-5f);
  occupy(&g, 1, 1, 4);
  occupy(&g, 1, 1, -2);
  ASSERT_TRUE(hm.build(g, 0.0f));
  EXPECT_EQ(hm.atIndex(c), 4);
  EXPECT_EQ(hm.lowestAtIndex(c), -2);
  EXPECT_TRUE(std::isnan(hm.surfaceHeightAtIndex(c)));  // the top voxel holds no points
  EXPECT_TRUE(std::isnan(hm.surfaceHeightAtIndex(hm.index(5, 5))));
  hm.set(5, 5, 2, 1);
  EXPECT_EQ(hm.lowestAt(5, 5), 1);
  hm.setSurfaceHeight(5, 5, 0.2f);
  EXPECT_FLOAT_EQ(hm.surfaceHeightAtIndex(hm.index(5, 5)), 0.2f);
  hm.set(5, 5, HeightMap::kNoHeight);
  EXPECT_TRUE(std::isnan(hm.surfaceHeightAtIndex(hm.index(5, 5))));
}

TEST(HeightMap, GroundHeightTakesTheTopTwoVoxelsPoints) {
  // A floor at z = -0.06 whose noise reaches into the voxel above (w = 0, [-0.05, 0.05)): the top
  // voxel's points are only the upper tail, the ground height averages both voxels' points.
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  const Eigen::Isometry3f T(Eigen::Translation3f(0.1f, 0.1f, 2.0f));
  std::vector<Eigen::Vector3f> one(1);
  const float zs[6] = {-0.04f, -0.045f, -0.07f, -0.08f, -0.065f, -0.06f};
  for (int rep = 0; rep < 2; ++rep) {  // 4 + 8 points: within the 8-point lists
    for (int i = 0; i < 6; ++i) {
      one[0] = Eigen::Vector3f(0.06f + 0.01f * i, 0.08f + 0.01f * rep, zs[i]) - T.translation();
      g.integrate(one, T);
    }
  }
  occupy(&g, 1, 1, 0);  // as after more frames
  occupy(&g, 1, 1, -1);
  HeightMap hm;
  ASSERT_TRUE(hm.build(g, 0.0f));
  const int c = hm.index(1, 1);
  ASSERT_EQ(hm.atIndex(c), 0);
  EXPECT_NEAR(hm.surfaceHeightAtIndex(c), -0.0425f, 1e-4f);  // the tail alone
  EXPECT_NEAR(hm.groundHeightAtIndex(c), -0.06f, 1e-4f);     // all six heights
  // No height: no ground height; set by hand for tests.
  EXPECT_TRUE(std::isnan(hm.groundHeightAtIndex(hm.index(5, 5))));
  hm.set(5, 5, 0);
  hm.setGroundHeight(5, 5, 0.01f);
  EXPECT_FLOAT_EQ(hm.groundHeightAtIndex(hm.index(5, 5)), 0.01f);
  hm.set(5, 5, HeightMap::kNoHeight);
  EXPECT_TRUE(std::isnan(hm.groundHeightAtIndex(hm.index(5, 5))));
}

TEST(HeightMap, ObservationMeansWeighEveryPointOnce) {
  // A level floor at z = 0 in voxel w = 0 seen 40 times; the nearer a point along its ray, the
  // higher (stereo noise in front of the surface), and 8 points of its lower noise tail fell into
  // the voxel below. The 8-point lists keep the nearest (highest) points of the top voxel and
  // weigh the 8 tail points as much as them; the moments weigh every point once.
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  std::vector<Eigen::Vector3f> one(1);
  double sum = 0.0;
  int n = 0;
  for (int f = 0; f < 40; ++f) {
    const float z = 0.02f - 0.001f * f;  // -0.019 .. 0.02, mean 0.0005
    const Eigen::Isometry3f T(Eigen::Translation3f(0.1f, 0.1f, 1.0f + 0.05f * f));
    one[0] = Eigen::Vector3f(0.1f, 0.1f, z) - T.translation();
    g.integrate(one, T);
    sum += z;
    ++n;
  }
  for (int f = 0; f < 8; ++f) {
    const Eigen::Isometry3f T(Eigen::Translation3f(0.1f, 0.1f, 2.0f));
    one[0] = Eigen::Vector3f(0.1f, 0.1f, -0.07f) - T.translation();
    g.integrate(one, T);
    sum += -0.07f;
    ++n;
  }
  occupy(&g, 1, 1, 0);
  g.setLogOdds({1, 1, 1}, 0);  // the fore neighbours' increments (incr_L) of 40 frames
  HeightMapConfig lists, means;
  means.observation_means = true;
  HeightMap hm_lists(lists), hm(means);
  ASSERT_FALSE(lists.observation_means);  // the default: 000's lists
  ASSERT_TRUE(hm_lists.build(g, 0.0f));
  ASSERT_TRUE(hm.build(g, 0.0f));
  const int c = hm.index(1, 1);
  ASSERT_EQ(hm.atIndex(c), 0);
  // Lists: the 8 highest floor points (mean 0.0165) and the 8 tail points, half and half.
  EXPECT_NEAR(hm_lists.surfaceHeightAtIndex(c), 0.0165f, 1e-4f);
  EXPECT_NEAR(hm_lists.groundHeightAtIndex(c), 0.5f * (0.0165f - 0.07f), 1e-4f);
  // Moments: the floor's 40 points and the 8 tail points, each once.
  EXPECT_NEAR(hm.surfaceHeightAtIndex(c), 0.0005f, 1e-4f);
  EXPECT_NEAR(hm.groundHeightAtIndex(c), sum / n, 1e-4f);
  EXPECT_LT(std::abs(hm.groundHeightAtIndex(c)), 0.015f);
}

TEST(HeightMap, NearViewPassesOverTheFarViewsNoiseTail) {
  // A floor at z = 0.02 (voxel w = 0 spans [-0.05, 0.05)): seen from 3.5 m, the upper tail of
  // its points fell into w = 1; seen from 1.4 m, its points stay in w = 0. Both voxels are
  // occupied. A table top at w = 7 stands over another column's floor seen from near.
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  std::vector<Eigen::Vector3f> one(1);
  auto observe = [&](int u, float z, float range) {
    const Eigen::Vector3f p(0.1f * u, 0.1f, z);
    const Eigen::Isometry3f T(Eigen::Translation3f(p + Eigen::Vector3f(0.0f, 0.0f, range)));
    one[0] = p - T.translation();
    g.integrate(one, T);
  };
  for (int f = 0; f < 6; ++f) {
    observe(1, 0.06f + 0.002f * f, 3.5f);  // the far views' tail
    observe(1, 0.01f + 0.002f * f, 3.5f);
    observe(1, 0.015f + 0.002f * f, 1.4f);  // the near views
    // A second column: the same floor, but its upper voxel was also seen from near (a surface
    // there, e.g. a low box's top).
    observe(2, 0.07f + 0.002f * f, 1.3f);
    observe(2, 0.015f + 0.002f * f, 1.4f);
    // A third: a table top seen from afar over a floor seen from near.
    observe(3, 0.72f, 3.5f);
    observe(3, 0.015f + 0.002f * f, 1.4f);
  }
  for (int u = 1; u <= 3; ++u) {
    for (int w = 0; w <= 7; ++w)
      g.setLogOdds({u, 1, w}, 0);
    occupy(&g, u, 1, 0);
  }
  occupy(&g, 1, 1, 1);
  occupy(&g, 2, 1, 1);
  occupy(&g, 3, 1, 7);

  HeightMapConfig paper, near;
  EXPECT_EQ(paper.near_view_ratio, 0.0);  // the default: 000's highest voxel
  near.near_view_ratio = 1.5;
  EXPECT_EQ(near.validate(), "");
  HeightMap hm_paper(paper), hm(near);
  ASSERT_TRUE(hm_paper.build(g, 0.0f));
  ASSERT_TRUE(hm.build(g, 0.0f));
  const int c1 = hm.index(1, 1), c2 = hm.index(2, 1), c3 = hm.index(3, 1);
  EXPECT_EQ(hm_paper.atIndex(c1), 1);  // 000: the tail is the column's top
  EXPECT_GT(hm_paper.surfaceHeightAtIndex(c1), 0.05f);
  EXPECT_EQ(hm.atIndex(c1), 0);  // the floor seen from near
  EXPECT_LT(hm.surfaceHeightAtIndex(c1), 0.05f);
  EXPECT_EQ(hm.lowestAtIndex(c1), 0);
  // Seen from near in the upper voxel too: kept.
  EXPECT_EQ(hm.atIndex(c2), 1);
  EXPECT_GT(hm.surfaceHeightAtIndex(c2), 0.05f);
  // Not directly on the voxel below: kept.
  EXPECT_EQ(hm.atIndex(c3), 7);
  // Below the ratio (3.5 / 1.4 = 2.5): kept.
  near.near_view_ratio = 3.0;
  HeightMap hm_strict(near);
  ASSERT_TRUE(hm_strict.build(g, 0.0f));
  EXPECT_EQ(hm_strict.atIndex(c1), 1);
  // Invalid values.
  near.near_view_ratio = 0.5;
  EXPECT_NE(near.validate().find("near_view_ratio"), std::string::npos);
  near.near_view_ratio = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(near.validate(), "");
}

// A floor's frame: `n_floor` points at z = `z_floor` in column (1, 1) and `n_tail` points of its
// noise tail at z = `z_tail`, all in one frame (dense disparity), from a camera 2 m above.
void denseFrame(VoxelGrid* g, int n_floor, float z_floor, int n_tail, float z_tail) {
  const Eigen::Isometry3f T(Eigen::Translation3f(0.1f, 0.1f, 2.0f));
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < n_floor; ++i)
    pts.push_back(Eigen::Vector3f(0.06f + 0.08f * i / n_floor, 0.1f, z_floor) - T.translation());
  for (int i = 0; i < n_tail; ++i)
    pts.push_back(Eigen::Vector3f(0.06f + 0.08f * i / n_tail, 0.12f, z_tail) - T.translation());
  g->integrate(pts, T);
}

TEST(HeightMap, TailSharePassesOverANoiseTailButKeepsASurface) {
  HeightMapConfig cfg;
  cfg.tail_share = 0.5;
  HeightMap hm(cfg), paper;
  {
    // A floor at z = 0.02 (w = 0) with 100 points a frame and 10 of its noise tail at z = 0.06
    // (w = 1): 000's one point per voxel per frame makes both voxels occupied alike.
    VoxelGrid g(smallGrid());
    g.recenter(Eigen::Vector3f::Zero());
    for (int f = 0; f < 12; ++f)
      denseFrame(&g, 100, 0.02f, 10, 0.06f);
    ASSERT_TRUE(g.isOccupied({1, 1, 0}));
    ASSERT_TRUE(g.isOccupied({1, 1, 1}));
    ASSERT_TRUE(paper.build(g, 0.0f));
    EXPECT_EQ(paper.at(1, 1), 1);  // 000: the highest occupied voxel, the tail
    ASSERT_TRUE(hm.build(g, 0.0f));
    EXPECT_EQ(hm.atIndex(hm.index(1, 1)), 0);  // the surface is where the points are
    EXPECT_EQ(hm.lowestAtIndex(hm.index(1, 1)), 0);
    EXPECT_NEAR(hm.surfaceHeightAtIndex(hm.index(1, 1)), 0.02f, 1e-4f);
  }
  {
    // A step's upper surface at z = 0.06 (w = 1) with 60 points a frame above 40 of its lower
    // noise tail (z = 0.04, w = 0): more than half as many points, kept.
    VoxelGrid g(smallGrid());
    g.recenter(Eigen::Vector3f::Zero());
    for (int f = 0; f < 12; ++f)
      denseFrame(&g, 40, 0.04f, 60, 0.06f);
    ASSERT_TRUE(hm.build(g, 0.0f));
    EXPECT_EQ(hm.at(1, 1), 1);
  }
  {
    // An obstacle's face: one point a voxel and frame up to w = 5, the top voxel kept.
    VoxelGrid g(smallGrid());
    g.recenter(Eigen::Vector3f::Zero());
    const Eigen::Isometry3f T(Eigen::Translation3f(-1.0f, 0.1f, 1.0f));
    for (int f = 0; f < 12; ++f) {
      std::vector<Eigen::Vector3f> pts;
      for (int w = 0; w <= 5; ++w)
        pts.push_back(Eigen::Vector3f(0.08f, 0.1f, 0.1f * w) - T.translation());
      g.integrate(pts, T);
    }
    ASSERT_TRUE(hm.build(g, 0.0f));
    EXPECT_EQ(hm.at(1, 1), 5);
  }
  cfg.tail_share = 1.5;
  EXPECT_NE(cfg.validate().find("tail_share"), std::string::npos);
}

TEST(HeightMap, MassHeightsTakeEveryPointOfTheSurfacesVoxels) {
  // A floor at z = -0.056 whose noise spreads over w = -1 and w = 0 (the band boundary at
  // -0.05): 70 points a frame at -0.07 and 30 at -0.023 (mean -0.0559). The top voxel's
  // list holds the upper part alone; every point of the three voxels around the top gives the
  // floor's height. mass_bands puts the column in the band its surface lies in.
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  for (int f = 0; f < 12; ++f)
    denseFrame(&g, 70, -0.07f, 30, -0.023f);
  ASSERT_TRUE(g.isOccupied({1, 1, 0}));
  ASSERT_TRUE(g.isOccupied({1, 1, -1}));
  const float expected = (70 * -0.07f + 30 * -0.023f) / 100.0f;
  HeightMap lists;
  ASSERT_TRUE(lists.build(g, 0.0f));
  const int c = lists.index(1, 1);
  EXPECT_EQ(lists.atIndex(c), 0);
  EXPECT_NEAR(lists.surfaceHeightAtIndex(c), -0.023f, 1e-4f);  // the tail alone
  HeightMapConfig cfg;
  cfg.mass_heights = true;
  HeightMap mass(cfg);
  ASSERT_TRUE(mass.build(g, 0.0f));
  EXPECT_EQ(mass.atIndex(c), 0);  // still the highest occupied voxel
  EXPECT_NEAR(mass.surfaceHeightAtIndex(c), expected, 1e-4f);
  EXPECT_NEAR(mass.groundHeightAtIndex(c), expected, 1e-4f);
  cfg.mass_bands = true;
  HeightMap bands(cfg);
  ASSERT_TRUE(bands.build(g, 0.0f));
  EXPECT_EQ(bands.atIndex(c), -1);  // -0.0559 lies in w = -1
  EXPECT_EQ(bands.lowestAtIndex(c), -1);
  EXPECT_NEAR(bands.surfaceHeightAtIndex(c), expected, 1e-4f);
  // Never above the top occupied voxel nor below the lowest: without the lower voxel occupied
  // the band stays the top one.
  g.setLogOdds({1, 1, -1}, 0);
  ASSERT_TRUE(bands.build(g, 0.0f));
  EXPECT_EQ(bands.atIndex(c), 0);
}

// Points of one frame on columns (u, v) at height z, n per column, seen from 2 m above.
struct ColumnPoints {
  int u, v, n;
  float z;
};
void columnsFrame(VoxelGrid* g, const std::vector<ColumnPoints>& columns) {
  const Eigen::Isometry3f T(Eigen::Translation3f(0.3f, 0.3f, 2.0f));
  std::vector<Eigen::Vector3f> pts;
  for (const ColumnPoints& c : columns) {
    for (int i = 0; i < c.n; ++i) {
      const float x = 0.1f * c.u - 0.04f + 0.08f * i / c.n;
      pts.push_back(Eigen::Vector3f(x, 0.1f * c.v, c.z) - T.translation());
    }
  }
  g->integrate(pts, T);
}

TEST(HeightMap, SparseEdgeShareTakesAThinStripBeyondAnEdgeAsUnobserved) {
  // A floor at z = 0.02 on u, v = 1..5, 200 points a column and frame. Beyond its u = 5 edge
  // (u = 7 and on never seen): column (6, 2) with 5 points a frame at the floor's height, as
  // block matching's foreground fattening leaves on the first pixels beyond an edge; (6, 3) with
  // 60 (partly in view); (6, 4) with 5 points three voxels up (an obstacle's top); (3, 3), inside
  // the floor, with 5 points; (6, 1) with 5 points a voxel below (a drop).
  std::vector<ColumnPoints> cols;
  for (int v = 1; v <= 5; ++v)
    for (int u = 1; u <= 5; ++u)
      cols.push_back({u, v, u == 3 && v == 3 ? 5 : 200, 0.02f});
  cols.push_back({6, 2, 5, 0.02f});
  cols.push_back({6, 3, 60, 0.02f});
  cols.push_back({6, 4, 5, 0.32f});
  cols.push_back({6, 1, 5, -0.18f});
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  for (int f = 0; f < 12; ++f)
    columnsFrame(&g, cols);
  HeightMap paper;
  ASSERT_TRUE(paper.build(g, 0.0f));
  for (const ColumnPoints& c : cols)
    ASSERT_NE(paper.at(c.u, c.v), HeightMap::kNoHeight) << c.u << " " << c.v;
  EXPECT_EQ(paper.sparseEdgeColumns(), 0);

  HeightMapConfig cfg;
  cfg.sparse_edge_share = 0.1;
  HeightMap hm(cfg);
  ASSERT_TRUE(hm.build(g, 0.0f));
  EXPECT_EQ(hm.at(6, 2), HeightMap::kNoHeight);  // the strip: not observed
  EXPECT_TRUE(std::isnan(hm.surfaceHeightAtIndex(hm.index(6, 2))));
  EXPECT_EQ(hm.at(6, 3), 0);   // 0.3 of its neighbour's points: kept
  EXPECT_EQ(hm.at(6, 4), 3);   // an obstacle's top: kept
  EXPECT_EQ(hm.at(6, 1), -2);  // a drop: kept
  EXPECT_EQ(hm.at(3, 3), 0);   // inside the floor: kept
  EXPECT_EQ(hm.at(5, 2), 0);   // the floor's edge itself: kept
  EXPECT_EQ(hm.sparseEdgeColumns(), 1);
  // Mass heights and bands change nothing of it.
  cfg.mass_heights = true;
  cfg.mass_bands = true;
  HeightMap mass(cfg);
  ASSERT_TRUE(mass.build(g, 0.0f));
  EXPECT_EQ(mass.at(6, 2), HeightMap::kNoHeight);
  EXPECT_EQ(mass.at(6, 3), 0);
  EXPECT_EQ(mass.sparseEdgeColumns(), 1);
  cfg.sparse_edge_share = 1.5;
  EXPECT_NE(cfg.validate().find("sparse_edge_share"), std::string::npos);
}

TEST(HeightMap, SparseEdgeShareKeepsAStripeOfReadingsBetweenUnobservedColumns) {
  // A pale floor seen only along its tile joints: a stripe along u (v = -5, u = -6..6) with 20
  // points a column and frame, crossed at u = 0 by a denser stripe along v (200 points). Every
  // cell of the thin stripe borders unobserved tiles on both sides, and the two beside the
  // crossing have a neighbour with ten times their points; neither lies between a denser column
  // and an unobserved one along a line, so the whole stripe stays measured ground. The thin
  // stripe's two ends, beside the unobserved, have an equal neighbour inwards: kept too.
  std::vector<ColumnPoints> cols;
  for (int u = -6; u <= 6; ++u)
    if (u != 0) cols.push_back({u, -5, 20, 0.02f});
  for (int v = -9; v <= -1; ++v)
    cols.push_back({0, v, 200, 0.02f});
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  for (int f = 0; f < 12; ++f)
    columnsFrame(&g, cols);
  HeightMapConfig cfg;
  cfg.sparse_edge_share = 0.2;
  HeightMap hm(cfg);
  ASSERT_TRUE(hm.build(g, 0.0f));
  for (const ColumnPoints& c : cols)
    EXPECT_EQ(hm.at(c.u, c.v), 0) << c.u << " " << c.v;
  EXPECT_EQ(hm.sparseEdgeColumns(), 0);
  // A thin column beside the crossing's end, in line with it (v = 0, the unobserved beyond at
  // v = 1): cleared.
  cols.push_back({0, 0, 5, 0.02f});
  VoxelGrid g2(smallGrid());
  g2.recenter(Eigen::Vector3f::Zero());
  for (int f = 0; f < 12; ++f)
    columnsFrame(&g2, cols);
  ASSERT_TRUE(hm.build(g2, 0.0f));
  EXPECT_EQ(hm.at(0, 0), HeightMap::kNoHeight);
  EXPECT_EQ(hm.at(-1, -5), 0);
  EXPECT_EQ(hm.at(1, -5), 0);
  EXPECT_EQ(hm.sparseEdgeColumns(), 1);
}

TEST(HeightMap, ManualResetAndSet) {
  HeightMap hm;
  hm.reset(-2, 3, 4, 5);
  EXPECT_EQ(hm.numCells(), 20);
  hm.set(-2, 3, 7);
  hm.set(1, 7, -1);
  hm.set(2, 7, 5);   // outside: ignored
  hm.set(-3, 3, 5);  // outside: ignored
  EXPECT_EQ(hm.at(-2, 3), 7);
  EXPECT_EQ(hm.atIndex(hm.index(1, 7)), -1);
  EXPECT_EQ(hm.at(2, 7), HeightMap::kNoHeight);
  EXPECT_EQ(hm.at(100, 100), HeightMap::kNoHeight);
  hm.reset(0, 0, -3, 4);  // negative size: empty
  EXPECT_EQ(hm.numCells(), 0);
  EXPECT_EQ(hm.at(0, 0), HeightMap::kNoHeight);
}

TEST(HeightMap, ScrollingWindowForgetsColumnsThatLeft) {
  VoxelGrid g(smallGrid());
  g.recenter(Eigen::Vector3f::Zero());
  occupy(&g, -9, 0, 0);  // near the window's -u edge
  HeightMap hm;
  ASSERT_TRUE(hm.build(g, 0.0f));
  EXPECT_EQ(hm.at(-9, 0), 0);
  g.recenter(Eigen::Vector3f(0.5f, 0.0f, 0.0f));
  ASSERT_TRUE(hm.build(g, 0.0f));
  EXPECT_EQ(hm.minU(), g.minIndex().u);
  EXPECT_FALSE(hm.inside(-9, 0));
  EXPECT_EQ(hm.at(-9, 0), HeightMap::kNoHeight);
}

}  // namespace
}  // namespace stereo_safety_map
