// The per-frame pipeline of paper 000 end to end: synthetic worlds seen by a pinhole camera
// 1.1 m above the robot's base, pitched down, driven forward over 24 frames with a small yaw
// wobble and alternating pitch, points with small noise. Each world's answer is known by
// construction.
#include "stereo_safety_map/core/safety_mapper.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace {

constexpr double kDeg = M_PI / 180.0;
using L = SafetyLabel;

// ---------------------------------------------------------------------------------------------
// Synthetic world: a height field plus solid boxes, ray cast from a pinhole camera.

struct Box {
  Eigen::Vector3d lo, hi;
  /// Blocks rays but gives no point: a surface block matching does not match (an untextured
  /// table top seen edge-on).
  bool unmatched = false;
};

struct World {
  std::function<double(double, double)> ground = [](double, double) { return 0.0; };
  std::vector<Box> boxes;
};

struct Rig {
  int width = 96, height = 72;  // pixels
  double hfov_deg = 80.0;
  double camera_height = 1.1;                     // above the robot's base [m]
  double pitch_a_deg = 22.0, pitch_b_deg = 34.0;  // down, alternating frames
  double yaw_amplitude_deg = 8.0;
  int frames = 24;
  double step = 0.03;          // forward motion per frame [m]; the last frame is at x = end_x
  double sigma = 0.003;        // isotropic noise [m]
  double sigma_range = 0.001;  // along-ray noise per squared metre of range (stereo-like)
  double max_range = 8.0;
  /// The true camera pitches this much further down than the pose the frames report (a chassis
  /// tilt odometry does not know) [deg].
  double unreported_pitch_deg = 0.0;
};

double hitBox(const Box& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double t0 = 0.0, t1 = 1e9;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-12) {
      if (o[a] < b.lo[a] || o[a] > b.hi[a]) return -1.0;
      continue;
    }
    double ta = (b.lo[a] - o[a]) / d[a], tb = (b.hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return -1.0;
  }
  return t0;
}

// Distance to the first surface along o + t d (|d| = 1) within tmax, or -1.
double castRay(const World& w, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double tmax) {
  double best = tmax;
  for (const Box& b : w.boxes) {
    const double t = hitBox(b, o, d);
    if (t > 0.0 && t < best) best = t;
  }
  double t = 0.0, prev = 0.0;
  bool below = false;
  while (t < best) {
    const Eigen::Vector3d p = o + t * d;
    const double h = p.z() - w.ground(p.x(), p.y());
    if (h < 0.0) {
      below = true;
      break;
    }
    prev = t;
    t += std::clamp(0.5 * h, 0.005, 0.05);
  }
  if (!below) return best < tmax ? best : -1.0;
  double lo = prev, hi = t;
  for (int i = 0; i < 30; ++i) {
    const double mid = 0.5 * (lo + hi);
    const Eigen::Vector3d p = o + mid * d;
    (p.z() < w.ground(p.x(), p.y()) ? hi : lo) = mid;
  }
  return hi;
}

// Optical frame (x right, y down, z forward) at `pos`, yawed, pitched down by pitch_deg.
Eigen::Isometry3f cameraPose(const Eigen::Vector3d& pos, double yaw_deg, double pitch_deg) {
  Eigen::Matrix3d base;
  base.col(0) = Eigen::Vector3d(0, -1, 0);
  base.col(1) = Eigen::Vector3d(0, 0, -1);
  base.col(2) = Eigen::Vector3d(1, 0, 0);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitZ()) *
               Eigen::AngleAxisd(pitch_deg * kDeg, Eigen::Vector3d::UnitY()) * base;
  T.translation() = pos;
  return T.cast<float>();
}

struct Frame {
  std::vector<Eigen::Vector3f> points;  // sensor frame
  Eigen::Isometry3f T;                  // fixed <- sensor
  Eigen::Vector3f robot;                // base position
};

Frame render(const World& w, const Rig& rig, double x, double y, double yaw_deg, double pitch_deg,
             std::mt19937* rng) {
  Frame f;
  const double base_z = w.ground(x, y);
  f.robot = Eigen::Vector3f(x, y, base_z);
  const Eigen::Vector3d cam(x, y, base_z + rig.camera_height);
  f.T = cameraPose(cam, yaw_deg, pitch_deg);
  const Eigen::Matrix3d R = f.T.linear().cast<double>();
  const double fpx = 0.5 * rig.width / std::tan(0.5 * rig.hfov_deg * kDeg);
  std::normal_distribution<double> n01(0.0, 1.0);
  for (int j = 0; j < rig.height; ++j) {
    for (int i = 0; i < rig.width; ++i) {
      const Eigen::Vector3d ray(((i + 0.5) - 0.5 * rig.width) / fpx,
                                ((j + 0.5) - 0.5 * rig.height) / fpx, 1.0);
      const Eigen::Vector3d d = (R * ray).normalized();
      const double t = castRay(w, cam, d, rig.max_range);
      if (t < 0.0) continue;
      Eigen::Vector3d p = cam + t * d;
      const bool on_unmatched = std::any_of(w.boxes.begin(), w.boxes.end(), [&](const Box& b) {
        return b.unmatched && (p.array() >= b.lo.array() - 1e-6).all() &&
               (p.array() <= b.hi.array() + 1e-6).all();
      });
      if (on_unmatched) continue;
      p += d * (rig.sigma_range * t * t * n01(*rng));
      p += rig.sigma * Eigen::Vector3d(n01(*rng), n01(*rng), n01(*rng));
      f.points.push_back((R.transpose() * (p - cam)).cast<float>());
    }
  }
  return f;
}

std::vector<Frame> drive(const World& w, const Rig& rig = Rig(), double end_x = 0.0,
                         unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::vector<Frame> frames;
  for (int k = 0; k < rig.frames; ++k) {
    const double x = end_x - rig.step * (rig.frames - 1 - k);
    const double yaw = rig.yaw_amplitude_deg * std::sin(0.9 * k);
    const double pitch = (k % 2 == 0) ? rig.pitch_a_deg : rig.pitch_b_deg;
    Frame f = render(w, rig, x, 0.0, yaw, pitch + rig.unreported_pitch_deg, &rng);
    if (rig.unreported_pitch_deg != 0.0) {
      f.T = cameraPose(f.T.translation().cast<double>(), yaw, pitch);  // what odometry reports
    }
    frames.push_back(f);
  }
  return frames;
}

std::unique_ptr<SafetyMapper> run(const std::vector<Frame>& frames,
                                  const SafetyMapperConfig& c = SafetyMapperConfig()) {
  auto m = std::make_unique<SafetyMapper>(c);
  for (const Frame& f : frames) {
    FrameResult r;
    EXPECT_TRUE(m->integrateFrame(f.points, f.T, f.robot, &r)) << toString(r.status);
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// Map inspection.

int cellOf(double x, double l = 0.1) {
  return static_cast<int>(std::lround(x / l));
}

L labelAt(const SafetyMap& m, double x, double y) {
  return m.labelAt(cellOf(x, m.resolution), cellOf(y, m.resolution));
}

// Labels of the cells whose centres are in [x0, x1] x [y0, y1].
std::vector<int> cellsIn(const SafetyMap& m, double x0, double x1, double y0, double y1) {
  std::vector<int> cells;
  for (int v = cellOf(y0, m.resolution); v <= cellOf(y1, m.resolution); ++v)
    for (int u = cellOf(x0, m.resolution); u <= cellOf(x1, m.resolution); ++u)
      if (m.inside(u, v)) cells.push_back(m.index(u, v));
  return cells;
}

int countLabel(const SafetyMap& m, const std::vector<int>& cells, L l) {
  return static_cast<int>(
      std::count_if(cells.begin(), cells.end(), [&](int c) { return m.labels[c] == l; }));
}

// ASCII picture for failure messages: x up the page, +y to the left.
std::string ascii(const SafetyMap& m, double x0 = -0.5, double x1 = 4.1, double half_y = 2.0) {
  static const char kCh[] = {' ', '?', '.', '/', '#'};
  std::string s =
      "\n(' ' Unexamined, ? Unknown, . Level, / Inclined, # Non-ground, D drop-off, R robot)\n";
  for (int u = cellOf(x1); u >= cellOf(x0); --u) {
    char buf[16];
    std::snprintf(buf, sizeof(buf), "%5.1f ", u * m.resolution);
    s += buf;
    for (int v = cellOf(half_y); v >= -cellOf(half_y); --v) {
      if (!m.inside(u, v)) {
        s += 'x';
      } else if (u == m.robot_u && v == m.robot_v) {
        s += 'R';
      } else {
        const int c = m.index(u, v);
        s += m.drop_off[c] ? 'D' : kCh[static_cast<int>(m.labels[c])];
      }
    }
    s += '\n';
  }
  return s;
}

// A pose 5 cm ahead of T: never stationary with respect to T.
Eigen::Isometry3f movedPose(const Eigen::Isometry3f& T) {
  Eigen::Isometry3f M = T;
  M.translation().x() += 0.05f;
  return M;
}

const SegmentInfo* robotSegment(const SafetyMap& m) {
  return m.robot_segment >= 0 ? &m.segments[m.robot_segment] : nullptr;
}

// ---------------------------------------------------------------------------------------------

TEST(SafetyMapperConfig, DefaultsAndValidate) {
  SafetyMapperConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_DOUBLE_EQ(c.stationary_translation, 0.01);
  EXPECT_DOUBLE_EQ(c.grid_look_ahead, 1.0);
  EXPECT_DOUBLE_EQ(c.stationary_rotation_deg, 1.0);
  EXPECT_TRUE(c.skip_stationary_frames);
  EXPECT_TRUE(c.scroll_with_robot);
  c.labelling.max_slope_deg = -1.0;
  EXPECT_EQ(c.validate().rfind("labelling.max_slope_deg", 0), 0u) << c.validate();
  EXPECT_THROW(SafetyMapper{c}, std::invalid_argument);
  c = SafetyMapperConfig();
  c.segmentation.connectivity = 5;
  EXPECT_EQ(c.validate().rfind("segmentation.connectivity", 0), 0u) << c.validate();
  c = SafetyMapperConfig();
  c.plane_fit.min_points = 0;
  EXPECT_EQ(c.validate().rfind("plane_fit.min_points", 0), 0u) << c.validate();
  c = SafetyMapperConfig();
  c.height_map.robot_height = -1.0;
  EXPECT_EQ(c.validate().rfind("height_map.robot_height", 0), 0u) << c.validate();
  c = SafetyMapperConfig();
  c.grid.voxel_size = 0.0;
  EXPECT_EQ(c.validate().rfind("grid.", 0), 0u) << c.validate();
  c = SafetyMapperConfig();
  c.stationary_translation = -0.1;
  EXPECT_NE(c.validate().find("stationary_translation"), std::string::npos);
  c = SafetyMapperConfig();
  c.stationary_rotation_deg = std::nan("");
  EXPECT_NE(c.validate().find("stationary_rotation_deg"), std::string::npos);
}

TEST(SafetyMapper, FlatFloorIsOneLevelSegmentAndFarCellsAreUnexamined) {
  World w;
  const auto mapper = run(drive(w));
  const SafetyMap& m = mapper->safetyMap();
  ASSERT_NE(robotSegment(m), nullptr) << ascii(m);
  const SegmentInfo& floor = *robotSegment(m);
  EXPECT_EQ(floor.label, L::kLevel);
  EXPECT_LT(floor.plane.slope_deg, 0.5);
  EXPECT_NEAR(floor.plane.c, 0.0, 0.01);
  int safe_segments = 0;
  for (const auto& s : m.segments)
    safe_segments += isSafe(s.label);
  EXPECT_EQ(safe_segments, 1) << ascii(m);
  EXPECT_GT(floor.cells.size(), 1000u);

  const auto ahead = cellsIn(m, 0.8, 3.5, -0.5, 0.5);
  EXPECT_EQ(countLabel(m, ahead, L::kLevel), static_cast<int>(ahead.size())) << ascii(m);
  // No obstacle where the floor is well observed. (At the field of view's far corners an
  // observed cell cut off from the floor by unobserved ones is, by Alg. 1, non-traversable.)
  EXPECT_EQ(countLabel(m, cellsIn(m, 0.0, 3.5, -1.5, 1.5), L::kNonGround), 0) << ascii(m);

  // Alg. 1 step 3: exactly the cells farther than R_max = 4 m from the robot's cell.
  ASSERT_EQ(m.robot_u, 0);
  ASSERT_EQ(m.robot_v, 0);
  for (int v = m.min_v; v < m.min_v + m.height; ++v) {
    for (int u = m.min_u; u < m.min_u + m.width; ++u) {
      const bool far = u * u + v * v > 40 * 40;
      ASSERT_EQ(m.labelAt(u, v) == L::kUnexamined, far) << u << " " << v;
    }
  }
  EXPECT_EQ(labelAt(m, 4.5, 0.0), L::kUnexamined);
  EXPECT_EQ(labelAt(m, 3.9, 0.0), L::kLevel);
  EXPECT_EQ(labelAt(m, -0.5, 0.0), L::kUnknown);  // behind the robot: never seen
}

TEST(SafetyMapper, FiveDegreeRampIsInclinedWithTheRightNormal) {
  World w;
  const double slope = std::tan(5.0 * kDeg);
  w.ground = [slope](double x, double) { return x < 1.0 ? 0.0 : (x - 1.0) * slope; };
  const auto mapper = run(drive(w));
  const SafetyMap& m = mapper->safetyMap();
  ASSERT_NE(robotSegment(m), nullptr) << ascii(m);
  EXPECT_EQ(robotSegment(m)->label, L::kLevel);
  EXPECT_EQ(countLabel(m, cellsIn(m, 0.4, 0.9, -0.3, 0.3), L::kLevel), 6 * 7) << ascii(m);
  const auto ramp = cellsIn(m, 1.8, 3.5, -0.5, 0.5);
  EXPECT_EQ(countLabel(m, ramp, L::kInclined), static_cast<int>(ramp.size())) << ascii(m);

  const Eigen::Vector3d truth(-std::sin(5.0 * kDeg), 0.0, std::cos(5.0 * kDeg));
  int inclined = 0;
  for (const auto& s : m.segments) {
    if (s.label != L::kInclined || s.cells.size() < 50) continue;
    ++inclined;
    EXPECT_LT(std::acos(std::min(1.0, s.plane.normal.dot(truth))) / kDeg, 0.5)
        << "segment " << s.id << " slope " << s.plane.slope_deg;
    EXPECT_TRUE(s.reachable);
  }
  EXPECT_GE(inclined, 2);  // the ramp rises 0.1 m (one voxel) every 1.14 m
}

TEST(SafetyMapper, FifteenDegreeRampIsNonGround) {
  World w;
  const double slope = std::tan(15.0 * kDeg);
  w.ground = [slope](double x, double) { return x < 1.0 ? 0.0 : (x - 1.0) * slope; };
  const auto mapper = run(drive(w));
  const SafetyMap& m = mapper->safetyMap();
  ASSERT_NE(robotSegment(m), nullptr) << ascii(m);
  EXPECT_EQ(robotSegment(m)->label, L::kLevel);
  const auto ramp = cellsIn(m, 1.3, 3.5, -0.5, 0.5);
  EXPECT_EQ(countLabel(m, ramp, L::kLevel) + countLabel(m, ramp, L::kInclined), 0) << ascii(m);
  EXPECT_GE(countLabel(m, ramp, L::kNonGround), static_cast<int>(0.9 * ramp.size())) << ascii(m);
  int steep = 0;
  for (const auto& s : m.segments) {
    if (s.indexed_height < 1 || s.cells.size() < 50) continue;
    ++steep;
    EXPECT_NEAR(s.plane.slope_deg, 15.0, 1.0);
    EXPECT_EQ(s.label, L::kNonGround);
  }
  EXPECT_GE(steep, 4);
}

TEST(SafetyMapper, DropOfTwentyCentimetres) {
  World w;
  w.ground = [](double x, double) { return x < 2.0 ? 0.0 : -0.2; };
  const auto mapper = run(drive(w));
  const SafetyMap& m = mapper->safetyMap();
  const auto upper = cellsIn(m, 0.5, 1.8, -0.5, 0.5);
  EXPECT_EQ(countLabel(m, upper, L::kLevel), static_cast<int>(upper.size())) << ascii(m);
  const auto lower = cellsIn(m, 2.5, 3.5, -0.5, 0.5);
  EXPECT_EQ(countLabel(m, lower, L::kNonGround), static_cast<int>(lower.size())) << ascii(m);
  // The occluded band behind the edge is Unknown and the edge is a potential drop-off.
  EXPECT_EQ(labelAt(m, 2.2, 0.0), L::kUnknown) << ascii(m);
  for (int v = -5; v <= 5; ++v) {
    bool edge = false;
    for (int u = 18; u <= 20; ++u)
      edge = edge || m.drop_off[m.index(u, v)];
    EXPECT_TRUE(edge) << "row v = " << v << ascii(m);
  }
  for (int c : cellsIn(m, -5.0, 1.7, -5.0, 5.0))
    EXPECT_EQ(m.drop_off[c], 0) << ascii(m);
  for (int c = 0; c < static_cast<int>(m.drop_off.size()); ++c) {
    if (m.drop_off[c]) {
      EXPECT_TRUE(isSafe(m.labels[c]));
    }
  }
}

TEST(SafetyMapper, FourCentimetreStepIsReachableTenCentimetreStepIsNot) {
  for (const double step : {0.04, 0.10}) {
    World w;
    const double base = step < 0.05 ? 0.03 : 0.0;  // both step sizes cross a voxel boundary
    w.ground = [base, step](double x, double) { return x < 1.8 ? base : base + step; };
    const auto mapper = run(drive(w));
    const SafetyMap& m = mapper->safetyMap();
    ASSERT_NE(robotSegment(m), nullptr) << ascii(m);
    const auto beyond = cellsIn(m, 2.0, 3.5, -0.5, 0.5);
    const L expect = step < 0.05 ? L::kLevel : L::kNonGround;
    EXPECT_EQ(countLabel(m, beyond, expect), static_cast<int>(beyond.size()))
        << "step " << step << ascii(m);
    // The upper level is its own segment: reachability, not the segmentation, decided.
    const int seg = m.segment[m.index(30, 0)];
    ASSERT_GE(seg, 0);
    EXPECT_NE(seg, m.robot_segment);
    EXPECT_NEAR(m.segments[seg].plane.c, base + step, 0.01);
    EXPECT_EQ(m.segments[seg].reachable, step < 0.05);
  }
}

TEST(SafetyMapper, ASunkenFloorLowerThanAVoxelIsNotLevel) {
  // 6.5 cm down into a sunken area, from a floor 3 cm above the base voxel's centre to one
  // 3.5 cm below it: both levels in the robot's voxel band (l_v = 0.1 m), as wherever a step
  // lower than a voxel does not happen to cross a voxel boundary. 000's Alg. 1 grows one segment
  // over both and its plane is level across the step (split_steps off).
  World w;
  w.ground = [](double x, double y) {
    return (x > 1.8 && x < 3.6 && std::abs(y) < 1.2) ? -0.035 : 0.03;
  };
  Rig rig;
  rig.sigma = 0.008;
  const auto frames = drive(w, rig);
  SafetyMapperConfig paper_rule;
  paper_rule.segmentation.split_steps = false;
  const auto merged = run(frames, paper_rule);
  const auto sunken = cellsIn(merged->safetyMap(), 2.1, 3.3, -0.8, 0.8);
  const auto upper = cellsIn(merged->safetyMap(), 0.6, 1.5, -0.8, 0.8);
  EXPECT_GT(countLabel(merged->safetyMap(), sunken, L::kLevel), static_cast<int>(sunken.size()) / 2)
      << "the case this test is about no longer arises" << ascii(merged->safetyMap());

  const auto mapper = run(frames);
  const SafetyMap& m = mapper->safetyMap();
  EXPECT_EQ(countLabel(m, sunken, L::kLevel) + countLabel(m, sunken, L::kInclined), 0) << ascii(m);
  EXPECT_GT(countLabel(m, sunken, L::kNonGround), static_cast<int>(sunken.size()) * 9 / 10)
      << ascii(m);
  EXPECT_EQ(countLabel(m, upper, L::kNonGround), 0) << ascii(m);
  EXPECT_GT(countLabel(m, upper, L::kLevel), static_cast<int>(upper.size()) * 95 / 100) << ascii(m);
  const int lower = m.segment[m.index(cellOf(2.8), 0)];
  ASSERT_GE(lower, 0) << ascii(m);
  EXPECT_NE(lower, m.robot_segment);
  EXPECT_EQ(m.segments[lower].indexed_height, robotSegment(m)->indexed_height);
  EXPECT_NEAR(m.segments[lower].plane.c, -0.035, 0.02);
}

TEST(SafetyMapper, BoxIsNonGround) {
  World w;
  w.boxes.push_back({{2.0, -0.3, -0.1}, {2.4, 0.3, 0.5}});
  const auto mapper = run(drive(w));
  const SafetyMap& m = mapper->safetyMap();
  const auto box = cellsIn(m, 2.05, 2.3, -0.25, 0.25);
  EXPECT_EQ(countLabel(m, box, L::kNonGround), static_cast<int>(box.size())) << ascii(m);
  for (int c : box)
    EXPECT_EQ(m.column_height[c], 5);  // the box's top at 0.5 m
  const auto front = cellsIn(m, 1.0, 1.8, -0.5, 0.5);
  EXPECT_EQ(countLabel(m, front, L::kLevel), static_cast<int>(front.size())) << ascii(m);
  EXPECT_EQ(labelAt(m, 2.0, 0.6), L::kLevel);  // beside the box
}

TEST(SafetyMapper, OverhangAboveTheRobotIsIgnoredBelowItIsNonGround) {
  // A slab 1.6-1.7 m up (robot height 1.5 m): the camera, pitched up a little, sees its face and
  // underside.
  Rig rig;
  rig.pitch_a_deg = 10.0;
  rig.pitch_b_deg = 30.0;
  World high;
  high.boxes.push_back({{2.0, -1.0, 1.6}, {3.0, 1.0, 1.7}});
  const auto mh = run(drive(high, rig));
  const SafetyMap& m = mh->safetyMap();
  int seen = 0;  // the slab is in the grid, so the test is not vacuous
  for (int u = 20; u <= 30; ++u)
    for (int v = -10; v <= 10; ++v)
      seen += mh->grid().isOccupied({u, v, 16}) + mh->grid().isOccupied({u, v, 17});
  EXPECT_GT(seen, 20);
  const auto under = cellsIn(m, 1.9, 3.1, -1.0, 1.0);
  EXPECT_EQ(countLabel(m, under, L::kNonGround), 0) << ascii(m);
  const auto core = cellsIn(m, 2.1, 2.9, -0.5, 0.5);
  EXPECT_EQ(countLabel(m, core, L::kLevel), static_cast<int>(core.size())) << ascii(m);
  for (int c : core)
    EXPECT_EQ(m.column_height[c], 0);

  // The same slab 0.6-0.7 m up, seen from the standard rig (its top is seen at a grazing angle
  // when the camera looks up, and free-space updates then thin it out).
  World low;
  low.boxes.push_back({{2.0, -1.0, 0.6}, {3.0, 1.0, 0.7}});
  const auto ml = run(drive(low));
  const SafetyMap& n = ml->safetyMap();
  const auto slab = cellsIn(n, 2.1, 2.8, -0.8, 0.8);
  EXPECT_EQ(countLabel(n, slab, L::kNonGround), static_cast<int>(slab.size())) << ascii(n);
  EXPECT_EQ(labelAt(n, 1.5, 0.0), L::kLevel);

  // With a 2 m tall robot the high slab blocks as well.
  SafetyMapperConfig tall;
  tall.height_map.robot_height = 2.0;
  const auto mt = run(drive(high, rig), tall);
  EXPECT_GT(countLabel(mt->safetyMap(), under, L::kNonGround), 20) << ascii(mt->safetyMap());
}

// 000 Alg. 2 steps 3-4 (small_obstacles off): small and thin segments are Unknown.
TEST(SafetyMapper, SmallAndThinSegmentsAreUnknown) {
  World w;
  // A 0.08 m square block 0.1 m high inside one cell (small segment) and a rail one cell wide,
  // 0.8 m long, 0.1 m high (thin segment).
  w.boxes.push_back({{1.96, -0.54, -0.1}, {2.04, -0.46, 0.1}});
  w.boxes.push_back({{2.46, 0.05, -0.1}, {2.54, 0.85, 0.1}});
  SafetyMapperConfig paper_rule;
  paper_rule.labelling.small_obstacles = false;
  const auto mapper = run(drive(w), paper_rule);
  const SafetyMap& m = mapper->safetyMap();
  const int small = m.segment[m.index(20, -5)];
  ASSERT_GE(small, 0) << ascii(m);
  EXPECT_EQ(m.segments[small].indexed_height, 1);
  EXPECT_LT(m.segments[small].cells.size(), 6u);
  EXPECT_EQ(m.labelAt(20, -5), L::kUnknown) << ascii(m);

  const int thin = m.segment[m.index(25, 4)];
  ASSERT_GE(thin, 0) << ascii(m);
  const SegmentInfo& t = m.segments[thin];
  EXPECT_EQ(t.indexed_height, 1);
  EXPECT_GE(t.cells.size(), 6u);  // not small: thin
  EXPECT_LT(t.num_interior, 0.1 * t.num_boundary);
  EXPECT_EQ(t.label, L::kUnknown);
  for (int c : t.cells)
    EXPECT_EQ(m.labels[c], L::kUnknown);

  const auto around = cellsIn(m, 1.0, 1.8, -0.8, 0.8);
  EXPECT_EQ(countLabel(m, around, L::kLevel), static_cast<int>(around.size())) << ascii(m);
}

// The same block and rail with the default rules: 10 cm above the floor beside them (> h_T),
// they are the tops of low obstacles, Non-ground (SafetyLabellingConfig::small_obstacles).
TEST(SafetyMapper, SmallAndThinSegmentsAboveTheFloorAreObstacles) {
  World w;
  w.boxes.push_back({{1.96, -0.54, -0.1}, {2.04, -0.46, 0.1}});
  w.boxes.push_back({{2.46, 0.05, -0.1}, {2.54, 0.85, 0.1}});
  const auto mapper = run(drive(w));
  const SafetyMap& m = mapper->safetyMap();
  EXPECT_EQ(m.labelAt(20, -5), L::kNonGround) << ascii(m);
  for (int v = 1; v <= 8; ++v)
    EXPECT_EQ(m.labelAt(25, v), L::kNonGround) << v << ascii(m);
  const auto around = cellsIn(m, 1.0, 1.8, -0.8, 0.8);
  EXPECT_EQ(countLabel(m, around, L::kLevel), static_cast<int>(around.size())) << ascii(m);
}

TEST(SafetyMapper, StationaryFramesAreSkipped) {
  World w;
  std::mt19937 rng(3);
  const Frame f0 = render(w, Rig(), 0.0, 0.0, 0.0, 30.0, &rng);
  SafetyMapperConfig paper;
  paper.stationary_warmup_frames = 0;  // 000 Sec. IV: from the second frame on
  SafetyMapper m(paper);
  FrameResult r;
  ASSERT_TRUE(m.integrateFrame(f0.points, f0.T, f0.robot, &r));  // the first frame always
  EXPECT_EQ(r.status, FrameStatus::kIntegrated);
  EXPECT_EQ(m.grid().frameCount(), 1u);

  EXPECT_FALSE(m.integrateFrame(f0.points, f0.T, f0.robot, &r));
  EXPECT_EQ(r.status, FrameStatus::kStationary);
  EXPECT_NE(std::string(toString(r.status)).find("stationary"), std::string::npos);
  EXPECT_EQ(m.grid().frameCount(), 1u);

  auto moved = [&](double dx, double yaw_deg) {
    Eigen::Isometry3f T = f0.T;
    T.translation().x() += static_cast<float>(dx);
    T.linear() = Eigen::AngleAxisf(static_cast<float>(yaw_deg * kDeg), Eigen::Vector3f::UnitZ()) *
                 T.linear();
    return T;
  };
  EXPECT_FALSE(m.integrateFrame(f0.points, moved(0.005, 0.5), f0.robot, &r));
  EXPECT_EQ(r.status, FrameStatus::kStationary);
  // Creeping: compared with the last integrated pose, not the last frame.
  EXPECT_FALSE(m.integrateFrame(f0.points, moved(0.008, 0.0), f0.robot, &r));
  ASSERT_TRUE(m.integrateFrame(f0.points, moved(0.015, 0.0), f0.robot, &r));
  EXPECT_EQ(m.grid().frameCount(), 2u);
  ASSERT_TRUE(m.integrateFrame(f0.points, moved(0.03, 1.5), f0.robot, &r));  // rotation alone
  EXPECT_EQ(m.framesIntegrated(), 3u);

  SafetyMapperConfig c = paper;
  c.skip_stationary_frames = false;
  SafetyMapper all(c);
  EXPECT_TRUE(all.integrateFrame(f0.points, f0.T, f0.robot, &r));
  EXPECT_TRUE(all.integrateFrame(f0.points, f0.T, f0.robot, &r));
  EXPECT_EQ(all.grid().frameCount(), 2u);

  // After reset() the next frame is a first frame again.
  m.reset();
  EXPECT_TRUE(m.safetyMap().labels.empty());
  EXPECT_TRUE(m.integrateFrame(f0.points, moved(0.03, 1.5), f0.robot, &r));
}

TEST(SafetyMapper, AChairSwitchedOnAtRestSeesItsObstaclesBeforeItMoves) {
  // The camera stands 1.6 m in front of a box; sensor noise differs from frame to frame.
  World w;
  w.boxes.push_back({{1.6, -0.3, -0.1}, {2.0, 0.3, 0.5}});
  std::mt19937 rng(5);
  std::vector<Frame> at_rest;
  for (int k = 0; k < 14; ++k)
    at_rest.push_back(render(w, Rig(), 0.0, 0.0, 0.0, 30.0, &rng));
  auto standStill = [&](const SafetyMapperConfig& c, int* integrated) {
    auto m = std::make_unique<SafetyMapper>(c);
    *integrated = 0;
    for (const Frame& f : at_rest) {
      FrameResult r;
      if (m->integrateFrame(f.points, f.T, f.robot, &r)) ++*integrated;
    }
    return m;
  };
  SafetyMapperConfig ours;
  ASSERT_EQ(ours.stationary_warmup_frames, 10);  // occ_t / incr_H
  int n = 0;
  const auto m = standStill(ours, &n);
  EXPECT_EQ(n, 10);  // the warm-up, then 000's skipping
  const auto box = cellsIn(m->safetyMap(), 1.7, 1.9, -0.2, 0.2);  // its front and top
  ASSERT_FALSE(box.empty());
  EXPECT_EQ(countLabel(m->safetyMap(), box, L::kNonGround), static_cast<int>(box.size()))
      << ascii(m->safetyMap());
  EXPECT_EQ(labelAt(m->safetyMap(), 1.0, 0.0), L::kLevel) << ascii(m->safetyMap());

  // 000 Sec. IV: the first frame alone, on which no voxel reaches occ_t.
  EXPECT_EQ(paperFaithful(ours).stationary_warmup_frames, 0);
  // The grid's sensor model too (000 Sec. IV: incr_L on both neighbours, always).
  SafetyMapperConfig model = ours;
  model.grid.neighbour_sigmas = 2.0;
  model.grid.incr_low_fore = 0;
  EXPECT_EQ(paperFaithful(model).grid.neighbour_sigmas, 0.0);
  EXPECT_EQ(paperFaithful(model).grid.incr_low_fore, -1);
  EXPECT_EQ(paperFaithful(model).grid.incr_low, model.grid.incr_low);
  SafetyMapperConfig skip_all = ours;
  skip_all.stationary_warmup_frames = 0;
  const auto p = standStill(skip_all, &n);
  EXPECT_EQ(n, 1);
  EXPECT_EQ(countLabel(p->safetyMap(), box, L::kNonGround), 0) << ascii(p->safetyMap());

  // A reset starts the warm-up again.
  m->reset();
  FrameResult r;
  for (int k = 0; k < 3; ++k) {
    EXPECT_TRUE(m->integrateFrame(at_rest[k].points, at_rest[k].T, at_rest[k].robot, &r));
  }
}

TEST(SafetyMapper, BadInputLeavesTheMapUncorrupted) {
  World w;
  w.boxes.push_back({{2.0, -0.3, -0.1}, {2.4, 0.3, 0.5}});
  const std::vector<Frame> frames = drive(w);
  const auto reference = run(frames);

  // Same frames with NaN / inf points and points outside the grid (high up, their rays cross
  // nothing) appended: the same map.
  std::vector<Frame> dirty = frames;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (Frame& f : dirty) {
    const Eigen::Isometry3f inv = f.T.inverse();
    f.points.emplace_back(nan, 0.0f, 1.0f);
    f.points.emplace_back(0.0f, inf, 1.0f);
    f.points.emplace_back(-inf, nan, inf);
    for (int i = 0; i < 20; ++i)
      f.points.push_back(inv * Eigen::Vector3f(0.1f * i, 7.0f, 1.0f));
  }
  SafetyMapper m;
  for (const Frame& f : dirty) {
    FrameResult r;
    ASSERT_TRUE(m.integrateFrame(f.points, f.T, f.robot, &r));
    EXPECT_EQ(r.integration.points_non_finite, 3u);
    EXPECT_GT(r.integration.points_outside_grid, 0u);
  }
  EXPECT_EQ(m.safetyMap().labels, reference->safetyMap().labels);
  EXPECT_EQ(m.safetyMap().column_height, reference->safetyMap().column_height);

  // Frames that must be rejected whole.
  const std::vector<SafetyLabel> before = m.safetyMap().labels;
  const std::uint32_t count = m.grid().frameCount();
  const Frame& last = frames.back();
  FrameResult r;
  EXPECT_FALSE(m.integrateFrame({}, last.T, last.robot, &r));
  EXPECT_EQ(r.status, FrameStatus::kEmptyInput);

  Eigen::Isometry3f far = last.T;
  far.translation() = Eigen::Vector3f(0.0f, 0.0f, 50.0f);  // above the 3 m window
  EXPECT_FALSE(m.integrateFrame(last.points, far, last.robot, &r));
  EXPECT_EQ(r.status, FrameStatus::kCameraOutsideGrid);

  Eigen::Isometry3f bad = last.T;
  bad.translation().x() = nan;
  EXPECT_FALSE(m.integrateFrame(last.points, bad, last.robot, &r));
  EXPECT_EQ(r.status, FrameStatus::kInvalidPose);
  bad = last.T;
  bad.linear() *= 2.0f;  // not rigid
  EXPECT_FALSE(m.integrateFrame(last.points, bad, last.robot, &r));
  EXPECT_EQ(r.status, FrameStatus::kInvalidPose);

  EXPECT_FALSE(m.integrateFrame(last.points, movedPose(last.T), Eigen::Vector3f(0, inf, 0), &r));
  EXPECT_EQ(r.status, FrameStatus::kInvalidRobotPosition);

  std::vector<Eigen::Vector3f> all_nan(100, Eigen::Vector3f(nan, nan, nan));
  EXPECT_FALSE(m.integrateFrame(all_nan, last.T, last.robot, &r));  // stationary as well
  EXPECT_EQ(m.grid().frameCount(), count);
  EXPECT_EQ(m.safetyMap().labels, before);
  EXPECT_FALSE(m.integrateFrame(last.points, last.T, last.robot, nullptr));  // no crash

  // A frame of NaN points from a new pose is integrated and changes nothing.
  ASSERT_TRUE(m.integrateFrame(all_nan, movedPose(last.T), last.robot, &r));
  EXPECT_EQ(r.integration.points_non_finite, 100u);
  EXPECT_EQ(m.safetyMap().labels, before);

  // A non-finite robot position for the map alone: nothing is labelled.
  const SafetyMap& empty = m.computeSafetyMap(Eigen::Vector3f(nan, 0, 0));
  EXPECT_TRUE(empty.segments.empty());
  for (auto l : empty.labels)
    EXPECT_EQ(l, L::kUnknown);
  EXPECT_EQ(m.computeSafetyMap(last.robot).labels, before);
}

TEST(SafetyMapper, GridScrollsWithTheRobot) {
  World w;
  Rig rig;
  rig.step = 0.1;  // 2.3 m in 24 frames
  const auto frames = drive(w, rig, 2.0);
  SafetyMapperConfig centred;
  centred.grid_look_ahead = 0.0;
  const auto scrolling = run(frames, centred);
  const SafetyMap& m = scrolling->safetyMap();
  EXPECT_EQ(m.robot_u, 20);
  EXPECT_EQ(m.min_u, 20 - 50);
  EXPECT_EQ(scrolling->grid().minIndex().u, 20 - 50);
  EXPECT_EQ(labelAt(m, 5.0, 0.0), L::kLevel) << ascii(m, 1.5, 6.1);

  // Centred 1 m ahead of the robot along the camera's heading (+x): the window reaches 6 m
  // ahead of the robot and R_max = 4 m behind it, and the map within R_max is the same.
  const auto ahead = run(frames);
  const SafetyMap& a = ahead->safetyMap();
  EXPECT_EQ(a.robot_u, 20);
  EXPECT_EQ(a.min_u, 20 + 10 - 50);
  EXPECT_TRUE(a.inside(cellOf(2.0 + 5.9), 0));
  EXPECT_EQ(labelAt(a, 5.0, 0.0), L::kLevel) << ascii(a, 1.5, 6.1);
  EXPECT_EQ(labelAt(a, 1.5, 0.0), labelAt(m, 1.5, 0.0));
  SafetyMapperConfig too_far;
  too_far.grid_look_ahead = 1.5;  // 5 m - 1.5 m < R_max
  EXPECT_NE(too_far.validate().find("grid_look_ahead"), std::string::npos);
  // A window narrower than 2 R_max allows no look-ahead but is valid centred on the robot.
  SafetyMapperConfig small;
  small.grid.size_x = small.grid.size_y = 5.0;
  EXPECT_NE(small.validate().find("grid_look_ahead"), std::string::npos);
  small.grid_look_ahead = 0.0;
  EXPECT_EQ(small.validate(), "");

  SafetyMapperConfig fixed = centred;
  fixed.scroll_with_robot = false;
  const auto still = run(frames, fixed);
  const SafetyMap& n = still->safetyMap();
  EXPECT_EQ(n.min_u, -3 - 50);  // placed by the first frame at x = -0.3
  EXPECT_EQ(n.robot_u, 20);
  EXPECT_EQ(labelAt(n, 1.5, 0.0), L::kLevel) << ascii(n, -0.5, 2.0);
  EXPECT_FALSE(n.inside(cellOf(5.0), 0));
}

// ---------------------------------------------------------------------------------------------
// Aging (observation_age.h): what the map can no longer vouch for.

// The frames of drive() stamped 0.0, 0.1, 0.2, ... s.
std::unique_ptr<SafetyMapper> runStamped(const std::vector<Frame>& frames,
                                         const SafetyMapperConfig& c) {
  auto m = std::make_unique<SafetyMapper>(c);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    FrameResult r;
    EXPECT_TRUE(m->integrateFrame(frames[k].points, frames[k].T, frames[k].robot, 0.1 * k, &r))
        << toString(r.status);
  }
  return m;
}

// Only the points of `f` whose fixed-frame x is at least x_min.
Frame keepBeyond(const Frame& f, double x_min) {
  Frame g = f;
  g.points.clear();
  for (const Eigen::Vector3f& p : f.points)
    if ((f.T * p).x() >= x_min) g.points.push_back(p);
  return g;
}

// Every cell is either unchanged or went from safe to Unknown.
void expectOnlySafeBecameUnknown(const SafetyMap& before, const SafetyMap& after) {
  ASSERT_EQ(before.labels.size(), after.labels.size());
  ASSERT_EQ(before.min_u, after.min_u);
  ASSERT_EQ(before.min_v, after.min_v);
  for (std::size_t k = 0; k < after.labels.size(); ++k) {
    if (after.labels[k] == before.labels[k]) continue;
    EXPECT_TRUE(isSafe(before.labels[k]) && after.labels[k] == L::kUnknown)
        << "cell " << k << ": " << toString(before.labels[k]) << " -> "
        << toString(after.labels[k]);
  }
}

World floorWithBox() {
  World w;
  w.boxes.push_back({{2.0, -0.3, -0.1}, {2.4, 0.3, 0.5}});
  return w;
}

TEST(SafetyMapperAging, DefaultsAndValidate) {
  SafetyMapperConfig c;
  EXPECT_DOUBLE_EQ(c.max_cell_age, 30.0);
  c.max_cell_age = 0.0;  // off
  EXPECT_EQ(c.validate(), "");
  c.max_cell_age = -1.0;
  EXPECT_NE(c.validate().find("max_cell_age"), std::string::npos);
  c.max_cell_age = std::nan("");
  EXPECT_NE(c.validate().find("max_cell_age"), std::string::npos);
  c.max_cell_age = 1e6;
  EXPECT_NE(c.validate().find("max_cell_age"), std::string::npos);
}

TEST(SafetyMapperAging, CellsNotReObservedFallBackToUnknownObstaclesStay) {
  const std::vector<Frame> frames = drive(floorWithBox());
  SafetyMapperConfig c;
  c.max_cell_age = 5.0;
  const auto m = runStamped(frames, c);  // last frame at t = 2.3 s
  const SafetyMap fresh = m->safetyMap();
  // (3.0, 0.0) lies in the box's shadow: the far floor is checked at y = 1 m.
  ASSERT_EQ(labelAt(fresh, 1.3, 1.0), L::kLevel) << ascii(fresh);
  ASSERT_EQ(labelAt(fresh, 3.0, 1.0), L::kLevel) << ascii(fresh);
  ASSERT_EQ(labelAt(fresh, 2.2, 0.0), L::kNonGround) << ascii(fresh);
  EXPECT_DOUBLE_EQ(m->latestTime(), 2.3);
  EXPECT_EQ(m->cellsAged(), 0u);

  // At t = 10 a frame (from a new pose, so integrated) that only sees beyond x = 2.5.
  const Frame far = keepBeyond(frames.back(), 2.5);
  FrameResult r;
  ASSERT_TRUE(m->integrateFrame(far.points, movedPose(far.T), far.robot, 10.0, &r));
  const SafetyMap& aged = m->safetyMap();
  EXPECT_EQ(labelAt(aged, 1.3, 1.0), L::kUnknown) << ascii(aged);    // last seen at 2.3 s
  EXPECT_EQ(labelAt(aged, 3.0, 1.0), L::kLevel) << ascii(aged);      // seen at 10 s
  EXPECT_EQ(labelAt(aged, 2.2, 0.0), L::kNonGround) << ascii(aged);  // obstacles stay
  EXPECT_GT(r.cells_aged, 0u);
  EXPECT_EQ(r.cells_aged, m->cellsAged());

  // The same map without aging is the fresh one plus the new frame: aging only turned safe
  // cells Unknown, and exactly r.cells_aged of them.
  SafetyMapperConfig off = c;
  off.max_cell_age = 0.0;
  const auto ref = runStamped(frames, off);
  ASSERT_TRUE(ref->integrateFrame(far.points, movedPose(far.T), far.robot, 10.0, &r));
  EXPECT_EQ(r.cells_aged, 0u);
  expectOnlySafeBecameUnknown(ref->safetyMap(), aged);
  std::size_t differ = 0;
  for (std::size_t k = 0; k < aged.labels.size(); ++k)
    differ += aged.labels[k] != ref->safetyMap().labels[k];
  EXPECT_EQ(differ, m->cellsAged());

  // Seen again: vouched for again.
  const Frame& full = frames.back();
  Eigen::Isometry3f T2 = movedPose(movedPose(full.T));
  ASSERT_TRUE(m->integrateFrame(full.points, T2, full.robot, 11.0, &r));
  EXPECT_EQ(labelAt(m->safetyMap(), 1.3, 1.0), L::kLevel) << ascii(m->safetyMap());
}

TEST(SafetyMapperAging, AgingWithoutFramesNeverMakesAnythingSafe) {
  const std::vector<Frame> frames = drive(floorWithBox());
  SafetyMapperConfig c;
  c.max_cell_age = 5.0;
  const auto m = runStamped(frames, c);  // frames at 0.0 .. 2.3 s
  const SafetyMap fresh = m->safetyMap();
  std::size_t safe_before = 0;
  for (SafetyLabel l : fresh.labels)
    safe_before += isSafe(l);
  ASSERT_GT(safe_before, 100u);

  // At 6 s, exactly the safe cells last observed before 1 s (the camera yaws and pitches from
  // frame to frame, so some were seen only early) fall back to Unknown.
  const std::size_t n = m->ageSafetyMap(6.0);
  const SafetyMap& aged = m->safetyMap();
  expectOnlySafeBecameUnknown(fresh, aged);
  std::size_t changed = 0;
  for (int v = aged.min_v; v < aged.min_v + aged.height; ++v) {
    for (int u = aged.min_u; u < aged.min_u + aged.width; ++u) {
      const int k = aged.index(u, v);
      if (!isSafe(fresh.labels[k])) continue;
      const double seen = m->observationAge().lastObserved(u, v);
      if (seen < 1.0) {
        EXPECT_EQ(aged.labels[k], L::kUnknown) << u << " " << v << " seen at " << seen;
        EXPECT_EQ(aged.drop_off[k], 0);
        ++changed;
      } else {
        EXPECT_EQ(aged.labels[k], fresh.labels[k]) << u << " " << v << " seen at " << seen;
      }
    }
  }
  EXPECT_EQ(n, changed);
  EXPECT_EQ(m->cellsAged(), n);

  // Long after the last frame every safe cell is gone, and nothing else has changed.
  const std::size_t rest = m->ageSafetyMap(1000.0);
  for (SafetyLabel l : m->safetyMap().labels)
    EXPECT_FALSE(isSafe(l));
  EXPECT_EQ(n + rest, safe_before);
  EXPECT_EQ(m->cellsAged(), safe_before);
  expectOnlySafeBecameUnknown(fresh, m->safetyMap());
  // A time older than the latest is the latest: nothing comes back.
  EXPECT_EQ(m->ageSafetyMap(3.0), 0u);
  EXPECT_DOUBLE_EQ(m->latestTime(), 1000.0);
  // Recomputing the map from the grid at the latest time keeps it aged.
  m->computeSafetyMap(frames.back().robot);
  for (SafetyLabel l : m->safetyMap().labels)
    EXPECT_FALSE(isSafe(l));
}

TEST(SafetyMapperAging, StationaryFramesStillObserve) {
  const std::vector<Frame> frames = drive(floorWithBox());
  SafetyMapperConfig c;
  c.max_cell_age = 5.0;
  const auto m = runStamped(frames, c);
  const SafetyMap fresh = m->safetyMap();
  const Frame& last = frames.back();
  FrameResult r;
  // The robot stands still; the camera keeps seeing the floor at 1.3 m.
  for (double t = 3.0; t <= 20.0; t += 1.0) {
    EXPECT_FALSE(m->integrateFrame(last.points, last.T, last.robot, t, &r));
    EXPECT_EQ(r.status, FrameStatus::kStationary);
  }
  EXPECT_EQ(labelAt(m->safetyMap(), 1.3, 1.0), L::kLevel) << ascii(m->safetyMap());
  EXPECT_EQ(labelAt(m->safetyMap(), 2.2, 0.0), L::kNonGround);
  expectOnlySafeBecameUnknown(fresh, m->safetyMap());
  // A stationary frame that sees nothing beyond 2.5 m: the near floor ages out.
  const Frame far = keepBeyond(last, 2.5);
  EXPECT_FALSE(m->integrateFrame(far.points, last.T, last.robot, 40.0, &r));
  EXPECT_EQ(r.status, FrameStatus::kStationary);
  EXPECT_GT(r.cells_aged, 0u);
  EXPECT_EQ(labelAt(m->safetyMap(), 1.3, 1.0), L::kUnknown) << ascii(m->safetyMap());
  EXPECT_EQ(labelAt(m->safetyMap(), 3.0, 1.0), L::kLevel) << ascii(m->safetyMap());
}

TEST(SafetyMapperAging, UnstampedFramesAndZeroAgeNeverAge) {
  const std::vector<Frame> frames = drive(floorWithBox());
  const auto unstamped = run(frames);  // default max_cell_age, no stamps
  const SafetyMap fresh = unstamped->safetyMap();
  EXPECT_TRUE(std::isnan(unstamped->latestTime()));
  EXPECT_EQ(unstamped->cellsAged(), 0u);
  SafetyMapperConfig off;
  off.max_cell_age = 0.0;
  const auto m = runStamped(frames, off);
  EXPECT_EQ(m->ageSafetyMap(1e6), 0u);
  EXPECT_EQ(m->safetyMap().labels, fresh.labels);
  // A NaN stamp is no stamp.
  SafetyMapper n;
  FrameResult r;
  ASSERT_TRUE(n.integrateFrame(frames[0].points, frames[0].T, frames[0].robot, std::nan(""), &r));
  EXPECT_TRUE(std::isnan(n.latestTime()));
}

TEST(SafetyMapperAging, ResetForgetsObservations) {
  const std::vector<Frame> frames = drive(floorWithBox());
  SafetyMapperConfig c;
  c.max_cell_age = 5.0;
  const auto m = runStamped(frames, c);
  m->reset();
  EXPECT_TRUE(std::isnan(m->latestTime()));
  EXPECT_EQ(m->observationAge().lastObserved(cellOf(1.3), 0), ObservationAge::kNever);
  // A bag played again: stamps from 0 on, the map builds up as the first time.
  const auto again = runStamped(frames, c);
  for (std::size_t k = 0; k < frames.size(); ++k)
    m->integrateFrame(frames[k].points, frames[k].T, frames[k].robot, 0.1 * k);
  EXPECT_EQ(m->safetyMap().labels, again->safetyMap().labels);
}

TEST(SafetyMapperReconfigure, StageChangeKeepsTheModelGridChangeStartsAgain) {
  const std::vector<Frame> frames = drive(floorWithBox());
  SafetyMapperConfig c;
  c.max_cell_age = 5.0;
  const auto m = runStamped(frames, c);
  const std::uint32_t integrated = m->grid().frameCount();
  ASSERT_GT(integrated, 0u);

  // An invalid configuration changes nothing.
  SafetyMapperConfig bad = c;
  bad.labelling.level_slope_deg = 20.0;  // > max_slope_deg
  bool grid_reset = true;
  EXPECT_NE(m->reconfigure(bad, &grid_reset), "");
  EXPECT_FALSE(grid_reset);
  EXPECT_EQ(m->config().labelling.level_slope_deg, c.labelling.level_slope_deg);

  // A labelling change: same model, new labels on the next map.
  SafetyMapperConfig steep = c;
  steep.labelling.max_slope_deg = 20.0;
  steep.labelling.level_slope_deg = 15.0;
  EXPECT_EQ(m->reconfigure(steep, &grid_reset), "");
  EXPECT_FALSE(grid_reset);
  EXPECT_EQ(m->grid().frameCount(), integrated);
  EXPECT_DOUBLE_EQ(m->latestTime(), 2.3);
  EXPECT_DOUBLE_EQ(m->config().labelling.max_slope_deg, 20.0);
  const auto ref = runStamped(frames, steep);
  m->computeSafetyMap(frames.back().robot);
  EXPECT_EQ(m->safetyMap().labels, ref->safetyMap().labels);

  // A sensor-model change starts a new grid.
  SafetyMapperConfig decr = steep;
  decr.grid.decr = 3;
  EXPECT_EQ(m->reconfigure(decr, &grid_reset), "");
  EXPECT_TRUE(grid_reset);
  EXPECT_EQ(m->grid().frameCount(), 0u);
  EXPECT_TRUE(m->safetyMap().labels.empty());
  EXPECT_TRUE(std::isnan(m->latestTime()));
  EXPECT_EQ(m->grid().config().decr, 3);
}

}  // namespace
}  // namespace stereo_safety_map

namespace stereo_safety_map {
namespace {

// Object permanence (SafetyMapperConfig::obstacle_memory): the floor with a box (x 2.0-2.4,
// |y| <= 0.3, 0.5 m high) driven up to. The box is Non-ground. A later labelling that would
// take its columns into the floor (here: robot_height lowered to 5 cm, so that the height map
// sees only their lowest voxel) keeps them Non-ground while their voxels are occupied; once
// free space was observed there (the voxels above emptied), the cells follow the labelling
// again. Without the memory they flip to Level at once.
// SafetyLabellingConfig::obstacle_face_margin under obstacle_memory: the floor cell before the
// box's near face is Non-ground by the margin; when the labelling no longer marks it (here: the
// rise raised beyond the box), the memory keeps it while the face column's top voxel stays
// occupied, and forgets it once rays have cleared the box.
TEST(SafetyMapperObstacleMemory, AFaceCellStaysWhileItsFaceIsOccupied) {
  const std::vector<Frame> frames = drive(floorWithBox());
  const Eigen::Vector3f robot = frames.back().robot;
  for (const bool memory : {false, true}) {
    SafetyMapperConfig c;
    c.obstacle_memory = memory;
    c.max_cell_age = 0.0;
    ASSERT_TRUE(c.labelling.obstacle_face_margin);
    // Every face column rings (obstacle_face_reach >= l_v): the box's face at x = 2.0 m stands
    // 5 cm inside its own column, beyond the default reach (these frames carry no stereo
    // geometry, so the range term is off), and this test is about the memory of a ringed cell.
    c.labelling.obstacle_face_reach = 1.0;
    const auto m = run(frames, c);
    ASSERT_EQ(labelAt(m->safetyMap(), 1.9, 0.0), L::kNonGround) << ascii(m->safetyMap());
    ASSERT_EQ(labelAt(m->safetyMap(), 1.3, 0.0), L::kLevel) << ascii(m->safetyMap());
    EXPECT_EQ(m->faceMemorySize() > 0, memory);
    SafetyMapperConfig r = c;
    r.labelling.obstacle_face_min_rise = 5.0;  // no face marks any more
    EXPECT_EQ(m->reconfigure(r), "");
    m->computeSafetyMap(robot);
    EXPECT_EQ(labelAt(m->safetyMap(), 1.9, 0.0), memory ? L::kNonGround : L::kLevel)
        << memory << ascii(m->safetyMap());
    EXPECT_EQ(labelAt(m->safetyMap(), 1.3, 0.0), L::kLevel);
    // The box's voxels cleared (free space observed through them): forgotten.
    VoxelGrid& g = m->grid();
    const VoxelIndex lo = g.indexOf(Eigen::Vector3f(1.95f, -0.4f, 0.1f));
    const VoxelIndex hi = g.indexOf(Eigen::Vector3f(2.5f, 0.4f, 0.7f));
    for (int w = lo.w; w <= hi.w; ++w)
      for (int v = lo.v; v <= hi.v; ++v)
        for (int u = lo.u; u <= hi.u; ++u)
          g.setLogOdds(VoxelIndex{u, v, w}, g.config().lop_min);
    m->computeSafetyMap(robot);
    EXPECT_EQ(labelAt(m->safetyMap(), 1.9, 0.0), L::kLevel) << memory << ascii(m->safetyMap());
    EXPECT_EQ(m->faceMemorySize(), 0u);
  }
}

TEST(SafetyMapperObstacleMemory, AnObstacleStaysUntilFreeSpaceIsObserved) {
  const std::vector<Frame> frames = drive(floorWithBox());
  for (const bool memory : {false, true}) {
    SafetyMapperConfig c;
    c.obstacle_memory = memory;
    c.max_cell_age = 0.0;
    // The box's columns relabelled as floor below have nothing seen free above them: that rule
    // (tested on its own) would make them Unknown whatever the memory does.
    c.unseen_floor_band = 0;
    const auto m = run(frames, c);
    const Eigen::Vector3f robot = frames.back().robot;
    ASSERT_EQ(labelAt(m->safetyMap(), 2.0, 0.0), L::kNonGround) << ascii(m->safetyMap());
    ASSERT_EQ(labelAt(m->safetyMap(), 1.3, 0.0), L::kLevel) << ascii(m->safetyMap());
    auto relabel = [&](double robot_height) {
      SafetyMapperConfig r = m->config();
      r.height_map.robot_height = robot_height;
      EXPECT_EQ(m->reconfigure(r), "");
      m->computeSafetyMap(robot);
      return labelAt(m->safetyMap(), 2.0, 0.0);
    };
    // The labelling would now call the box's near face floor.
    EXPECT_EQ(relabel(0.05), memory ? L::kNonGround : L::kLevel) << memory << ascii(m->safetyMap());
    EXPECT_EQ(m->cellsRemembered() > 0, memory);
    EXPECT_EQ(labelAt(m->safetyMap(), 1.3, 0.0), L::kLevel);
    VoxelGrid& g = m->grid();
    const VoxelIndex lo = g.indexOf(Eigen::Vector3f(1.9f, -0.4f, 0.1f));
    const VoxelIndex hi = g.indexOf(Eigen::Vector3f(2.5f, 0.4f, 0.7f));
    auto setBand = [&](int lop) {
      for (int w = lo.w; w <= hi.w; ++w)
        for (int v = lo.v; v <= hi.v; ++v)
          for (int u = lo.u; u <= hi.u; ++u)
            g.setLogOdds(VoxelIndex{u, v, w}, lop);
    };
    if (memory) {
      // Rays grazing the box took its voxels below occ_t but not back to the prior: forgotten
      // with the default margin (1), still remembered with obstacle_memory_clear_margin occ_t.
      SafetyMapperConfig strict = c;
      strict.obstacle_memory_clear_margin = strict.grid.occ_threshold;
      const auto e = run(frames, strict);
      SafetyMapperConfig r = strict;
      r.height_map.robot_height = 0.05;
      EXPECT_EQ(e->reconfigure(r), "");
      VoxelGrid& ge = e->grid();
      for (int w = lo.w; w <= hi.w; ++w)
        for (int v = lo.v; v <= hi.v; ++v)
          for (int u = lo.u; u <= hi.u; ++u)
            ge.setLogOdds(VoxelIndex{u, v, w}, ge.config().occ_threshold / 2);
      e->computeSafetyMap(robot);
      EXPECT_EQ(labelAt(e->safetyMap(), 2.0, 0.0), L::kNonGround) << ascii(e->safetyMap());
      setBand(g.config().occ_threshold / 2);
      EXPECT_EQ(relabel(0.05), L::kLevel) << ascii(m->safetyMap());
      EXPECT_EQ(m->cellsRemembered(), 0u);
      strict.obstacle_memory_clear_margin = strict.grid.occ_threshold - strict.grid.lop_min + 1;
      EXPECT_NE(strict.validate(), "");
      strict.obstacle_memory_clear_margin = 0;
      EXPECT_NE(strict.validate(), "");
    }
    // Free space observed through the box's columns: their upper voxels emptied.
    setBand(-10);
    EXPECT_EQ(relabel(0.05), L::kLevel) << memory << ascii(m->safetyMap());
    EXPECT_EQ(m->cellsRemembered(), 0u);
  }
}

// What the memory takes (risesAboveLocalGround): a column whose measured top stands more than h_T
// above the safe ground around it, not the floor's noise that reached into the voxel above it
// (a top 4 cm above a floor that reads 3 cm high, as an unreported pitch makes it read at
// range). Without safe ground around it the robot's base is the ground; without points the
// column is remembered.
TEST(SafetyMapperObstacleMemory, TheFloorsNoiseIsNotRemembered) {
  HeightMap hm;
  hm.reset(0, 0, 7, 7);
  SafetyMap m;
  m.width = m.height = 7;
  m.labels.assign(49, L::kLevel);
  for (int v = 0; v < 7; ++v)
    for (int u = 0; u < 7; ++u) {
      hm.set(u, v, 0);
      hm.setSurfaceHeight(u, v, 0.03f);
    }
  const int c = 3 * 7 + 3;
  m.labels[c] = L::kNonGround;
  hm.set(3, 3, 1, -1);
  const double h_t = 0.05;
  hm.setSurfaceHeight(3, 3, 0.07f);
  EXPECT_FALSE(risesAboveLocalGround(m, hm, c, 0.0f, h_t));
  hm.setSurfaceHeight(3, 3, 0.30f);  // a post
  EXPECT_TRUE(risesAboveLocalGround(m, hm, c, 0.0f, h_t));
  hm.setSurfaceHeight(3, 3, 0.09f);  // a low obstacle, 6 cm above that floor
  EXPECT_TRUE(risesAboveLocalGround(m, hm, c, 0.0f, h_t));
  // The lowest safe surface nearby is the ground: one high floor cell does not hide the post.
  hm.setSurfaceHeight(2, 3, 0.08f);
  EXPECT_TRUE(risesAboveLocalGround(m, hm, c, 0.0f, h_t));
  // No safe cell within 2 cells: the robot's base decides.
  for (int k = 0; k < 49; ++k)
    if (k != c) m.labels[k] = L::kUnknown;
  hm.setSurfaceHeight(3, 3, 0.07f);
  EXPECT_TRUE(risesAboveLocalGround(m, hm, c, 0.0f, h_t));
  EXPECT_FALSE(risesAboveLocalGround(m, hm, c, 0.03f, h_t));
  // No measured surface: remembered.
  hm.setSurfaceHeight(3, 3, std::numeric_limits<float>::quiet_NaN());
  EXPECT_TRUE(risesAboveLocalGround(m, hm, c, 0.03f, h_t));
}

// SafetyMapperConfig::obstacle_memory_max_range: the box is remembered only when it stood
// within that range of the robot while it was Non-ground.
TEST(SafetyMapperObstacleMemory, OnlyWhatWasNearEnoughIsRemembered) {
  const std::vector<Frame> frames = drive(floorWithBox());
  const Eigen::Vector3f robot = frames.back().robot;
  const double to_box = 2.0 - robot.x();  // to the box's near face
  ASSERT_GT(to_box, 0.5);
  for (const double range : {0.0, to_box + 0.5, to_box - 0.3}) {
    SafetyMapperConfig c;
    c.max_cell_age = 0.0;
    c.unseen_floor_band = 0;  // as in AnObstacleStaysUntilFreeSpaceIsObserved
    c.obstacle_memory_max_range = range;
    const auto m = run(frames, c);
    ASSERT_EQ(labelAt(m->safetyMap(), 2.0, 0.0), L::kNonGround) << range << ascii(m->safetyMap());
    SafetyMapperConfig r = c;
    r.height_map.robot_height = 0.05;  // the labelling would now call the box's near face floor
    EXPECT_EQ(m->reconfigure(r), "");
    m->computeSafetyMap(robot);
    const bool near = range == 0.0 || range > to_box;
    EXPECT_EQ(labelAt(m->safetyMap(), 2.0, 0.0), near ? L::kNonGround : L::kLevel)
        << range << ascii(m->safetyMap());
  }
  SafetyMapperConfig bad;
  bad.obstacle_memory_max_range = -1.0;
  EXPECT_NE(bad.validate(), "");
}

TEST(SafetyMapperObstacleMemory, ResetAndThePapersConfigurationForget) {
  const auto m = run(drive(floorWithBox()));
  m->reset();
  EXPECT_TRUE(m->safetyMap().labels.empty());
  EXPECT_EQ(m->cellsRemembered(), 0u);
  EXPECT_FALSE(paperFaithful(SafetyMapperConfig()).obstacle_memory);
  EXPECT_TRUE(SafetyMapperConfig().obstacle_memory);
}

// HeightMapConfig::sparse_edge_share reads the hit masses: the mapper keeps them for it alone,
// and 000's configuration turns it off.
TEST(SafetyMapperSparseEdges, TheRuleKeepsTheHitMassesAndIsOffInThePapersConfiguration) {
  SafetyMapperConfig paper = paperFaithful(SafetyMapperConfig());
  EXPECT_FALSE(SafetyMapper(paper).grid().hitMassTracking());
  SafetyMapperConfig c = paper;
  c.height_map.sparse_edge_share = 0.1;
  EXPECT_TRUE(SafetyMapper(c).grid().hitMassTracking());
  EXPECT_EQ(paperFaithful(c).height_map.sparse_edge_share, 0.0);
  EXPECT_EQ(SafetyMapperConfig().height_map.sparse_edge_share, 0.0);  // a switch, off
}

TEST(SafetyMapperOverhangRoof, OnByDefaultOffInThePapersConfiguration) {
  EXPECT_TRUE(SafetyMapperConfig().overhang_roof.enabled);
  EXPECT_FALSE(paperFaithful(SafetyMapperConfig()).overhang_roof.enabled);
  SafetyMapperConfig bad;
  bad.overhang_roof.max_span = -1.0;
  EXPECT_NE(bad.validate().find("overhang_roof_max_span"), std::string::npos);
}

// OverhangRoofConfig::remember: a flat floor driven over to x = 0 (camera 1.1 m up), then a table
// top's front edge put into the grid at x = 1.6 m, |y| <= 0.3 m, 0.8 m high, with rays observed
// passing below it. The floor seen under it is Non-ground (overhang_roof). A later view from which
// the rule no longer reaches those cells (here: max_span cut to 0.15 m) keeps them Non-ground while
// the roof's top voxel stays occupied; rays clearing that voxel forget them. Without `remember`
// they follow the last view at once.
TEST(SafetyMapperOverhangRoof, TheFloorUnderARoofStaysNonGroundWhileTheRoofStands) {
  EXPECT_TRUE(SafetyMapperConfig().overhang_roof.remember);
  const std::vector<Frame> frames = drive(World());
  for (const bool remember : {false, true}) {
    SafetyMapperConfig c;
    c.max_cell_age = 0.0;
    c.overhang_roof.remember = remember;
    const auto m = run(frames, c);
    const Eigen::Vector3f robot = frames.back().robot;
    ASSERT_EQ(labelAt(m->safetyMap(), 2.2, 0.0), L::kLevel) << ascii(m->safetyMap());
    VoxelGrid& g = m->grid();
    const std::int32_t w_base = g.indexOf(robot).w;
    std::vector<VoxelIndex> tops;
    for (double y = -0.3; y <= 0.31; y += 0.1) {
      const VoxelIndex top = g.indexOf(Eigen::Vector3f(1.6f, static_cast<float>(y), 0.8f));
      g.setLogOdds(top, 200);
      for (std::int32_t w = w_base + 2; w < top.w; ++w)
        g.setLogOdds(VoxelIndex{top.u, top.v, w}, -20);
      tops.push_back(top);
    }
    m->computeSafetyMap(robot);
    EXPECT_GT(m->cellsUnderOverhangs(), 0);
    for (const double x : {1.8, 2.0, 2.2, 2.4})
      EXPECT_EQ(labelAt(m->safetyMap(), x, 0.0), L::kNonGround) << x << ascii(m->safetyMap());
    EXPECT_EQ(labelAt(m->safetyMap(), 2.9, 0.0), L::kLevel) << ascii(m->safetyMap());
    EXPECT_EQ(m->roofMemorySize() > 0, remember);

    // The view changes: the rule reaches only the cell right behind the edge.
    SafetyMapperConfig near_view = m->config();
    near_view.overhang_roof.max_span = 0.15;
    ASSERT_EQ(m->reconfigure(near_view), "");
    m->computeSafetyMap(robot);
    for (const double x : {2.0, 2.2, 2.4}) {
      EXPECT_EQ(labelAt(m->safetyMap(), x, 0.0), remember ? L::kNonGround : L::kLevel)
          << remember << " " << x << ascii(m->safetyMap());
    }
    EXPECT_EQ(m->cellsRemembered() > 0, remember);

    // Free space observed where the roof was: forgotten, the floor is Level again.
    for (const VoxelIndex& top : tops)
      g.setLogOdds(top, -10);
    m->computeSafetyMap(robot);
    for (const double x : {1.8, 2.0, 2.2, 2.4})
      EXPECT_EQ(labelAt(m->safetyMap(), x, 0.0), L::kLevel) << x << ascii(m->safetyMap());
    EXPECT_EQ(m->roofMemorySize(), 0u);
  }
}

// SafetyMapperConfig::unseen_overhang_min_height: a table top that stereo does not match (no
// point on it) while the rays to the floor pass under it and the rays to the wall behind pass
// over it. Its floor is seen and Level for 000's map; with the rule it is not safe.
World unmatchedTableWorld() {
  World w;
  Box top{{2.0, -0.5, 0.70}, {2.8, 0.5, 0.74}};
  top.unmatched = true;
  w.boxes.push_back(top);
  w.boxes.push_back(Box{{3.6, -3.0, 0.0}, {3.8, 3.0, 2.0}});  // a wall behind it
  return w;
}

TEST(SafetyMapperUnseenOverhang, OnByDefaultOffInThePapersConfiguration) {
  EXPECT_GT(SafetyMapperConfig().unseen_overhang_min_height, 0.0);
  EXPECT_EQ(paperFaithful(SafetyMapperConfig()).unseen_overhang_min_height, 0.0);
  SafetyMapperConfig c;
  c.unseen_overhang_min_height = -0.1;
  EXPECT_NE(c.validate(), "");
  c.unseen_overhang_min_height = 0.3;
  EXPECT_EQ(c.validate(), "");
}

TEST(SafetyMapperUnseenOverhang, TheFloorUnderATopThatGaveNoPointIsNotSafe) {
  const std::vector<Frame> frames = drive(unmatchedTableWorld());
  SafetyMapperConfig c;
  c.max_cell_age = 0.0;
  c.unseen_overhang_min_height = 0.0;
  const auto off = run(frames, c);
  // 000's map: the floor under the top is seen and Level (the table is missed).
  // (The first 0.2 m behind the front edge: rays that pass under the edge graze the top's
  // voxel there, and rays over the top the voxel above it; the hidden layer is thinner than a
  // voxel.)
  const std::vector<int> under = cellsIn(off->safetyMap(), 2.3, 2.7, -0.3, 0.3);
  int level_under = 0;
  for (const int k : under)
    level_under += off->safetyMap().labels[k] == L::kLevel;
  ASSERT_GE(level_under, 15) << ascii(off->safetyMap());
  EXPECT_EQ(off->cellsUnderUnseenOverhangs(), 0);

  // The top's voxel was not seen (a few grazing rays at most) between voxels seen free under
  // and over it.
  const VoxelGrid& g = off->grid();
  const VoxelIndex top = g.indexOf(Eigen::Vector3f(2.4f, 0.0f, 0.72f));
  const int free_lop = SafetyMapperConfig().unseen_overhang_free_lop;
  EXPECT_GT(g.logOdds(top), -free_lop);
  EXPECT_LE(g.logOdds(VoxelIndex{top.u, top.v, top.w - 2}), -free_lop);
  EXPECT_LE(g.logOdds(VoxelIndex{top.u, top.v, top.w + 2}), -free_lop);

  for (const bool non_ground : {false, true}) {
    c.unseen_overhang_min_height = SafetyMapperConfig().unseen_overhang_min_height;
    c.unseen_overhang_non_ground = non_ground;
    const auto on = run(frames, c);
    const L expected = non_ground ? L::kNonGround : L::kUnknown;
    for (const int k : under) {
      const L got = on->safetyMap().labels[k];
      EXPECT_FALSE(isSafe(got)) << k << ascii(on->safetyMap());
      if (off->safetyMap().labels[k] == L::kLevel) EXPECT_EQ(got, expected) << k;
    }
    EXPECT_GT(on->cellsUnderUnseenOverhangs(), 0);
    // Open floor before the table and beside it keeps its label.
    for (const auto& [x, y] : {std::pair{1.2, 0.0}, std::pair{1.6, 0.0}, std::pair{2.4, 1.3}}) {
      EXPECT_EQ(labelAt(on->safetyMap(), x, y), labelAt(off->safetyMap(), x, y))
          << x << " " << y << ascii(on->safetyMap());
    }
  }
}

// SafetyMapperConfig::unseen_overhang_min_width: a hidden voxel in one column (rays that happen to
// miss it) is not a top; a layer hidden across a square of that side is.
TEST(SafetyMapperUnseenOverhang, OnlyAHiddenLayerAcrossASquareCounts) {
  const std::vector<Frame> frames = drive(World());
  SafetyMapperConfig c;
  c.max_cell_age = 0.0;
  c.obstacle_memory = false;
  ASSERT_EQ(c.unseen_overhang_min_width, 2);
  auto m = run(frames, c);
  const Eigen::Vector3f robot = frames.back().robot;
  VoxelGrid& g = m->grid();
  // Hide the voxel 0.5 m above the floor in the columns of `cells`, between voxels seen free.
  auto hide = [&](const std::vector<std::pair<double, double>>& cells) {
    for (const auto& [x, y] : cells) {
      const VoxelIndex top = g.indexOf(Eigen::Vector3f(x, y, 0.55f));
      g.setLogOdds(VoxelIndex{top.u, top.v, top.w - 1}, -50);
      g.setLogOdds(top, 0);
      g.setLogOdds(VoxelIndex{top.u, top.v, top.w + 1}, -50);
    }
  };
  ASSERT_EQ(labelAt(m->computeSafetyMap(robot), 2.0, 0.0), L::kLevel) << ascii(m->safetyMap());
  ASSERT_EQ(labelAt(m->safetyMap(), 2.1, 0.1), L::kLevel);
  hide({{2.0, 0.0}});
  EXPECT_EQ(labelAt(m->computeSafetyMap(robot), 2.0, 0.0), L::kLevel) << ascii(m->safetyMap());
  EXPECT_EQ(m->cellsUnderUnseenOverhangs(), 0);
  SafetyMapperConfig every = m->config();
  every.unseen_overhang_min_width = 1;
  ASSERT_EQ(m->reconfigure(every), "");
  EXPECT_EQ(labelAt(m->computeSafetyMap(robot), 2.0, 0.0), L::kUnknown) << ascii(m->safetyMap());
  EXPECT_EQ(m->cellsUnderUnseenOverhangs(), 1);
  ASSERT_EQ(m->reconfigure(c), "");
  hide({{2.1, 0.0}, {2.0, 0.1}, {2.1, 0.1}});
  m->computeSafetyMap(robot);
  for (const auto& [x, y] : {std::pair{2.0, 0.0}, {2.1, 0.0}, {2.0, 0.1}, {2.1, 0.1}})
    EXPECT_EQ(labelAt(m->safetyMap(), x, y), L::kUnknown) << x << " " << y << ascii(m->safetyMap());
  EXPECT_EQ(m->cellsUnderUnseenOverhangs(), 4);
  EXPECT_EQ(labelAt(m->safetyMap(), 2.2, 0.0), L::kLevel);
}

// SafetyMapperConfig::unseen_floor_band: a floor cell above which no ray ever passed (ground
// points that stereo's noise pushed behind an obstacle's face) is not safe; open floor, whose
// low voxels the rays to the floor beyond it pass through, keeps its label.
TEST(SafetyMapperUnseenFloor, FloorNothingWasSeenAboveIsUnknown) {
  EXPECT_GT(SafetyMapperConfig().unseen_floor_band, 0);  // on by default
  EXPECT_EQ(paperFaithful(SafetyMapperConfig()).unseen_floor_band, 0);
  SafetyMapperConfig bad;
  bad.unseen_floor_band = 11;
  EXPECT_NE(bad.validate(), "");
  const std::vector<Frame> frames = drive(World());
  SafetyMapperConfig c;
  c.max_cell_age = 0.0;
  c.obstacle_memory = false;
  c.unseen_floor_band = 0;
  const auto off = run(frames, c);
  c.unseen_floor_band = 2;
  c.unseen_floor_min_range = 1.0;  // the robot ends at x = 0
  auto m = run(frames, c);
  const Eigen::Vector3f robot = frames.back().robot;
  // The open floor ahead within 3 m: the rule takes (almost) none of it.
  const std::vector<int> ahead = cellsIn(off->safetyMap(), 1.0, 3.0, -1.0, 1.0);
  int level_off = 0, level_on = 0;
  for (const int k : ahead) {
    level_off += off->safetyMap().labels[k] == L::kLevel;
    level_on += m->safetyMap().labels[k] == L::kLevel;
  }
  ASSERT_GE(level_off, 300) << ascii(off->safetyMap());
  EXPECT_GE(level_on, level_off - level_off / 50) << ascii(m->safetyMap());

  // One floor cell whose two voxels above the ground were never seen free.
  VoxelGrid& g = m->grid();
  ASSERT_EQ(labelAt(m->computeSafetyMap(robot), 2.0, 0.0), L::kLevel) << ascii(m->safetyMap());
  const int before = m->cellsUnseenFloor();  // e.g. the floor's last row at the range limit
  EXPECT_LE(before, 5) << ascii(m->safetyMap());
  const SafetyMap& sm = m->safetyMap();
  const std::int32_t w =
      m->heightMap().atIndex(sm.index(cellOf(2.0, sm.resolution), cellOf(0.0, sm.resolution)));
  VoxelIndex ground = g.indexOf(Eigen::Vector3f(2.0f, 0.0f, 0.0f));
  ground.w = w;
  // Not seen free: a few hits, a few passing rays.
  const int free_lop = c.unseen_overhang_free_lop;
  g.setLogOdds(VoxelIndex{ground.u, ground.v, ground.w + 1}, 4);
  g.setLogOdds(VoxelIndex{ground.u, ground.v, ground.w + 2}, -free_lop + 1);
  EXPECT_EQ(labelAt(m->computeSafetyMap(robot), 2.0, 0.0), L::kUnknown) << ascii(m->safetyMap());
  EXPECT_EQ(m->cellsUnseenFloor(), before + 1);
  EXPECT_EQ(labelAt(m->safetyMap(), 2.1, 0.0), L::kLevel);
  // Off: the cell is Level again.
  SafetyMapperConfig no = m->config();
  no.unseen_floor_band = 0;
  ASSERT_EQ(m->reconfigure(no), "");
  EXPECT_EQ(labelAt(m->computeSafetyMap(robot), 2.0, 0.0), L::kLevel);
  EXPECT_EQ(m->cellsUnseenFloor(), 0);
  // One voxel of the band seen free is enough.
  ASSERT_EQ(m->reconfigure(c), "");
  g.setLogOdds(VoxelIndex{ground.u, ground.v, ground.w + 2}, -free_lop);
  EXPECT_EQ(labelAt(m->computeSafetyMap(robot), 2.0, 0.0), L::kLevel) << ascii(m->safetyMap());
  // Nearer than unseen_floor_min_range the rule does not ask.
  g.setLogOdds(VoxelIndex{ground.u, ground.v, ground.w + 2}, 0);
  SafetyMapperConfig far = c;
  far.unseen_floor_min_range = 2.5;
  ASSERT_EQ(m->reconfigure(far), "");
  EXPECT_EQ(labelAt(m->computeSafetyMap(robot), 2.0, 0.0), L::kLevel) << ascii(m->safetyMap());
  ASSERT_EQ(m->reconfigure(c), "");
  EXPECT_EQ(labelAt(m->computeSafetyMap(robot), 2.0, 0.0), L::kUnknown);

  // Without free-space decrements (decr 0: nothing is ever seen free) the rule is off.
  SafetyMapperConfig hits_only = c;
  hits_only.grid.decr = 0;
  const auto h = run(frames, hits_only);
  EXPECT_EQ(h->cellsUnseenFloor(), 0);
  EXPECT_EQ(labelAt(h->safetyMap(), 2.0, 0.0), L::kLevel) << ascii(h->safetyMap());
}

// ---------------------------------------------------------------------------------------------
// Re-levelling on the ground the chair stands on (FrameLevellingConfig::near_radius and
// filter_frames): a camera whose true pitch is 1 deg further down than the pose says.

constexpr double kUnreportedPitchDeg = 1.0;

std::vector<Frame> driveTilted(const World& w, double end_x) {
  Rig rig;
  rig.frames = 30;
  rig.unreported_pitch_deg = kUnreportedPitchDeg;
  return drive(w, rig, end_x);
}

SafetyMapperConfig learnedLevelling() {
  SafetyMapperConfig c;
  c.relevel.enabled = true;
  c.relevel.near_radius = 2.5;
  c.relevel.filter_frames = 10;
  return c;
}

// Mean height of the map's measured surface over the cells of x in [x0, x1], |y| <= 0.5.
double meanSurface(const SafetyMapper& m, double x0, double x1) {
  double sum = 0.0;
  int n = 0;
  for (const int c : cellsIn(m.safetyMap(), x0, x1, -0.5, 0.5)) {
    const float z = m.heightMap().surfaceHeightAtIndex(c);
    if (std::isfinite(z)) {
      sum += z;
      ++n;
    }
  }
  return n > 0 ? sum / n : std::nan("");
}

TEST(SafetyMapperRelevel, AnUnreportedTiltIsLearnedFromTheGroundUnderTheChair) {
  EXPECT_EQ(FrameLevellingConfig().near_radius, 0.0);  // off by default (safety_map.yaml: why)
  EXPECT_EQ(FrameLevellingConfig().filter_frames, 0);
  const World w;  // level floor z = 0
  const std::vector<Frame> frames = driveTilted(w, 0.0);
  const auto tilted = run(frames);
  const auto levelled = run(frames, learnedLevelling());
  // 1 deg at 3 m is 5 cm: the tilted floor there stands well off z = 0.
  const double far_tilted = meanSurface(*tilted, 2.8, 3.4);
  const double far_levelled = meanSurface(*levelled, 2.8, 3.4);
  ASSERT_TRUE(std::isfinite(far_tilted) && std::isfinite(far_levelled));
  EXPECT_GT(std::abs(far_tilted - meanSurface(*tilted, 0.8, 1.2)), 0.025);
  EXPECT_LT(std::abs(far_levelled - meanSurface(*levelled, 0.8, 1.2)), 0.015);
  // The last frame's correction is the tilt (about the heading's lateral axis, the fixed y
  // axis here as the chair looks along +x within 8 deg).
  SafetyMapper m(learnedLevelling());
  FrameResult r;
  for (const Frame& f : frames)
    ASSERT_TRUE(m.integrateFrame(f.points, f.T, f.robot, &r));
  EXPECT_TRUE(r.levelling.applied);
  EXPECT_NEAR(std::hypot(r.levelling.pitch_deg, r.levelling.roll_deg), kUnreportedPitchDeg, 0.2);
}

TEST(SafetyMapperRelevel, ADropAheadIsNotLevelledAway) {
  // A 10 cm drop 1.8 m ahead of the last position, inside near_radius: the levelled map must
  // still read it as a drop (the lower side Non-ground), as the untilted map does.
  World w;
  w.ground = [](double x, double) { return x < 1.8 ? 0.0 : -0.10; };
  const auto levelled = run(driveTilted(w, 0.0), learnedLevelling());
  const SafetyMap& m = levelled->safetyMap();
  const auto lower = cellsIn(m, 2.3, 3.2, -0.4, 0.4);
  ASSERT_FALSE(lower.empty());
  EXPECT_EQ(countLabel(m, lower, L::kNonGround), static_cast<int>(lower.size())) << ascii(m);
  EXPECT_GT(meanSurface(*levelled, 0.8, 1.4) - meanSurface(*levelled, 2.3, 3.2), 0.07);
}

TEST(SafetyMapperFootprint, ARobotSegmentWithoutAPlaneOfItsOwnStandsOnTheBase) {
  // Issue 15, "the robot stands on ground" (dev seed 149): the camera sees a floor from 1.6 m on
  // and, under the chair, one row of columns along the heading whose points lie on a line. That
  // row seeds the robot's segment (an observed cell before a footprint cell) and the footprint
  // joins it, but its points give no plane (their spread across the line is 0). The segment lies
  // on the base's level plane, so the floor beyond the blind zone is reached across the
  // footprint bridge, as when the footprint alone seeds it.
  const Eigen::Vector3f robot(0.0f, 0.0f, 0.0f);
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();  // sensor axes = fixed axes
  T.translation() = Eigen::Vector3f(0.0f, 0.0f, 1.1f);
  std::vector<Eigen::Vector3f> world;
  for (double x = 1.605; x < 3.6; x += 0.02)
    for (double y = -1.0; y < 1.0; y += 0.02)
      world.emplace_back(x, y, 0.0);
  for (double x = -0.195; x < 0.2; x += 0.01)
    world.emplace_back(x, 0.005, 0.0);  // one row of cells, every point on the line y = 0.005
  std::vector<Eigen::Vector3f> points;
  for (const Eigen::Vector3f& p : world)
    points.push_back(T.inverse() * p);

  SafetyMapperConfig c;
  c.skip_stationary_frames = false;
  c.max_cell_age = 0.0;
  SafetyMapper m(c);
  for (int k = 0; k < 12; ++k) {
    FrameResult r;
    ASSERT_TRUE(m.integrateFrame(points, T, robot, &r)) << toString(r.status);
  }
  const SafetyMap& sm = m.safetyMap();
  const SegmentInfo* rs = robotSegment(sm);
  ASSERT_NE(rs, nullptr) << ascii(sm);
  // The row seeded it: the cell under the base is observed, in the robot's segment.
  EXPECT_EQ(sm.segment[sm.index(0, 0)], sm.robot_segment) << ascii(sm);
  EXPECT_GT(m.heightMap().atIndex(sm.index(0, 0)), HeightMap::kNoHeight) << ascii(sm);
  EXPECT_TRUE(rs->plane.valid);
  EXPECT_TRUE(rs->plane.from_base);
  EXPECT_NEAR(rs->plane.c, 0.0, 1e-6);
  EXPECT_NEAR(rs->plane.slope_deg, 0.0, 1e-9);
  const auto ahead = cellsIn(sm, 1.7, 2.5, -0.5, 0.5);
  EXPECT_EQ(countLabel(sm, ahead, L::kLevel), static_cast<int>(ahead.size())) << ascii(sm);

  // Off in the paper's configuration (no footprint): no plane, nothing reachable.
  SafetyMapperConfig p = paperFaithful(c);
  p.skip_stationary_frames = false;
  SafetyMapper pm(p);
  for (int k = 0; k < 12; ++k) {
    FrameResult r;
    ASSERT_TRUE(pm.integrateFrame(points, T, robot, &r)) << toString(r.status);
  }
  EXPECT_EQ(countLabel(pm.safetyMap(), cellsIn(pm.safetyMap(), 1.7, 2.5, -0.5, 0.5), L::kLevel), 0)
      << ascii(pm.safetyMap());
}

}  // namespace
}  // namespace stereo_safety_map
