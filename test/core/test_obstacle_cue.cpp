// Tests of the single-frame obstacle cue fused into the safety map (obstacle_cue.h): it marks
// cells Non-ground in the next map, never makes a cell safe, expires, and leaves the voxel grid's
// evidence untouched.
#include "stereo_safety_map/core/obstacle_cue.h"
#include "stereo_safety_map/core/safety_mapper.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace stereo_safety_map {
namespace {

using L = SafetyLabel;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// A 10 x 10 map over cells u, v in [0, 10) (0.1 m), every label and a drop-off edge in it.
SafetyMap makeMap() {
  SafetyMap m;
  m.min_u = 0;
  m.min_v = 0;
  m.width = 10;
  m.height = 10;
  m.resolution = 0.1;
  const std::size_t n = 100;
  m.labels.assign(n, L::kLevel);
  m.segment.assign(n, 0);
  m.drop_off.assign(n, 0);
  m.column_height.assign(n, 0);
  for (int u = 0; u < 10; ++u) {
    m.labels[m.index(u, 1)] = L::kInclined;
    m.labels[m.index(u, 2)] = L::kUnknown;
    m.labels[m.index(u, 3)] = L::kUnexamined;
    m.labels[m.index(u, 4)] = L::kNonGround;
  }
  m.drop_off[m.index(5, 0)] = 1;
  return m;
}

// `n` points around the centre of cell (u, v) at height z.
void addPoints(std::vector<Eigen::Vector3f>* pts, int u, int v, int n, float z = 0.3f) {
  for (int k = 0; k < n; ++k) {
    pts->emplace_back(0.1f * u + 0.01f * (k % 3) - 0.01f, 0.1f * v + 0.01f * (k / 3 % 3) - 0.01f,
                      z + 0.01f * k);
  }
}

TEST(ObstacleCueConfig, DefaultsAreValidAndBadValuesAreNamed) {
  EXPECT_EQ(ObstacleCueConfig().validate(), "");
  ObstacleCueConfig c;
  c.lifetime = -1.0;
  EXPECT_NE(c.validate().find("lifetime"), std::string::npos);
  c = ObstacleCueConfig();
  c.lifetime = NAN;
  EXPECT_NE(c.validate().find("lifetime"), std::string::npos);
  c = ObstacleCueConfig();
  c.min_points_per_cell = 0;
  EXPECT_NE(c.validate().find("min_points_per_cell"), std::string::npos);
  EXPECT_THROW(ObstacleCueFusion{c}, std::invalid_argument);
  c = ObstacleCueConfig();
  c.max_cues = 0;
  EXPECT_NE(c.validate().find("max_cues"), std::string::npos);
}

TEST(ObstacleCue, MarksCellsWithEnoughPointsNonGroundAndNothingElse) {
  ObstacleCueFusion fusion;  // min_points_per_cell 3, lifetime 1 s
  std::vector<Eigen::Vector3f> pts;
  addPoints(&pts, 2, 0, 5);        // Level
  addPoints(&pts, 5, 0, 3);        // Level, on a drop-off edge
  addPoints(&pts, 3, 1, 4);        // Inclined
  addPoints(&pts, 4, 2, 3);        // Unknown
  addPoints(&pts, 6, 3, 3);        // Unexamined
  addPoints(&pts, 7, 4, 9);        // already Non-ground
  addPoints(&pts, 8, 0, 2);        // too few points
  addPoints(&pts, 9, 0, 5, 2.0f);  // overhang, above max_z
  addPoints(&pts, 50, 50, 5);      // outside the map
  pts.emplace_back(kNaN, 0.0f, 0.3f);
  pts.emplace_back(0.2f, kNaN, 0.3f);
  ASSERT_TRUE(fusion.addCue(10.0, pts));
  EXPECT_FALSE(fusion.addCue(NAN, pts));
  EXPECT_EQ(fusion.size(), 1);

  const SafetyMap before = makeMap();
  SafetyMap map = before;
  std::vector<std::uint8_t> marked;
  const ObstacleCueStats s = fusion.apply(10.0, 1.5f, &map, &marked);
  ASSERT_EQ(marked.size(), 100u);
  EXPECT_EQ(std::count(marked.begin(), marked.end(), 1), 6);
  EXPECT_EQ(marked[map.index(7, 4)], 1);  // already Non-ground, still marked
  EXPECT_EQ(marked[map.index(8, 0)], 0);
  EXPECT_EQ(s.live_cues, 1);
  EXPECT_EQ(s.cells_marked, 6u);
  EXPECT_EQ(s.cells_changed, 5u);
  EXPECT_EQ(s.safe_cells_changed, 3u);
  EXPECT_EQ(s.points_used, 5u + 3u + 4u + 3u + 3u + 9u + 2u);
  int changed = 0;
  for (int v = 0; v < 10; ++v) {
    for (int u = 0; u < 10; ++u) {
      const int i = map.index(u, v);
      if (map.labels[i] != before.labels[i]) {
        ++changed;
        EXPECT_EQ(map.labels[i], L::kNonGround) << u << "," << v;  // never anything else
      }
    }
  }
  EXPECT_EQ(changed, 5);
  EXPECT_EQ(map.labelAt(2, 0), L::kNonGround);
  EXPECT_EQ(map.labelAt(5, 0), L::kNonGround);
  EXPECT_EQ(map.drop_off[map.index(5, 0)], 0);  // no drop-off annotation on Non-ground
  EXPECT_EQ(map.labelAt(3, 1), L::kNonGround);
  EXPECT_EQ(map.labelAt(4, 2), L::kNonGround);
  EXPECT_EQ(map.labelAt(6, 3), L::kNonGround);
  EXPECT_EQ(map.labelAt(8, 0), L::kLevel);
  EXPECT_EQ(map.labelAt(9, 0), L::kLevel);

  // A lower max_z (a shorter robot) leaves the 0.3 m points out.
  SafetyMap low = before;
  EXPECT_EQ(fusion.apply(10.0, 0.2f, &low).cells_marked, 0u);
  EXPECT_EQ(low.labels, before.labels);
}

TEST(ObstacleCue, PointsOfSeveralLiveCuesAddUp) {
  ObstacleCueFusion fusion;
  std::vector<Eigen::Vector3f> a, b;
  addPoints(&a, 2, 0, 2);
  addPoints(&b, 2, 0, 1);
  fusion.addCue(10.0, a);
  SafetyMap map = makeMap();
  EXPECT_EQ(fusion.apply(10.0, 1.5f, &map).cells_marked, 0u);
  fusion.addCue(10.1, b);
  EXPECT_EQ(fusion.apply(10.1, 1.5f, &map).cells_marked, 1u);
  EXPECT_EQ(map.labelAt(2, 0), L::kNonGround);
}

TEST(ObstacleCue, CuesExpireAndTimeGoingBackForgetsThem) {
  ObstacleCueFusion fusion;  // lifetime 1 s
  std::vector<Eigen::Vector3f> pts;
  addPoints(&pts, 2, 0, 5);
  fusion.addCue(10.0, pts);
  SafetyMap map = makeMap();
  EXPECT_EQ(fusion.apply(10.9, 1.5f, &map).cells_changed, 1u);
  map = makeMap();
  const ObstacleCueStats late = fusion.apply(11.1, 1.5f, &map);
  EXPECT_EQ(late.live_cues, 0);
  EXPECT_EQ(late.cells_marked, 0u);
  EXPECT_EQ(map.labels, makeMap().labels);
  EXPECT_EQ(fusion.size(), 0);

  fusion.addCue(100.0, pts);
  map = makeMap();
  EXPECT_EQ(fusion.apply(5.0, 1.5f, &map).cells_marked, 0u);  // a bag restarted
  EXPECT_EQ(fusion.size(), 0);

  // lifetime 0: only maps with the cue's own stamp.
  ObstacleCueConfig c;
  c.lifetime = 0.0;
  ObstacleCueFusion exact(c);
  exact.addCue(10.0, pts);
  map = makeMap();
  EXPECT_EQ(exact.apply(10.0, 1.5f, &map).cells_marked, 1u);
  EXPECT_EQ(exact.apply(10.05, 1.5f, &map).live_cues, 0);
}

TEST(ObstacleCue, OldestCueIsDroppedBeyondMaxCues) {
  ObstacleCueConfig c;
  c.max_cues = 2;
  c.min_points_per_cell = 1;
  ObstacleCueFusion fusion(c);
  for (int k = 0; k < 3; ++k) {
    std::vector<Eigen::Vector3f> pts;
    addPoints(&pts, k, 0, 1);
    fusion.addCue(10.0 + 0.1 * k, pts);
  }
  EXPECT_EQ(fusion.size(), 2);
  SafetyMap map = makeMap();
  fusion.apply(10.2, 1.5f, &map);
  EXPECT_EQ(map.labelAt(0, 0), L::kLevel);  // the first cue was dropped
  EXPECT_EQ(map.labelAt(1, 0), L::kNonGround);
  EXPECT_EQ(map.labelAt(2, 0), L::kNonGround);
  fusion.clear();
  EXPECT_EQ(fusion.size(), 0);
  EXPECT_EQ(fusion.apply(10.2, 1.5f, nullptr).live_cues, 0);  // no crash
}

// The cue with the real pipeline: a level floor seen for a few frames gives Level cells; a cue
// with the points of a pole the grid has not confirmed makes the pole's cell Non-ground in the
// next map at once, does not change the grid, and once it has expired the map is 000's again.
TEST(ObstacleCue, FusedIntoTheSafetyMapperWithoutTouchingTheGrid) {
  SafetyMapperConfig mc;
  mc.skip_stationary_frames = false;
  SafetyMapper mapper(mc);
  // Camera 1.1 m above the base at the origin, looking along +x, pitched down 30 deg.
  const double p = 30.0 * M_PI / 180.0;
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  const Eigen::Vector3f fwd(std::cos(p), 0.0f, -std::sin(p)), right(0.0f, -1.0f, 0.0f);
  T.linear().col(0) = right;
  T.linear().col(1) = fwd.cross(right);
  T.linear().col(2) = fwd;
  T.translation() = Eigen::Vector3f(0.0f, 0.0f, 1.1f);
  std::vector<Eigen::Vector3f> floor_sensor;
  for (float x = 0.6f; x < 3.5f; x += 0.025f) {
    for (float y = -1.2f; y < 1.2f; y += 0.025f)
      floor_sensor.push_back(T.inverse() * Eigen::Vector3f(x, y, 0.0f));
  }
  const Eigen::Vector3f robot(0.0f, 0.0f, 0.0f);
  for (int k = 0; k < 12; ++k)
    ASSERT_TRUE(mapper.integrateFrame(floor_sensor, T, robot));
  // The cue's frame: integrated as usual, then the cue is applied to its map.
  ASSERT_TRUE(mapper.integrateFrame(floor_sensor, T, robot));
  const SafetyMap plain = mapper.safetyMap();
  const int u = 20, v = 3;  // the pole's cell, (2.0, 0.3)
  ASSERT_TRUE(plain.inside(u, v));
  ASSERT_EQ(plain.labelAt(u, v), L::kLevel);

  // Snapshot of the grid's evidence.
  const VoxelGrid& g = mapper.grid();
  std::vector<int> lop;
  const VoxelIndex gmin = g.minIndex();
  for (int w = gmin.w; w < gmin.w + g.sizeW(); ++w)
    for (int vv = gmin.v; vv < gmin.v + g.sizeV(); ++vv)
      for (int uu = gmin.u; uu < gmin.u + g.sizeU(); ++uu)
        lop.push_back(g.logOdds({uu, vv, w}));

  ObstacleCueFusion fusion;
  std::vector<Eigen::Vector3f> pole;
  for (int k = 0; k < 40; ++k)
    pole.emplace_back(2.0f + 0.002f * (k % 5), 0.3f, 0.06f + 0.02f * k);
  fusion.addCue(1.0, pole);
  const ObstacleCueStats s = fusion.apply(
      1.0, robot.z() + static_cast<float>(mc.height_map.robot_height), &mapper.mutableSafetyMap());
  EXPECT_EQ(s.cells_changed, 1u);
  EXPECT_EQ(s.safe_cells_changed, 1u);
  const SafetyMap& fused = mapper.safetyMap();
  EXPECT_EQ(fused.labelAt(u, v), L::kNonGround);
  for (std::size_t i = 0; i < fused.labels.size(); ++i) {
    if (static_cast<int>(i) == fused.index(u, v)) continue;
    EXPECT_EQ(fused.labels[i], plain.labels[i]) << i;
  }

  // The grid is exactly what the frames made of it: the next map without a live cue is 000's.
  std::size_t k = 0;
  for (int w = gmin.w; w < gmin.w + g.sizeW(); ++w)
    for (int vv = gmin.v; vv < gmin.v + g.sizeV(); ++vv)
      for (int uu = gmin.u; uu < gmin.u + g.sizeU(); ++uu)
        ASSERT_EQ(g.logOdds({uu, vv, w}), lop[k++]);
  mapper.computeSafetyMap(robot);
  EXPECT_EQ(fusion.apply(2.5, 1.5f, &mapper.mutableSafetyMap()).cells_marked, 0u);  // expired
  EXPECT_EQ(mapper.safetyMap().labels, plain.labels);
}

}  // namespace
}  // namespace stereo_safety_map
