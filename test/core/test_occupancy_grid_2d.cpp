// Tests of the 2D stereo occupancy grid (paper 002, Sec. 3 and 4.3). Worlds are ray-cast
// exactly (floor + boxes), so every expected cell follows from the geometry.
#include "stereo_safety_map/core/occupancy_grid_2d.h"

#include "stereo_safety_map/core/disparity_filters.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace stereo_safety_map {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

StereoCameraModel makeModel(int w, int h, double f, double baseline) {
  StereoCameraModel m;
  m.fx = f;
  m.fy = f;
  m.cx = (w - 1) / 2.0;
  m.cy = (h - 1) / 2.0;
  m.cx_right = m.cx;
  m.baseline = baseline;
  m.width = w;
  m.height = h;
  return m;
}

// Left optical frame (x right, y down, z forward) at `position`, heading `yaw` about z and
// pitched down by `pitch` [rad].
Eigen::Isometry3f cameraPose(const Eigen::Vector3f& position, float yaw, float pitch) {
  Eigen::Matrix3f optical_to_body;
  optical_to_body << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear() = (Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()) *
                Eigen::AngleAxisf(pitch, Eigen::Vector3f::UnitY()))
                   .toRotationMatrix() *
               optical_to_body;
  T.translation() = position;
  return T;
}

struct Box {
  Eigen::Vector3f lo, hi;
};

// Exact disparity of the first surface hit (floor z = 0 and boxes); 0 where nothing is hit.
cv::Mat render(const StereoCameraModel& m, const Eigen::Isometry3f& T,
               const std::vector<Box>& boxes, bool floor = true) {
  cv::Mat d(m.height, m.width, CV_32FC1, cv::Scalar(0));
  const Eigen::Vector3f o = T.translation();
  for (int y = 0; y < m.height; ++y) {
    for (int x = 0; x < m.width; ++x) {
      // Per unit depth Z, so the hit parameter is the depth itself.
      const Eigen::Vector3f r =
          T.linear() * Eigen::Vector3f((x - m.cx) / m.fx, (y - m.cy) / m.fy, 1.0f);
      float best = kInf;
      if (floor && r.z() < 0.0f) best = -o.z() / r.z();
      for (const Box& b : boxes) {
        float t0 = 0.0f, t1 = kInf;
        bool hit = true;
        for (int a = 0; a < 3 && hit; ++a) {
          if (std::abs(r[a]) < 1e-12f) {
            hit = o[a] >= b.lo[a] && o[a] <= b.hi[a];
            continue;
          }
          float ta = (b.lo[a] - o[a]) / r[a], tb = (b.hi[a] - o[a]) / r[a];
          if (ta > tb) std::swap(ta, tb);
          t0 = std::max(t0, ta);
          t1 = std::min(t1, tb);
          hit = t0 <= t1;
        }
        if (hit && t0 > 0.0f) best = std::min(best, t0);
      }
      if (std::isfinite(best)) d.at<float>(y, x) = static_cast<float>(m.fx * m.baseline / best);
    }
  }
  return d;
}

cv::Mat snapshot(const OccupancyGrid2D& g) {
  cv::Mat img;
  g.toImage(&img);
  return img.clone();
}

bool sameGrid(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && cv::countNonZero(a != b) == 0;
}

// --- config ------------------------------------------------------------------------------------

TEST(OccupancyGrid2DConfig, DefaultsArePaperValuesAndValid) {
  const OccupancyGrid2DConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_EQ(c.k, 20);
  EXPECT_EQ(c.free_threshold, 50);
  EXPECT_EQ(c.occupied_threshold, 150);
  EXPECT_DOUBLE_EQ(c.disparity_half_width, 0.5);
  EXPECT_TRUE(c.accuracy_preservation);
  EXPECT_EQ(OccupancyGrid2D::kUnknownValue, 128);
}

TEST(OccupancyGrid2DConfig, InvalidValuesNameTheParameter) {
  const auto message = [](void (*edit)(OccupancyGrid2DConfig&)) {
    OccupancyGrid2DConfig c;
    edit(c);
    return c.validate();
  };
  EXPECT_NE(message([](OccupancyGrid2DConfig& c) { c.resolution = 0.0; }).find("resolution"),
            std::string::npos);
  EXPECT_NE(message([](OccupancyGrid2DConfig& c) { c.size_x = std::nan(""); }).find("size_x"),
            std::string::npos);
  EXPECT_NE(message([](OccupancyGrid2DConfig& c) { c.k = 0; }).find("k must"), std::string::npos);
  EXPECT_NE(message([](OccupancyGrid2DConfig& c) { c.k = 256; }).find("k must"), std::string::npos);
  EXPECT_NE(message([](OccupancyGrid2DConfig& c) {
              c.occupied_threshold = 40;
            }).find("occupied_threshold"),
            std::string::npos);
  // Never-seen cells (128) must stay unknown: neither free nor occupied.
  EXPECT_NE(
      message([](OccupancyGrid2DConfig& c) { c.free_threshold = 129; }).find("free_threshold"),
      std::string::npos);
  EXPECT_NE(message([](OccupancyGrid2DConfig& c) {
              c.occupied_threshold = 127;
            }).find("occupied_threshold"),
            std::string::npos);
  EXPECT_EQ(message([](OccupancyGrid2DConfig& c) {
              c.free_threshold = 128;
              c.occupied_threshold = 128;
            }),
            "");
  EXPECT_NE(message([](OccupancyGrid2DConfig& c) { c.robot_height = 0.05; }).find("robot_height"),
            std::string::npos);
  EXPECT_NE(message([](OccupancyGrid2DConfig& c) {
              c.disparity_half_width = -0.5;
            }).find("disparity_half_width"),
            std::string::npos);
  OccupancyGrid2DConfig bad;
  bad.size_y = 0.0;
  EXPECT_THROW(OccupancyGrid2D g(bad), std::invalid_argument);
}

// --- sensor model (002 Sec. 3.2) ---------------------------------------------------------------

TEST(UncertaintyTrapezoid, CornersForKnownFBdx) {
  // f = 100 px, B = 0.12 m (fB = 12), pixel x - cx = 9.5, d = 3.5:
  // Z(4) = 3, Z(3) = 4; X = (9.5 -/+ 0.5) Z / f.
  StereoCameraModel m = makeModel(160, 120, 100.0, 0.12);
  UncertaintyTrapezoid t;
  ASSERT_TRUE(computeUncertaintyTrapezoid(m, m.cx + 9.5, 3.5, 0.5, &t));
  EXPECT_NEAR(t.z_near, 3.0, 1e-12);
  EXPECT_NEAR(t.z_far, 4.0, 1e-12);
  EXPECT_NEAR(t.x_near_left, 0.27, 1e-12);
  EXPECT_NEAR(t.x_near_right, 0.30, 1e-12);
  EXPECT_NEAR(t.x_far_left, 0.36, 1e-12);
  EXPECT_NEAR(t.x_far_right, 0.40, 1e-12);

  // A principal-point offset between the cameras shifts the disparity (d - (cx - cx_right)).
  m.cx_right = m.cx - 1.0;
  ASSERT_TRUE(computeUncertaintyTrapezoid(m, m.cx + 9.5, 4.5, 0.5, &t));
  EXPECT_NEAR(t.z_near, 3.0, 1e-12);
  EXPECT_NEAR(t.z_far, 4.0, 1e-12);
}

TEST(UncertaintyTrapezoid, UnboundedFarEdgeAndInvalidInput) {
  const StereoCameraModel m = makeModel(160, 120, 100.0, 0.12);
  UncertaintyTrapezoid t;
  ASSERT_TRUE(computeUncertaintyTrapezoid(m, 10.0, 0.4, 0.5, &t));
  EXPECT_NEAR(t.z_near, 12.0 / 0.9, 1e-12);
  EXPECT_TRUE(std::isinf(t.z_far));
  EXPECT_FALSE(computeUncertaintyTrapezoid(m, 10.0, 0.0, 0.5, &t));
  EXPECT_FALSE(computeUncertaintyTrapezoid(m, 10.0, -2.0, 0.5, &t));
  EXPECT_FALSE(computeUncertaintyTrapezoid(m, 10.0, kNaN, 0.5, &t));
  StereoCameraModel zero_f = m;
  zero_f.fx = 0.0;
  EXPECT_FALSE(computeUncertaintyTrapezoid(zero_f, 10.0, 4.0, 0.5, &t));
}

TEST(GroundProjection, LevelCameraIsThePapersTrapezoid) {
  // Level camera at (1, 2, 0.5) looking along +x: optical Z -> +x, optical X -> -y. The row
  // does not matter for a level camera.
  const StereoCameraModel m = makeModel(160, 120, 100.0, 0.12);
  const Eigen::Isometry3f T = cameraPose({1.0f, 2.0f, 0.5f}, 0.0f, 0.0f);
  GroundRegion g;
  ASSERT_TRUE(projectUncertaintyRegion(m, m.cx + 9.5, 10.0, 3.5, 0.5, T, 100.0, &g));
  EXPECT_TRUE(g.camera.isApprox(Eigen::Vector2f(1.0f, 2.0f)));
  EXPECT_NEAR(g.near_left.x(), 4.0, 1e-5);
  EXPECT_NEAR(g.near_left.y(), 2.0 - 0.27, 1e-5);
  EXPECT_NEAR(g.near_right.x(), 4.0, 1e-5);
  EXPECT_NEAR(g.near_right.y(), 2.0 - 0.30, 1e-5);
  EXPECT_NEAR(g.far_left.x(), 5.0, 1e-5);
  EXPECT_NEAR(g.far_left.y(), 2.0 - 0.36, 1e-5);
  EXPECT_NEAR(g.far_right.x(), 5.0, 1e-5);
  EXPECT_NEAR(g.far_right.y(), 2.0 - 0.40, 1e-5);
}

TEST(GroundProjection, PitchedCameraProjectsCornersThroughThePose) {
  const StereoCameraModel m = makeModel(160, 120, 100.0, 0.12);
  const float pitch = 0.5f, yaw = 1.2f;
  const Eigen::Isometry3f T = cameraPose({0.5f, -1.0f, 1.2f}, yaw, pitch);
  const double x = 30.0, y = 90.0, d = 3.5;
  GroundRegion g;
  ASSERT_TRUE(projectUncertaintyRegion(m, x, y, d, 0.5, T, 100.0, &g));
  // Corners of Sec. 3.2 in the optical frame at the pixel's row, moved by the pose.
  const auto corner = [&](double z, double edge) -> Eigen::Vector2f {
    const Eigen::Vector3f p(static_cast<float>((x + edge - m.cx) * z / m.fx),
                            static_cast<float>((y - m.cy) * z / m.fy), static_cast<float>(z));
    return (T * p).head<2>();
  };
  EXPECT_LT((g.near_left - corner(3.0, -0.5)).norm(), 1e-5f);
  EXPECT_LT((g.near_right - corner(3.0, 0.5)).norm(), 1e-5f);
  EXPECT_LT((g.far_left - corner(4.0, -0.5)).norm(), 1e-5f);
  EXPECT_LT((g.far_right - corner(4.0, 0.5)).norm(), 1e-5f);
  // Still a trapezoid: near and far edges parallel, sides pointing back at the camera.
  const Eigen::Vector2f near_edge = g.near_right - g.near_left;
  const Eigen::Vector2f far_edge = g.far_right - g.far_left;
  EXPECT_NEAR(near_edge.x() * far_edge.y() - near_edge.y() * far_edge.x(), 0.0f, 1e-6f);
  const Eigen::Vector2f a = g.near_left - g.camera, b = g.far_left - g.camera;
  EXPECT_NEAR(a.x() * b.y() - a.y() * b.x(), 0.0f, 1e-4f);
}

TEST(GroundProjection, UnboundedFarEdgeIsTruncatedBeyondTheRange) {
  const StereoCameraModel m = makeModel(160, 120, 100.0, 0.12);
  const Eigen::Isometry3f T = cameraPose({0.0f, 0.0f, 0.5f}, 0.0f, 0.0f);
  GroundRegion g;
  ASSERT_TRUE(projectUncertaintyRegion(m, m.cx, m.cy, 0.3, 0.5, T, 30.0, &g));
  EXPECT_TRUE(g.far_left.allFinite());
  EXPECT_TRUE(g.far_right.allFinite());
  EXPECT_GE(g.far_left.norm(), 30.0f - 1e-3f);
  EXPECT_GE(g.far_right.norm(), 30.0f - 1e-3f);
  EXPECT_NEAR(g.near_left.x(), 12.0 / 0.8, 1e-3);
}

// --- reduction (002 Sec. 3.3) ------------------------------------------------------------------

TEST(Reduction, ColumnMaximumOverValidInBandDisparities) {
  // fB = 1, level camera 0.5 m above the floor: height of (y, d) = 0.5 - (y - 2.5) / (10 d).
  const StereoCameraModel m = makeModel(8, 6, 10.0, 0.1);
  const Eigen::Isometry3f T = cameraPose({0.0f, 0.0f, 0.5f}, 0.0f, 0.0f);
  cv::Mat d(6, 8, CV_32FC1, cv::Scalar(0));
  // Column 1: invalid values never win; d = 2 at row 1 is the closest.
  d.at<float>(0, 1) = 1.0f;
  d.at<float>(1, 1) = 2.0f;
  d.at<float>(2, 1) = 1.5f;
  d.at<float>(3, 1) = kNaN;
  d.at<float>(4, 1) = kInf;
  d.at<float>(5, 1) = -3.0f;
  // Column 2: a floor point (row 5, d = 0.6 -> 0.083 m high) has the larger disparity but lies
  // below the band; the obstacle at row 2 (d = 0.5 -> 0.6 m high) wins.
  d.at<float>(5, 2) = 0.6f;
  d.at<float>(2, 2) = 0.5f;
  // Column 3: everything above the robot (1.75 m and 2.0 m high).
  d.at<float>(0, 3) = 0.2f;
  d.at<float>(1, 3) = 0.1f;
  std::vector<ColumnReading> row;
  ASSERT_EQ(reduceToClosestObstacleRow(d, m, T, 0.0f, 0.1f, 1.5f, &row), Grid2DStatus::kOk);
  ASSERT_EQ(row.size(), 8u);
  EXPECT_FALSE(row[0].valid());
  EXPECT_EQ(row[0].disparity, 0.0f);
  ASSERT_TRUE(row[1].valid());
  EXPECT_EQ(row[1].disparity, 2.0f);
  EXPECT_EQ(row[1].row, 1);
  ASSERT_TRUE(row[2].valid());
  EXPECT_EQ(row[2].disparity, 0.5f);
  EXPECT_EQ(row[2].row, 2);
  EXPECT_FALSE(row[3].valid());

  // Without the band the floor point wins column 2 and column 3 reads the overhead points.
  ASSERT_EQ(reduceToClosestObstacleRow(d, m, T, 0.0f, -10.0f, 10.0f, &row), Grid2DStatus::kOk);
  EXPECT_EQ(row[2].disparity, 0.6f);
  EXPECT_EQ(row[2].row, 5);
  EXPECT_EQ(row[3].disparity, 0.2f);

  // The band is measured from floor_z: raising the floor by 0.3 m puts the 0.6 m point at 0.3 m.
  ASSERT_EQ(reduceToClosestObstacleRow(d, m, T, 0.55f, 0.1f, 1.5f, &row), Grid2DStatus::kOk);
  EXPECT_FALSE(row[2].valid());

  // The output buffer is reused.
  const ColumnReading* data = row.data();
  ASSERT_EQ(reduceToClosestObstacleRow(d, m, T, 0.0f, 0.1f, 1.5f, &row), Grid2DStatus::kOk);
  EXPECT_EQ(row.data(), data);
}

// --- update (002 Sec. 3.4) ---------------------------------------------------------------------

// A level camera at the origin, 0.5 m high, looking along +x; every column reads d = 4
// (fB = 12: trapezoid Z = 12 / 4.5 = 2.667 .. 12 / 3.5 = 3.429 m, field of view |y| < 0.8 x).
class WallRow : public ::testing::Test {
 protected:
  void SetUp() override {
    model = makeModel(160, 120, 100.0, 0.12);
    pose = cameraPose({0.0f, 0.0f, 0.5f}, 0.0f, 0.0f);
    row.assign(160, ColumnReading{4.0f, 60});
  }
  static bool inClear(const Eigen::Vector2f& c) {
    return c.x() >= 0.3f && c.x() <= 2.5f && std::abs(c.y()) <= 0.7f * c.x();
  }
  static bool inTrapezoid(const Eigen::Vector2f& c) {
    return c.x() >= 2.75f && c.x() <= 3.35f && std::abs(c.y()) <= 0.7f * c.x();
  }
  static bool outside(const Eigen::Vector2f& c) {
    return c.x() < -0.1f || c.x() > 3.55f || std::abs(c.y()) > 0.85f * c.x() + 0.1f;
  }
  StereoCameraModel model;
  Eigen::Isometry3f pose;
  std::vector<ColumnReading> row;
};

TEST_F(WallRow, TrapezoidRaisesClearTriangleLowersOutsideUntouched) {
  OccupancyGrid2D grid;
  const Grid2DUpdateStats s = grid.updateFromRow(row, model, pose);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s.columns_with_reading, 160);
  EXPECT_EQ(s.columns_explained, 0);
  int n_clear = 0, n_occ = 0, n_out = 0;
  const GridCell2D mn = grid.minIndex();
  for (int v = mn.v; v < mn.v + grid.sizeV(); ++v) {
    for (int u = mn.u; u < mn.u + grid.sizeU(); ++u) {
      const GridCell2D c{u, v};
      const Eigen::Vector2f p = grid.centerOf(c);
      // One reading: +K or -K exactly once, however many columns overlap a cell.
      if (inClear(p)) {
        ASSERT_EQ(grid.value(c), 108) << u << "," << v;
        ++n_clear;
      } else if (inTrapezoid(p)) {
        ASSERT_EQ(grid.value(c), 148) << u << "," << v;
        EXPECT_EQ(grid.storedDisparity(c), 4.0f);
        ++n_occ;
      } else if (outside(p)) {
        ASSERT_EQ(grid.value(c), 128) << u << "," << v;
        ++n_out;
      }
    }
  }
  EXPECT_GT(n_clear, 100);
  EXPECT_GT(n_occ, 100);
  EXPECT_GT(n_out, 1000);
  EXPECT_EQ(s.cells_raised + s.cells_lowered,
            static_cast<int>(cv::countNonZero(snapshot(grid) != 128)));
}

TEST_F(WallRow, ValuesClipAt0And255) {
  OccupancyGrid2D grid;
  const GridCell2D occ = grid.indexOf({3.0f, 0.0f});
  const GridCell2D clr = grid.indexOf({1.5f, 0.0f});
  for (int i = 0; i < 6; ++i)
    ASSERT_TRUE(grid.updateFromRow(row, model, pose).ok());
  EXPECT_EQ(grid.value(occ), 128 + 6 * 20);
  EXPECT_EQ(grid.value(clr), 128 - 6 * 20);
  ASSERT_TRUE(grid.updateFromRow(row, model, pose).ok());
  EXPECT_EQ(grid.value(occ), 255);  // 268 clipped
  EXPECT_EQ(grid.value(clr), 0);    // -12 clipped, no unsigned wrap
  for (int i = 0; i < 30; ++i)
    ASSERT_TRUE(grid.updateFromRow(row, model, pose).ok());
  EXPECT_EQ(grid.value(occ), 255);
  EXPECT_EQ(grid.value(clr), 0);
  EXPECT_TRUE(grid.isOccupied(occ));
  EXPECT_TRUE(grid.isFree(clr));

  // Clipping does not stick: the wall moves back to 5 m and the old wall cell is seen clear.
  std::vector<ColumnReading> farther(160, ColumnReading{12.0f / 5.0f, 60});
  ASSERT_TRUE(grid.updateFromRow(farther, model, pose).ok());
  EXPECT_EQ(grid.value(occ), 235);
}

TEST(OccupancyGrid2D, ThresholdsAndCellAccess) {
  OccupancyGrid2D grid;
  const GridCell2D c{3, -4};
  EXPECT_EQ(grid.value(c), 128);
  EXPECT_TRUE(grid.isUnknown(c));
  grid.setCell(c, 49);
  EXPECT_TRUE(grid.isFree(c));
  grid.setCell(c, 50);
  EXPECT_FALSE(grid.isFree(c));
  EXPECT_TRUE(grid.isUnknown(c));
  grid.setCell(c, 150);
  EXPECT_FALSE(grid.isOccupied(c));
  grid.setCell(c, 151, 7.0f);
  EXPECT_TRUE(grid.isOccupied(c));
  EXPECT_EQ(grid.storedDisparity(c), 7.0f);
  const GridCell2D far_away{100000, 0};
  EXPECT_FALSE(grid.contains(far_away));
  EXPECT_EQ(grid.value(far_away), 128);
  grid.setCell(far_away, 0);  // ignored
  EXPECT_EQ(grid.value(far_away), 128);
  EXPECT_EQ(grid.indexOf({0.149f, -0.151f}), (GridCell2D{1, -2}));
  EXPECT_TRUE(grid.centerOf({1, -2}).isApprox(Eigen::Vector2f(0.1f, -0.2f)));

  cv::Mat img;
  grid.toImage(&img);
  ASSERT_EQ(img.rows, 200);
  ASSERT_EQ(img.cols, 200);
  EXPECT_EQ(img.at<std::uint8_t>(c.v - grid.minIndex().v, c.u - grid.minIndex().u), 151);
}

TEST(OccupancyGrid2D, RecenterScrollsWithTheRobot) {
  OccupancyGrid2D grid;
  EXPECT_EQ(grid.minIndex(), (GridCell2D{-100, -100}));
  grid.setCell({90, 10}, 200, 5.0f);
  grid.setCell({-95, 0}, 10);
  // 3 cells along +x: column u = -100..-98 leaves, 100..102 enters.
  EXPECT_EQ(grid.recenter({0.3f, 0.0f}), 3u * 200u);
  EXPECT_EQ(grid.minIndex(), (GridCell2D{-97, -100}));
  EXPECT_EQ(grid.value({90, 10}), 200);
  EXPECT_EQ(grid.storedDisparity({90, 10}), 5.0f);
  EXPECT_EQ(grid.value({-95, 0}), 10);
  for (int v = -100; v < 100; ++v) {
    for (int u = 100; u < 103; ++u)
      ASSERT_EQ(grid.value({u, v}), 128);
  }
  // The cell at u = 90 leaves when the window moves 8 m farther; it must come back unknown.
  grid.recenter({8.3f, 0.0f});
  EXPECT_FALSE(grid.contains({-95, 0}));
  EXPECT_EQ(grid.value({90, 10}), 200);
  grid.recenter({-15.0f, 0.0f});
  EXPECT_EQ(grid.value({90, 10}), 128);
  grid.recenter({8.3f, 0.0f});
  EXPECT_EQ(grid.value({90, 10}), 128);
  EXPECT_EQ(grid.storedDisparity({90, 10}), 0.0f);
  EXPECT_EQ(grid.recenter({8.3f, 0.0f}), 0u);
  EXPECT_EQ(grid.recenter({kNaN, 0.0f}), 0u);
}

// --- accuracy preservation (002 Sec. 4.3) ------------------------------------------------------

class PillarWorld : public ::testing::Test {
 protected:
  void SetUp() override {
    model = makeModel(320, 240, 300.0, 0.12);  // fB = 36
    // Pillar front face at x = 6.92 (cell u = 69), |y| <= 0.08 (cells v = -1, 0, 1).
    pillar = {Eigen::Vector3f(6.92f, -0.08f, 0.0f), Eigen::Vector3f(7.08f, 0.08f, 1.0f)};
    // A second pillar that is only ever seen from far.
    other = {Eigen::Vector3f(6.92f, 1.92f, 0.0f), Eigen::Vector3f(7.08f, 2.08f, 1.0f)};
    near_pose = cameraPose({6.0f, 0.0f, 0.6f}, 0.0f, 0.0f);  // 0.92 m: d = 39, 2 cm deep
    far_pose = cameraPose({0.0f, 0.0f, 0.6f}, 0.0f, 0.0f);   // 6.92 m: d = 5.2, 1.3 m deep
  }

  // Close views of the first pillar, then far views of both.
  OccupancyGrid2D run(bool preservation, int* explained) {
    OccupancyGrid2DConfig c;
    c.accuracy_preservation = preservation;
    OccupancyGrid2D grid(c);
    const cv::Mat near_img = render(model, near_pose, {pillar});
    const cv::Mat far_img = render(model, far_pose, {pillar, other});
    for (int i = 0; i < 3; ++i)
      EXPECT_TRUE(grid.update(near_img, model, near_pose).ok());
    *explained = 0;
    for (int i = 0; i < 5; ++i) {
      const Grid2DUpdateStats s = grid.update(far_img, model, far_pose);
      EXPECT_TRUE(s.ok());
      *explained += s.columns_explained;
    }
    return grid;
  }

  static std::vector<GridCell2D> occupiedNear(const OccupancyGrid2D& g, int u0, int u1, int v0,
                                              int v1) {
    std::vector<GridCell2D> out;
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        if (g.isOccupied({u, v})) out.push_back({u, v});
      }
    }
    return out;
  }

  StereoCameraModel model;
  Box pillar, other;
  Eigen::Isometry3f near_pose, far_pose;
};

TEST_F(PillarWorld, CloseRangeObstacleStaysSharpWhenSeenFromFar) {
  int explained = 0;
  const OccupancyGrid2D grid = run(true, &explained);
  EXPECT_GT(explained, 0);
  // Footprint: exactly the three cells of the front face, as seen from close range.
  const std::vector<GridCell2D> occ = occupiedNear(grid, 55, 85, -6, 6);
  ASSERT_EQ(occ.size(), 3u);
  for (const GridCell2D& c : occ) {
    EXPECT_EQ(c.u, 69);
    EXPECT_GE(c.v, -1);
    EXPECT_LE(c.v, 1);
    EXPECT_GT(grid.storedDisparity(c), 38.0f);
  }
  // Cells the far trapezoids cover (6.3 .. 7.6 m) but only they would fill: not raised.
  EXPECT_LT(grid.value({66, 0}), 128);  // seen clear from close range
  EXPECT_EQ(grid.value({73, 0}), 128);  // hidden behind the pillar
  EXPECT_EQ(grid.value({75, 0}), 128);
  // Preservation does not hide new obstacles: the other pillar is raised from far.
  EXPECT_FALSE(occupiedNear(grid, 60, 80, 17, 23).empty());
}

TEST_F(PillarWorld, CloseRangeObstacleBlursWithoutPreservation) {
  int explained = 0;
  const OccupancyGrid2D grid = run(false, &explained);
  EXPECT_EQ(explained, 0);
  EXPECT_GT(occupiedNear(grid, 55, 85, -6, 6).size(), 10u);
  EXPECT_TRUE(grid.isOccupied({66, 0}));
  EXPECT_TRUE(grid.isOccupied({73, 0}));
  EXPECT_TRUE(grid.isOccupied({75, 0}));
}

// --- height band -------------------------------------------------------------------------------

class PitchedCamera : public ::testing::Test {
 protected:
  void SetUp() override {
    model = makeModel(320, 240, 300.0, 0.12);
    pose = cameraPose({0.0f, 0.0f, 1.2f}, 0.0f, 0.5236f);  // 30 deg down
  }
  StereoCameraModel model;
  Eigen::Isometry3f pose;
};

TEST_F(PitchedCamera, FloorNeverBecomesAnObstacle) {
  const cv::Mat img = render(model, pose, {});
  ASSERT_GT(cv::countNonZero(img > 0), 320 * 200);  // the floor fills most of the image
  OccupancyGrid2D grid;
  for (int i = 0; i < 10; ++i) {
    const Grid2DUpdateStats s = grid.update(img, model, pose);
    ASSERT_TRUE(s.ok());
    EXPECT_EQ(s.columns_with_reading, 0);
  }
  EXPECT_EQ(cv::countNonZero(snapshot(grid) > 128), 0);

  // Contrast: a band reaching down to the floor turns the floor into obstacles.
  OccupancyGrid2DConfig c;
  c.floor_clearance = -0.5;
  OccupancyGrid2D no_band(c);
  ASSERT_TRUE(no_band.update(img, model, pose).ok());
  EXPECT_GT(cv::countNonZero(snapshot(no_band) > 128), 10);
}

TEST_F(PitchedCamera, ObstacleAboveTheBandIsIgnoredObstacleInsideIsMapped) {
  const Box overhead{Eigen::Vector3f(3.0f, -0.5f, 1.6f), Eigen::Vector3f(3.5f, 0.5f, 2.0f)};
  const Box crate{Eigen::Vector3f(2.95f, -0.5f, 0.0f), Eigen::Vector3f(3.5f, 0.5f, 1.0f)};
  // 10 deg down so that the top of the field of view (+11.8 deg) sees the overhead box.
  const Eigen::Isometry3f shallow = cameraPose({0.0f, 0.0f, 1.2f}, 0.0f, 0.1745f);
  const cv::Mat above = render(model, shallow, {overhead});
  const cv::Mat inside = render(model, pose, {crate});
  // The overhead box is in view (its disparities differ from the bare floor's).
  ASSERT_GT(cv::countNonZero(above != render(model, shallow, {})), 100);
  OccupancyGrid2D grid;
  for (int i = 0; i < 5; ++i) {
    const Grid2DUpdateStats s = grid.update(above, model, shallow);
    ASSERT_TRUE(s.ok());
    EXPECT_EQ(s.columns_with_reading, 0);
  }
  EXPECT_EQ(cv::countNonZero(snapshot(grid) != 128), 0);
  // Contrast: a taller robot would map it.
  OccupancyGrid2DConfig tall;
  tall.robot_height = 2.5;
  OccupancyGrid2D tall_grid(tall);
  ASSERT_TRUE(tall_grid.update(above, model, shallow).ok());
  EXPECT_GT(cv::countNonZero(snapshot(tall_grid) > 128), 0);

  for (int i = 0; i < 5; ++i)
    ASSERT_TRUE(grid.update(inside, model, pose).ok());
  // Front top edge of the crate at x = 2.95 .. 3.0 is the closest in-band point per column.
  EXPECT_TRUE(grid.isOccupied(grid.indexOf({2.95f, 0.0f})));
  EXPECT_TRUE(grid.isOccupied(grid.indexOf({2.95f, 0.4f})));
  EXPECT_TRUE(grid.isFree(grid.indexOf({2.0f, 0.0f})));
  EXPECT_FALSE(grid.isOccupied(grid.indexOf({2.5f, 0.0f})));
  EXPECT_EQ(grid.value(grid.indexOf({3.6f, 0.0f})), 128);  // behind the crate
}

// --- spike removal before the grid (002 Sec. 4.2 with Sec. 3.3) --------------------------------

// 002 Sec. 4.1-4.2: a coherent mismatch patch floating in front of a wall becomes a ghost
// obstacle in the grid; spike removal (disparity_filters.h, run before the grid as in the
// disparity nodelet) deletes it, while a one-pixel-wide pole that stands on the floor - part of
// the floor's continuous disparity surface - survives and stays an obstacle.
class GhostAndPole : public ::testing::Test {
 protected:
  void SetUp() override {
    model = makeModel(320, 240, 300.0, 0.12);  // fB = 36
    pose = cameraPose({0.0f, 0.0f, 0.6f}, 0.0f, 0.1745f);
    const Box wall{Eigen::Vector3f(8.0f, -6.0f, 0.0f), Eigen::Vector3f(8.3f, 6.0f, 2.0f)};
    image = render(model, pose, {wall});
    // Pole: image column 200 from the floor row at about 4 m up by 40 rows, all at the
    // disparity of its base, as a thin upright object at one depth.
    pole_base_row = -1;
    for (int y = 0; y < model.height; ++y) {
      if (image.at<float>(y, 200) >= 9.0f) {
        pole_base_row = y;
        break;
      }
    }
    ASSERT_GT(pole_base_row, 60);
    const float pole_d = image.at<float>(pole_base_row, 200);
    for (int y = pole_base_row - 40; y <= pole_base_row; ++y)
      image.at<float>(y, 200) = pole_d;
    // Ghost: a 12 x 12 patch at d = 18 (2 m) where the wall (d ~ 4.5) is seen.
    image(cv::Rect(60, 40, 12, 12)).setTo(18.0f);
    ghost_xy = pointOf(65.5, 45.0, 18.0);
    pole_xy = pointOf(200.0, pole_base_row - 20.0, pole_d);
  }
  Eigen::Vector2f pointOf(double x, double y, double d) const {
    const double z = model.fx * model.baseline / d;
    const Eigen::Vector3f p(static_cast<float>((x - model.cx) * z / model.fx),
                            static_cast<float>((y - model.cy) * z / model.fy),
                            static_cast<float>(z));
    return (pose * p).head<2>();
  }
  OccupancyGrid2D map(const cv::Mat& disparity) const {
    OccupancyGrid2D grid;
    for (int i = 0; i < 5; ++i)
      EXPECT_TRUE(grid.update(disparity, model, pose).ok());
    return grid;
  }
  StereoCameraModel model;
  Eigen::Isometry3f pose;
  cv::Mat image;
  int pole_base_row = -1;
  Eigen::Vector2f ghost_xy, pole_xy;
};

TEST_F(GhostAndPole, SpikeRemovalDeletesTheGhostObstacleKeepsThePole) {
  // Without spike removal: both are obstacles.
  const OccupancyGrid2D raw = map(image);
  EXPECT_TRUE(raw.isOccupied(raw.indexOf(ghost_xy))) << ghost_xy.transpose();
  EXPECT_TRUE(raw.isOccupied(raw.indexOf(pole_xy))) << pole_xy.transpose();

  cv::Mat filtered = image.clone();
  SpikeRemovalConfig spikes;     // 002 Sec. 4.2: |d_j - d_i| <= 1, surfaces below 200 px go
  spikes.min_region_size = 200;  // the 12 x 12 px ghost; the default (50 px) keeps it
  ASSERT_EQ(filterSpikes(spikes, &filtered), 144);
  const OccupancyGrid2D clean = map(filtered);
  // The ghost's cell is now seen through: cleared by the wall's readings behind it.
  EXPECT_FALSE(clean.isOccupied(clean.indexOf(ghost_xy)));
  EXPECT_TRUE(clean.isFree(clean.indexOf(ghost_xy)));
  EXPECT_TRUE(clean.isOccupied(clean.indexOf(pole_xy)));
  // Nothing else occupied between the camera and the wall but the pole.
  int occupied_before_wall = 0;
  const GridCell2D mn = clean.minIndex();
  for (int v = mn.v; v < mn.v + clean.sizeV(); ++v) {
    for (int u = mn.u; u < mn.u + clean.sizeU(); ++u) {
      const Eigen::Vector2f c = clean.centerOf({u, v});
      if (c.x() < 7.0f && clean.isOccupied({u, v})) {
        ++occupied_before_wall;
        EXPECT_LT((c - pole_xy).norm(), 0.5f) << c.transpose();
      }
    }
  }
  EXPECT_GE(occupied_before_wall, 1);
}

// --- bad input ---------------------------------------------------------------------------------

TEST_F(PitchedCamera, BadInputIsRefusedAndLeavesTheGridUnchanged) {
  const Box crate{Eigen::Vector3f(2.95f, -0.5f, 0.0f), Eigen::Vector3f(3.5f, 0.5f, 1.0f)};
  const cv::Mat img = render(model, pose, {crate});
  OccupancyGrid2D grid;
  ASSERT_TRUE(grid.update(img, model, pose).ok());
  const cv::Mat before = snapshot(grid);
  ASSERT_GT(cv::countNonZero(before != 128), 0);

  EXPECT_EQ(grid.update(cv::Mat(), model, pose).status, Grid2DStatus::kEmptyImage);
  EXPECT_EQ(grid.update(cv::Mat(240, 320, CV_8UC1, cv::Scalar(10)), model, pose).status,
            Grid2DStatus::kWrongImageType);
  EXPECT_EQ(grid.update(cv::Mat(240, 320, CV_32FC3, cv::Scalar(10)), model, pose).status,
            Grid2DStatus::kWrongImageType);
  EXPECT_EQ(grid.update(cv::Mat(240, 320, CV_64FC1, cv::Scalar(10)), model, pose).status,
            Grid2DStatus::kWrongImageType);
  EXPECT_EQ(grid.update(img(cv::Rect(0, 0, 100, 100)), model, pose).status,
            Grid2DStatus::kImageSizeMismatch);
  StereoCameraModel zero_f = model;
  zero_f.fx = 0.0;
  EXPECT_EQ(grid.update(img, zero_f, pose).status, Grid2DStatus::kBadCameraModel);
  StereoCameraModel nan_b = model;
  nan_b.baseline = std::nan("");
  EXPECT_EQ(grid.update(img, nan_b, pose).status, Grid2DStatus::kBadCameraModel);
  StereoCameraModel no_size = model;
  no_size.width = 0;
  EXPECT_EQ(grid.update(img, no_size, pose).status, Grid2DStatus::kBadCameraModel);
  Eigen::Isometry3f nan_pose = pose;
  nan_pose.translation().x() = kNaN;
  EXPECT_EQ(grid.update(img, model, nan_pose).status, Grid2DStatus::kBadPose);
  EXPECT_FALSE(grid.update(img, model, pose, kNaN).ok());
  EXPECT_TRUE(sameGrid(before, snapshot(grid)));

  // Images of nothing but invalid values are valid input that carries no reading.
  for (const float bad : {kNaN, kInf, -kInf, 0.0f, -1.0f}) {
    const Grid2DUpdateStats s =
        grid.update(cv::Mat(240, 320, CV_32FC1, cv::Scalar(bad)), model, pose);
    EXPECT_TRUE(s.ok());
    EXPECT_EQ(s.columns_with_reading, 0);
  }
  EXPECT_TRUE(sameGrid(before, snapshot(grid)));

  // Reduced rows with junk readings, or of the wrong length, change nothing either.
  std::vector<ColumnReading> junk(320, ColumnReading{kNaN, 10});
  junk[1] = ColumnReading{-4.0f, 10};
  junk[2] = ColumnReading{kInf, 10};
  junk[3] = ColumnReading{5.0f, -1};
  const Grid2DUpdateStats s = grid.updateFromRow(junk, model, pose);
  EXPECT_TRUE(s.ok());
  EXPECT_EQ(s.columns_with_reading, 0);
  EXPECT_EQ(grid.updateFromRow(std::vector<ColumnReading>(5), model, pose).status,
            Grid2DStatus::kImageSizeMismatch);
  EXPECT_EQ(grid.updateFromRow(junk, zero_f, pose).status, Grid2DStatus::kBadCameraModel);
  EXPECT_TRUE(sameGrid(before, snapshot(grid)));

  // Still works afterwards.
  ASSERT_TRUE(grid.update(img, model, pose).ok());
  EXPECT_FALSE(sameGrid(before, snapshot(grid)));
}

}  // namespace
}  // namespace stereo_safety_map
