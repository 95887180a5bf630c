// Least-squares plane fit (000, Sec. V-B).
#include "stereo_safety_map/core/ground_segmentation.h"
#include "stereo_safety_map/core/plane_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace stereo_safety_map {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Points of z = a x + b y + c on an n x n lattice of spacing h around (x0, y0), plus noise.
std::vector<Eigen::Vector3d> planePoints(double a, double b, double c, double x0, double y0, int n,
                                         double h, double sigma, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = x0 + (i - n / 2) * h, y = y0 + (j - n / 2) * h;
      pts.emplace_back(x, y, a * x + b * y + c + (sigma > 0 ? noise(rng) : 0.0));
    }
  return pts;
}

TEST(PlaneFitConfig, Validate) {
  PlaneFitConfig c;
  EXPECT_EQ(c.validate(), "");
  c.min_points = 2;
  EXPECT_NE(c.validate().find("min_points"), std::string::npos);
  EXPECT_THROW(PlaneFitter{c}, std::invalid_argument);
  c = PlaneFitConfig();
  c.min_xy_stddev = 0.0;
  EXPECT_NE(c.validate().find("min_xy_stddev"), std::string::npos);
  c = PlaneFitConfig();
  c.vertical_margin = 4;
  EXPECT_NE(c.validate().find("vertical_margin"), std::string::npos);
}

TEST(PlaneFit, ExactPlane) {
  const auto pts = planePoints(0.1, -0.05, 0.3, 1.0, 2.0, 10, 0.05, 0.0);
  const GroundPlane p = fitPlane(pts);
  ASSERT_TRUE(p.valid);
  EXPECT_NEAR(p.a, 0.1, 1e-12);
  EXPECT_NEAR(p.b, -0.05, 1e-12);
  EXPECT_NEAR(p.c, 0.3, 1e-12);
  EXPECT_NEAR(p.residual_rms, 0.0, 1e-9);
  EXPECT_EQ(p.num_points, 100u);
  EXPECT_NEAR(p.slope_deg, std::atan(std::hypot(0.1, 0.05)) / kDeg, 1e-9);
  EXPECT_NEAR(p.normal.norm(), 1.0, 1e-12);
  EXPECT_GT(p.normal.z(), 0.0);
  EXPECT_NEAR(p.normal.x() / p.normal.z(), -0.1, 1e-12);
  EXPECT_NEAR(p.normal.y() / p.normal.z(), 0.05, 1e-12);
  EXPECT_NEAR(p.centroid.x(), 0.975, 1e-12);  // lattice offsets -5..4 times 0.05
  EXPECT_NEAR(p.centroid.z(), p.heightAt(p.centroid.x(), p.centroid.y()), 1e-12);
}

TEST(PlaneFit, HorizontalPlane) {
  const GroundPlane p = fitPlane(planePoints(0.0, 0.0, -0.2, 0.0, 0.0, 5, 0.1, 0.0));
  ASSERT_TRUE(p.valid);
  EXPECT_NEAR(p.slope_deg, 0.0, 1e-9);
  EXPECT_NEAR((p.normal - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(p.heightAt(10.0, -3.0), -0.2, 1e-12);
}

TEST(PlaneFit, NoisyPlane) {
  // A 5 deg ramp falling along y, 1 cm noise: slope within 0.1 deg, residual ~ noise.
  const double b = -std::tan(5.0 * kDeg);
  const auto pts = planePoints(0.0, b, 0.1, 2.0, 1.0, 30, 0.03, 0.01, 7);
  const GroundPlane p = fitPlane(pts);
  ASSERT_TRUE(p.valid);
  EXPECT_NEAR(p.slope_deg, 5.0, 0.1);
  const Eigen::Vector3d truth = Eigen::Vector3d(0.0, -b, 1.0).normalized();
  EXPECT_LT(std::acos(std::min(1.0, p.normal.dot(truth))) / kDeg, 0.1);
  EXPECT_NEAR(p.residual_rms, 0.01, 0.001);
}

TEST(PlaneFit, FarFromTheOriginFitsAsWellAsNearIt) {
  // Uncentred normal equations lose ~all digits here (x^2 ~ 1e12 next to 1e-4 variations).
  const double x0 = 1.0e6, y0 = -2.0e6;
  const double a = 0.02, b = 0.07;
  const double c = 5.0 - a * x0 - b * y0;  // z ~ 5 m around (x0, y0)
  const auto far = planePoints(a, b, c, x0, y0, 20, 0.05, 0.0);
  const GroundPlane p = fitPlane(far);
  ASSERT_TRUE(p.valid);
  EXPECT_NEAR(p.a, a, 1e-8);
  EXPECT_NEAR(p.b, b, 1e-8);
  EXPECT_NEAR(p.heightAt(x0, y0), 5.0, 1e-6);
  EXPECT_NEAR(p.residual_rms, 0.0, 1e-6);

  // The same ramp near the origin gives the same slope.
  const GroundPlane q = fitPlane(planePoints(a, b, 5.0, 0.0, 0.0, 20, 0.05, 0.0));
  ASSERT_TRUE(q.valid);
  EXPECT_NEAR(p.slope_deg, q.slope_deg, 1e-6);

  // Float input (the voxel grid's point type) 1 km away: float resolution there is 0.06 mm.
  PlaneFitAccumulator acc;
  for (const auto& v : planePoints(a, b, 0.0, 1000.0, 1000.0, 20, 0.05, 0.0)) {
    acc.add(Eigen::Vector3f(v.cast<float>()));
  }
  const GroundPlane f = acc.fit(PlaneFitConfig());
  ASSERT_TRUE(f.valid);
  EXPECT_NEAR(f.slope_deg, q.slope_deg, 0.05);
}

TEST(PlaneFit, TooFewPointsAreInvalid) {
  const auto pts = planePoints(0.1, 0.0, 0.0, 0.0, 0.0, 3, 0.1, 0.0);  // 9 points
  PlaneFitConfig c;
  c.min_points = 9;
  EXPECT_TRUE(fitPlane(pts, c).valid);
  c.min_points = 10;
  const GroundPlane p = fitPlane(pts, c);
  EXPECT_FALSE(p.valid);
  EXPECT_EQ(p.num_points, 9u);

  EXPECT_FALSE(fitPlane({}).valid);
  EXPECT_EQ(fitPlane({}).num_points, 0u);
  const std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 1, 0}};
  EXPECT_FALSE(fitPlane(two).valid);
  c.min_points = 3;
  const std::vector<Eigen::Vector3d> three = {{0, 0, 0}, {1, 0, 0.1}, {0, 1, 0.2}};
  const GroundPlane t = fitPlane(three, c);
  ASSERT_TRUE(t.valid);
  EXPECT_NEAR(t.a, 0.1, 1e-12);
  EXPECT_NEAR(t.b, 0.2, 1e-12);
}

TEST(PlaneFit, DegenerateGeometryIsInvalid) {
  std::vector<Eigen::Vector3d> line, spot, wall;
  for (int i = 0; i < 50; ++i) {
    line.emplace_back(0.1 * i, 0.05 * i, 0.3 * std::sin(i));                // collinear in xy
    spot.emplace_back(1.0, 2.0, 0.01 * i);                                  // one xy position
    wall.emplace_back(2.0 + 1e-4 * std::cos(i), 0.02 * i, 0.01 * (i % 7));  // vertical plane
  }
  EXPECT_FALSE(fitPlane(line).valid);
  EXPECT_FALSE(fitPlane(spot).valid);
  EXPECT_FALSE(fitPlane(wall).valid);
  EXPECT_EQ(fitPlane(line).num_points, 50u);

  // A one-voxel-wide strip (points spread over 0.1 m across) is not degenerate.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> across(-0.05, 0.05);
  std::vector<Eigen::Vector3d> strip;
  for (int i = 0; i < 50; ++i)
    strip.emplace_back(0.04 * i, across(rng), 0.0);
  EXPECT_TRUE(fitPlane(strip).valid);
}

TEST(PlaneFit, NonFinitePointsAreIgnored) {
  auto pts = planePoints(0.05, 0.0, 0.0, 0.0, 0.0, 5, 0.1, 0.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  pts.insert(pts.begin(), Eigen::Vector3d(nan, 0, 0));  // not even as the reference point
  pts.emplace_back(0, inf, 0);
  pts.emplace_back(0, 0, -inf);
  const GroundPlane p = fitPlane(pts);
  ASSERT_TRUE(p.valid);
  EXPECT_EQ(p.num_points, 25u);
  EXPECT_NEAR(p.a, 0.05, 1e-12);
}

// A grid with points integrated from a camera above: floor z = 0 on x in [0.6, 1.4], a
// 5 deg ramp point set and points 0.3 m above in the same columns.
class PlaneFitterGrid : public ::testing::Test {
 protected:
  void SetUp() override {
    VoxelGridConfig c;
    c.size_x = c.size_y = 4.0;
    grid_ = std::make_unique<VoxelGrid>(c);
    grid_->recenter(Eigen::Vector3f::Zero());
    const Eigen::Isometry3f T(Eigen::Translation3f(1.0f, 0.0f, 2.0f));
    std::vector<Eigen::Vector3f> pts;
    for (int i = 0; i < 40; ++i)
      for (int j = 0; j < 40; ++j) {
        const float x = 0.6f + 0.02f * i + 0.001f, y = -0.4f + 0.02f * j + 0.001f;
        pts.emplace_back(Eigen::Vector3f(x, y, 0.0f) - T.translation());
        pts.emplace_back(Eigen::Vector3f(x, y, 0.3f) - T.translation());
      }
    // One point per voxel per frame: integrate the points one frame each.
    std::vector<Eigen::Vector3f> one(1);
    for (const auto& p : pts) {
      one[0] = p;
      grid_->integrate(one, T);
    }
    hm_.reset(-20, -20, 40, 40);
    for (int v = -4; v <= 3; ++v)
      for (int u = 6; u <= 14; ++u)
        hm_.set(u, v, 0);
  }
  std::unique_ptr<VoxelGrid> grid_;
  HeightMap hm_;
};

TEST_F(PlaneFitterGrid, UsesOnlyThePointsAtTheSegmentsIndexedHeight) {
  GroundSegmentation seg;
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm_, VoxelIndex{10, 0, 0}, 0.1, &s));
  ASSERT_EQ(s.numSegments(), 1);
  PlaneFitConfig lists;
  lists.observation_means = false;  // 000 Sec. V-B: the voxels' point lists
  PlaneFitter fitter(lists);
  const GroundPlane p = fitter.fitSegment(*grid_, s, 0);
  ASSERT_TRUE(p.valid);
  EXPECT_NEAR(p.c, 0.0, 1e-5);
  EXPECT_NEAR(p.slope_deg, 0.0, 1e-3);
  // Columns u 6..14 (x 0.55..1.45) and v -4..3 hold the points at x 0.6..1.38, y -0.4..0.38;
  // each voxel kept at most point_list_capacity of the 25 that fell into it.
  EXPECT_GT(p.num_points, 8u * 8u * 4u);
  EXPECT_LE(p.num_points, 9u * 8u * 8u);
  // With the voxels' moments every point in the columns counts: 38 of the 40 rows
  // (y 0.361 and 0.381 lie in row v = 4, outside the segment) of 40 points.
  PlaneFitConfig means;
  means.observation_means = true;
  const GroundPlane m = PlaneFitter(means).fitSegment(*grid_, s, 0);
  ASSERT_TRUE(m.valid);
  EXPECT_NEAR(m.c, 0.0, 1e-5);
  EXPECT_NEAR(m.slope_deg, 0.0, 1e-3);
  EXPECT_EQ(m.num_points, 38u * 40u);

  // The same columns at the upper height give the upper points.
  for (auto& h : s.segment_height)
    h = 3;
  const GroundPlane q = fitter.fitSegment(*grid_, s, 0);
  ASSERT_TRUE(q.valid);
  EXPECT_NEAR(q.c, 0.3, 1e-5);
  EXPECT_EQ(q.num_points, p.num_points);

  std::vector<GroundPlane> planes(5);
  fitter.fitAll(*grid_, s, &planes);
  EXPECT_EQ(planes.size(), 1u);
  EXPECT_FALSE(fitter.fitSegment(*grid_, s, 1).valid);
  EXPECT_FALSE(fitter.fitSegment(*grid_, s, -1).valid);
  fitter.fitAll(*grid_, s, nullptr);  // no crash
}

// A noisy 6 deg ramp integrated into a grid: its band at indexed height 1 (z 0.05..0.15) cuts
// the noise off at its top and bottom, which flattens the band's least-squares slope; the
// points that spilled into the layers above and below restore it (vertical_margin).
TEST(PlaneFitter, VerticalMarginRestoresTheSlopeOfANoisyRampBand) {
  VoxelGridConfig gc;
  gc.size_x = gc.size_y = 4.0;
  VoxelGrid grid(gc);
  grid.recenter(Eigen::Vector3f::Zero());
  const double slope = std::tan(6.0 * M_PI / 180.0);
  const Eigen::Isometry3f T(Eigen::Translation3f(0.0f, 0.0f, 2.0f));
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 0.03f);
  std::vector<Eigen::Vector3f> one(1);
  for (int rep = 0; rep < 12; ++rep)
    for (int i = 0; i < 60; ++i)
      for (int j = 0; j < 20; ++j) {
        const float x = 0.0f + 0.025f * i + 0.004f * rep, y = -0.25f + 0.025f * j;
        one[0] =
            Eigen::Vector3f(x, y, static_cast<float>(slope * x) + noise(rng)) - T.translation();
        grid.integrate(one, T);
      }
  HeightMap hm;
  hm.reset(-20, -20, 40, 40);
  // The band of indexed height 1: x where the ramp is at 0.05..0.15 m.
  for (int u = 0; u < 20; ++u) {
    const double z = slope * u * 0.1;
    if (z < 0.05 || z >= 0.15) continue;
    for (int v = -2; v <= 2; ++v)
      hm.set(u, v, 1);
  }
  GroundSegmentationConfig sc;
  sc.segment_islands = true;
  sc.seed_radius = 0.0;
  sc.footprint_radius = 0.0;  // the robot's cell is far from the band: no footprint segment
  GroundSegments s;
  ASSERT_TRUE(GroundSegmentation(sc).segment(hm, VoxelIndex{-10, 0, 0}, 0.1, &s));
  ASSERT_EQ(s.numSegments(), 1);
  PlaneFitConfig band_only;
  band_only.observation_means = false;  // the lists, as in 000 Sec. V-B
  band_only.vertical_margin = 0;
  const GroundPlane p0 = PlaneFitter(band_only).fitSegment(grid, s, 0);
  PlaneFitConfig margin;
  margin.observation_means = false;
  margin.vertical_margin = 1;
  const GroundPlane p1 = PlaneFitter(margin).fitSegment(grid, s, 0);
  ASSERT_TRUE(p0.valid);
  ASSERT_TRUE(p1.valid);
  EXPECT_GT(std::abs(p0.slope_deg - 6.0), 1.0);  // flattened
  EXPECT_LT(std::abs(p1.slope_deg - 6.0), 0.7);
  EXPECT_GT(p1.num_points, p0.num_points);
}

// A level floor seen from cameras at different heights: the nearer a point along its ray, the
// higher (stereo noise in front of the surface). Each voxel's list keeps its 8 nearest points,
// so a plane on the lists stands above the floor; on the voxels' moments every point counts.
// A grid that receives one point per call, each seen from straight above by a camera whose
// height grows with the frame f: the list of a voxel keeps the earliest frames' points.
struct PointsFromAbove {
  static VoxelGridConfig config() {
    VoxelGridConfig gc;
    gc.size_x = gc.size_y = 4.0;
    return gc;
  }
  PointsFromAbove() : grid(config()) { grid.recenter(Eigen::Vector3f::Zero()); }
  void add(int f, float x, float y, float z) {
    const Eigen::Isometry3f T(Eigen::Translation3f(x, y, 1.0f + 0.05f * f));
    const std::vector<Eigen::Vector3f> one{Eigen::Vector3f(x, y, z) - T.translation()};
    grid.integrate(one, T);
    sum += z;
    ++n;
  }
  double mean() const { return sum / n; }
  VoxelGrid grid;
  double sum = 0.0;
  int n = 0;
};

// The one segment of the columns u in [0, nu), v in [v0, v1] at height index 0.
void oneSegment(int nu, int v0, int v1, GroundSegments* s) {
  HeightMap hm;
  hm.reset(-20, -20, 40, 40);
  for (int u = 0; u < nu; ++u)
    for (int v = v0; v <= v1; ++v)
      hm.set(u, v, 0);
  ASSERT_TRUE(GroundSegmentation().segment(hm, VoxelIndex{0, 0, 0}, 0.1, s));
  ASSERT_EQ(s->numSegments(), 1);
}

TEST(PlaneFitter, ObservationMeansFitEveryPointNotTheNearest) {
  PointsFromAbove pts;
  for (int f = 0; f < 40; ++f) {
    const float z = 0.02f - 0.001f * f;  // mean 0.0005 m
    for (int u = 0; u < 10; ++u)
      for (int v = -2; v <= 2; ++v)
        pts.add(f, 0.1f * u + 0.002f * (f % 7) - 0.006f, 0.1f * v + 0.002f * (f % 5), z);
  }
  GroundSegments s;
  ASSERT_NO_FATAL_FAILURE(oneSegment(10, -2, 2, &s));
  PlaneFitConfig lists;
  lists.observation_means = false;
  const GroundPlane pl = PlaneFitter(lists).fitSegment(pts.grid, s, 0);
  PlaneFitConfig means;
  means.observation_means = true;
  const GroundPlane pm = PlaneFitter(means).fitSegment(pts.grid, s, 0);
  ASSERT_TRUE(pl.valid);
  ASSERT_TRUE(pm.valid);
  EXPECT_NEAR(pl.heightAt(0.5, 0.0), 0.0165, 1e-3);  // the 8 nearest: 0.02 .. 0.013
  EXPECT_NEAR(pm.heightAt(0.5, 0.0), pts.mean(), 1e-3);
  EXPECT_NEAR(pm.slope_deg, 0.0, 0.1);
  EXPECT_EQ(pm.num_points, static_cast<std::size_t>(pts.n));
  EXPECT_EQ(pl.num_points, 8u * 50u);
}

TEST(PlaneFitter, ObservationMeansFitAStripOneCellWide) {
  // A corridor of floor one cell wide (10 x 1 cells): one mean per voxel would have no spread
  // across it and no plane; the lists' points keep their spread, moved to the voxels' means.
  PointsFromAbove pts;
  for (int f = 0; f < 30; ++f) {
    const float z = 0.03f - 0.001f * f;  // mean 0.0155 m; the 8 nearest the camera are higher
    for (int u = 0; u < 10; ++u) {
      // y in -+ +- pairs: the 8 nearest (f = 0..7) are as high on either side.
      pts.add(f, 0.1f * u + 0.003f * (f % 5) - 0.006f, (f % 4 == 0 || f % 4 == 3) ? -0.03f : 0.03f,
              z);
    }
  }
  GroundSegments s;
  ASSERT_NO_FATAL_FAILURE(oneSegment(10, 0, 0, &s));
  PlaneFitConfig means;
  means.observation_means = true;
  const GroundPlane pm = PlaneFitter(means).fitSegment(pts.grid, s, 0);
  ASSERT_TRUE(pm.valid) << "a strip one cell wide has a plane";
  EXPECT_NEAR(pm.heightAt(0.5, 0.0), pts.mean(), 2e-3);
  EXPECT_NEAR(pm.slope_deg, 0.0, 1.0);
  EXPECT_EQ(pm.num_points, static_cast<std::size_t>(pts.n));
  const GroundPlane pl = PlaneFitter(PlaneFitConfig()).fitSegment(pts.grid, s, 0);
  ASSERT_TRUE(pl.valid);
  EXPECT_GT(pl.heightAt(0.5, 0.0), pm.heightAt(0.5, 0.0) + 0.005);  // the lists sit in front
}

TEST(PlaneFitter, MassHeightsFitTheColumnsHeightsAndLeaveOutALowerSurfacesTail) {
  // A segment of band w = 0, 10 x 6 cells: the floor at z = 0.01 over v = 0..3 and, over
  // v = 4..5, the columns where a street 9 cm lower reached into the band with the upper tail
  // of its noise (10 points a frame at z = -0.04 over 90 at z = -0.09 in w = -1). Each frame is
  // dense: many points per voxel, seen from above.
  VoxelGridConfig gc;
  gc.size_x = gc.size_y = 4.0;
  VoxelGrid grid(gc);
  grid.recenter(Eigen::Vector3f::Zero());
  for (int f = 0; f < 12; ++f) {
    const Eigen::Isometry3f T(Eigen::Translation3f(0.45f, 0.25f, 2.0f));
    std::vector<Eigen::Vector3f> pts;
    for (int u = 0; u < 10; ++u) {
      for (int v = 0; v < 6; ++v) {
        for (int k = 0; k < 9; ++k) {
          const float x = 0.1f * u - 0.04f + 0.01f * k, y = 0.1f * v - 0.03f + 0.006f * k;
          if (v < 4) {
            pts.push_back(Eigen::Vector3f(x, y, 0.01f) - T.translation());
          } else {
            pts.push_back(Eigen::Vector3f(x, y, k == 0 ? -0.04f : -0.09f) - T.translation());
          }
        }
      }
    }
    grid.integrate(pts, T);
  }
  GroundSegments s;
  ASSERT_NO_FATAL_FAILURE(oneSegment(10, 0, 5, &s));
  const GroundPlane lists = PlaneFitter(PlaneFitConfig()).fitSegment(grid, s, 0);
  ASSERT_TRUE(lists.valid);
  PlaneFitConfig cfg;
  cfg.mass_heights = true;
  const GroundPlane mass = PlaneFitter(cfg).fitSegment(grid, s, 0);
  ASSERT_TRUE(mass.valid);
  // The street's columns (every point: -0.085) are off the floor's plane and left out: the
  // plane is the floor's, level at 0.01 where the street's columns begin.
  EXPECT_NEAR(mass.heightAt(0.45, 0.4), 0.01, 3e-3);
  EXPECT_LT(mass.slope_deg, 1.0);
  // Without the refits a fit to the columns' heights tilts across them; the lists hold only the
  // street's tail in the band, which drags the plane less but still lowers it.
  EXPECT_LT(lists.heightAt(0.45, 0.4), 0.01 - 2e-3);
}

TEST(PlaneFit, AWeightedPointIsThatManyEqualPoints) {
  const std::vector<Eigen::Vector3d> pts = planePoints(0.1, -0.05, 0.3, 2.0, 1.0, 5, 0.1, 0.02);
  PlaneFitAccumulator repeated, weighted;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const int w = 1 + static_cast<int>(i % 4);
    for (int k = 0; k < w; ++k)
      repeated.add(pts[i]);
    weighted.add(pts[i], static_cast<double>(w));
  }
  weighted.add(Eigen::Vector3d(0, 0, 9), 0.0);  // ignored
  weighted.add(Eigen::Vector3d(0, 0, 9), -1.0);
  weighted.add(Eigen::Vector3d(0, 0, 9), std::numeric_limits<double>::quiet_NaN());
  const GroundPlane a = repeated.fit(PlaneFitConfig()), b = weighted.fit(PlaneFitConfig());
  ASSERT_TRUE(a.valid);
  ASSERT_TRUE(b.valid);
  EXPECT_NEAR(a.a, b.a, 1e-9);
  EXPECT_NEAR(a.b, b.b, 1e-9);
  EXPECT_NEAR(a.c, b.c, 1e-9);
  EXPECT_NEAR(a.residual_rms, b.residual_rms, 1e-9);
  EXPECT_EQ(a.num_points, b.num_points);
  EXPECT_EQ(weighted.count(), pts.size());
}

TEST_F(PlaneFitterGrid, SegmentWithoutPointsIsInvalid) {
  HeightMap hm;
  hm.reset(-20, -20, 40, 40);
  for (int v = 10; v <= 15; ++v)
    for (int u = 10; u <= 15; ++u)
      hm.set(u, v, 0);  // columns that received no points
  GroundSegmentation seg;
  GroundSegments s;
  ASSERT_TRUE(seg.segment(hm, VoxelIndex{12, 12, 0}, 0.1, &s));
  ASSERT_EQ(s.numSegments(), 1);
  const GroundPlane p = PlaneFitter().fitSegment(*grid_, s, 0);
  EXPECT_FALSE(p.valid);
  EXPECT_EQ(p.num_points, 0u);
}

}  // namespace
}  // namespace stereo_safety_map
