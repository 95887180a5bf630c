// Benchmark of the 2D stereo occupancy grid (paper 002): one 640x480 disparity image per update.
// Prints min / median / max milliseconds over repetitions for the reduction alone and for the
// full update, on ray-cast scenes. Target: well under 5 ms per full update.
//
//   g++ -std=c++17 -O2 -Iinclude -I/usr/include/eigen3 -I/usr/include/opencv4
//     src/core/occupancy_grid_2d.cpp src/core/stereo_camera_model.cpp
//     src/tools/bench_occupancy_grid_2d.cpp -lopencv_core
//     -o /tmp/bench_og2d && /tmp/bench_og2d [repetitions]
#include "stereo_safety_map/core/occupancy_grid_2d.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <random>
#include <vector>

using namespace stereo_safety_map;

namespace {

struct Box {
  Eigen::Vector3f lo, hi;
};

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

// Floor + boxes, exact disparities, then `invalid_fraction` of the pixels set to NaN or 0 as a
// validated disparity image has them (002 Sec. 2.2).
cv::Mat render(const StereoCameraModel& m, const Eigen::Isometry3f& T,
               const std::vector<Box>& boxes, double invalid_fraction, unsigned seed) {
  const float inf = std::numeric_limits<float>::infinity();
  cv::Mat d(m.height, m.width, CV_32FC1, cv::Scalar(0));
  const Eigen::Vector3f o = T.translation();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (int y = 0; y < m.height; ++y) {
    for (int x = 0; x < m.width; ++x) {
      const Eigen::Vector3f r =
          T.linear() * Eigen::Vector3f((x - m.cx) / m.fx, (y - m.cy) / m.fy, 1.0f);
      float best = r.z() < 0.0f ? -o.z() / r.z() : inf;
      for (const Box& b : boxes) {
        float t0 = 0.0f, t1 = inf;
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
      float v = std::isfinite(best) ? static_cast<float>(m.fx * m.baseline / best) : 0.0f;
      const double u = uni(rng);
      if (u < invalid_fraction / 2) {
        v = std::numeric_limits<float>::quiet_NaN();
      } else if (u < invalid_fraction) {
        v = 0.0f;
      }
      d.at<float>(y, x) = v;
    }
  }
  return d;
}

struct Summary {
  double min, median, max;
};

template <typename F>
Summary time(int reps, F&& f) {
  std::vector<double> ms(static_cast<std::size_t>(reps));
  for (int i = 0; i < reps; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    f(i);
    const auto t1 = std::chrono::steady_clock::now();
    ms[static_cast<std::size_t>(i)] = std::chrono::duration<double, std::milli>(t1 - t0).count();
  }
  std::sort(ms.begin(), ms.end());
  return {ms.front(), ms[ms.size() / 2], ms.back()};
}

void print(const char* what, const Summary& s) {
  std::printf("%-58s min %7.3f  median %7.3f  max %7.3f ms\n", what, s.min, s.median, s.max);
}

}  // namespace

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::max(1, std::atoi(argv[1])) : 300;
  StereoCameraModel m;
  m.width = 640;
  m.height = 480;
  m.fx = m.fy = 500.0;
  m.cx = m.cx_right = 319.5;
  m.cy = 239.5;
  m.baseline = 0.12;

  // Wheelchair camera: 1.2 m high, 20 deg down. Room: wall at 8 m, furniture, a doorway.
  const std::vector<Box> room = {
      {{8.0f, -6.0f, 0.0f}, {8.3f, 6.0f, 2.5f}},  {{2.5f, -1.5f, 0.0f}, {3.0f, -0.6f, 0.8f}},
      {{4.0f, 0.8f, 0.0f}, {4.6f, 1.6f, 1.1f}},   {{1.8f, 0.3f, 0.0f}, {1.9f, 0.4f, 1.0f}},
      {{6.0f, -3.0f, 0.0f}, {6.2f, -0.7f, 2.0f}}, {{6.0f, 0.7f, 0.0f}, {6.2f, 3.0f, 2.0f}},
      {{3.0f, 2.5f, 0.7f}, {3.8f, 3.5f, 0.75f}}};
  const Eigen::Isometry3f pitched_a = cameraPose({0.0f, 0.0f, 1.2f}, 0.0f, 0.349f);
  const Eigen::Isometry3f pitched_b = cameraPose({0.3f, 0.1f, 1.2f}, 0.05f, 0.349f);
  const cv::Mat room_a = render(m, pitched_a, room, 0.1, 1);
  const cv::Mat room_b = render(m, pitched_b, room, 0.1, 2);
  // Worst case for the rasteriser: a level camera 1 m from a wall, every column valid.
  const Eigen::Isometry3f level = cameraPose({0.0f, 0.0f, 0.6f}, 0.0f, 0.0f);
  const cv::Mat wall = render(m, level, {{{1.0f, -5.0f, 0.0f}, {1.2f, 5.0f, 2.0f}}}, 0.0, 3);
  // Far range: wall at 9 m, long trapezoids crossing the window.
  const cv::Mat far_wall = render(m, level, {{{9.0f, -9.0f, 0.0f}, {9.2f, 9.0f, 2.0f}}}, 0.0, 4);

  OccupancyGrid2D grid;  // 20 x 20 m at 0.1 m
  std::vector<ColumnReading> row;
  std::printf("640x480 disparity, %d repetitions, grid %d x %d cells\n", reps, grid.sizeU(),
              grid.sizeV());

  print("reduce only (pitched camera, room, 10% invalid)", time(reps, [&](int i) {
          reduceToClosestObstacleRow(i % 2 ? room_b : room_a, m, i % 2 ? pitched_b : pitched_a,
                                     0.0f, 0.1f, 1.5f, &row);
        }));
  int valid = 0;
  print("full update (pitched camera, room, 10% invalid)", time(reps, [&](int i) {
          valid = grid.update(i % 2 ? room_b : room_a, m, i % 2 ? pitched_b : pitched_a)
                      .columns_with_reading;
        }));
  std::printf("  (%d of 640 columns with a reading)\n", valid);
  grid.clear();
  print("full update (level camera, wall at 1 m, all columns)",
        time(reps, [&](int) { grid.update(wall, m, level); }));
  grid.clear();
  print("full update (level camera, wall at 9 m, all columns)",
        time(reps, [&](int) { grid.update(far_wall, m, level); }));
  // The 9 m wall seen first from 1 m: the far readings are then explained (002 Sec. 4.3).
  grid.clear();
  const Eigen::Isometry3f close = cameraPose({8.0f, 0.0f, 0.6f}, 0.0f, 0.0f);
  grid.update(render(m, close, {{{9.0f, -9.0f, 0.0f}, {9.2f, 9.0f, 2.0f}}}, 0.0, 5), m, close);
  int explained = 0;
  print("full update (wall at 9 m, seen before from 1 m: explained)",
        time(reps, [&](int) { explained = grid.update(far_wall, m, level).columns_explained; }));
  std::printf("  (%d of 640 columns explained)\n", explained);
  return 0;
}
