// Tests of the laser occupancy grid (001 Sec. 3): ray casting, scan geometry, scrolling and bad
// input.
#include "stereo_safety_map/core/laser_grid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace stereo_safety_map {
namespace {

Eigen::Isometry3f laserPose(float x, float y, float yaw) {
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear() = Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3f(x, y, 0.3f);
  return T;
}

LaserScanInfo scanInfo(double angle_min, double increment) {
  LaserScanInfo s;
  s.angle_min = angle_min;
  s.angle_increment = increment;
  s.range_min = 0.05;
  s.range_max = 20.0;
  return s;
}

TEST(LaserGrid, OneBeamFreesItsPathAndMarksItsReturn) {
  LaserGrid grid;  // 100 x 100 cells of 0.1 m around the origin
  const LaserIntegrationStats st =
      grid.integrate(scanInfo(0.0, 0.01), {2.0f}, laserPose(0.f, 0.f, 0.f));
  EXPECT_FALSE(st.rejected);
  EXPECT_EQ(st.returns, 1u);
  EXPECT_EQ(st.cells_occupied, 1u);
  EXPECT_EQ(st.cells_freed, 20u);  // cells 0..19
  for (int u = 0; u < 20; ++u)
    EXPECT_EQ(grid.state(u, 0), LaserCellState::kFree) << u;
  EXPECT_EQ(grid.state(20, 0), LaserCellState::kOccupied);
  EXPECT_EQ(grid.stateAt(2.0, 0.0), LaserCellState::kOccupied);
  EXPECT_EQ(grid.state(21, 0), LaserCellState::kUnknown);
  EXPECT_EQ(grid.state(10, 1), LaserCellState::kUnknown);
  EXPECT_EQ(grid.state(-1, 0), LaserCellState::kUnknown);
}

TEST(LaserGrid, FullScanOfASquareRoom) {
  LaserGrid grid;
  // Walls at x = +-3 m and y = +-3 m, laser at (0.52, -0.31).
  const float lx = 0.52f, ly = -0.31f;
  const int n = 1440;
  std::vector<float> ranges(n);
  const LaserScanInfo info = scanInfo(-M_PI, 2.0 * M_PI / n);
  for (int i = 0; i < n; ++i) {
    const double a = info.angle_min + i * info.angle_increment;
    const double c = std::cos(a), s = std::sin(a);
    double t = 1e9;
    if (c > 1e-9) t = std::min(t, (3.0 - lx) / c);
    if (c < -1e-9) t = std::min(t, (-3.0 - lx) / c);
    if (s > 1e-9) t = std::min(t, (3.0 - ly) / s);
    if (s < -1e-9) t = std::min(t, (-3.0 - ly) / s);
    ranges[i] = static_cast<float>(t);
  }
  grid.integrate(info, ranges, laserPose(lx, ly, 0.f));
  // Interior free, wall cells occupied, outside unknown.
  for (int u = -27; u <= 27; u += 3) {
    for (int v = -27; v <= 27; v += 3) {
      EXPECT_EQ(grid.state(u, v), LaserCellState::kFree) << u << "," << v;
    }
  }
  int occupied_on_walls = 0;
  for (int k = -29; k <= 29; ++k) {
    occupied_on_walls += grid.state(30, k) == LaserCellState::kOccupied;
    occupied_on_walls += grid.state(-30, k) == LaserCellState::kOccupied;
    occupied_on_walls += grid.state(k, 30) == LaserCellState::kOccupied;
    occupied_on_walls += grid.state(k, -30) == LaserCellState::kOccupied;
  }
  EXPECT_GT(occupied_on_walls, 4 * 59 * 9 / 10);
  EXPECT_EQ(grid.state(35, 0), LaserCellState::kUnknown);
  EXPECT_EQ(grid.state(0, -40), LaserCellState::kUnknown);
}

TEST(LaserGrid, LaserPoseRotatesAndShiftsTheBeams) {
  LaserGrid grid;
  // Yawed 90 degrees: beam angle 0 points along fixed +y.
  grid.integrate(scanInfo(0.0, 0.1), {1.5f}, laserPose(1.0f, 2.0f, static_cast<float>(M_PI / 2)));
  EXPECT_EQ(grid.stateAt(1.0, 3.5), LaserCellState::kOccupied);
  EXPECT_EQ(grid.stateAt(1.0, 2.7), LaserCellState::kFree);
  EXPECT_EQ(grid.stateAt(2.5, 2.0), LaserCellState::kUnknown);
}

TEST(LaserGrid, AReturnWinsOverABeamCrossingItsCellInTheSameScan) {
  LaserGrid grid;
  // Beam 0 returns at 1.0 m; beam 1, 0.5 mrad away, passes through that cell to 2.0 m.
  grid.integrate(scanInfo(0.0, 0.0005), {1.0f, 2.0f}, laserPose(0.f, 0.f, 0.f));
  EXPECT_EQ(grid.state(10, 0), LaserCellState::kOccupied);
  EXPECT_EQ(grid.state(20, 0), LaserCellState::kOccupied);
  EXPECT_EQ(grid.state(15, 0), LaserCellState::kFree);
}

TEST(LaserGrid, RepeatedMissesClearADepartedObstacleWithinTheClamp) {
  LaserGridConfig cfg;
  LaserGrid grid(cfg);
  for (int k = 0; k < 20; ++k)
    grid.integrate(scanInfo(0.0, 0.1), {1.0f}, laserPose(0, 0, 0));
  EXPECT_FLOAT_EQ(grid.logOdds(10, 0), static_cast<float>(cfg.log_odds_max));
  int scans = 0;
  while (grid.state(10, 0) != LaserCellState::kFree && scans < 100) {
    grid.integrate(scanInfo(0.0, 0.1), {3.0f}, laserPose(0, 0, 0));
    ++scans;
  }
  // From the clamp 3.5 down to -0.3 at -0.4 per scan: 10 scans.
  EXPECT_EQ(scans, 10);
  for (int k = 0; k < 50; ++k)
    grid.integrate(scanInfo(0.0, 0.1), {3.0f}, laserPose(0, 0, 0));
  EXPECT_FLOAT_EQ(grid.logOdds(10, 0), static_cast<float>(cfg.log_odds_min));
}

TEST(LaserGrid, NoReturnClearsToRangeMaxOnlyWhenConfigured) {
  LaserScanInfo info = scanInfo(0.0, 0.1);
  info.range_max = 3.0;
  {
    LaserGrid grid;
    const LaserIntegrationStats st =
        grid.integrate(info, {std::numeric_limits<float>::infinity(), 5.0f}, laserPose(0, 0, 0));
    EXPECT_EQ(st.no_return, 2u);
    EXPECT_EQ(st.cells_occupied, 0u);
    EXPECT_EQ(grid.state(29, 0), LaserCellState::kFree);
    EXPECT_EQ(grid.state(30, 0), LaserCellState::kFree);  // the cell at range_max itself
    EXPECT_EQ(grid.state(31, 0), LaserCellState::kUnknown);
  }
  {
    LaserGridConfig cfg;
    cfg.clear_no_return = false;
    LaserGrid grid(cfg);
    grid.integrate(info, {std::numeric_limits<float>::infinity()}, laserPose(0, 0, 0));
    EXPECT_EQ(grid.state(10, 0), LaserCellState::kUnknown);
  }
}

TEST(LaserGrid, BeamsFromOutsideTheWindowAreClipped) {
  LaserGrid grid;  // window x in [-5.05, 4.95)
  grid.integrate(scanInfo(0.0, 0.1), {17.0f}, laserPose(-15.f, 0.f, 0.f));  // return at x = 2
  EXPECT_EQ(grid.stateAt(2.0, 0.0), LaserCellState::kOccupied);
  EXPECT_EQ(grid.stateAt(-5.0, 0.0), LaserCellState::kFree);
  EXPECT_EQ(grid.stateAt(1.5, 0.0), LaserCellState::kFree);
  // A beam that never enters the window changes nothing.
  const LaserIntegrationStats st =
      grid.integrate(scanInfo(M_PI / 2, 0.1), {10.0f}, laserPose(-15.f, 0.f, 0.f));
  EXPECT_EQ(st.cells_freed + st.cells_occupied, 0u);
}

TEST(LaserGrid, ScrollingKeepsCellsThatStayAndClearsCellsThatLeave) {
  LaserGrid grid;
  ASSERT_EQ(grid.minU(), -50);
  grid.setLogOdds(40, 0, 2.0f);   // stays after moving by +20
  grid.setLogOdds(-45, 3, 2.0f);  // leaves
  EXPECT_EQ(grid.moveTo(-30, -50), 20u * 100u);
  EXPECT_EQ(grid.state(40, 0), LaserCellState::kOccupied);
  EXPECT_FALSE(grid.inside(-45, 3));
  EXPECT_EQ(grid.state(-45, 3), LaserCellState::kUnknown);
  // The storage of u = -45 now holds u = 55, which must start unknown.
  EXPECT_EQ(grid.state(55, 3), LaserCellState::kUnknown);
  EXPECT_FLOAT_EQ(grid.logOdds(55, 3), 0.0f);
  // Back again: the cell that left was forgotten.
  grid.moveTo(-50, -50);
  EXPECT_EQ(grid.state(-45, 3), LaserCellState::kUnknown);
  EXPECT_EQ(grid.state(40, 0), LaserCellState::kOccupied);
  // Diagonal move, and a jump larger than the window.
  grid.setLogOdds(0, 0, 2.0f);
  EXPECT_EQ(grid.moveTo(-45, -47), 5u * 100 + 3u * 100 - 5u * 3);
  EXPECT_EQ(grid.state(0, 0), LaserCellState::kOccupied);
  grid.recenter(100.0, 100.0);
  EXPECT_EQ(grid.minU(), 1000 - 50);
  EXPECT_EQ(grid.minV(), 1000 - 50);
  EXPECT_EQ(grid.state(1000, 1000), LaserCellState::kUnknown);
  grid.recenter(std::nan(""), 0.0);  // ignored
  EXPECT_EQ(grid.minU(), 950);
}

TEST(LaserGrid, BadInputIsSkippedWithoutCrashing) {
  LaserGrid grid;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  // NaN, -inf, too short: skipped; one valid beam still counts.
  LaserIntegrationStats st =
      grid.integrate(scanInfo(0.0, 0.2), {nan, -inf, 0.01f, 1.0f}, laserPose(0, 0, 0));
  EXPECT_EQ(st.invalid, 3u);
  EXPECT_EQ(st.returns, 1u);
  EXPECT_EQ(grid.stateAt(std::cos(0.6), std::sin(0.6)), LaserCellState::kOccupied);

  // Empty scan: nothing happens.
  st = grid.integrate(scanInfo(0.0, 0.1), {}, laserPose(0, 0, 0));
  EXPECT_FALSE(st.rejected);
  EXPECT_EQ(st.cells_freed + st.cells_occupied, 0u);

  // Bad geometry or pose: rejected, grid unchanged.
  const float before = grid.logOdds(5, 0);
  LaserScanInfo bad = scanInfo(0.0, 0.0);
  EXPECT_TRUE(grid.integrate(bad, {1.0f}, laserPose(0, 0, 0)).rejected);
  bad = scanInfo(0.0, 0.1);
  bad.range_max = 0.01;
  EXPECT_TRUE(grid.integrate(bad, {1.0f}, laserPose(0, 0, 0)).rejected);
  bad = scanInfo(nan, 0.1);
  EXPECT_TRUE(grid.integrate(bad, {1.0f}, laserPose(0, 0, 0)).rejected);
  EXPECT_TRUE(grid.integrate(scanInfo(0.0, 0.1), {1.0f}, laserPose(nan, 0, 0)).rejected);
  EXPECT_FLOAT_EQ(grid.logOdds(5, 0), before);

  grid.setLogOdds(-20, 20, nan);  // ignored
  EXPECT_FLOAT_EQ(grid.logOdds(-20, 20), 0.0f);
  grid.setLogOdds(1000, 1000, 1.0f);  // outside: ignored
  EXPECT_FLOAT_EQ(grid.logOdds(1000, 1000), 0.0f);
}

TEST(LaserGrid, ConfigValidation) {
  EXPECT_TRUE(LaserGridConfig().validate().empty());
  const auto expectBad = [](const LaserGridConfig& c, const char* name) {
    const std::string why = c.validate();
    EXPECT_NE(why.find(name), std::string::npos) << why;
    EXPECT_THROW(LaserGrid{c}, std::invalid_argument);
  };
  LaserGridConfig c;
  c.width = 0;  // zero-size grid
  expectBad(c, "width");
  c = LaserGridConfig();
  c.height = 0;
  expectBad(c, "height");
  c = LaserGridConfig();
  c.resolution = 0.0;
  expectBad(c, "resolution");
  c = LaserGridConfig();
  c.log_odds_miss = 0.1;
  expectBad(c, "log_odds_miss");
  c = LaserGridConfig();
  c.occupied_threshold = 5.0;
  expectBad(c, "log_odds_max");
}

}  // namespace
}  // namespace stereo_safety_map
