// Benchmark of VoxelGrid::integrate() (000, Sec. IV) on a synthetic stereo frame.
//
// A 640x480 pinhole camera (f = 500 px) 1.1 m above a floor z = 0, pitched down 15 deg, sees the
// floor and a few boxes; pixels whose surface is farther than 8 m have no point (NaN, as an
// invalid disparity). Depth gets stereo-like noise growing with z^2. The robot drives forward
// 2 cm per frame with a slight yaw oscillation; 50 frames go into a default grid (recenter()
// before each). Prints min / median / max ms of integrate() (and of recenter()).
//
// Build and run (one core):
//   g++ -std=c++17 -O2 -Iinclude -I/usr/include/eigen3 src/core/voxel_grid.cpp
//     src/tools/bench_voxel_grid.cpp -o /tmp/bench_voxel_grid && /tmp/bench_voxel_grid
#include "stereo_safety_map/core/voxel_grid.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <random>
#include <vector>

namespace {

using stereo_safety_map::IntegrationStats;
using stereo_safety_map::VoxelGrid;

struct Box {
  Eigen::Vector3f lo, hi;
};

// Nearest hit parameter of the ray o + t d with an axis-aligned box, or +inf.
float hitBox(const Eigen::Vector3f& o, const Eigen::Vector3f& d, const Box& b) {
  float t0 = 0.0f, t1 = std::numeric_limits<float>::infinity();
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0.0f) {
      if (o[i] < b.lo[i] || o[i] > b.hi[i]) return std::numeric_limits<float>::infinity();
      continue;
    }
    float ta = (b.lo[i] - o[i]) / d[i], tb = (b.hi[i] - o[i]) / d[i];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 <= t1 ? t0 : std::numeric_limits<float>::infinity();
}

// Camera pose: optical frame (x right, y down, z forward) at height 1.1 m, pitched down.
Eigen::Isometry3f cameraPose(float x, float y, float yaw) {
  const float pitch = 15.0f * 3.14159265f / 180.0f;
  const Eigen::Vector3f fwd(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                            -std::sin(pitch));
  const Eigen::Vector3f right(std::sin(yaw), -std::cos(yaw), 0.0f);
  const Eigen::Vector3f down = fwd.cross(right);
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear().col(0) = right;
  T.linear().col(1) = down;
  T.linear().col(2) = fwd;
  T.translation() = Eigen::Vector3f(x, y, 1.1f);
  return T;
}

void renderFrame(const Eigen::Isometry3f& T, const std::vector<Box>& boxes, std::mt19937& rng,
                 std::vector<Eigen::Vector3f>& out) {
  constexpr int kW = 640, kH = 480;
  constexpr float kF = 500.0f, kCx = 319.5f, kCy = 239.5f;
  constexpr float kMaxRange = 8.0f;
  constexpr float kBaseline = 0.12f, kSigmaDisparity = 0.1f;  // px
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::normal_distribution<float> noise(0.0f, 1.0f);
  out.resize(static_cast<std::size_t>(kW) * kH);
  const Eigen::Vector3f o = T.translation();
  for (int r = 0; r < kH; ++r) {
    for (int c = 0; c < kW; ++c) {
      const Eigen::Vector3f dir_opt((c - kCx) / kF, (r - kCy) / kF, 1.0f);
      const Eigen::Vector3f d = T.linear() * dir_opt;
      float t = d.z() < 0.0f ? -o.z() / d.z() : std::numeric_limits<float>::infinity();
      for (const Box& b : boxes)
        t = std::min(t, hitBox(o, d, b));
      Eigen::Vector3f& p = out[static_cast<std::size_t>(r) * kW + c];
      if (!(t * dir_opt.norm() <= kMaxRange)) {
        p = Eigen::Vector3f(nan, nan, nan);
        continue;
      }
      const float z = t + noise(rng) * t * t * kSigmaDisparity / (kF * kBaseline);
      p = z * dir_opt;
    }
  }
}

// CPU time of this thread [ms]: unlike wall time it does not count time stolen by other
// processes, which matters on the shared 2-core machine.
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main() {
  const std::vector<Box> boxes = {
      {{2.5f, 0.5f, 0.0f}, {3.1f, 1.1f, 0.8f}},
      {{2.0f, -1.5f, 0.0f}, {2.4f, -0.5f, 0.5f}},
      {{5.0f, -0.3f, 0.0f}, {6.0f, 0.2f, 1.2f}},
      {{3.5f, -2.6f, 0.0f}, {4.5f, -2.2f, 2.0f}},
  };
  VoxelGrid grid;
  std::mt19937 rng(1);
  std::vector<Eigen::Vector3f> frame;
  constexpr int kFrames = 50;
  std::vector<double> t_integrate, t_integrate_cpu, t_recenter;
  IntegrationStats last;
  std::size_t valid = 0;
  for (int f = 0; f < kFrames; ++f) {
    const float x = 0.02f * f, y = 0.005f * std::sin(0.3f * f), yaw = 0.03f * std::sin(0.2f * f);
    const Eigen::Isometry3f T = cameraPose(x, y, yaw);
    renderFrame(T, boxes, rng, frame);

    const auto t0 = std::chrono::steady_clock::now();
    grid.recenter(Eigen::Vector3f(x, y, 0.0f));
    const auto t1 = std::chrono::steady_clock::now();
    const double c1 = threadCpuMs();
    last = grid.integrate(frame, T);
    const double c2 = threadCpuMs();
    const auto t2 = std::chrono::steady_clock::now();
    t_integrate_cpu.push_back(c2 - c1);
    t_recenter.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    t_integrate.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
    valid = last.points_in - last.points_non_finite;
  }
  std::printf(
      "frame 640x480, %zu valid points; last frame: used %zu (outside grid %zu), "
      "duplicate %zu, out of range %zu, decrements %zu\n",
      valid, last.points_used, last.points_outside_grid, last.points_duplicate,
      last.points_out_of_range, last.voxels_decremented);
  std::printf("integrate() over %d frames, wall: min %.3f ms, median %.3f ms, max %.3f ms\n",
              kFrames, *std::min_element(t_integrate.begin(), t_integrate.end()),
              median(t_integrate), *std::max_element(t_integrate.begin(), t_integrate.end()));
  std::printf("integrate() over %d frames, cpu:  min %.3f ms, median %.3f ms, max %.3f ms\n",
              kFrames, *std::min_element(t_integrate_cpu.begin(), t_integrate_cpu.end()),
              median(t_integrate_cpu),
              *std::max_element(t_integrate_cpu.begin(), t_integrate_cpu.end()));
  std::printf("recenter(), wall:                  min %.3f ms, median %.3f ms, max %.3f ms\n",
              *std::min_element(t_recenter.begin(), t_recenter.end()), median(t_recenter),
              *std::max_element(t_recenter.begin(), t_recenter.end()));
  return 0;
}
