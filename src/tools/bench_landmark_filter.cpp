// Benchmark of LandmarkFilter::update (001 Sec. 4.2) on dense synthetic stereo.
//
// A camera 1 m above a floor looks 10 degrees down at a room: floor, a wall 7 m ahead, a box
// and a side wall. Every pixel (every `step`-th) is reprojected with the pixel noise of Eq. (1)
// plus a fraction of outliers with random disparity; the robot drives 5 cm per frame (0.5 m/s at
// 10 Hz). Prints min / median / max milliseconds of update() over the measured frames (wall time,
// and this thread's CPU time, which a shared machine disturbs less), after 15 warm-up frames, and
// which fraction of the true and of the outlier points the keep mask passes.
//
// Usage: bench_landmark_filter [width=400] [height=300] [step=1] [frames=60] [outliers=0.02]
// (400 x 300 at step 1 gives 120000 points per frame.)
#include "stereo_safety_map/core/landmark_filter.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <vector>

using stereo_safety_map::LandmarkFilter;
using stereo_safety_map::LandmarkFilterConfig;
using stereo_safety_map::LandmarkFilterStats;
using stereo_safety_map::StereoCameraModel;

namespace {

// CPU time of this thread: on a shared machine it is less disturbed than wall time.
double threadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

// Distance along a robot-frame ray (x forward, y left, z up) from origin o to the scene.
double castRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double best = 1e9;
  const auto plane = [&](int axis, double value) {
    if (std::abs(d[axis]) < 1e-9) return;
    const double t = (value - o[axis]) / d[axis];
    if (t > 0.0 && t < best) best = t;
  };
  plane(2, 0.0);   // floor
  plane(0, 7.0);   // front wall
  plane(1, -2.0);  // right wall
  // Box 0.6 m high, x in [3, 3.8], y in [0.3, 1.1].
  for (int axis = 0; axis < 3; ++axis) {
    const double lo[3] = {3.0, 0.3, 0.0}, hi[3] = {3.8, 1.1, 0.6};
    for (double v : {lo[axis], hi[axis]}) {
      if (std::abs(d[axis]) < 1e-9) continue;
      const double t = (v - o[axis]) / d[axis];
      if (t <= 0.0 || t >= best) continue;
      const Eigen::Vector3d p = o + t * d;
      bool inside = true;
      for (int a = 0; a < 3; ++a) {
        if (a != axis && (p[a] < lo[a] - 1e-9 || p[a] > hi[a] + 1e-9)) inside = false;
      }
      if (inside) best = t;
    }
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  const int width = argc > 1 ? std::max(16, std::atoi(argv[1])) : 400;
  const int height = argc > 2 ? std::max(16, std::atoi(argv[2])) : 300;
  const int step = argc > 3 ? std::max(1, std::atoi(argv[3])) : 1;
  const int frames = argc > 4 ? std::max(1, std::atoi(argv[4])) : 60;
  const double outlier_fraction = argc > 5 ? std::atof(argv[5]) : 0.02;
  const int warmup = 15;

  StereoCameraModel cam;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = 0.78 * width;  // ~65 degree horizontal field of view
  cam.cx = cam.cx_right = 0.5 * width;
  cam.cy = 0.5 * height;
  cam.baseline = 0.12;

  LandmarkFilterConfig cfg;
  LandmarkFilter filter(cam, cfg);

  // Optical (z forward, x right, y down) to robot axes, pitched 10 degrees down.
  Eigen::Matrix3d optical_to_robot;
  optical_to_robot << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Eigen::Matrix3d pitch =
      Eigen::AngleAxisd(10.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d R = pitch * optical_to_robot;

  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const auto& em = cfg.error_model;

  std::vector<Eigen::Vector3f> points;
  std::vector<std::uint8_t> keep;
  std::vector<bool> is_outlier;
  std::size_t outliers = 0, outliers_kept = 0, inliers = 0, inliers_kept = 0;
  std::vector<double> ms, cpu_ms;
  std::size_t total_points = 0;
  for (int k = 0; k < warmup + frames; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R;
    T.translation() = Eigen::Vector3d(0.05 * k, 0.0, 1.0);
    points.clear();
    is_outlier.clear();
    for (int r = 0; r < height; r += step) {
      for (int c = 0; c < width; c += step) {
        const Eigen::Vector3d ray_cam((c - cam.cx) / cam.fx, (r - cam.cy) / cam.fy, 1.0);
        const double t = castRay(T.translation(), R * ray_cam);
        const double z = t;  // ray_cam has unit z, so t is the optical depth
        if (!(z > 0.3 && z < 7.5)) continue;
        double rr = r + em.sigma_row * noise(rng);
        double cc = c + em.sigma_col * noise(rng);
        double d = cam.fx * cam.baseline / z + em.sigma_disparity * noise(rng);
        const bool outlier = uni(rng) < outlier_fraction;
        if (outlier) d = 8.0 + 60.0 * uni(rng);  // mismatch
        is_outlier.push_back(outlier);
        const double zz = cam.fx * cam.baseline / d;
        points.emplace_back(static_cast<float>((cc - cam.cx) * zz / cam.fx),
                            static_cast<float>((rr - cam.cy) * zz / cam.fy),
                            static_cast<float>(zz));
      }
    }
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = threadCpuMs();
    const LandmarkFilterStats& st = filter.update(points, T.cast<float>(), 0.1 * k, &keep);
    const double c1 = threadCpuMs();
    const auto t1 = std::chrono::steady_clock::now();
    if (k >= warmup) {
      ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      cpu_ms.push_back(c1 - c0);
      total_points += points.size();
      for (std::size_t i = 0; i < points.size(); ++i) {
        if (is_outlier[i]) {
          ++outliers;
          outliers_kept += keep[i];
        } else {
          ++inliers;
          inliers_kept += keep[i];
        }
      }
    }
    if (k == warmup + frames - 1) {
      std::printf(
          "last frame: points %zu  invalid %zu  in_gate %zu  matched %zu  kept %zu  "
          "pairs %zu  created %zu  expired %zu  stale %zu  in_view %zu  temporary %zu  permanent "
          "%zu\n",
          st.points_in, st.points_invalid, st.points_in_gate, st.points_matched, st.points_kept,
          st.candidates_tested, st.landmarks_created, st.landmarks_expired, st.landmarks_stale,
          st.landmarks_in_view, st.temporary, st.permanent);
    }
  }
  std::printf("kept: %.1f %% of inliers, %.2f %% of outliers (random disparity)\n",
              100.0 * inliers_kept / std::max<std::size_t>(1, inliers),
              100.0 * outliers_kept / std::max<std::size_t>(1, outliers));
  std::sort(ms.begin(), ms.end());
  std::sort(cpu_ms.begin(), cpu_ms.end());
  std::printf(
      "bench_landmark_filter %dx%d step %d: %.0f points/frame, %d frames\n"
      "  wall: min %.2f ms  median %.2f ms  max %.2f ms\n"
      "  cpu:  min %.2f ms  median %.2f ms  max %.2f ms\n",
      width, height, step, static_cast<double>(total_points) / frames, frames, ms.front(),
      ms[ms.size() / 2], ms.back(), cpu_ms.front(), cpu_ms[cpu_ms.size() / 2], cpu_ms.back());
  return 0;
}
