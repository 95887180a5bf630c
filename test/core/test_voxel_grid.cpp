// Tests of the 3D log-odds voxel grid (000, Sec. IV) on worlds whose answer is known by
// construction.
#include "stereo_safety_map/core/voxel_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <new>
#include <random>
#include <stdexcept>
#include <tuple>
#include <vector>

// Counts heap allocations while enabled, to check that integrate() and recenter() do not
// allocate (000 Sec. VII-D: the update runs every frame).
namespace {
std::atomic<bool> g_count_allocs{false};
std::atomic<long> g_allocs{0};

// Out of line so that the compiler does not pair the inlined free() with operator new.
__attribute__((noinline)) void* countedMalloc(std::size_t n) {
  if (g_count_allocs.load(std::memory_order_relaxed)) ++g_allocs;
  return std::malloc(n ? n : 1);
}
__attribute__((noinline)) void countedFree(void* p) {
  std::free(p);
}
}  // namespace

void* operator new(std::size_t n) {
  if (void* p = countedMalloc(n)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
  return operator new(n);
}
void operator delete(void* p) noexcept {
  countedFree(p);
}
void operator delete[](void* p) noexcept {
  countedFree(p);
}
void operator delete(void* p, std::size_t) noexcept {
  countedFree(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  countedFree(p);
}

namespace stereo_safety_map {
namespace {

using Vec = Eigen::Vector3f;
using Points = std::vector<Eigen::Vector3f>;

Eigen::Isometry3f cameraAt(const Vec& t) {
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.translation() = t;
  return T;
}

// Integrates fixed-frame points seen from a camera with identity orientation at `cam`.
// Exact for the coordinates used with cam = 0 (the sensor frame is the fixed frame).
IntegrationStats seeWorld(VoxelGrid& g, const Vec& cam, const Points& world) {
  Points sensor;
  for (const Vec& p : world)
    sensor.push_back(p - cam);
  return g.integrate(sensor, cameraAt(cam));
}

VoxelIndex idx(int u, int v, int w) {
  return VoxelIndex{u, v, w};
}

// Reference traversal by dense sampling of the segment (independent of the DDA), plus the
// first voxel after the endpoint. Asserts the sampled sequence is face-connected, so a voxel
// missed by the sampling would fail the test rather than hide.
struct SampledRay {
  std::vector<VoxelIndex> voxels;  // camera voxel ... endpoint voxel
  VoxelIndex aft;
};
VoxelIndex sampleIndex(const Eigen::Vector3d& p, double l) {
  return idx(static_cast<int>(std::floor(p.x() / l + 0.5)),
             static_cast<int>(std::floor(p.y() / l + 0.5)),
             static_cast<int>(std::floor(p.z() / l + 0.5)));
}
SampledRay sampleRay(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double l) {
  SampledRay r;
  const int n = 400000;
  for (int i = 0; i <= n; ++i) {
    const VoxelIndex v = sampleIndex(a + (b - a) * (static_cast<double>(i) / n), l);
    if (r.voxels.empty() || r.voxels.back() != v) r.voxels.push_back(v);
  }
  const VoxelIndex end = r.voxels.back();
  for (int i = 1;; ++i) {
    const VoxelIndex v = sampleIndex(b + (b - a) * (static_cast<double>(i) / n), l);
    if (v != end) {
      r.aft = v;
      break;
    }
  }
  auto faceStep = [](const VoxelIndex& p, const VoxelIndex& q) {
    return std::abs(p.u - q.u) + std::abs(p.v - q.v) + std::abs(p.w - q.w) == 1;
  };
  for (std::size_t i = 1; i < r.voxels.size(); ++i)
    EXPECT_TRUE(faceStep(r.voxels[i - 1], r.voxels[i])) << "oracle sampling too coarse";
  EXPECT_TRUE(faceStep(end, r.aft));
  return r;
}

std::size_t countNonZero(const VoxelGrid& g) {
  std::size_t n = 0;
  const VoxelIndex m = g.minIndex();
  for (int u = m.u; u < m.u + g.sizeU(); ++u)
    for (int v = m.v; v < m.v + g.sizeV(); ++v)
      for (int w = m.w; w < m.w + g.sizeW(); ++w)
        if (g.logOdds(idx(u, v, w)) != 0) ++n;
  return n;
}

// ---------------------------------------------------------------------------------------------
// Config

TEST(VoxelGridConfig, DefaultsArePaperValuesAndValid) {
  const VoxelGridConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_DOUBLE_EQ(c.voxel_size, 0.1);  // 000 Sec. IV
  EXPECT_EQ(c.incr_high, 10);
  EXPECT_EQ(c.incr_low, 4);
  EXPECT_EQ(c.decr, 1);
  EXPECT_EQ(c.occ_threshold, 100);
  VoxelGrid g(c);
  EXPECT_EQ(g.sizeU(), 100);
  EXPECT_EQ(g.sizeV(), 100);
  EXPECT_EQ(g.sizeW(), 30);
}

TEST(VoxelGridConfig, RejectsEachBadValueNamingTheParameter) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<std::pair<std::string, std::function<void(VoxelGridConfig&)>>> cases = {
      {"voxel_size", [](VoxelGridConfig& c) { c.voxel_size = 0.0; }},
      {"voxel_size", [](VoxelGridConfig& c) { c.voxel_size = -0.1; }},
      {"voxel_size", [&](VoxelGridConfig& c) { c.voxel_size = nan; }},
      {"size_x", [](VoxelGridConfig& c) { c.size_x = 0.0; }},
      {"size_x", [](VoxelGridConfig& c) { c.size_x = 0.05; }},  // < voxel_size
      {"size_y", [](VoxelGridConfig& c) { c.size_y = -1.0; }},
      {"size_z", [&](VoxelGridConfig& c) { c.size_z = nan; }},
      {"size_z", [](VoxelGridConfig& c) { c.size_z = std::numeric_limits<double>::infinity(); }},
      {"voxel_size", [](VoxelGridConfig& c) { c.voxel_size = 0.001; }},  // 3e11 voxels
      {"size_x", [](VoxelGridConfig& c) { c.size_x = 1e300; }},
      {"z_below_robot", [](VoxelGridConfig& c) { c.z_below_robot = -0.1; }},
      {"z_below_robot", [](VoxelGridConfig& c) { c.z_below_robot = 3.5; }},
      {"incr_high", [](VoxelGridConfig& c) { c.incr_high = -1; }},
      {"incr_high", [](VoxelGridConfig& c) { c.incr_high = 40000; }},
      {"incr_low", [](VoxelGridConfig& c) { c.incr_low = -4; }},
      {"decr", [](VoxelGridConfig& c) { c.decr = -1; }},
      {"decr", [](VoxelGridConfig& c) { c.decr = 1 << 20; }},
      {"lop_min", [](VoxelGridConfig& c) { c.lop_min = 0; }},
      {"lop_min", [](VoxelGridConfig& c) { c.lop_min = -40000; }},
      {"lop_max", [](VoxelGridConfig& c) { c.lop_max = 0; }},
      {"lop_max", [](VoxelGridConfig& c) { c.lop_max = 40000; }},
      {"occ_threshold", [](VoxelGridConfig& c) { c.occ_threshold = 0; }},
      {"occ_threshold", [](VoxelGridConfig& c) { c.occ_threshold = 251; }},
      {"point_list_capacity", [](VoxelGridConfig& c) { c.point_list_capacity = 0; }},
      {"point_list_capacity", [](VoxelGridConfig& c) { c.point_list_capacity = 256; }},
      {"point_list_capacity",
       [](VoxelGridConfig& c) {
         c.size_x = c.size_y = 40.0;  // 4.8M voxels x 255 points
         c.point_list_capacity = 255;
       }},
      {"min_range", [](VoxelGridConfig& c) { c.min_range = -0.1; }},
      {"min_range", [&](VoxelGridConfig& c) { c.min_range = nan; }},
      {"max_range", [](VoxelGridConfig& c) { c.max_range = 0.2; }},  // == min_range
      {"max_range",
       [](VoxelGridConfig& c) { c.max_range = std::numeric_limits<double>::infinity(); }},
      {"neighbour_sigmas", [](VoxelGridConfig& c) { c.neighbour_sigmas = -1.0; }},
      {"neighbour_sigmas", [&](VoxelGridConfig& c) { c.neighbour_sigmas = nan; }},
      {"neighbour_sigmas", [](VoxelGridConfig& c) { c.neighbour_sigmas = 101.0; }},
      {"disparity_sigma", [](VoxelGridConfig& c) { c.disparity_sigma = 0.0; }},
      {"disparity_sigma", [](VoxelGridConfig& c) { c.disparity_sigma = 11.0; }},
  };
  for (const auto& [name, mutate] : cases) {
    VoxelGridConfig c;
    mutate(c);
    const std::string msg = c.validate();
    EXPECT_NE(msg.find(name), std::string::npos) << "expected '" << name << "' in: " << msg;
    try {
      VoxelGrid g(c);
      ADD_FAILURE() << "constructor accepted bad " << name;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()), msg);
    }
  }
}

TEST(VoxelGridConfig, AcceptsEdgeValues) {
  VoxelGridConfig c;
  c.z_below_robot = 0.0;
  c.incr_low = 0;
  c.decr = 0;
  c.min_range = 0.0;
  c.occ_threshold = c.lop_max;
  c.point_list_capacity = 255;
  c.size_x = c.size_y = c.size_z = c.voxel_size;
  EXPECT_EQ(c.validate(), "");
  VoxelGrid g(c);
  EXPECT_EQ(g.sizeU(), 1);
}

// ---------------------------------------------------------------------------------------------
// Eq. (1) indexing and the window

TEST(VoxelGridIndex, RoundsPerEq1WithHalfOpenVoxels) {
  VoxelGridConfig c;
  c.voxel_size = 0.25;  // exact in binary, so the boundaries are exact
  VoxelGrid g(c);
  EXPECT_EQ(g.indexOf(Vec(0.0f, 0.0f, 0.0f)), idx(0, 0, 0));
  EXPECT_EQ(g.indexOf(Vec(0.124f, 0.0f, 0.0f)).u, 0);
  EXPECT_EQ(g.indexOf(Vec(0.125f, 0.0f, 0.0f)).u, 1);   // (u + 1/2) l_v starts voxel u + 1
  EXPECT_EQ(g.indexOf(Vec(-0.125f, 0.0f, 0.0f)).u, 0);  // (u - 1/2) l_v belongs to voxel u
  EXPECT_EQ(g.indexOf(Vec(-0.126f, 0.0f, 0.0f)).u, -1);
  EXPECT_EQ(g.indexOf(Vec(0.0f, -0.375f, 0.0f)).v, -1);
  EXPECT_EQ(g.indexOf(Vec(0.0f, -0.376f, 0.0f)).v, -2);
  EXPECT_EQ(g.indexOf(Vec(0.0f, 0.0f, -0.625f)).w, -2);
  EXPECT_EQ(g.indexOf(Vec(0.0f, 0.0f, 0.624f)).w, 2);
  EXPECT_EQ(g.indexOf(Vec(0.0f, 0.0f, 0.625f)).w, 3);
}

TEST(VoxelGridIndex, DefaultVoxelSizeAndCentres) {
  VoxelGrid g;
  EXPECT_EQ(g.indexOf(Vec(0.04f, -0.04f, 0.06f)), idx(0, 0, 1));
  EXPECT_EQ(g.indexOf(Vec(-0.06f, 2.34f, -1.0f)), idx(-1, 23, -10));
  EXPECT_EQ(g.indexOf(Vec(-3.46f, -0.151f, 0.149f)), idx(-35, -2, 1));
  for (const VoxelIndex& i : {idx(0, 0, 0), idx(-7, 13, -3), idx(49, -50, 19), idx(-123, 456, 7)}) {
    EXPECT_EQ(g.indexOf(g.centerOf(i)), i);
    EXPECT_NEAR(g.centerOf(i).x(), i.u * 0.1f, 1e-6f);
    EXPECT_NEAR(g.centerOf(i).z(), i.w * 0.1f, 1e-6f);
  }
}

TEST(VoxelGridIndex, HugeAndNonFiniteCoordinatesDoNotOverflow) {
  VoxelGrid g;
  const float inf = std::numeric_limits<float>::infinity();
  const VoxelIndex i = g.indexOf(Vec(1e30f, -1e30f, std::nanf("")));
  EXPECT_GT(i.u, 1000000);
  EXPECT_LT(i.v, -1000000);
  EXPECT_FALSE(g.contains(i));
  const VoxelIndex j = g.indexOf(Vec(inf, -inf, 3e38f));
  EXPECT_GT(j.u, 1000000);
  EXPECT_LT(j.v, -1000000);
  EXPECT_GT(j.w, 1000000);
  EXPECT_FALSE(g.contains(j));
  EXPECT_FALSE(g.contains(idx(std::numeric_limits<int>::min(), 0, 0)));
  EXPECT_FALSE(g.contains(idx(0, std::numeric_limits<int>::max(), 0)));
  EXPECT_EQ(g.logOdds(i), 0);
  EXPECT_FALSE(g.isOccupied(j));
  EXPECT_TRUE(g.points(i).empty());
  g.setLogOdds(i, 50);  // ignored outside the window
}

TEST(VoxelGridWindow, PlacementBeforeAndAfterRecenter) {
  VoxelGrid g;
  // Before any recenter(): xy centre at the origin, bottom at -z_below_robot.
  EXPECT_EQ(g.minIndex(), idx(-50, -50, -10));
  EXPECT_TRUE(g.contains(idx(-50, -50, -10)));
  EXPECT_TRUE(g.contains(idx(49, 49, 19)));
  EXPECT_FALSE(g.contains(idx(50, 0, 0)));
  EXPECT_FALSE(g.contains(idx(0, -51, 0)));
  EXPECT_FALSE(g.contains(idx(0, 0, 20)));
  EXPECT_FALSE(g.contains(idx(0, 0, -11)));
  // Robot at voxel (12, -5, 5): it sits at the xy centre, z_below_robot / l_v above the bottom.
  g.recenter(Vec(1.23f, -0.47f, 0.5f));
  EXPECT_EQ(g.minIndex(), idx(12 - 50, -5 - 50, 5 - 10));
  EXPECT_EQ(g.sizeU(), 100);
  EXPECT_EQ(g.sizeW(), 30);
  // Non-finite robot positions are ignored.
  EXPECT_EQ(g.recenter(Vec(std::nanf(""), 0.0f, 0.0f)), 0u);
  EXPECT_EQ(g.minIndex(), idx(-38, -55, -5));
}

// ---------------------------------------------------------------------------------------------
// Sensor model (000, Sec. IV)

TEST(VoxelGridSensorModel, OccupiedAfterCeilOccOverIncrHighFrames) {
  for (int incr : {10, 7, 30, 100}) {
    VoxelGridConfig c;
    c.incr_high = incr;
    VoxelGrid g(c);
    const int frames = (c.occ_threshold + incr - 1) / incr;
    const VoxelIndex target = idx(20, 0, 0);
    for (int f = 1; f <= frames; ++f) {
      seeWorld(g, Vec::Zero(), {Vec(2.0f, 0.0f, 0.0f)});
      EXPECT_EQ(g.logOdds(target), std::min(f * incr, c.lop_max));
      EXPECT_EQ(g.isOccupied(target), f == frames) << "incr " << incr << " frame " << f;
    }
    EXPECT_EQ(g.frameCount(), static_cast<std::uint32_t>(frames));
  }
}

TEST(VoxelGridSensorModel, AxisAlignedRayExactValues) {
  VoxelGrid g;
  const IntegrationStats s = seeWorld(g, Vec::Zero(), {Vec(1.0f, 0.0f, 0.0f)});
  EXPECT_EQ(s.points_used, 1u);
  EXPECT_EQ(s.voxels_decremented, 9u);
  for (int u = 0; u <= 8; ++u)
    EXPECT_EQ(g.logOdds(idx(u, 0, 0)), -1) << u;  // incl. camera's
  EXPECT_EQ(g.logOdds(idx(9, 0, 0)), 4);          // fore, incr_L
  EXPECT_EQ(g.logOdds(idx(10, 0, 0)), 10);        // endpoint, incr_H
  EXPECT_EQ(g.logOdds(idx(11, 0, 0)), 4);         // aft, incr_L
  EXPECT_EQ(g.logOdds(idx(12, 0, 0)), 0);
  EXPECT_EQ(g.logOdds(idx(-1, 0, 0)), 0);
  EXPECT_EQ(g.logOdds(idx(5, 1, 0)), 0);
  EXPECT_EQ(countNonZero(g), 12u);

  // Negative direction along z, other parameters.
  VoxelGridConfig c;
  c.incr_high = 20;
  c.incr_low = 3;
  c.decr = 5;
  VoxelGrid h(c);
  seeWorld(h, Vec(0.0f, 0.0f, 1.5f), {Vec(0.0f, 0.0f, 0.5f)});
  for (int w = 15; w >= 7; --w)
    EXPECT_EQ(h.logOdds(idx(0, 0, w)), -5) << w;
  EXPECT_EQ(h.logOdds(idx(0, 0, 6)), 3);
  EXPECT_EQ(h.logOdds(idx(0, 0, 5)), 20);
  EXPECT_EQ(h.logOdds(idx(0, 0, 4)), 3);
  EXPECT_EQ(countNonZero(h), 12u);
}

TEST(VoxelGridSensorModel, NeighbourIncrementOnlyWhereTheRangeErrorReaches) {
  // f b = 500 px x 0.12 m, sigma_d 0.5 px: sigma_Z = Z^2 / 120 (001 Sec. 4.1); 2 sigma_Z is
  // 1.7 cm at 1 m and 15 cm at 3 m. Voxel 10 spans [0.95, 1.05) m, voxel 30 [2.95, 3.05) m.
  VoxelGridConfig c;
  c.neighbour_sigmas = 2.0;
  const double fb = 500.0 * 0.12;

  // Without the stereo geometry the paper's rule: incr_L on both sides.
  VoxelGrid paper(c);
  seeWorld(paper, Vec::Zero(), {Vec(1.0f, 0.0f, 0.0f)});
  EXPECT_EQ(paper.logOdds(idx(9, 0, 0)), 4);
  EXPECT_EQ(paper.logOdds(idx(11, 0, 0)), 4);

  // Near: both faces 5 cm from the point, beyond 1.7 cm: no incr_L, and the fore neighbour is
  // not decremented either.
  VoxelGrid near(c);
  near.setStereoGeometry(fb);
  seeWorld(near, Vec::Zero(), {Vec(1.0f, 0.0f, 0.0f)});
  EXPECT_EQ(near.logOdds(idx(8, 0, 0)), -1);
  EXPECT_EQ(near.logOdds(idx(9, 0, 0)), 0);
  EXPECT_EQ(near.logOdds(idx(10, 0, 0)), 10);
  EXPECT_EQ(near.logOdds(idx(11, 0, 0)), 0);

  // 1 cm before the aft face: the aft neighbour is within reach, the fore one (9 cm) is not.
  VoxelGrid edge(c);
  edge.setStereoGeometry(fb);
  seeWorld(edge, Vec::Zero(), {Vec(1.04f, 0.0f, 0.0f)});
  EXPECT_EQ(edge.logOdds(idx(9, 0, 0)), 0);
  EXPECT_EQ(edge.logOdds(idx(11, 0, 0)), 4);

  // Far: 5 cm is well within 15 cm, incr_L on both sides as in the paper.
  VoxelGrid far(c);
  far.setStereoGeometry(fb);
  seeWorld(far, Vec::Zero(), {Vec(3.0f, 0.0f, 0.0f)});
  EXPECT_EQ(far.logOdds(idx(29, 0, 0)), 4);
  EXPECT_EQ(far.logOdds(idx(30, 0, 0)), 10);
  EXPECT_EQ(far.logOdds(idx(31, 0, 0)), 4);

  // A floor point seen from above at 1.3 m: its ray enters the floor voxel through the top
  // face, so the paper's fore neighbour is the voxel above the floor.
  const Vec cam(0.0f, 0.0f, 1.2f), floor_point(0.5f, 0.0f, 0.0f);
  VoxelGrid above_paper(c), above(c);
  above.setStereoGeometry(fb);
  seeWorld(above_paper, cam, {floor_point});
  seeWorld(above, cam, {floor_point});
  EXPECT_EQ(above_paper.logOdds(idx(5, 0, 1)), 4);
  EXPECT_EQ(above.logOdds(idx(5, 0, 1)), 0);
  EXPECT_EQ(above.logOdds(idx(5, 0, 0)), 10);

  // neighbour_sigmas 0, or an unknown geometry, is the paper's rule.
  c.neighbour_sigmas = 0.0;
  VoxelGrid off(c);
  off.setStereoGeometry(fb);
  seeWorld(off, Vec::Zero(), {Vec(1.0f, 0.0f, 0.0f)});
  EXPECT_EQ(off.logOdds(idx(9, 0, 0)), 4);
  EXPECT_EQ(off.logOdds(idx(11, 0, 0)), 4);
  c.neighbour_sigmas = 2.0;
  VoxelGrid unknown(c);
  unknown.setStereoGeometry(fb);
  unknown.setStereoGeometry(std::numeric_limits<double>::quiet_NaN());
  seeWorld(unknown, Vec::Zero(), {Vec(1.0f, 0.0f, 0.0f)});
  EXPECT_EQ(unknown.logOdds(idx(9, 0, 0)), 4);
  EXPECT_EQ(unknown.logOdds(idx(11, 0, 0)), 4);
}

TEST(VoxelGridSensorModel, ForeNeighbourIncrementOfItsOwn) {
  // incr_low_fore -1 (default): the fore neighbour gets incr_low, as in 000 Sec. IV.
  VoxelGridConfig c;
  c.incr_low = 4;
  EXPECT_EQ(c.incr_low_fore, -1);
  VoxelGrid paper(c);
  seeWorld(paper, Vec::Zero(), {Vec(1.0f, 0.0f, 0.0f)});
  EXPECT_EQ(paper.logOdds(idx(9, 0, 0)), 4);
  EXPECT_EQ(paper.logOdds(idx(11, 0, 0)), 4);

  // 0: the fore neighbour gets nothing (and is not decremented), the aft one incr_low.
  c.incr_low_fore = 0;
  EXPECT_EQ(c.validate(), "");
  VoxelGrid aft_only(c);
  seeWorld(aft_only, Vec::Zero(), {Vec(1.0f, 0.0f, 0.0f)});
  EXPECT_EQ(aft_only.logOdds(idx(8, 0, 0)), -1);
  EXPECT_EQ(aft_only.logOdds(idx(9, 0, 0)), 0);
  EXPECT_EQ(aft_only.logOdds(idx(10, 0, 0)), 10);
  EXPECT_EQ(aft_only.logOdds(idx(11, 0, 0)), 4);

  // A floor point seen from above: the voxel above the floor is left alone, the one below it
  // (the aft neighbour) still gets incr_low.
  const Vec cam(0.0f, 0.0f, 1.2f), floor_point(0.5f, 0.0f, 0.0f);
  VoxelGrid above(c);
  seeWorld(above, cam, {floor_point});
  EXPECT_EQ(above.logOdds(idx(5, 0, 1)), 0);
  EXPECT_EQ(above.logOdds(idx(5, 0, 0)), 10);
  EXPECT_EQ(above.logOdds(idx(5, 0, -1)), 4);

  // 2: its own amount.
  c.incr_low_fore = 2;
  VoxelGrid two(c);
  seeWorld(two, Vec::Zero(), {Vec(1.0f, 0.0f, 0.0f)});
  EXPECT_EQ(two.logOdds(idx(9, 0, 0)), 2);
  EXPECT_EQ(two.logOdds(idx(11, 0, 0)), 4);

  c.incr_low_fore = -2;
  EXPECT_NE(c.validate().find("incr_low_fore"), std::string::npos);
  c.incr_low_fore = 40000;
  EXPECT_NE(c.validate().find("incr_low_fore"), std::string::npos);
}

void checkRayAgainstSampling(const Eigen::Isometry3f& T, const Vec& world_point) {
  VoxelGrid g;
  const Vec ps = T.inverse() * world_point;
  const Vec pf = T * ps;  // what the grid sees
  const Vec cam = T.translation();
  const SampledRay ray = sampleRay(cam.cast<double>(), pf.cast<double>(), 0.1);
  ASSERT_GE(ray.voxels.size(), 4u);
  const IntegrationStats s = g.integrate({ps}, T);
  EXPECT_EQ(s.points_used, 1u);
  const std::size_t m = ray.voxels.size();
  for (std::size_t i = 0; i + 2 < m; ++i)
    EXPECT_EQ(g.logOdds(ray.voxels[i]), -1) << "voxel " << i << " of " << m;
  EXPECT_EQ(g.logOdds(ray.voxels[m - 2]), 4);
  EXPECT_EQ(g.logOdds(ray.voxels[m - 1]), 10);
  EXPECT_EQ(g.logOdds(ray.aft), 4);
  EXPECT_EQ(s.voxels_decremented, m - 2);
  EXPECT_EQ(countNonZero(g), m + 1);  // nothing off the ray
}

TEST(VoxelGridSensorModel, DiagonalRaysMatchSampledTraversal) {
  checkRayAgainstSampling(Eigen::Isometry3f::Identity(), Vec(0.73f, 0.41f, 0.27f));
  checkRayAgainstSampling(cameraAt(Vec(0.013f, -0.021f, 1.1f)), Vec(2.37f, -1.19f, 0.0f));
  checkRayAgainstSampling(cameraAt(Vec(-0.31f, 0.52f, 0.33f)), Vec(-3.17f, 2.61f, -0.77f));
  // A rotated (optical-frame-like) sensor.
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear() = (Eigen::AngleAxisf(0.3f, Vec::UnitZ()) * Eigen::AngleAxisf(-1.83f, Vec::UnitX()))
                   .toRotationMatrix();
  T.translation() = Vec(0.21f, -0.17f, 1.1f);
  checkRayAgainstSampling(T, Vec(3.11f, 0.77f, 0.03f));
  checkRayAgainstSampling(T, Vec(-1.42f, -2.93f, 0.61f));
}

TEST(VoxelGridSensorModel, PointInCameraVoxelGetsOnlyEndpointAndAft) {
  VoxelGridConfig c;
  c.min_range = 0.0;
  VoxelGrid g(c);
  seeWorld(g, Vec::Zero(), {Vec(0.03f, 0.0f, 0.0f)});
  EXPECT_EQ(g.logOdds(idx(0, 0, 0)), 10);
  EXPECT_EQ(g.logOdds(idx(1, 0, 0)), 4);
  EXPECT_EQ(countNonZero(g), 2u);
  // The point exactly at the camera: no direction, so no aft neighbour.
  VoxelGrid h(c);
  seeWorld(h, Vec::Zero(), {Vec::Zero()});
  EXPECT_EQ(h.logOdds(idx(0, 0, 0)), 10);
  EXPECT_EQ(countNonZero(h), 1u);
}

TEST(VoxelGridSensorModel, IntegrateAgreesWithIndexOfOnVoxelFaces) {
  // Points exactly on faces and one float step either side: integrate() must file each one in
  // the voxel indexOf() names, whatever l_v (0.15 has no exact binary inverse).
  for (double l : {0.1, 0.25, 0.15, 0.07}) {
    VoxelGridConfig c;
    c.voxel_size = l;
    c.size_x = c.size_y = c.size_z = 60 * l;
    c.z_below_robot = 30 * l;
    c.min_range = 0.0;
    c.max_range = 100.0;
    VoxelGrid g(c);
    int checked = 0;
    for (int k = -20; k <= 20; k += 3) {
      const float face = static_cast<float>((k + 0.5) * l);
      for (float x : {std::nextafter(face, -1e9f), face, std::nextafter(face, 1e9f)}) {
        const Vec p(x, static_cast<float>(-7.5 * l), static_cast<float>(3.5 * l));
        g.integrate({p}, Eigen::Isometry3f::Identity());
        const VoxelIndex i = g.indexOf(p);
        ASSERT_TRUE(g.contains(i));
        bool found = false;
        for (const VoxelPoint& q : g.points(i))
          found = found || q.position == p;
        EXPECT_TRUE(found) << "l " << l << " x " << x;
        ++checked;
      }
    }
    EXPECT_EQ(checked, 42);
  }
}

TEST(VoxelGridSensorModel, ExactDiagonalThroughVoxelEdges) {
  // The ray (0,0,0) -> (1,1,0) passes exactly through voxel edges: whichever way the ties go,
  // the walk is face-connected, takes |du| + |dv| steps and ends in the endpoint voxel.
  VoxelGrid g;
  const IntegrationStats s = seeWorld(g, Vec::Zero(), {Vec(1.0f, 1.0f, 0.0f)});
  EXPECT_EQ(s.voxels_decremented, 19u);  // 21 voxels on the walk minus fore and endpoint
  EXPECT_EQ(g.logOdds(idx(10, 10, 0)), 10);
  const int fore = g.logOdds(idx(9, 10, 0)) == 4 ? 1 : 0;
  EXPECT_EQ(fore + (g.logOdds(idx(10, 9, 0)) == 4 ? 1 : 0), 1);
  const int aft =
      (g.logOdds(idx(11, 10, 0)) == 4 ? 1 : 0) + (g.logOdds(idx(10, 11, 0)) == 4 ? 1 : 0);
  EXPECT_EQ(aft, 1);
  EXPECT_EQ(g.logOdds(idx(0, 0, 0)), -1);
  EXPECT_EQ(countNonZero(g), 22u);
  for (int i = 0; i <= 9; ++i)
    EXPECT_EQ(g.logOdds(idx(i, i, 0)), -1) << i;  // on the diagonal
}

TEST(VoxelGridSensorModel, OnePointPerVoxelPerFrame) {
  VoxelGrid g;
  // Two points in voxel (20, 0, 0), the second closer: only the first counts (000 Sec. IV).
  const IntegrationStats s = seeWorld(g, Vec::Zero(),
                                      {Vec(2.02f, 0.01f, 0.0f), Vec(1.97f, -0.01f, 0.01f),
                                       Vec(3.0f, 0.0f, 0.0f), Vec(3.01f, 0.0f, 0.0f)});
  EXPECT_EQ(s.points_in, 4u);
  EXPECT_EQ(s.points_used, 2u);
  EXPECT_EQ(s.points_duplicate, 2u);
  EXPECT_EQ(g.logOdds(idx(20, 0, 0)), 10 - 1);  // endpoint once, and on the ray to (30, 0, 0)
  const VoxelPointList list = g.points(idx(20, 0, 0));
  ASSERT_EQ(list.size, 1u);
  EXPECT_FLOAT_EQ(list.data[0].position.x(), 2.02f);
  EXPECT_EQ(g.logOdds(idx(30, 0, 0)), 10);
  // The next frame may use the voxel again.
  const IntegrationStats s2 = seeWorld(g, Vec::Zero(), {Vec(2.0f, 0.0f, 0.0f)});
  EXPECT_EQ(s2.points_duplicate, 0u);
  EXPECT_EQ(g.logOdds(idx(20, 0, 0)), 19);
  EXPECT_EQ(g.points(idx(20, 0, 0)).size, 2u);
}

TEST(VoxelGridSensorModel, LogOddsClampedBothWays) {
  VoxelGrid g;
  const VoxelIndex i = idx(20, 0, 0);
  g.setLogOdds(i, 10000);
  EXPECT_EQ(g.logOdds(i), 250);
  g.setLogOdds(i, -10000);
  EXPECT_EQ(g.logOdds(i), -100);
  g.setLogOdds(i, 0);
  for (int f = 0; f < 40; ++f)
    seeWorld(g, Vec::Zero(), {Vec(2.0f, 0.0f, 0.0f)});
  EXPECT_EQ(g.logOdds(i), 250);
  EXPECT_EQ(g.logOdds(idx(10, 0, 0)), -40);
  for (int f = 0; f < 400; ++f)
    seeWorld(g, Vec::Zero(), {Vec(4.0f, 0.0f, 0.0f)});
  EXPECT_EQ(g.logOdds(i), -100);
  EXPECT_EQ(g.logOdds(idx(10, 0, 0)), -100);
  EXPECT_EQ(g.logOdds(idx(40, 0, 0)), 250);
  EXPECT_TRUE(g.isOccupied(idx(40, 0, 0)));
}

TEST(VoxelGridSensorModel, IncrementsAppliedAfterDecrementsOfTheFrame) {
  // Ray A ends in X = (20, 0, 0), ray B crosses X. With X at lop_max, B's decrement must not
  // eat A's evidence whatever the input order.
  for (bool a_first : {true, false}) {
    VoxelGrid g;
    const VoxelIndex x = idx(20, 0, 0);
    g.setLogOdds(x, 250);
    const Vec a(2.0f, 0.0f, 0.0f), b(4.0f, 0.0f, 0.0f);
    seeWorld(g, Vec::Zero(), a_first ? Points{a, b} : Points{b, a});
    EXPECT_EQ(g.logOdds(x), 250) << a_first;
    // And at lop_min the decrement is clamped first, then the increment counts fully.
    g.setLogOdds(x, -100);
    seeWorld(g, Vec::Zero(), a_first ? Points{a, b} : Points{b, a});
    EXPECT_EQ(g.logOdds(x), -90) << a_first;
  }
}

TEST(VoxelGridSensorModel, MovedObstacleIsClearedAfterComputedFrames) {
  for (int decr : {1, 3, 5}) {
    VoxelGridConfig c;
    c.decr = decr;
    VoxelGrid g(c);
    Points wall, behind;
    for (int v = -4; v <= 4; ++v) {
      wall.push_back(Vec(2.0f, 0.1f * v, 0.0f));    // voxels (20, v, 0)
      behind.push_back(Vec(4.0f, 0.2f * v, 0.0f));  // rays cross (20, v, 0) mid-voxel
    }
    const int wall_frames = 30;
    for (int f = 0; f < wall_frames; ++f)
      seeWorld(g, Vec::Zero(), wall);
    const int l0 = std::min(wall_frames * c.incr_high, c.lop_max);
    for (int v = -4; v <= 4; ++v) {
      ASSERT_EQ(g.logOdds(idx(20, v, 0)), l0);
      ASSERT_TRUE(g.isOccupied(idx(20, v, 0)));
    }
    // Each frame behind the wall takes decr off every wall voxel: occupied while
    // l0 - k decr >= occ_t.
    const int k = (l0 - c.occ_threshold) / decr + 1;
    for (int f = 1; f < k; ++f)
      seeWorld(g, Vec::Zero(), behind);
    for (int v = -4; v <= 4; ++v)
      EXPECT_TRUE(g.isOccupied(idx(20, v, 0))) << decr;
    seeWorld(g, Vec::Zero(), behind);
    for (int v = -4; v <= 4; ++v) {
      EXPECT_FALSE(g.isOccupied(idx(20, v, 0))) << decr;
      EXPECT_EQ(g.logOdds(idx(20, v, 0)), l0 - k * decr);
      EXPECT_TRUE(g.isOccupied(idx(40, 2 * v, 0)) || k * c.incr_high < c.occ_threshold);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Point lists

TEST(VoxelGridPoints, OrderedByRangeCapacityRespectedCloserWins) {
  VoxelGridConfig c;
  c.point_list_capacity = 3;
  VoxelGrid g(c);
  // One point per frame into voxel (20, 0, 0), seen from different distances along x.
  const std::vector<float> ranges = {5.0f, 3.0f, 4.0f, 2.0f, 6.0f, 2.5f, 3.0f};
  for (std::size_t f = 0; f < ranges.size(); ++f) {
    const Vec p(2.0f + 0.005f * static_cast<float>(f), 0.0f, 0.0f);
    const Vec cam = p - Vec(ranges[f], 0.0f, 0.0f);
    g.integrate({Vec(ranges[f], 0.0f, 0.0f)}, cameraAt(cam));
  }
  const VoxelPointList list = g.points(idx(20, 0, 0));
  ASSERT_EQ(list.size, 3u);
  EXPECT_FLOAT_EQ(list.data[0].range, 2.0f);
  EXPECT_FLOAT_EQ(list.data[1].range, 2.5f);
  EXPECT_FLOAT_EQ(list.data[2].range, 3.0f);  // the first 3.0 (frame 1); the later tie lost
  EXPECT_NEAR(list.data[0].position.x(), 2.015f, 1e-5f);
  EXPECT_NEAR(list.data[1].position.x(), 2.025f, 1e-5f);
  EXPECT_NEAR(list.data[2].position.x(), 2.005f, 1e-5f);
  int n = 0;
  for (const VoxelPoint& p : list) {
    EXPECT_EQ(g.indexOf(p.position), idx(20, 0, 0));
    ++n;
  }
  EXPECT_EQ(n, 3);
  EXPECT_TRUE(g.points(idx(21, 0, 0)).empty());
}

TEST(VoxelGridPoints, FullCapacityKeepsTheClosestSorted) {
  VoxelGridConfig c;
  c.size_x = c.size_y = 4.0;
  c.size_z = 1.0;
  c.z_below_robot = 0.5;
  c.point_list_capacity = 255;
  VoxelGrid g(c);
  constexpr int kFreeLop = 10;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> range(0.5f, 1.9f);
  std::vector<float> seen;
  for (int f = 0; f < 600; ++f) {
    const float r = range(rng);
    seen.push_back(r);
    g.integrate({Vec(r, 0.0f, 0.0f)}, cameraAt(Vec(1.0f - r, 0.0f, 0.0f)));  // point at x = 1
  }
  std::sort(seen.begin(), seen.end());
  const VoxelPointList list = g.points(idx(10, 0, 0));
  ASSERT_EQ(list.size, 255u);
  for (std::size_t i = 0; i < list.size; ++i)
    EXPECT_FLOAT_EQ(list.data[i].range, seen[i]) << i;
}

TEST(VoxelGridPoints, MomentsCountEveryPointWhileTheListKeepsTheClosest) {
  // One point per frame into the voxel at x = 1, from cameras at varying distance: the list keeps
  // the 8 nearest, the moments hold all of them (HeightMapConfig::observation_means).
  VoxelGridConfig c;
  c.size_x = c.size_y = 4.0;
  c.size_z = 1.0;
  c.z_below_robot = 0.5;
  VoxelGrid g(c);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> range(0.5f, 1.9f), z(-0.04f, 0.04f);
  double sum_z = 0.0, sum_x = 0.0;
  const int frames = 40;
  for (int f = 0; f < frames; ++f) {
    const float r = range(rng), pz = z(rng), px = 1.0f + 0.5f * z(rng);
    sum_z += pz;
    sum_x += px;
    g.integrate({Vec(r, 0.0f, pz)}, cameraAt(Vec(px - r, 0.0f, 0.0f)));
  }
  const VoxelIndex i = idx(10, 0, 0);
  ASSERT_EQ(g.points(i).size, 8u);
  const VoxelMoments m = g.moments(i);
  EXPECT_FLOAT_EQ(m.weight, static_cast<float>(frames));
  EXPECT_NEAR(m.sz / m.weight, sum_z / frames, 1e-6);
  EXPECT_NEAR(m.sx / m.weight, sum_x / frames, 1e-6);
  EXPECT_NEAR(m.sy / m.weight, 0.0, 1e-6);
  EXPECT_EQ(g.moments(idx(11, 0, 0)).weight, 0.0f);    // a voxel without points
  EXPECT_EQ(g.moments(idx(1000, 0, 0)).weight, 0.0f);  // outside the window
  // Past kMomentWindow points the old ones fade: a surface that moved is followed.
  for (int f = 0; f < 300; ++f)
    g.integrate({Vec(1.0f, 0.0f, 0.03f)}, cameraAt(Vec(0.0f, 0.0f, 0.0f)));
  const VoxelMoments later = g.moments(i);
  EXPECT_LE(later.weight, VoxelGrid::kMomentWindow + 1e-3f);
  EXPECT_GT(later.weight, VoxelGrid::kMomentWindow - 1.0f);
  EXPECT_NEAR(later.sz / later.weight, 0.03, 2e-3);
  g.clear();
  EXPECT_EQ(g.moments(i).weight, 0.0f);
}

TEST(VoxelGridPoints, HitMassCountsEveryPointOfTheFrameAndFades) {
  // 000 Sec. IV integrates one point per voxel per frame; hitMass() counts all of them: 30 points
  // of a frame in one voxel and 2 in the voxel above weigh 30 and 2, not 1 and 1.
  VoxelGridConfig c;
  c.size_x = c.size_y = 4.0;
  c.size_z = 1.0;
  c.z_below_robot = 0.5;
  VoxelGrid g(c);
  Points frame;
  double sum_z = 0.0;
  for (int k = 0; k < 30; ++k) {
    const float z = -0.04f + 0.08f * static_cast<float>(k) / 29.0f;  // voxel w = 0
    frame.push_back(Vec(1.0f, 0.0f, z));
    sum_z += z;
  }
  frame.push_back(Vec(1.0f, 0.0f, 0.07f));  // voxel w = 1
  frame.push_back(Vec(1.0f, 0.0f, 0.09f));
  g.integrate(frame, cameraAt(Vec::Zero()));
  EXPECT_FLOAT_EQ(g.hitMass(idx(10, 0, 0)), 30.0f);
  EXPECT_FLOAT_EQ(g.hitMass(idx(10, 0, 1)), 2.0f);
  EXPECT_EQ(g.hitMass(idx(11, 0, 0)), 0.0f);    // a voxel without points
  EXPECT_EQ(g.hitMass(idx(1000, 0, 0)), 0.0f);  // outside the window
  EXPECT_NEAR(g.hitMeanZ(idx(10, 0, 0)), sum_z / 30.0, 1e-5);
  EXPECT_NEAR(g.hitMeanZ(idx(10, 0, 1)), 0.08, 1e-5);
  EXPECT_TRUE(std::isnan(g.hitMeanZ(idx(11, 0, 0))));
  // The mean of every point of the two voxels, each point weighing the same.
  EXPECT_NEAR(g.massMeanZ(10, 0, -1, 1), (sum_z + 0.16) / 32.0, 1e-5);
  EXPECT_TRUE(std::isnan(g.massMeanZ(11, 0, -1, 1)));
  // The point list still holds one point per frame (000 Sec. IV).
  EXPECT_EQ(g.points(idx(10, 0, 0)).size, 1u);
  // Not tracked (SafetyMapper when no switch reads it): the same frame adds no mass, and the
  // occupancy evidence is the same.
  VoxelGrid untracked(c);
  untracked.setHitMassTracking(false);
  untracked.integrate(frame, cameraAt(Vec::Zero()));
  EXPECT_EQ(untracked.hitMass(idx(10, 0, 0)), 0.0f);
  EXPECT_EQ(untracked.logOdds(idx(10, 0, 0)), g.logOdds(idx(10, 0, 0)));
  // Frames without points fade the mass by (1 - 1 / kHitMassWindow) each; the mean is kept.
  for (int f = 0; f < 10; ++f)
    g.integrate({Vec(-1.0f, 0.0f, 0.0f)}, cameraAt(Vec::Zero()));
  const float keep = std::pow(1.0f - 1.0f / VoxelGrid::kHitMassWindow, 10.0f);
  EXPECT_NEAR(g.hitMass(idx(10, 0, 0)), 30.0f * keep, 1e-3f);
  EXPECT_NEAR(g.hitMass(idx(10, 0, 1)), 2.0f * keep, 1e-4f);
  EXPECT_NEAR(g.hitMeanZ(idx(10, 0, 0)), sum_z / 30.0, 1e-5);
  EXPECT_NEAR(g.massMeanZ(10, 0, -1, 1), (sum_z + 0.16) / 32.0, 1e-5);
  // A new frame adds to the faded sum.
  g.integrate({Vec(1.0f, 0.0f, 0.0f)}, cameraAt(Vec::Zero()));
  EXPECT_NEAR(g.hitMass(idx(10, 0, 0)),
              30.0f * keep * (1.0f - 1.0f / VoxelGrid::kHitMassWindow) + 1.0f, 1e-3f);
  g.clear();
  EXPECT_EQ(g.hitMass(idx(10, 0, 0)), 0.0f);
  EXPECT_TRUE(std::isnan(g.massMeanZ(10, 0, -1, 1)));
}

TEST(VoxelGridPoints, HitMassLeavesWithTheWindow) {
  VoxelGridConfig c;
  c.size_x = c.size_y = 2.0;
  c.size_z = 1.0;
  c.z_below_robot = 0.5;
  VoxelGrid g(c);
  g.recenter(Vec::Zero());
  g.integrate({Vec(0.5f, 0.0f, 0.0f), Vec(0.5f, 0.0f, 0.01f)}, cameraAt(Vec::Zero()));
  EXPECT_FLOAT_EQ(g.hitMass(idx(5, 0, 0)), 2.0f);
  g.recenter(Vec(5.0f, 0.0f, 0.0f));  // the voxel leaves the window
  EXPECT_EQ(g.hitMass(idx(5, 0, 0)), 0.0f);
  g.recenter(Vec::Zero());  // and comes back empty
  EXPECT_EQ(g.hitMass(idx(5, 0, 0)), 0.0f);
  EXPECT_TRUE(std::isnan(g.hitMeanZ(idx(5, 0, 0))));
}

TEST(VoxelGridPoints, RangeIsDistanceToCameraWithRotation) {
  VoxelGrid g;
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear() = Eigen::AngleAxisf(0.7f, Vec(1.0f, 2.0f, 3.0f).normalized()).toRotationMatrix();
  T.translation() = Vec(0.4f, -0.3f, 1.0f);
  const Vec ps(0.5f, -1.2f, -0.9f);
  const Vec pf = T * ps;
  ASSERT_TRUE(g.contains(g.indexOf(pf))) << pf.transpose();
  g.integrate({ps}, T);
  const VoxelPointList list = g.points(g.indexOf(pf));
  ASSERT_EQ(list.size, 1u);
  EXPECT_NEAR(list.data[0].range, ps.norm(), 1e-5f);
  EXPECT_NEAR((list.data[0].position - pf).norm(), 0.0f, 1e-6f);
  EXPECT_EQ(g.logOdds(g.indexOf(pf)), 10);
}

// ---------------------------------------------------------------------------------------------
// Scrolling

TEST(VoxelGridScroll, ContentStaysAtItsGlobalIndexAndLeavingVoxelsAreCleared) {
  VoxelGrid g;
  seeWorld(g, Vec::Zero(), {Vec(1.0f, 0.5f, 0.2f)});
  const VoxelIndex hit = idx(10, 5, 2);
  ASSERT_EQ(g.logOdds(hit), 10);
  g.setLogOdds(idx(-50, 7, 3), 77);    // will leave when the window moves +x
  g.setLogOdds(idx(-47, -50, 0), 55);  // stays

  const std::size_t cleared = g.recenter(Vec(0.3f, 0.0f, 0.0f));
  EXPECT_EQ(cleared, 3u * 100 * 30);
  EXPECT_EQ(g.minIndex(), idx(-47, -50, -10));
  EXPECT_EQ(g.sizeU(), 100);
  EXPECT_EQ(g.logOdds(hit), 10);
  ASSERT_EQ(g.points(hit).size, 1u);
  EXPECT_EQ(g.indexOf(g.points(hit).data[0].position), hit);
  EXPECT_EQ(g.logOdds(idx(-47, -50, 0)), 55);
  EXPECT_FALSE(g.contains(idx(-50, 7, 3)));
  // The slot of -50 now holds 50, which must read empty.
  EXPECT_EQ(g.logOdds(idx(50, 7, 3)), 0);
  EXPECT_EQ(g.logOdds(idx(52, 7, 3)), 0);

  // Back: -50 re-enters empty, the ones that entered at +x leave.
  g.setLogOdds(idx(51, 0, 0), 33);
  EXPECT_EQ(g.recenter(Vec::Zero()), 3u * 100 * 30);
  EXPECT_EQ(g.logOdds(idx(-50, 7, 3)), 0);
  EXPECT_EQ(g.logOdds(hit), 10);
  EXPECT_FALSE(g.contains(idx(51, 0, 0)));
  // Staying put clears nothing; a jump larger than the window clears everything.
  EXPECT_EQ(g.recenter(Vec(0.01f, -0.02f, 0.03f)), 0u);
  EXPECT_EQ(g.logOdds(hit), 10);
  EXPECT_EQ(g.recenter(Vec(100.0f, 0.0f, 0.0f)), 300000u);
  g.recenter(Vec::Zero());
  EXPECT_EQ(g.logOdds(hit), 0);
  EXPECT_TRUE(g.points(hit).empty());
}

TEST(VoxelGridScroll, RandomScrollsAgreeWithAReferenceMap) {
  VoxelGridConfig c;
  c.size_x = 2.0;
  c.size_y = 1.6;
  c.size_z = 0.8;
  c.z_below_robot = 0.3;
  VoxelGrid g(c);
  std::mt19937 rng(42);
  std::map<std::tuple<int, int, int>, int> ref;
  auto inWindow = [&](int u, int v, int w, const VoxelIndex& m) {
    return u >= m.u && u < m.u + g.sizeU() && v >= m.v && v < m.v + g.sizeV() && w >= m.w &&
           w < m.w + g.sizeW();
  };
  for (int iter = 0; iter < 200; ++iter) {
    const VoxelIndex m = g.minIndex();
    for (int j = 0; j < 30; ++j) {
      const int u = m.u + static_cast<int>(rng() % g.sizeU());
      const int v = m.v + static_cast<int>(rng() % g.sizeV());
      const int w = m.w + static_cast<int>(rng() % g.sizeW());
      const int val = static_cast<int>(rng() % 300) - 100;
      g.setLogOdds(idx(u, v, w), val);
      ref[{u, v, w}] = std::max(-100, std::min(250, val));
    }
    const float range = iter % 10 == 0 ? 5.0f : 0.4f;  // mostly small shifts, some jumps
    std::uniform_real_distribution<float> d(-range, range);
    const Vec robot(d(rng), d(rng), d(rng));
    std::size_t expect_cleared = 0;
    const VoxelIndex old = g.minIndex();
    const std::size_t cleared = g.recenter(robot);
    const VoxelIndex nm = g.minIndex();
    for (int u = nm.u; u < nm.u + g.sizeU(); ++u)
      for (int v = nm.v; v < nm.v + g.sizeV(); ++v)
        for (int w = nm.w; w < nm.w + g.sizeW(); ++w)
          if (!inWindow(u, v, w, old)) ++expect_cleared;
    EXPECT_EQ(cleared, expect_cleared);
    for (auto it = ref.begin(); it != ref.end();) {
      const auto [u, v, w] = it->first;
      it = inWindow(u, v, w, nm) ? std::next(it) : ref.erase(it);
    }
    for (int u = nm.u; u < nm.u + g.sizeU(); ++u)
      for (int v = nm.v; v < nm.v + g.sizeV(); ++v)
        for (int w = nm.w; w < nm.w + g.sizeW(); ++w) {
          const auto it = ref.find({u, v, w});
          ASSERT_EQ(g.logOdds(idx(u, v, w)), it == ref.end() ? 0 : it->second)
              << "iter " << iter << " voxel " << u << "," << v << "," << w;
        }
  }
}

// Column queries after scrolls (the ring rotated): a small grid recentred 40 times at random,
// `writes` random log-odds in [lop_lo, lop_lo + 250) per recentring, then query(g, m, u, v, lo,
// hi, iter) for every column of the window and one beyond each side, with [lo, hi] inside,
// across and outside the window.
template <typename Query>
void queryColumnsAfterScrolls(unsigned seed, int writes, int lop_lo, Query&& query) {
  VoxelGridConfig c;
  c.size_x = 1.2;
  c.size_y = 0.8;
  c.size_z = 1.0;
  c.z_below_robot = 0.4;
  VoxelGrid g(c);
  std::mt19937 rng(seed);
  for (int iter = 0; iter < 40; ++iter) {
    std::uniform_real_distribution<float> d(-0.7f, 0.7f);
    g.recenter(Vec(d(rng), d(rng), d(rng)));
    const VoxelIndex m = g.minIndex();
    for (int j = 0; j < writes; ++j) {
      const int u = m.u + static_cast<int>(rng() % g.sizeU());
      const int v = m.v + static_cast<int>(rng() % g.sizeV());
      const int w = m.w + static_cast<int>(rng() % g.sizeW());
      g.setLogOdds(idx(u, v, w), static_cast<int>(rng() % 250) + lop_lo);  // occ_t = 100
    }
    for (int u = m.u - 1; u <= m.u + g.sizeU(); ++u) {
      for (int v = m.v - 1; v <= m.v + g.sizeV(); ++v) {
        const int lo = m.w - 2 + static_cast<int>(rng() % (g.sizeW() + 2));
        const int hi = lo + static_cast<int>(rng() % (g.sizeW() + 4)) - 1;
        query(g, m, u, v, lo, hi, iter);
      }
    }
  }
}

// occupiedExtent() reads a column in ring order: after scrolls the ring is rotated, so compare
// it with isOccupied() on every voxel, for ranges inside, across and outside the window.
TEST(VoxelGridScroll, OccupiedExtentAgreesWithIsOccupiedAfterScrolls) {
  int columns_with_voxels = 0;
  queryColumnsAfterScrolls(
      7, 60, -50,
      [&](const VoxelGrid& g, const VoxelIndex&, int u, int v, int lo, int hi, int iter) {
        int top = -12345, bottom = -12345;
        for (int w = hi; w >= lo; --w) {
          if (!g.isOccupied(idx(u, v, w))) continue;
          if (top == -12345) top = w;
          bottom = w;
        }
        int got_top = -777, got_bottom = -777;
        const bool found = g.occupiedExtent(u, v, lo, hi, &got_top, &got_bottom);
        ASSERT_EQ(found, top != -12345) << "iter " << iter << " column " << u << "," << v;
        if (found) {
          ++columns_with_voxels;
          EXPECT_EQ(got_top, top);
          EXPECT_EQ(got_bottom, bottom);
        } else {
          EXPECT_EQ(got_top, -777);  // untouched
          EXPECT_EQ(got_bottom, -777);
        }
      });
  EXPECT_GT(columns_with_voxels, 100);  // the comparison saw occupied columns
}

// hiddenBelowObserved() reads the column in ring order too: against logOdds() voxel by voxel.
TEST(VoxelGridScroll, HiddenBelowObservedAgreesWithLogOddsAfterScrolls) {
  constexpr int kFreeLop = 10;
  int hidden = 0, not_hidden = 0;
  queryColumnsAfterScrolls(
      11, 120, -100,
      [&](const VoxelGrid& g, const VoxelIndex& m, int u, int v, int lo, int hi, int iter) {
        bool expected = false, seen_above = false;
        const bool inside = u >= m.u && u < m.u + g.sizeU() && v >= m.v && v < m.v + g.sizeV();
        for (int w = hi; inside && w >= lo; --w) {
          if (w < m.w || w >= m.w + g.sizeW()) continue;  // outside the window: not a voxel
          const int lop = g.logOdds(idx(u, v, w));
          if (lop >= g.config().occ_threshold || lop <= -kFreeLop) {
            seen_above = true;
          } else if (seen_above) {
            expected = true;
            break;
          }
        }
        const bool got = g.hiddenBelowObserved(u, v, lo, hi, kFreeLop);
        ASSERT_EQ(got, expected) << "iter " << iter << " column " << u << "," << v;
        (got ? hidden : not_hidden) += 1;
      });
  EXPECT_GT(hidden, 50);  // both answers were asked for
  EXPECT_GT(not_hidden, 50);
}

// seenFreeWithin() as well (SafetyMapperConfig::unseen_floor_band).
TEST(VoxelGridScroll, SeenFreeWithinAgreesWithLogOddsAfterScrolls) {
  constexpr int kFreeLop = 10;
  int seen = 0, not_seen = 0;
  queryColumnsAfterScrolls(
      13, 120, -100,
      [&](const VoxelGrid& g, const VoxelIndex& m, int u, int v, int lo, int hi, int iter) {
        bool expected = false;
        const bool inside = u >= m.u && u < m.u + g.sizeU() && v >= m.v && v < m.v + g.sizeV();
        for (int w = lo; inside && w <= hi; ++w) {
          if (w < m.w || w >= m.w + g.sizeW()) continue;  // outside the window: not a voxel
          if (g.logOdds(idx(u, v, w)) <= -kFreeLop) expected = true;
        }
        const bool got = g.seenFreeWithin(u, v, lo, hi, kFreeLop);
        ASSERT_EQ(got, expected) << "iter " << iter << " column " << u << "," << v;
        (got ? seen : not_seen) += 1;
      });
  EXPECT_GT(seen, 50);  // both answers were asked for
  EXPECT_GT(not_seen, 50);
}

TEST(VoxelGrid, HiddenBelowObservedNeedsAVoxelSeenAbove) {
  VoxelGrid g;
  g.recenter(Vec(0.0f, 0.0f, 0.0f));
  const VoxelIndex f = g.indexOf(Vec(1.0f, 0.0f, 0.0f));
  g.setLogOdds(f, 200);  // the floor
  for (int w = 1; w <= 3; ++w)
    g.setLogOdds(idx(f.u, f.v, f.w + w), -50);  // seen free
  // Open space above what was seen: nothing hidden.
  EXPECT_FALSE(g.hiddenBelowObserved(f.u, f.v, f.w + 1, f.w + 12, 10));
  g.setLogOdds(idx(f.u, f.v, f.w + 9), -9);  // a few rays passed there: not seen free
  EXPECT_FALSE(g.hiddenBelowObserved(f.u, f.v, f.w + 1, f.w + 12, 10));
  EXPECT_TRUE(g.hiddenBelowObserved(f.u, f.v, f.w + 1, f.w + 12, 9));
  g.setLogOdds(idx(f.u, f.v, f.w + 9), -10);  // rays passed over a layer at w + 4 .. 8
  EXPECT_TRUE(g.hiddenBelowObserved(f.u, f.v, f.w + 1, f.w + 12, 10));
  EXPECT_TRUE(g.hiddenBelowObserved(f.u, f.v, f.w + 8, f.w + 9, 10));
  EXPECT_FALSE(g.hiddenBelowObserved(f.u, f.v, f.w + 9, f.w + 12, 10));  // below the range
  EXPECT_FALSE(g.hiddenBelowObserved(f.u, f.v, f.w + 1, f.w + 3, 10));
  g.setLogOdds(idx(f.u, f.v, f.w + 6), -3);  // grazed: still hidden
  EXPECT_TRUE(g.hiddenBelowObserved(f.u, f.v, f.w + 5, f.w + 9, 10));
  g.setLogOdds(idx(f.u, f.v, f.w + 9), 0);
  g.setLogOdds(idx(f.u, f.v, f.w + 11), 150);  // occupied above counts as seen
  EXPECT_TRUE(g.hiddenBelowObserved(f.u, f.v, f.w + 1, f.w + 12, 10));
  EXPECT_FALSE(g.hiddenBelowObserved(f.u + 100000, f.v, f.w + 1, f.w + 12, 10));  // outside
}

TEST(VoxelGridScroll, IntegrationAfterScrollUsesGlobalIndices) {
  VoxelGrid g;
  g.recenter(Vec(3.37f, -2.21f, 0.4f));
  const Vec cam(3.4f, -2.2f, 1.5f);
  const Vec p(5.13f, -1.07f, 0.33f);
  const Eigen::Isometry3f T = cameraAt(cam);
  const Vec ps = T.inverse() * p;
  const Vec pf = T * ps;
  g.integrate({ps}, T);
  EXPECT_EQ(g.logOdds(g.indexOf(pf)), 10);
  EXPECT_EQ(g.logOdds(g.indexOf(cam)), -1);
  ASSERT_EQ(g.points(g.indexOf(pf)).size, 1u);
}

// ---------------------------------------------------------------------------------------------
// Bad input

TEST(VoxelGridBadInput, EmptyFrame) {
  VoxelGrid g;
  const IntegrationStats s = g.integrate({}, Eigen::Isometry3f::Identity());
  EXPECT_EQ(s.points_in, 0u);
  EXPECT_EQ(s.points_used, 0u);
  EXPECT_EQ(g.frameCount(), 1u);
  EXPECT_EQ(countNonZero(g), 0u);
}

TEST(VoxelGridBadInput, NonFiniteAndOutOfRangePointsAreSkippedAndCounted) {
  VoxelGrid g;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const Points pts = {Vec(nan, 0.0f, 1.0f),   Vec(1.0f, inf, 0.0f),
                      Vec(0.0f, 0.0f, -inf),  Vec(0.1f, 0.0f, 0.0f),  // < min_range
                      Vec(8.5f, 0.0f, 0.0f),                          // > max_range
                      Vec(1e30f, 0.0f, 0.0f), Vec(2.0f, 0.0f, 0.0f)};
  const IntegrationStats s = g.integrate(pts, Eigen::Isometry3f::Identity());
  EXPECT_EQ(s.points_in, 7u);
  EXPECT_EQ(s.points_non_finite, 3u);
  EXPECT_EQ(s.points_out_of_range, 3u);
  EXPECT_EQ(s.points_used, 1u);
  EXPECT_EQ(g.logOdds(idx(20, 0, 0)), 10);
  EXPECT_EQ(countNonZero(g), 22u);  // 19 decremented + fore + endpoint + aft
  // A non-finite pose: every point is unusable, nothing changes.
  Eigen::Isometry3f bad = Eigen::Isometry3f::Identity();
  bad.translation().x() = nan;
  const IntegrationStats s2 = g.integrate({Vec(2.0f, 0.0f, 0.0f)}, bad);
  EXPECT_EQ(s2.points_non_finite, 1u);
  EXPECT_EQ(g.logOdds(idx(20, 0, 0)), 10);
}

TEST(VoxelGridBadInput, EndpointOutsideWindowStillClearsInWindowPart) {
  VoxelGrid g;
  // Window u in [-50, 50). Camera at u = 45, point at u = 75.
  const IntegrationStats s = seeWorld(g, Vec(4.5f, 0.0f, 0.0f), {Vec(7.5f, 0.0f, 0.0f)});
  EXPECT_EQ(s.points_used, 1u);
  EXPECT_EQ(s.points_outside_grid, 1u);
  EXPECT_EQ(s.voxels_decremented, 5u);
  for (int u = 45; u <= 49; ++u)
    EXPECT_EQ(g.logOdds(idx(u, 0, 0)), -1);
  EXPECT_EQ(countNonZero(g), 5u);
  // An endpoint just past the edge: its fore neighbour is in the window and gets incr_L.
  VoxelGrid h;
  seeWorld(h, Vec(4.5f, 0.0f, 0.0f), {Vec(5.0f, 0.0f, 0.0f)});
  EXPECT_EQ(h.logOdds(idx(49, 0, 0)), 4);
  for (int u = 45; u <= 48; ++u)
    EXPECT_EQ(h.logOdds(idx(u, 0, 0)), -1);
  // And an endpoint just before the edge: the aft neighbour is outside, nothing breaks.
  VoxelGrid k;
  seeWorld(k, Vec(4.5f, 0.0f, 0.0f), {Vec(4.9f, 0.0f, 0.0f)});
  EXPECT_EQ(k.logOdds(idx(49, 0, 0)), 10);
  EXPECT_EQ(k.logOdds(idx(48, 0, 0)), 4);
  ASSERT_EQ(k.points(idx(49, 0, 0)).size, 1u);
  // Two endpoints in the same voxel outside the window count once (000 Sec. IV).
  VoxelGrid d;
  const IntegrationStats sd =
      seeWorld(d, Vec(4.5f, 0.0f, 0.0f), {Vec(7.5f, 0.0f, 0.0f), Vec(7.51f, 0.01f, 0.0f)});
  EXPECT_EQ(sd.points_used, 1u);
  EXPECT_EQ(sd.points_duplicate, 1u);
  EXPECT_EQ(d.logOdds(idx(45, 0, 0)), -1);
}

TEST(VoxelGridBadInput, CameraOutsideWindowRayIsClipped) {
  VoxelGrid g;
  // Camera at u = -70, 2 m outside; point at u = -10.
  const IntegrationStats s = seeWorld(g, Vec(-7.0f, 0.0f, 0.0f), {Vec(-1.0f, 0.0f, 0.0f)});
  EXPECT_EQ(s.points_used, 1u);
  EXPECT_EQ(s.points_outside_grid, 0u);
  for (int u = -50; u <= -12; ++u)
    EXPECT_EQ(g.logOdds(idx(u, 0, 0)), -1) << u;
  EXPECT_EQ(g.logOdds(idx(-11, 0, 0)), 4);
  EXPECT_EQ(g.logOdds(idx(-10, 0, 0)), 10);
  EXPECT_EQ(g.logOdds(idx(-9, 0, 0)), 4);
  EXPECT_EQ(s.voxels_decremented, 39u);
  EXPECT_EQ(countNonZero(g), 42u);

  // Diagonal from outside: the in-window part must match the sampled traversal.
  VoxelGrid h;
  const Vec cam(-6.23f, 3.11f, 2.47f), p(-2.71f, 1.13f, 0.37f);
  const Eigen::Isometry3f T = cameraAt(cam);
  const Vec ps = T.inverse() * p;
  const Vec pf = T * ps;
  h.integrate({ps}, T);
  const SampledRay ray = sampleRay(cam.cast<double>(), pf.cast<double>(), 0.1);
  std::size_t inside = 0;
  for (std::size_t i = 0; i + 2 < ray.voxels.size(); ++i) {
    if (!h.contains(ray.voxels[i])) continue;
    ++inside;
    EXPECT_EQ(h.logOdds(ray.voxels[i]), -1);
  }
  EXPECT_GT(inside, 10u);
  EXPECT_EQ(h.logOdds(ray.voxels[ray.voxels.size() - 2]), 4);
  EXPECT_EQ(h.logOdds(ray.voxels.back()), 10);
  EXPECT_EQ(countNonZero(h), inside + 3);

  // A ray that misses the window entirely does nothing.
  VoxelGrid k;
  const IntegrationStats sk = seeWorld(k, Vec(-7.0f, 0.0f, 5.0f), {Vec(-1.0f, 0.0f, 4.0f)});
  EXPECT_EQ(sk.points_outside_grid, 1u);
  EXPECT_EQ(sk.voxels_decremented, 0u);
  EXPECT_EQ(countNonZero(k), 0u);
}

TEST(VoxelGridBadInput, ManyDistinctOutsideEndpointsOverflowTheDedupSetGracefully) {
  // Three spherical shells around the camera, mostly outside the 10 x 10 x 3 m window: far more
  // distinct outside voxels than the de-duplication set holds.
  VoxelGrid g;
  Points pts;
  for (float radius : {6.5f, 7.0f, 7.5f}) {
    for (int i = 0; i < 800; ++i) {
      for (int j = 0; j < 200; ++j) {
        const float az = 6.2831853f * i / 800, el = -1.2f + 2.4f * j / 200;
        pts.push_back(radius *
                      Vec(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)));
      }
    }
  }
  pts.push_back(pts.front());  // a true duplicate
  const IntegrationStats s = g.integrate(pts, cameraAt(Vec(0.0f, 0.0f, 0.5f)));
  EXPECT_EQ(s.points_used + s.points_duplicate, pts.size());
  EXPECT_GE(s.points_duplicate, 1u);
  EXPECT_GT(s.points_outside_grid, 100000u);
  EXPECT_EQ(g.logOdds(g.indexOf(Vec(0.0f, 0.0f, 0.5f))), -100);  // every ray crosses it
  EXPECT_LT(g.logOdds(g.indexOf(Vec(4.0f, 0.0f, 0.5f))), 0);     // crossed by the rays near az = 0
}

TEST(VoxelGridBadInput, HugeCoordinatesDoNotOverflow) {
  VoxelGrid g;
  for (const float big : {1e30f, -1e30f, 3e9f, -2.2e9f, 3.3e38f}) {
    const Eigen::Isometry3f T = cameraAt(Vec(big, -big, big));
    const IntegrationStats s =
        g.integrate({Vec(1.0f, 0.0f, 0.0f), Vec(0.0f, 2.0f, 1.0f), Vec(3.0f, -1.0f, 2.0f)}, T);
    EXPECT_EQ(s.points_in, 3u);
    EXPECT_EQ(s.points_used + s.points_non_finite + s.points_duplicate, 3u);
    EXPECT_EQ(s.voxels_decremented, 0u);
    g.recenter(Vec(big, big, -big));
    g.recenter(Vec::Zero());
  }
  EXPECT_EQ(countNonZero(g), 0u);
  // A finite point pushed past FLT_MAX by the translation is non-finite.
  const IntegrationStats s = g.integrate({Vec(5.0f, 0.0f, 0.0f)}, cameraAt(Vec(3.4e38f, 0, 0)));
  EXPECT_EQ(s.points_used + s.points_non_finite, 1u);
}

// ---------------------------------------------------------------------------------------------
// Housekeeping

TEST(VoxelGridMisc, ClearResetsEverythingButKeepsTheWindow) {
  VoxelGrid g;
  g.recenter(Vec(1.0f, 1.0f, 0.0f));
  seeWorld(g, Vec(1.0f, 1.0f, 1.0f), {Vec(2.0f, 1.0f, 0.0f)});
  const VoxelIndex e = g.indexOf(Vec(2.0f, 1.0f, 0.0f));
  ASSERT_EQ(g.logOdds(e), 10);
  g.clear();
  EXPECT_EQ(countNonZero(g), 0u);
  EXPECT_TRUE(g.points(e).empty());
  EXPECT_EQ(g.minIndex(), idx(-40, -40, -10));
  // Stamps were reset too: the same voxel is usable in the next frame.
  EXPECT_EQ(seeWorld(g, Vec(1.0f, 1.0f, 1.0f), {Vec(2.0f, 1.0f, 0.0f)}).points_used, 1u);
}

TEST(VoxelGridMisc, CopiesAreDeepAndIndependent) {
  VoxelGrid g;
  seeWorld(g, Vec::Zero(), {Vec(2.0f, 0.0f, 0.0f)});
  VoxelGrid h = g;
  EXPECT_EQ(h.logOdds(idx(20, 0, 0)), 10);
  ASSERT_EQ(h.points(idx(20, 0, 0)).size, 1u);
  EXPECT_NE(h.points(idx(20, 0, 0)).data, g.points(idx(20, 0, 0)).data);
  seeWorld(h, Vec::Zero(), {Vec(2.0f, 0.0f, 0.0f)});
  EXPECT_EQ(h.logOdds(idx(20, 0, 0)), 20);
  EXPECT_EQ(g.logOdds(idx(20, 0, 0)), 10);
}

TEST(VoxelGridMisc, StatsPartitionTheInput) {
  VoxelGrid g;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> d(-9.0f, 9.0f);
  Points pts;
  for (int i = 0; i < 5000; ++i)
    pts.push_back(Vec(d(rng), d(rng), d(rng) * 0.2f));
  pts.push_back(Vec(std::nanf(""), 0.0f, 0.0f));
  const IntegrationStats s = g.integrate(pts, cameraAt(Vec(0.0f, 0.0f, 1.0f)));
  EXPECT_EQ(s.points_in, pts.size());
  EXPECT_EQ(s.points_non_finite + s.points_out_of_range + s.points_duplicate + s.points_used,
            s.points_in);
  EXPECT_GT(s.points_outside_grid, 0u);
  EXPECT_LT(s.points_outside_grid, s.points_used);
  EXPECT_GT(s.points_duplicate, 0u);
}

TEST(VoxelGridMisc, IntegrateAndRecenterDoNotAllocate) {
  VoxelGrid g;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> d(-7.0f, 7.0f);
  Points pts;
  for (int i = 0; i < 20000; ++i)
    pts.push_back(Vec(d(rng), d(rng), d(rng) * 0.3f));
  const Eigen::Isometry3f T = cameraAt(Vec(0.0f, 0.0f, 1.1f));
  g.integrate(pts, T);
  g_allocs = 0;
  g_count_allocs = true;
  std::size_t used = 0;
  for (int f = 0; f < 3; ++f)
    used += g.integrate(pts, T).points_used;
  g.recenter(Vec(0.35f, -0.2f, 0.0f));
  used += g.integrate(pts, T).points_used;
  g_count_allocs = false;
  EXPECT_EQ(g_allocs.load(), 0);
  EXPECT_GT(used, 0u);
}

}  // namespace
}  // namespace stereo_safety_map
