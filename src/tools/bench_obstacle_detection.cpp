// Benchmark of ObstacleDetector (paper 003: OD Algorithm 2 + OS Algorithm 2 + Sec. 5 rules) on
// synthetic 640x480 range images.
//
// A pinhole camera (f = 600 px) 1.1 m above a floor z = 0, pitched down 15 deg, as on the
// wheelchair. Two scenes: "typical" is a floor with several obstacles (a pole, a box, a box
// turned 45 deg, a person-sized cylinder, a 10 cm curb across the view; ~29 % of the valid pixels
// are obstacle points); "dense" adds a ridge with a sideways slope and a wall across the view at 9
// m
// (~50 % obstacle points). Points farther than 10 m are missing (NaN), as with a stereo range
// limit; "+ noise" adds spatially smooth range noise (sigma = 0.2 % of the range, correlated
// over ~8 px). Prints min / median / max ms over the repetitions, as wall time and as the
// thread's CPU time (the latter is what one core costs when the machine is shared), for
// detect() with the default (early-exit) search, the exhaustive OD Algorithm 2 and the
// column-wise baseline.
//
// Build and run (one core):
//   g++ -std=c++17 -O2 -Iinclude -I/usr/include/eigen3 -I/usr/include/opencv4
//     src/core/obstacle_detection.cpp src/tools/bench_obstacle_detection.cpp -lopencv_core
//     -lopencv_imgproc -o /tmp/bench_obstacle_detection && /tmp/bench_obstacle_detection [reps]
//   [case]   (only the cases whose name contains `case`; a trailing $ anchors the end, e.g.
//   "dense: detect$")
#include "stereo_safety_map/core/obstacle_detection.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <limits>
#include <random>
#include <vector>

namespace {

using stereo_safety_map::ObstacleDetectionConfig;
using stereo_safety_map::ObstacleDetectionResult;
using stereo_safety_map::ObstacleDetector;

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
float rad(float deg) {
  return deg * static_cast<float>(M_PI) / 180.0f;
}

struct Plane {
  Eigen::Vector3f n;
  float d;  // solid where n . x <= d
};
struct Shape {
  std::vector<Plane> planes;  // convex polyhedron, or empty for a vertical cylinder
  float cx = 0, cy = 0, radius = 0, height = 0;
};

float hit(const Shape& s, const Eigen::Vector3f& o, const Eigen::Vector3f& d) {
  if (!s.planes.empty()) {
    float t_in = -kInf, t_out = kInf;
    for (const Plane& p : s.planes) {
      const float den = p.n.dot(d), num = p.d - p.n.dot(o);
      if (den == 0.0f) {
        if (num < 0.0f) return kInf;
        continue;
      }
      const float t = num / den;
      if (den < 0.0f) {
        t_in = std::max(t_in, t);
      } else {
        t_out = std::min(t_out, t);
      }
    }
    return (t_in <= t_out && t_in > 0.0f) ? t_in : kInf;
  }
  float best = kInf;
  const float ox = o.x() - s.cx, oy = o.y() - s.cy;
  const float a = d.x() * d.x() + d.y() * d.y(), b = 2.0f * (ox * d.x() + oy * d.y()),
              c = ox * ox + oy * oy - s.radius * s.radius, disc = b * b - 4.0f * a * c;
  if (a > 0.0f && disc >= 0.0f) {
    const float t = (-b - std::sqrt(disc)) / (2.0f * a), z = o.z() + t * d.z();
    if (t > 0.0f && z >= 0.0f && z <= s.height) best = t;
  }
  if (d.z() != 0.0f) {
    const float t = (s.height - o.z()) / d.z();
    const float x = ox + t * d.x(), y = oy + t * d.y();
    if (t > 0.0f && x * x + y * y <= s.radius * s.radius) best = std::min(best, t);
  }
  return best;
}

Shape box(float x, float y, float z, float hx, float hy, float hz, float yaw) {
  const Eigen::Vector3f c(x, y, z), ax(std::cos(yaw), std::sin(yaw), 0),
      ay(-std::sin(yaw), std::cos(yaw), 0), az(0, 0, 1);
  const Eigen::Vector3f axes[3] = {ax, ay, az};
  const float half[3] = {hx, hy, hz};
  Shape s;
  for (int i = 0; i < 3; ++i) {
    s.planes.push_back({axes[i], axes[i].dot(c) + half[i]});
    s.planes.push_back({-axes[i], -axes[i].dot(c) + half[i]});
  }
  return s;
}

Shape cylinder(float x, float y, float r, float h) {
  Shape s;
  s.cx = x;
  s.cy = y;
  s.radius = r;
  s.height = h;
  return s;
}

std::vector<Shape> scene(bool dense) {
  std::vector<Shape> s;
  s.push_back({{{Eigen::Vector3f(0, 0, 1), 0.0f}}});                   // floor
  s.push_back(cylinder(2.5f, 0.5f, 0.05f, 1.0f));                      // pole
  s.push_back(box(3.0f, -0.6f, 0.3f, 0.25f, 0.2f, 0.3f, rad(20.0f)));  // box
  s.push_back(box(5.0f, 1.0f, 0.35f, 0.3f, 0.3f, 0.35f, rad(45.0f)));  // turned box
  s.push_back(cylinder(4.0f, -1.5f, 0.2f, 1.7f));                      // person
  s.push_back(box(6.5f, 0.0f, 0.05f, 0.5f, 20.0f, 0.05f, 0.0f));       // 10 cm curb
  if (!dense) return s;
  const float t60 = std::tan(rad(60.0f));
  s.push_back({{{Eigen::Vector3f(0, -1, 1.0f / t60), -1.2f},  // ridge, left side
                {Eigen::Vector3f(0, 1, 0.5f), 1.6f},
                {Eigen::Vector3f(1, 0, 0), 8.0f},
                {Eigen::Vector3f(-1, 0, 0), -2.0f},
                {Eigen::Vector3f(0, 0, -1), 0.01f}}});
  s.push_back(box(9.0f, 0.0f, 0.75f, 0.1f, 20.0f, 0.75f, 0.0f));  // wall
  return s;
}

Eigen::Isometry3f cameraPose() {
  const float p = rad(15.0f);
  const Eigen::Vector3f fwd(std::cos(p), 0.0f, -std::sin(p)), right(0.0f, -1.0f, 0.0f);
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear().col(0) = right;
  T.linear().col(1) = fwd.cross(right);
  T.linear().col(2) = fwd;
  T.translation() = Eigen::Vector3f(0.0f, 0.0f, 1.1f);
  return T;
}

cv::Mat render(int w, int h, float f, const Eigen::Isometry3f& T, float max_range, bool dense) {
  const std::vector<Shape> shapes = scene(dense);
  cv::Mat xyz(h, w, CV_32FC3);
  const float cx = 0.5f * (w - 1), cy = 0.5f * (h - 1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector3f dc((u - cx) / f, (v - cy) / f, 1.0f), d = T.linear() * dc;
      float best = kInf;
      for (const Shape& s : shapes)
        best = std::min(best, hit(s, T.translation(), d));
      xyz.at<cv::Vec3f>(v, u) = best * dc.norm() <= max_range
                                    ? cv::Vec3f(best * dc.x(), best * dc.y(), best)
                                    : cv::Vec3f(kNaN, kNaN, kNaN);
    }
  }
  return xyz;
}

// Multiplies every point by (1 + e) with e smooth Gaussian noise of standard deviation sigma.
cv::Mat addSmoothNoise(const cv::Mat& xyz, float sigma) {
  std::mt19937 rng(1);
  std::normal_distribution<float> g(0.0f, 1.0f);
  cv::Mat e(xyz.size(), CV_32F);
  for (int i = 0; i < static_cast<int>(e.total()); ++i)
    e.at<float>(i) = g(rng);
  cv::GaussianBlur(e, e, cv::Size(0, 0), 4.0);
  cv::Scalar mean, sd;
  cv::meanStdDev(e, mean, sd);
  cv::Mat out = xyz.clone();
  for (int i = 0; i < static_cast<int>(e.total()); ++i) {
    out.at<cv::Vec3f>(i) *= 1.0f + sigma * e.at<float>(i) / static_cast<float>(sd[0]);
  }
  return out;
}

double cpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

struct Timing {
  double min, median, max;
};

Timing summary(std::vector<double> ms) {
  std::sort(ms.begin(), ms.end());
  return {ms.front(), ms[ms.size() / 2], ms.back()};
}

// Times fn() `reps` times; returns {wall, cpu}.
template <typename F>
std::pair<Timing, Timing> timeIt(int reps, F&& fn) {
  std::vector<double> wall, cpu;
  for (int i = 0; i < reps; ++i) {
    const double c0 = cpuMs();
    const auto t0 = std::chrono::steady_clock::now();
    fn();
    const auto t1 = std::chrono::steady_clock::now();
    cpu.push_back(cpuMs() - c0);
    wall.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  return {summary(wall), summary(cpu)};
}

const char* g_filter = nullptr;  // run only the cases whose name contains it ('$': ends with it)

bool selected(const char* name) {
  if (g_filter == nullptr) return true;
  const std::size_t n = std::strlen(g_filter);
  if (n > 0 && g_filter[n - 1] == '$') {
    const std::size_t m = std::strlen(name);
    return m >= n - 1 && std::strncmp(name + m - (n - 1), g_filter, n - 1) == 0;
  }
  return std::strstr(name, g_filter) != nullptr;
}

void run(const char* name, const cv::Mat& xyz, float f, const Eigen::Isometry3f& T,
         const ObstacleDetectionConfig& cfg, bool columnwise, int reps) {
  if (!selected(name)) return;
  ObstacleDetector det(cfg);
  ObstacleDetectionResult res;
  auto call = [&] {
    if (columnwise) {
      det.detectColumnwise(xyz, f, T, &res);
    } else {
      det.detect(xyz, f, T, &res);
    }
  };
  call();  // warm-up: buffers
  const auto t = timeIt(reps, call);
  std::printf(
      "%-34s wall %6.2f / %6.2f / %6.2f  cpu %6.2f / %6.2f / %6.2f ms | %4.1f tests/px, "
      "%5.1f %% obstacle px, %zu obstacles (%d accepted)\n",
      name, t.first.min, t.first.median, t.first.max, t.second.min, t.second.median, t.second.max,
      static_cast<double>(res.pairs_tested) / std::max<std::size_t>(1, res.valid_points),
      100.0 * cv::countNonZero(res.mask) / std::max<std::size_t>(1, res.valid_points),
      res.obstacles.size(), res.num_accepted);
}

}  // namespace

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::max(1, std::atoi(argv[1])) : 50;
  if (argc > 2) g_filter = argv[2];
  const int w = 640, h = 480;
  const float f = 600.0f;
  const Eigen::Isometry3f T = cameraPose();
  std::printf("640x480, f = 600, %d repetitions, min / median / max\n", reps);
  ObstacleDetectionConfig fast;
  ObstacleDetectionConfig exhaustive;
  exhaustive.exhaustive_search = true;
  ObstacleDetectionConfig no_feet;
  no_feet.search_foot_points = false;
  for (bool dense : {false, true}) {
    const cv::Mat clean = render(w, h, f, T, 10.0f, dense);
    const cv::Mat noisy = addSmoothNoise(clean, 0.002f);
    const char* scene_name = dense ? "dense" : "typical";
    char name[64];
    std::snprintf(name, sizeof(name), "%s: detect", scene_name);
    run(name, clean, f, T, fast, false, reps);
    std::snprintf(name, sizeof(name), "%s + noise: detect", scene_name);
    run(name, noisy, f, T, fast, false, reps);
    std::snprintf(name, sizeof(name), "%s: detect, no foot search", scene_name);
    run(name, clean, f, T, no_feet, false, reps);
    std::snprintf(name, sizeof(name), "%s: detect, exhaustive", scene_name);
    run(name, clean, f, T, exhaustive, false, std::max(1, reps / 10));
    std::snprintf(name, sizeof(name), "%s: detectColumnwise", scene_name);
    run(name, clean, f, T, fast, true, reps);
  }
  return 0;
}
