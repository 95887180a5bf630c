// Tests of the laser + stereo hybrid safety map (001 Sec. 2 and 5): the combination table, the
// overhang that only vision sees, narrow passages, drop-off edges, scores and bad input.
#include "stereo_safety_map/core/hybrid_safety_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <stdexcept>

namespace stereo_safety_map {
namespace {

SafetyMap visionMap(int min_u, int min_v, int width, int height,
                    SafetyLabel fill = SafetyLabel::kLevel) {
  SafetyMap m;
  m.min_u = min_u;
  m.min_v = min_v;
  m.width = width;
  m.height = height;
  m.resolution = 0.1;
  m.labels.assign(static_cast<std::size_t>(width) * height, fill);
  m.drop_off.assign(m.labels.size(), 0);
  return m;
}

void setVision(SafetyMap* m, int u, int v, SafetyLabel l) {
  m->labels[m->index(u, v)] = l;
}

constexpr float kOccupied = 2.0f;
constexpr float kFree = -1.0f;

TEST(HybridSafetyMap, MergedMapFollowsTheCombinationTable) {
  HybridSafetyMapConfig cfg;
  cfg.detect_narrow_passages = false;  // the table alone
  const SafetyLabel vision[5] = {SafetyLabel::kNonGround, SafetyLabel::kInclined,
                                 SafetyLabel::kLevel, SafetyLabel::kUnknown,
                                 SafetyLabel::kUnexamined};
  const float laser[3] = {kOccupied, kFree, 0.0f};  // occupied, free, unknown
  using H = HybridLabel;
  const H expected[3][5] = {{H::kObstacle, H::kObstacle, H::kObstacle, H::kObstacle, H::kObstacle},
                            {H::kHazard, H::kCaution, H::kSafe, H::kUnknown, H::kUnknown},
                            {H::kHazard, H::kCaution, H::kSafe, H::kUnknown, H::kUnknown}};
  // Variants: laser_free_required_for_safe turns (b) Unknown; the other flag turns (a) Safe.
  const H expected_strict[3][5] = {
      {H::kObstacle, H::kObstacle, H::kObstacle, H::kObstacle, H::kObstacle},
      {H::kHazard, H::kCaution, H::kSafe, H::kSafe, H::kSafe},
      {H::kHazard, H::kUnknown, H::kUnknown, H::kUnknown, H::kUnknown}};

  SafetyMap v = visionMap(0, 0, 5, 3);
  LaserGrid grid;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 5; ++col) {
      setVision(&v, col, row, vision[col]);
      grid.setLogOdds(col, row, laser[row]);
    }
  }
  HybridSafetyMap out;
  HybridSafetyMapBuilder(cfg).build(HybridSource::kMerged, v, grid, &out);
  ASSERT_EQ(out.width, 5);
  ASSERT_EQ(out.height, 3);
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 5; ++col) {
      EXPECT_EQ(out.labelAt(col, row), expected[row][col]) << "row " << row << " col " << col;
    }
  }
  cfg.laser_free_required_for_safe = true;
  cfg.laser_free_vision_unknown_is_safe = true;
  HybridSafetyMapBuilder(cfg).build(HybridSource::kMerged, v, grid, &out);
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 5; ++col) {
      EXPECT_EQ(out.labelAt(col, row), expected_strict[row][col])
          << "row " << row << " col " << col;
    }
  }
  // The single-sensor maps.
  HybridSafetyMapBuilder(HybridSafetyMapConfig{false})
      .build(HybridSource::kLaserOnly, v, grid, &out);
  for (int col = 0; col < 5; ++col) {
    EXPECT_EQ(out.labelAt(col, 0), H::kObstacle);
    EXPECT_EQ(out.labelAt(col, 1), H::kSafe);
    EXPECT_EQ(out.labelAt(col, 2), H::kUnknown);
  }
  HybridSafetyMapBuilder(HybridSafetyMapConfig{false})
      .build(HybridSource::kStereoOnly, v, grid, &out);
  const H stereo[5] = {H::kObstacle, H::kCaution, H::kSafe, H::kUnknown, H::kUnknown};
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 5; ++col)
      EXPECT_EQ(out.labelAt(col, row), stereo[col]);
  }
}

// 001 Fig. 6: a table whose legs the laser sees and whose top it does not.
TEST(HybridSafetyMap, LaserOnlyMissesAnOverhangThatTheMergedMapCatches) {
  // A 6 x 6 m room, cells u, v in [0, 60); walls on the border cells.
  constexpr int n = 60;
  // Table top over u in [25, 35), v in [25, 33); legs are the four corner cells.
  const auto in_table = [](int u, int v) { return u >= 25 && u < 35 && v >= 25 && v < 33; };
  const auto is_leg = [](int u, int v) { return (u == 25 || u == 34) && (v == 25 || v == 32); };
  const auto is_wall = [](int u, int v) { return u == 0 || v == 0 || u == n - 1 || v == n - 1; };

  // Laser 0.3 m high at (1.5, 1.5) m: beams hit walls and legs, pass under the table top.
  LaserGridConfig lc;
  lc.width = n;
  lc.height = n;
  LaserGrid laser(lc);
  laser.moveTo(0, 0);
  const double lx = 1.5, ly = 1.5;
  const int beams = 2880;
  std::vector<float> ranges(beams);
  LaserScanInfo info;
  info.angle_min = -M_PI;
  info.angle_increment = 2.0 * M_PI / beams;
  info.range_min = 0.05;
  info.range_max = 30.0;
  for (int i = 0; i < beams; ++i) {
    const double a = info.angle_min + i * info.angle_increment;
    double r = 0.0;
    for (; r < 20.0; r += 0.002) {
      const int u = static_cast<int>(std::floor((lx + r * std::cos(a)) / 0.1 + 0.5));
      const int v = static_cast<int>(std::floor((ly + r * std::sin(a)) / 0.1 + 0.5));
      if (is_wall(u, v) || is_leg(u, v)) break;
    }
    ranges[i] = static_cast<float>(r);
  }
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.translation() = Eigen::Vector3f(lx, ly, 0.3f);
  laser.integrate(info, ranges, T);
  ASSERT_EQ(laser.state(25, 25), LaserCellState::kOccupied);  // a leg
  ASSERT_EQ(laser.state(29, 25), LaserCellState::kFree);      // under the top, front edge

  // Stereo sees walls, legs and the top as Non-ground (000 labels overhangs below robot height
  // Non-ground), the floor as Level.
  SafetyMap vision = visionMap(0, 0, n, n);
  for (int v = 0; v < n; ++v) {
    for (int u = 0; u < n; ++u) {
      if (is_wall(u, v) || in_table(u, v)) setVision(&vision, u, v, SafetyLabel::kNonGround);
    }
  }

  // Ground truth: walls and legs Obstacle, the top a Hazard, floor Safe.
  HybridSafetyMap truth;
  truth.width = truth.height = n;
  truth.labels.assign(n * n, HybridLabel::kSafe);
  for (int v = 0; v < n; ++v) {
    for (int u = 0; u < n; ++u) {
      if (is_wall(u, v) || is_leg(u, v)) {
        truth.labels[truth.index(u, v)] = HybridLabel::kObstacle;
      } else if (in_table(u, v)) {
        truth.labels[truth.index(u, v)] = HybridLabel::kHazard;
      }
    }
  }

  HybridSafetyMapBuilder builder;
  HybridSafetyMap merged, laser_only, stereo_only;
  builder.build(HybridSource::kMerged, vision, laser, &merged);
  builder.build(HybridSource::kLaserOnly, vision, laser, &laser_only);
  builder.build(HybridSource::kStereoOnly, vision, laser, &stereo_only);

  // The table top: traversable to the laser (Caution: the legs are 0.8 m apart), a hazard in the
  // merged map.
  EXPECT_EQ(laser_only.labelAt(29, 25), HybridLabel::kCaution);
  EXPECT_EQ(laser_only.labelAt(29, 28), HybridLabel::kSafe);
  EXPECT_EQ(merged.labelAt(29, 25), HybridLabel::kHazard);
  EXPECT_EQ(merged.labelAt(25, 25), HybridLabel::kObstacle);  // a leg: seen by both
  EXPECT_EQ(stereo_only.labelAt(29, 25), HybridLabel::kObstacle);
  int laser_safe_under_top = 0, merged_safe_under_top = 0;
  for (int v = 25; v < 33; ++v) {
    for (int u = 25; u < 35; ++u) {
      laser_safe_under_top += isTraversable(laser_only.labelAt(u, v));
      merged_safe_under_top += isTraversable(merged.labelAt(u, v));
    }
  }
  EXPECT_GT(laser_safe_under_top, 40);  // of 76 top cells; some lie in leg shadows
  EXPECT_EQ(merged_safe_under_top, 0);

  // 001 Table 2's statistics, safe class positive.
  const auto scores = [&truth](const HybridSafetyMap& m, ConfusionCounts* c) {
    EXPECT_EQ(countHybridConfusion(m, truth, c), "");
    return safeClassScores(*c);
  };
  ConfusionCounts c_laser, c_merged, c_stereo;
  const SafeClassScores s_laser = scores(laser_only, &c_laser);
  const SafeClassScores s_merged = scores(merged, &c_merged);
  const SafeClassScores s_stereo = scores(stereo_only, &c_stereo);
  // B (safe in the map, unsafe in the truth) is 000's FN.
  EXPECT_GE(c_laser.fn, static_cast<std::uint64_t>(laser_safe_under_top));
  EXPECT_EQ(c_merged.fn, 0u);
  EXPECT_DOUBLE_EQ(s_merged.precision, 1.0);
  EXPECT_LT(s_laser.precision, s_merged.precision);
  EXPECT_GT(s_merged.f1, s_laser.f1);
  EXPECT_DOUBLE_EQ(s_stereo.precision, 1.0);
}

TEST(HybridSafetyMap, PassagesNarrowerThanTheMinimumWidthAreCaution) {
  // Two rooms joined by a corridor along u, walls of Non-ground; corridor free width w cells.
  const auto corridor = [](int free_cells, HybridSafetyMap* out) {
    SafetyMap v = visionMap(0, 0, 60, 40);
    const int v0 = 20 - free_cells / 2;  // corridor rows [v0, v0 + free_cells)
    for (int u = 20; u < 40; ++u) {
      for (int row = 0; row < 40; ++row) {
        if (row < v0 || row >= v0 + free_cells) setVision(&v, u, row, SafetyLabel::kNonGround);
      }
    }
    LaserGrid grid;  // no laser information
    HybridSafetyMapBuilder().build(HybridSource::kMerged, v, grid, out);
    return v0;
  };
  HybridSafetyMap out;
  // 0.9 m free < 0.915 m: every corridor cell is Caution.
  int v0 = corridor(9, &out);
  for (int u = 22; u < 38; ++u) {
    for (int row = v0; row < v0 + 9; ++row) {
      EXPECT_EQ(out.labelAt(u, row), HybridLabel::kCaution) << u << "," << row;
    }
  }
  // The rooms stay Safe, also along their walls and at the map border.
  EXPECT_EQ(out.labelAt(19, 0), HybridLabel::kSafe);
  EXPECT_EQ(out.labelAt(0, 0), HybridLabel::kSafe);
  EXPECT_EQ(out.labelAt(40, 39), HybridLabel::kSafe);
  EXPECT_EQ(out.labelAt(10, 20), HybridLabel::kSafe);
  // 1.0 m free >= 0.915 m: Safe, including the cells along the corridor walls.
  v0 = corridor(10, &out);
  for (int u = 22; u < 38; ++u) {
    for (int row = v0; row < v0 + 10; ++row) {
      EXPECT_EQ(out.labelAt(u, row), HybridLabel::kSafe) << u << "," << row;
    }
  }
  // A doorway in a wall: 0.8 m gap.
  SafetyMap v = visionMap(0, 0, 40, 40);
  for (int row = 0; row < 40; ++row) {
    if (row < 16 || row >= 24) setVision(&v, 20, row, SafetyLabel::kNonGround);
  }
  LaserGrid grid;
  HybridSafetyMapBuilder().build(HybridSource::kMerged, v, grid, &out);
  for (int row = 16; row < 24; ++row)
    EXPECT_EQ(out.labelAt(20, row), HybridLabel::kCaution);
  EXPECT_EQ(out.labelAt(19, 10), HybridLabel::kSafe);
  EXPECT_EQ(out.labelAt(15, 20), HybridLabel::kSafe);
  // Turned off, nothing is Caution.
  HybridSafetyMapConfig off;
  off.detect_narrow_passages = false;
  HybridSafetyMapBuilder(off).build(HybridSource::kMerged, v, grid, &out);
  EXPECT_EQ(out.labelAt(20, 18), HybridLabel::kSafe);
}

TEST(HybridSafetyMap, PotentialDropOffEdgesAreHazardByDefault) {
  SafetyMap v = visionMap(-5, -5, 10, 10);
  v.drop_off[v.index(0, 0)] = 1;
  LaserGrid grid;
  grid.setLogOdds(0, 0, kFree);
  HybridSafetyMap out;
  HybridSafetyMapBuilder().build(HybridSource::kMerged, v, grid, &out);
  EXPECT_EQ(out.labelAt(0, 0), HybridLabel::kHazard);
  EXPECT_EQ(out.labelAt(1, 0), HybridLabel::kSafe);
  HybridSafetyMapBuilder().build(HybridSource::kStereoOnly, v, grid, &out);
  EXPECT_EQ(out.labelAt(0, 0), HybridLabel::kHazard);
  HybridSafetyMapBuilder().build(HybridSource::kLaserOnly, v, grid, &out);
  EXPECT_EQ(out.labelAt(0, 0), HybridLabel::kSafe);  // the laser knows nothing of drop-offs
  // Lethal to a costmap's static layer.
  EXPECT_EQ(toOccupancyValue(HybridLabel::kHazard, HybridSafetyMapConfig()), 100);
}

TEST(HybridSafetyMap, PotentialDropOffEdgesAreCautionWithTheHazardSwitchOff) {
  SafetyMap v = visionMap(-5, -5, 10, 10);
  v.drop_off[v.index(0, 0)] = 1;
  LaserGrid grid;
  grid.setLogOdds(0, 0, kFree);
  HybridSafetyMap out;
  HybridSafetyMapConfig caution;
  caution.drop_off_edges_are_hazard = false;
  HybridSafetyMapBuilder b(caution);
  b.build(HybridSource::kMerged, v, grid, &out);
  EXPECT_EQ(out.labelAt(0, 0), HybridLabel::kCaution);
  EXPECT_EQ(out.labelAt(1, 0), HybridLabel::kSafe);
  b.build(HybridSource::kStereoOnly, v, grid, &out);
  EXPECT_EQ(out.labelAt(0, 0), HybridLabel::kCaution);
  b.build(HybridSource::kLaserOnly, v, grid, &out);
  EXPECT_EQ(out.labelAt(0, 0), HybridLabel::kSafe);  // the laser knows nothing of drop-offs
  HybridSafetyMapConfig cfg = caution;
  cfg.drop_off_edges_are_caution = false;
  HybridSafetyMapBuilder(cfg).build(HybridSource::kMerged, v, grid, &out);
  EXPECT_EQ(out.labelAt(0, 0), HybridLabel::kSafe);
}

TEST(HybridSafetyMap, LaserGridOfAnotherWindowAndResolutionIsSampledAtCellCentres) {
  SafetyMap v = visionMap(10, 10, 10, 10);
  LaserGridConfig lc;
  lc.resolution = 0.05;
  LaserGrid grid(lc);                  // window [-50, 50) cells of 5 cm: x in [-2.525, 2.475)
  grid.setLogOdds(24, 24, kOccupied);  // (1.2, 1.2) m, the centre of cell (12, 12)
  HybridSafetyMap out;
  HybridSafetyMapBuilder().build(HybridSource::kMerged, v, grid, &out);
  EXPECT_EQ(out.min_u, 10);
  EXPECT_EQ(out.labelAt(12, 12), HybridLabel::kObstacle);
  EXPECT_EQ(out.labelAt(13, 12), HybridLabel::kSafe);
}

TEST(HybridSafetyMap, WithoutAVisionMapTheLaserGridGivesTheCells) {
  LaserGridConfig lc;
  lc.width = 20;
  lc.height = 10;
  LaserGrid grid(lc);
  grid.setLogOdds(0, 0, kOccupied);
  grid.setLogOdds(1, 0, kFree);
  const SafetyMap empty;  // width 0: no stereo map yet
  HybridSafetyMap out;
  HybridSafetyMapBuilder().build(HybridSource::kMerged, empty, grid, &out);
  EXPECT_EQ(out.width, 20);
  EXPECT_EQ(out.height, 10);
  EXPECT_EQ(out.min_u, grid.minU());
  EXPECT_EQ(out.labelAt(0, 0), HybridLabel::kObstacle);
  EXPECT_EQ(out.labelAt(1, 0), HybridLabel::kUnknown);  // laser-free, vision-unknown
  // A vision map whose label vector does not match its size is not read.
  SafetyMap broken = visionMap(0, 0, 5, 5);
  broken.labels.resize(3);
  HybridSafetyMapBuilder().build(HybridSource::kStereoOnly, broken, grid, &out);
  EXPECT_EQ(out.width, 20);
  for (HybridLabel l : out.labels)
    EXPECT_EQ(l, HybridLabel::kUnknown);
  // Missing drop-off layer: ignored.
  SafetyMap no_drop = visionMap(0, 0, 5, 5);
  no_drop.drop_off.clear();
  HybridSafetyMapBuilder().build(HybridSource::kMerged, no_drop, grid, &out);
  EXPECT_EQ(out.labelAt(2, 2), HybridLabel::kSafe);
}

TEST(HybridSafetyMap, ConfusionCountsFollowTheTeamConventions) {
  HybridSafetyMap truth, map;
  truth.width = map.width = 5;
  truth.height = map.height = 1;
  using H = HybridLabel;
  truth.labels = {H::kSafe, H::kSafe, H::kObstacle, H::kUnknown, H::kHazard};
  map.labels = {H::kSafe, H::kUnknown, H::kCaution, H::kSafe, H::kObstacle};
  ConfusionCounts c;
  ASSERT_EQ(countHybridConfusion(map, truth, &c), "");
  EXPECT_EQ(c.tn, 1u);                   // A: cell 0
  EXPECT_EQ(c.fn, 1u);                   // B: cell 2, Caution is traversable
  EXPECT_EQ(c.fp, 0u);                   // C
  EXPECT_EQ(c.tp, 1u);                   // cell 4
  EXPECT_EQ(c.unclassified_in_map, 1u);  // cell 1
  EXPECT_EQ(c.unclassified_in_gt, 1u);   // cell 3
  EXPECT_EQ(c.maps, 1u);
  const SafeClassScores s = safeClassScores(c);
  EXPECT_DOUBLE_EQ(s.precision, 0.5);
  EXPECT_DOUBLE_EQ(s.recall, 1.0);
  EXPECT_DOUBLE_EQ(s.f1, 2.0 / 3.0);
  // Map cells outside the ground truth are unclassified in it.
  map.min_u = 3;
  ConfusionCounts shifted;
  ASSERT_EQ(countHybridConfusion(map, truth, &shifted), "");
  // u = 3: Safe vs Unknown; u = 4: Unknown vs Hazard; u = 5..7 lie outside the truth.
  EXPECT_EQ(shifted.classified(), 0u);
  EXPECT_EQ(shifted.unclassified_in_gt, 4u);
  EXPECT_EQ(shifted.unclassified_in_map, 1u);
  // Inconsistent maps or resolutions are refused without counting.
  ConfusionCounts untouched;
  map.min_u = 0;
  map.resolution = 0.2;
  EXPECT_NE(countHybridConfusion(map, truth, &untouched), "");
  map.resolution = 0.1;
  map.labels.pop_back();
  EXPECT_NE(countHybridConfusion(map, truth, &untouched), "");
  EXPECT_EQ(untouched.maps, 0u);
  EXPECT_NE(countHybridConfusion(truth, truth, nullptr), "");
}

TEST(HybridSafetyMap, LabelTablesAndConfigValidation) {
  const HybridSafetyMapConfig d;
  EXPECT_EQ(toOccupancyValue(HybridLabel::kUnknown, d), -1);
  EXPECT_EQ(toOccupancyValue(HybridLabel::kSafe, d), 0);
  EXPECT_EQ(toOccupancyValue(HybridLabel::kCaution, d), 50);
  EXPECT_EQ(toOccupancyValue(HybridLabel::kHazard, d), 100);  // lethal by default
  EXPECT_EQ(toOccupancyValue(HybridLabel::kObstacle, d), 100);
  HybridSafetyMapConfig c;
  c.hazard_cost = 99;
  c.caution_cost = 30;
  EXPECT_EQ(c.validate(), "");
  EXPECT_EQ(toOccupancyValue(HybridLabel::kHazard, c), 99);
  EXPECT_EQ(toOccupancyValue(HybridLabel::kCaution, c), 30);
  EXPECT_EQ(toOccupancyValue(HybridLabel::kObstacle, c), 100);
  c.hazard_cost = 0;  // a hazard free: refused
  EXPECT_NE(c.validate().find("hazard_cost"), std::string::npos);
  c = HybridSafetyMapConfig();
  c.caution_cost = 100;
  EXPECT_NE(c.validate().find("caution_cost"), std::string::npos);
  EXPECT_STREQ(toString(HybridLabel::kHazard), "hazard");
  EXPECT_TRUE(isTraversable(HybridLabel::kCaution));
  EXPECT_FALSE(isTraversable(HybridLabel::kUnknown));

  EXPECT_TRUE(HybridSafetyMapConfig().validate().empty());
  c = HybridSafetyMapConfig();
  c.min_passage_width = 0.0;
  EXPECT_NE(c.validate().find("min_passage_width"), std::string::npos);
  EXPECT_THROW(HybridSafetyMapBuilder{c}, std::invalid_argument);
  c.min_passage_width = std::nan("");
  EXPECT_FALSE(c.validate().empty());
}

}  // namespace
}  // namespace stereo_safety_map
