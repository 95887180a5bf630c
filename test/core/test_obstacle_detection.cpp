// Tests of 3D obstacle detection and segmentation (paper 003). Range images are ray cast from
// analytic scenes seen by a pinhole camera 1.1 m above a floor z = 0 and pitched down 15 deg
// (f = 300 px, 320 x 240), so which pixel sees which object is known by construction.
#include "stereo_safety_map/core/obstacle_detection.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <new>
#include <numeric>
#include <random>
#include <set>
#include <stdexcept>
#include <vector>

// Counts heap allocations, to check that a warmed-up detector does not allocate. (GCC cannot
// see that the replaced operator new and delete below match.)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
static std::size_t g_allocations = 0;
void* operator new(std::size_t n) {
  ++g_allocations;
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}

namespace ssm = stereo_safety_map;
using ssm::decimateRangeImage;
using ssm::ObstacleDetectionConfig;
using ssm::ObstacleDetectionResult;
using ssm::ObstacleDetector;
using ssm::ObstacleInfo;
using ssm::ObstacleRejection;
using ssm::raisedObstaclePoints;

namespace {

constexpr float kPi = static_cast<float>(M_PI);
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInfF = std::numeric_limits<float>::infinity();
float deg(float d) {
  return d * kPi / 180.0f;
}

// ---------------------------------------------------------------------------------------------
// A tiny ray caster.

struct Plane {
  Eigen::Vector3f n;  // solid where n . x <= d
  float d;
};

struct Shape {
  enum Kind { kPolyhedron, kCylinder } kind = kPolyhedron;
  std::vector<Plane> planes;     // convex polyhedron (intersection of half-spaces)
  Eigen::Vector2f center{0, 0};  // vertical cylinder
  float radius = 0, z0 = 0, z1 = 0;
};

// Entry parameter of the ray o + t d into the shape, +inf when it misses (or starts inside).
float hit(const Shape& s, const Eigen::Vector3f& o, const Eigen::Vector3f& d) {
  if (s.kind == Shape::kPolyhedron) {
    float t_in = -kInfF, t_out = kInfF;
    for (const Plane& p : s.planes) {
      const float den = p.n.dot(d), num = p.d - p.n.dot(o);
      if (den == 0.0f) {
        if (num < 0.0f) return kInfF;
        continue;
      }
      const float t = num / den;
      if (den < 0.0f) {
        t_in = std::max(t_in, t);
      } else {
        t_out = std::min(t_out, t);
      }
    }
    return (t_in <= t_out && t_in > 0.0f) ? t_in : kInfF;
  }
  float best = kInfF;
  const Eigen::Vector2f oc = o.head<2>() - s.center, dd = d.head<2>();
  const float a = dd.squaredNorm(), b = 2.0f * oc.dot(dd),
              c = oc.squaredNorm() - s.radius * s.radius;
  const float disc = b * b - 4.0f * a * c;
  if (a > 0.0f && disc >= 0.0f) {
    const float t = (-b - std::sqrt(disc)) / (2.0f * a);
    const float z = o.z() + t * d.z();
    if (t > 0.0f && z >= s.z0 && z <= s.z1) best = t;
  }
  if (d.z() != 0.0f) {  // top cap
    const float t = (s.z1 - o.z()) / d.z();
    if (t > 0.0f && (oc + t * dd).squaredNorm() <= s.radius * s.radius) best = std::min(best, t);
  }
  return best;
}

Shape floorShape(float height = 0.0f) {
  Shape s;
  s.planes = {{Eigen::Vector3f(0, 0, 1), height}};
  return s;
}

// Box of half extents `half` centred at `c`, turned by `yaw` about the vertical.
Shape box(const Eigen::Vector3f& c, const Eigen::Vector3f& half, float yaw = 0.0f) {
  Shape s;
  const Eigen::Vector3f ax(std::cos(yaw), std::sin(yaw), 0), ay(-std::sin(yaw), std::cos(yaw), 0),
      az(0, 0, 1);
  const Eigen::Vector3f axes[3] = {ax, ay, az};
  for (int i = 0; i < 3; ++i) {
    s.planes.push_back({axes[i], axes[i].dot(c) + half[i]});
    s.planes.push_back({-axes[i], -axes[i].dot(c) + half[i]});
  }
  return s;
}

Shape pole(float x, float y, float radius, float height) {
  Shape s;
  s.kind = Shape::kCylinder;
  s.center = Eigen::Vector2f(x, y);
  s.radius = radius;
  s.z0 = -0.01f;
  s.z1 = height;
  return s;
}

// A surface rising from the floor at x = x0 with `slope` up to `top`, then level, spanning the
// whole view (no side or far edges in sight).
Shape ramp(float x0, float slope, float top) {
  Shape s;
  const float t = std::tan(slope);
  s.planes = {{Eigen::Vector3f(-t, 0, 1), -t * x0}, {Eigen::Vector3f(0, 0, 1), top},
              {Eigen::Vector3f(0, 0, -1), 0.01f},   {Eigen::Vector3f(1, 0, 0), 100.0f},
              {Eigen::Vector3f(0, 1, 0), 100.0f},   {Eigen::Vector3f(0, -1, 0), 100.0f}};
  return s;
}

struct Camera {
  int width = 320, height = 240;
  float f = 300.0f;
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();  // camera -> fixed (z up)
  float cx() const { return 0.5f * (width - 1); }
  float cy() const { return 0.5f * (height - 1); }
};

// Camera at `height` over the origin looking along +x, pitched down, then rolled.
Camera makeCamera(int width = 320, int height = 240, float f = 300.0f, float cam_height = 1.1f,
                  float pitch_deg = 15.0f, float roll_deg = 0.0f) {
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.f = f;
  const float p = deg(pitch_deg), r = deg(roll_deg);
  const Eigen::Vector3f fwd(std::cos(p), 0.0f, -std::sin(p)), right0(0.0f, -1.0f, 0.0f);
  const Eigen::Vector3f down0 = fwd.cross(right0);
  const Eigen::Vector3f right = std::cos(r) * right0 + std::sin(r) * down0;
  const Eigen::Vector3f down = fwd.cross(right);
  cam.T.linear().col(0) = right;
  cam.T.linear().col(1) = down;
  cam.T.linear().col(2) = fwd;
  cam.T.translation() = Eigen::Vector3f(0.0f, 0.0f, cam_height);
  return cam;
}

struct Rendered {
  cv::Mat xyz;  // CV_32FC3, camera optical frame, NaN where nothing is hit
  cv::Mat id;   // CV_32S, index of the shape hit, -1 for none
  int count(int shape) const { return cv::countNonZero(id == shape); }
};

Rendered render(const std::vector<Shape>& scene, const Camera& cam, float max_range = 30.0f) {
  Rendered out;
  out.xyz.create(cam.height, cam.width, CV_32FC3);
  out.id.create(cam.height, cam.width, CV_32S);
  const Eigen::Matrix3f R = cam.T.linear();
  const Eigen::Vector3f o = cam.T.translation();
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const Eigen::Vector3f dc((u - cam.cx()) / cam.f, (v - cam.cy()) / cam.f, 1.0f);
      const Eigen::Vector3f d = R * dc;
      float best = kInfF;
      int best_id = -1;
      for (std::size_t k = 0; k < scene.size(); ++k) {
        const float t = hit(scene[k], o, d);
        if (t < best) {
          best = t;
          best_id = static_cast<int>(k);
        }
      }
      if (best_id >= 0 && best * dc.norm() > max_range) best_id = -1;
      out.id.at<int>(v, u) = best_id;
      out.xyz.at<cv::Vec3f>(v, u) = best_id >= 0 ? cv::Vec3f(best * dc.x(), best * dc.y(), best)
                                                 : cv::Vec3f(kNaN, kNaN, kNaN);
    }
  }
  return out;
}

// Pixels of `shape` whose fixed-frame height is in (min_z, max_z).
cv::Mat shapePixelsAbove(const Rendered& img, const Camera& cam, int shape, float min_z,
                         float max_z = 1e9f) {
  cv::Mat sel(img.id.size(), CV_8U, cv::Scalar(0));
  for (int v = 0; v < img.id.rows; ++v) {
    for (int u = 0; u < img.id.cols; ++u) {
      if (img.id.at<int>(v, u) != shape) continue;
      const cv::Vec3f p = img.xyz.at<cv::Vec3f>(v, u);
      const float z = (cam.T * Eigen::Vector3f(p[0], p[1], p[2])).z();
      if (z > min_z && z < max_z) sel.at<std::uint8_t>(v, u) = 255;
    }
  }
  return sel;
}

int countMasked(const cv::Mat& mask, const cv::Mat& sel) {
  return cv::countNonZero((mask != 0) & (sel != 0));
}

// Labels (non-zero) found on the selected pixels, with their pixel counts.
std::map<int, int> labelsOn(const ObstacleDetectionResult& res, const cv::Mat& sel) {
  std::map<int, int> out;
  for (int v = 0; v < sel.rows; ++v) {
    for (int u = 0; u < sel.cols; ++u) {
      const int l = res.labels.at<int>(v, u);
      if (sel.at<std::uint8_t>(v, u) && l != 0) ++out[l];
    }
  }
  return out;
}

int dominantLabel(const ObstacleDetectionResult& res, const cv::Mat& sel) {
  int best = 0, best_n = 0;
  for (const auto& kv : labelsOn(res, sel)) {
    if (kv.second > best_n) {
      best = kv.first;
      best_n = kv.second;
    }
  }
  return best;
}

ObstacleDetectionResult detect(const Rendered& img, const Camera& cam,
                               const ObstacleDetectionConfig& cfg = ObstacleDetectionConfig(),
                               bool columnwise = false) {
  ObstacleDetector det(cfg);
  ObstacleDetectionResult res;
  const bool ok = columnwise ? det.detectColumnwise(img.xyz, cam.f, cam.T, &res)
                             : det.detect(img.xyz, cam.f, cam.T, &res);
  EXPECT_TRUE(ok) << res.error;
  return res;
}

// 003's Definition 1 with its constant thresholds (no stereo noise margin) and no Sec. 5 rules.
ObstacleDetectionConfig noRejection() {
  ObstacleDetectionConfig cfg;
  cfg.reject_false_obstacles = false;
  cfg.noise_sigmas = 0.0;
  return cfg;
}

// ---------------------------------------------------------------------------------------------

TEST(ObstacleDetectionConfig, DefaultsAreValid) {
  EXPECT_EQ(ObstacleDetectionConfig().validate(), "");
}

TEST(ObstacleDetectionConfig, EachBadParameterIsNamed) {
  auto check = [](auto set, const char* name) {
    ObstacleDetectionConfig cfg;
    set(cfg);
    const std::string err = cfg.validate();
    EXPECT_NE(err.find(name), std::string::npos) << name << ": " << err;
    EXPECT_THROW(ObstacleDetector{cfg}, std::invalid_argument) << name;
  };
  check([](ObstacleDetectionConfig& c) { c.height_threshold = 0.0; }, "height_threshold");
  check([](ObstacleDetectionConfig& c) { c.height_threshold = NAN; }, "height_threshold");
  check([](ObstacleDetectionConfig& c) { c.max_height = 0.04; }, "max_height");
  check([](ObstacleDetectionConfig& c) { c.max_height = INFINITY; }, "max_height");
  check([](ObstacleDetectionConfig& c) { c.slope_threshold_deg = 90.0; }, "slope_threshold_deg");
  check([](ObstacleDetectionConfig& c) { c.slope_threshold_deg = 0.0; }, "slope_threshold_deg");
  check([](ObstacleDetectionConfig& c) { c.sample_spacing = -0.1; }, "sample_spacing");
  check([](ObstacleDetectionConfig& c) { c.max_candidates_per_pixel = -1; },
        "max_candidates_per_pixel");
  check([](ObstacleDetectionConfig& c) { c.surface_link_distance = -0.1; },
        "surface_link_distance");
  check([](ObstacleDetectionConfig& c) { c.surface_link_pixels = NAN; }, "surface_link_pixels");
  check([](ObstacleDetectionConfig& c) { c.min_avg_slope_deg = 91.0; }, "min_avg_slope_deg");
  check([](ObstacleDetectionConfig& c) { c.min_max_slope_deg = -1.0; }, "min_max_slope_deg");
  check([](ObstacleDetectionConfig& c) { c.min_avg_height = -1.0; }, "min_avg_height");
  check([](ObstacleDetectionConfig& c) { c.min_max_height = NAN; }, "min_max_height");
  check([](ObstacleDetectionConfig& c) { c.min_bbox_perimeter = -1.0; }, "min_bbox_perimeter");
  check([](ObstacleDetectionConfig& c) { c.min_volume = -1.0; }, "min_volume");
  check([](ObstacleDetectionConfig& c) { c.noise_sigmas = -0.5; }, "noise_sigmas");
  check([](ObstacleDetectionConfig& c) { c.noise_sigmas = NAN; }, "noise_sigmas");
  check([](ObstacleDetectionConfig& c) { c.disparity_sigma = 0.0; }, "disparity_sigma");
}

TEST(ObstacleDetection, Definition1) {
  ObstacleDetector det;  // H_T 0.05, H_max 0.3, theta_T 45 deg
  const Eigen::Vector3f a(1, 2, 0);
  EXPECT_TRUE(det.compatible(a, a + Eigen::Vector3f(0, 0, 0.1f)));           // vertical 10 cm
  EXPECT_TRUE(det.compatible(a + Eigen::Vector3f(0, 0, 0.1f), a));           // symmetric
  EXPECT_FALSE(det.compatible(a, a + Eigen::Vector3f(0, 0, 0.04f)));         // below H_T
  EXPECT_FALSE(det.compatible(a, a + Eigen::Vector3f(0, 0, 0.35f)));         // above H_max
  EXPECT_TRUE(det.compatible(a, a + Eigen::Vector3f(0.06f, 0.05f, 0.1f)));   // 52 deg
  EXPECT_FALSE(det.compatible(a, a + Eigen::Vector3f(0.08f, 0.07f, 0.1f)));  // 41 deg
  EXPECT_FALSE(det.compatible(a, Eigen::Vector3f(NAN, 2, 0.1f)));
}

TEST(ObstacleDetection, FlatFloorHasNoObstacle) {
  // Also rolled: heights come from the pose, not from the camera's y axis.
  for (float roll : {0.0f, 12.0f}) {
    const Camera cam = makeCamera(320, 240, 300.0f, 1.1f, 25.0f, roll);
    const Rendered img = render({floorShape()}, cam);
    const ObstacleDetectionResult res = detect(img, cam);
    EXPECT_GT(res.valid_points, 40000u);
    EXPECT_EQ(cv::countNonZero(res.mask), 0) << "roll " << roll;
    EXPECT_TRUE(res.obstacles.empty());
  }
}

TEST(ObstacleDetection, PoleIsOneObstacleWithItsMeasures) {
  const Camera cam = makeCamera();
  const Rendered img = render({floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f)}, cam);
  const ObstacleDetectionResult res = detect(img, cam);
  const cv::Mat pole_px = shapePixelsAbove(img, cam, 1, 0.06f);
  ASSERT_GT(cv::countNonZero(pole_px), 500);
  // Every pole pixel above H_T is a raised obstacle point.
  EXPECT_EQ(cv::countNonZero((res.mask == ObstacleDetectionResult::kRaised) & pole_px),
            cv::countNonZero(pole_px));
  ASSERT_EQ(res.num_accepted, 1);
  ASSERT_EQ(res.obstacles.size(), 1u);
  const ObstacleInfo& o = res.obstacles[0];
  EXPECT_EQ(dominantLabel(res, pole_px), o.label);
  EXPECT_FALSE(o.rejected);
  EXPECT_NEAR(o.ground_height, 0.0f, 0.01f);
  EXPECT_NEAR(o.max_height, 1.0f, 0.02f);
  EXPECT_GT(o.max_slope_deg, 85.0f);
  EXPECT_GT(o.avg_slope_deg, 45.0f);
  // The box holds the pole plus the floor at its foot within H_max / tan(theta_T) = 0.3 m.
  EXPECT_LT(o.bbox_min.x(), 2.46f);
  EXPECT_GT(o.bbox_min.x(), 2.45f - 0.31f);
  EXPECT_NEAR(o.bbox_max.z(), 1.0f, 0.02f);
  EXPECT_GT(o.bbox_min.y(), 0.3f - 0.05f - 0.31f);
  EXPECT_LT(o.bbox_max.y(), 0.3f + 0.05f + 0.31f);
  // Floor pixels farther than 0.3 m from the pole are never obstacle points.
  int far_floor_marked = 0;
  for (int v = 0; v < img.id.rows; ++v) {
    for (int u = 0; u < img.id.cols; ++u) {
      if (img.id.at<int>(v, u) != 0 || res.mask.at<std::uint8_t>(v, u) == 0) continue;
      const cv::Vec3f p = img.xyz.at<cv::Vec3f>(v, u);
      const Eigen::Vector3f q = cam.T * Eigen::Vector3f(p[0], p[1], p[2]);
      if ((q.head<2>() - Eigen::Vector2f(2.5f, 0.3f)).norm() > 0.05f + 0.3f + 0.01f) {
        ++far_floor_marked;
      }
    }
  }
  EXPECT_EQ(far_floor_marked, 0);
  // The floor at the foot is an obstacle point of Definition 1, but only as a lower end.
  const cv::Mat floor_marked = (img.id == 0) & (res.mask != 0);
  EXPECT_GT(cv::countNonZero(floor_marked), 0);
  EXPECT_EQ(cv::countNonZero(floor_marked & (res.mask == ObstacleDetectionResult::kRaised)), 0);
}

TEST(ObstacleDetection, SlantedWallReportsItsSlope) {
  // A wall leaning back at 60 deg from the horizontal, turned 30 deg away from facing the
  // camera: its steepest pairs run along its fall line.
  const float lean = deg(60.0f), yaw = deg(30.0f);
  const Eigen::Vector3f fall_dir(std::cos(yaw), std::sin(yaw), 0.0f);  // horizontal, into wall
  const Eigen::Vector3f foot(3.0f, 0.0f, 0.0f);
  Shape wall;
  const Eigen::Vector3f n = -std::sin(lean) * fall_dir + Eigen::Vector3f(0, 0, std::cos(lean));
  const Eigen::Vector3f side(-std::sin(yaw), std::cos(yaw), 0.0f);
  wall.planes = {{n, n.dot(foot)},
                 {Eigen::Vector3f(0, 0, 1), 1.2f},
                 {side, side.dot(foot) + 30.0f},
                 {-side, -side.dot(foot) + 30.0f},
                 {fall_dir, fall_dir.dot(foot) + 1.5f},
                 {Eigen::Vector3f(0, 0, -1), 0.01f}};
  const Camera cam = makeCamera();
  const Rendered img = render({floorShape(), wall}, cam);
  const ObstacleDetectionResult res = detect(img, cam);
  const cv::Mat wall_px = shapePixelsAbove(img, cam, 1, 0.06f);
  ASSERT_GT(cv::countNonZero(wall_px), 3000);
  EXPECT_GT(countMasked(res.mask, wall_px), 0.99 * cv::countNonZero(wall_px));
  const int l = dominantLabel(res, wall_px);
  ASSERT_GT(l, 0);
  EXPECT_EQ(labelsOn(res, wall_px).size(), 1u);
  const ObstacleInfo& o = res.obstacles[l - 1];
  EXPECT_FALSE(o.rejected);
  EXPECT_NEAR(o.max_slope_deg, 60.0f, 1.0f);
  EXPECT_GT(o.avg_slope_deg, 50.0f);
  EXPECT_NEAR(o.max_height, 1.2f, 0.02f);
}

TEST(ObstacleDetection, RampBelowThetaTIsNotAnObstacle) {
  const Camera cam = makeCamera();
  // 20 deg ramp rising 0.5 m: any two of its points are joined by a line at most 20 deg steep.
  const Rendered img = render({floorShape(), ramp(2.0f, deg(20.0f), 0.5f)}, cam);
  ASSERT_GT(img.count(1), 10000);
  const ObstacleDetectionResult res = detect(img, cam);
  EXPECT_EQ(cv::countNonZero(res.mask), 0);
  EXPECT_TRUE(res.obstacles.empty());
  const ObstacleDetectionResult col = detect(img, cam, ObstacleDetectionConfig(), true);
  EXPECT_EQ(cv::countNonZero(col.mask), 0);
  // The same ramp at 60 deg is one.
  const Rendered steep = render({floorShape(), ramp(2.0f, deg(60.0f), 0.5f)}, cam);
  const ObstacleDetectionResult res2 = detect(steep, cam);
  EXPECT_GT(countMasked(res2.mask, shapePixelsAbove(steep, cam, 1, 0.06f)), 500);

  // Heights come from the pose (gravity), not from the camera's y axis: seen by a camera pitched
  // down 35 deg and rolled 15 deg, the 20 deg ramp rises more than 45 deg along the image's
  // vertical, and is still no obstacle.
  const Camera tilted = makeCamera(320, 240, 300.0f, 1.1f, 35.0f, 15.0f);
  const Rendered seen = render({floorShape(), ramp(2.0f, deg(20.0f), 0.5f)}, tilted);
  ASSERT_GT(seen.count(1), 10000);
  EXPECT_EQ(cv::countNonZero(detect(seen, tilted).mask), 0);
  EXPECT_EQ(cv::countNonZero(detect(seen, tilted, ObstacleDetectionConfig(), true).mask), 0);
}

TEST(ObstacleDetection, StepBelowHTIsNotAnObstacleButACurbIs) {
  const Camera cam = makeCamera();
  const Rendered low = render({floorShape(), ramp(2.5f, deg(89.9f), 0.03f)}, cam);
  EXPECT_EQ(cv::countNonZero(detect(low, cam).mask), 0);
  EXPECT_EQ(cv::countNonZero(detect(low, cam, ObstacleDetectionConfig(), true).mask), 0);

  const Rendered curb = render({floorShape(), ramp(2.5f, deg(89.9f), 0.10f)}, cam);
  const ObstacleDetectionResult res = detect(curb, cam);
  // Along the whole edge: every column that sees the curb's face has obstacle points.
  int columns_with_face = 0, columns_detected = 0;
  for (int u = 0; u < cam.width; ++u) {
    bool face = false, found = false;
    for (int v = 0; v < cam.height; ++v) {
      const cv::Vec3f p = curb.xyz.at<cv::Vec3f>(v, u);
      const Eigen::Vector3f q = cam.T * Eigen::Vector3f(p[0], p[1], p[2]);
      if (curb.id.at<int>(v, u) == 1 && q.x() < 2.501f) face = true;
      if (res.mask.at<std::uint8_t>(v, u) == ObstacleDetectionResult::kRaised) found = true;
    }
    columns_with_face += face;
    columns_detected += face && found;
  }
  EXPECT_GT(columns_with_face, 300);
  EXPECT_EQ(columns_detected, columns_with_face);
  EXPECT_EQ(res.num_accepted, 1);
}

TEST(ObstacleDetection, ObjectsTouchingInTheImageButApartIn3DGetTwoLabels) {
  // A low box in front of a tall one 2 m behind: the near box's top edge and the far box's
  // visible bottom meet in the image (003 Fig. 6).
  const Camera cam = makeCamera();
  const Rendered img = render({floorShape(), box({2.2f, 0, 0.25f}, {0.05f, 0.3f, 0.25f}),
                               box({4.2f, 0, 0.75f}, {0.15f, 0.3f, 0.75f})},
                              cam);
  const cv::Mat near_px = shapePixelsAbove(img, cam, 1, 0.06f);
  const cv::Mat far_px = shapePixelsAbove(img, cam, 2, -1.0f);
  ASSERT_GT(cv::countNonZero(near_px), 1000);
  ASSERT_GT(cv::countNonZero(far_px), 1000);
  // They touch: some far-box pixel is 8-adjacent to a near-box pixel.
  cv::Mat grown;
  cv::dilate(near_px, grown, cv::Mat::ones(3, 3, CV_8U));
  ASSERT_GT(cv::countNonZero(grown & far_px), 10);

  const ObstacleDetectionResult res = detect(img, cam);
  const int ln = dominantLabel(res, near_px), lf = dominantLabel(res, far_px);
  ASSERT_GT(ln, 0);
  ASSERT_GT(lf, 0);
  EXPECT_NE(ln, lf);
  EXPECT_EQ(labelsOn(res, near_px).size(), 1u);
  EXPECT_EQ(labelsOn(res, far_px).size(), 1u);
  EXPECT_EQ(res.num_accepted, 2);
  EXPECT_NEAR(res.obstacles[ln - 1].max_height, 0.5f, 0.02f);
  EXPECT_NEAR(res.obstacles[lf - 1].bbox_max.z(), 1.5f, 0.02f);

  // The paper's exhaustive search separates them as well.
  ObstacleDetectionConfig exhaustive;
  exhaustive.exhaustive_search = true;
  const ObstacleDetectionResult all = detect(img, cam, exhaustive);
  EXPECT_NE(dominantLabel(all, near_px), dominantLabel(all, far_px));
  EXPECT_EQ(all.num_accepted, 2);

  // 2D blob colouring, as in the column-wise baseline, merges them.
  const ObstacleDetectionResult col = detect(img, cam, ObstacleDetectionConfig(), true);
  const int cn = dominantLabel(col, near_px), cf = dominantLabel(col, far_px);
  ASSERT_GT(cn, 0);
  EXPECT_EQ(cn, cf);
}

TEST(ObstacleDetection, PoleBesideAFarWallInTheImageGetsItsOwnLabel) {
  // A pole 2.5 m away in front of a wall at 4.5 m: in the image the pole's raised pixels are
  // side by side with the wall's (003 Fig. 6), but no pair of them is compatible (1.9 m apart),
  // so the surface links of the early-exit search must not join them across the depth gap.
  const Camera cam = makeCamera();
  const Rendered img = render(
      {floorShape(), pole(2.5f, 0.0f, 0.06f, 1.0f), box({4.6f, 0, 0.5f}, {0.1f, 20.0f, 0.5f})},
      cam);
  const cv::Mat pole_px = shapePixelsAbove(img, cam, 1, 0.06f);
  const cv::Mat wall_px = shapePixelsAbove(img, cam, 2, 0.06f);
  ASSERT_GT(cv::countNonZero(pole_px), 500);
  ASSERT_GT(cv::countNonZero(wall_px), 5000);
  cv::Mat grown;
  cv::dilate(pole_px, grown, cv::Mat::ones(3, 3, CV_8U));
  ASSERT_GT(cv::countNonZero(grown & wall_px), 50);  // side by side in the image

  for (bool exhaustive : {false, true}) {
    ObstacleDetectionConfig cfg;
    cfg.exhaustive_search = exhaustive;
    const ObstacleDetectionResult res = detect(img, cam, cfg);
    const int lp = dominantLabel(res, pole_px), lw = dominantLabel(res, wall_px);
    ASSERT_GT(lp, 0);
    ASSERT_GT(lw, 0);
    EXPECT_NE(lp, lw) << "exhaustive " << exhaustive;
    EXPECT_EQ(labelsOn(res, pole_px).size(), 1u) << "exhaustive " << exhaustive;
    EXPECT_EQ(res.num_accepted, 2) << "exhaustive " << exhaustive;
    EXPECT_NEAR(res.obstacles[lp - 1].max_height, 1.0f, 0.02f);
  }
}

TEST(ObstacleDetection, SmallFalseBlobsAreRejectedByTheRules) {
  const Camera cam = makeCamera();
  // A 4 x 4 x 7 cm object: taller than H_T, so Definition 1 finds it, but its volume is below
  // min_volume. Next to it a pole, which must stay.
  Rendered img = render({floorShape(), box({2.5f, -0.4f, 0.035f}, {0.02f, 0.02f, 0.035f}),
                         pole(2.5f, 0.3f, 0.05f, 1.0f)},
                        cam);
  // A stereo mismatch: a 2 x 2 patch of floor pixels seen 15 % too close, hovering ~0.15 m.
  cv::Mat blob_px(img.id.size(), CV_8U, cv::Scalar(0));
  for (int v = 150; v < 152; ++v) {
    for (int u = 60; u < 62; ++u) {
      ASSERT_EQ(img.id.at<int>(v, u), 0);
      img.xyz.at<cv::Vec3f>(v, u) *= 0.85f;
      blob_px.at<std::uint8_t>(v, u) = 255;
    }
  }
  const cv::Mat small_px = shapePixelsAbove(img, cam, 1, 0.055f);
  const cv::Mat pole_px = shapePixelsAbove(img, cam, 2, 0.06f);
  ASSERT_GT(cv::countNonZero(small_px), 3);

  // Without the rules all three are obstacles.
  const ObstacleDetectionResult raw = detect(img, cam, noRejection());
  EXPECT_EQ(raw.num_accepted, 3);
  EXPECT_GT(countMasked(raw.mask, small_px), 0);
  EXPECT_EQ(countMasked(raw.mask, blob_px), 4);

  const ObstacleDetectionResult res = detect(img, cam);
  ASSERT_EQ(res.obstacles.size(), 3u);
  EXPECT_EQ(res.num_accepted, 1);
  const int ls = dominantLabel(res, small_px), lb = dominantLabel(res, blob_px),
            lp = dominantLabel(res, pole_px);
  ASSERT_GT(ls, 0);
  ASSERT_GT(lb, 0);
  ASSERT_GT(lp, 0);
  EXPECT_TRUE(res.obstacles[ls - 1].rejected);
  EXPECT_EQ(res.obstacles[ls - 1].rejection, ObstacleRejection::kSmallVolume);
  EXPECT_TRUE(res.obstacles[lb - 1].rejected);
  EXPECT_EQ(res.obstacles[lb - 1].rejection, ObstacleRejection::kSmallVolume);
  EXPECT_FALSE(res.obstacles[lp - 1].rejected);
  // Rejected obstacles leave the mask but keep their labels.
  EXPECT_EQ(countMasked(res.mask, small_px), 0);
  EXPECT_EQ(countMasked(res.mask, blob_px), 0);
  EXPECT_EQ(labelsOn(res, blob_px).at(lb), 4);
  EXPECT_EQ(countMasked(res.mask, pole_px), cv::countNonZero(pole_px));
  EXPECT_STREQ(ssm::toString(ObstacleRejection::kSmallVolume), "small bounding volume");

  // The other rules fire on their own measure.
  ObstacleDetectionConfig cfg;
  cfg.min_volume = 0.0;
  cfg.min_max_height = 0.5;  // the pole is 1 m, the others lower
  const ObstacleDetectionResult by_height = detect(img, cam, cfg);
  EXPECT_EQ(by_height.obstacles[ls - 1].rejection, ObstacleRejection::kLowMaxHeight);
  EXPECT_FALSE(by_height.obstacles[lp - 1].rejected);
  cfg = ObstacleDetectionConfig();
  cfg.min_max_slope_deg = 89.0;  // the hovering blob's pairs are not vertical
  EXPECT_EQ(detect(img, cam, cfg).obstacles[lb - 1].rejection, ObstacleRejection::kLowMaxSlope);
}

TEST(ObstacleDetection, SidewaysSlopeIsMissedByTheColumnwiseBaseline) {
  // A ridge running away from the camera on its right, its visible face sloping 60 deg up to
  // the right (003 Fig. 9 and 12): along an image column the face rises far more gently than
  // 60 deg, so the 1D profiles see no obstacle, while Definition 1 in 3D does.
  const float slope = std::tan(deg(60.0f));
  Shape ridge;
  ridge.planes = {{Eigen::Vector3f(0, 1, 1.0f / slope), -0.45f},  // face: y <= -0.45 - z / tan
                  {Eigen::Vector3f(0, -1, 0.5f), 0.9f},           // hidden back face
                  {Eigen::Vector3f(1, 0, 0), 30.0f},
                  {Eigen::Vector3f(-1, 0, 0), -0.3f},
                  {Eigen::Vector3f(0, 0, -1), 0.01f}};
  const Camera cam = makeCamera();
  const Rendered img = render({floorShape(), ridge}, cam);
  const cv::Mat face_px = shapePixelsAbove(img, cam, 1, 0.06f);
  const int face = cv::countNonZero(face_px);
  ASSERT_GT(face, 2000);

  const ObstacleDetectionResult res = detect(img, cam);
  const ObstacleDetectionResult col = detect(img, cam, ObstacleDetectionConfig(), true);
  const int found = countMasked(res.mask, face_px), col_found = countMasked(col.mask, face_px);
  EXPECT_GT(found, 0.95 * face);
  EXPECT_LT(col_found, 0.05 * face);
  const int l = dominantLabel(res, face_px);
  ASSERT_GT(l, 0);
  EXPECT_NEAR(res.obstacles[l - 1].max_slope_deg, 60.0f, 1.0f);
}

TEST(ObstacleDetection, BoxTurned45DegIsFoundByBoth) {
  // The box of the brief: faces at 45 deg to the line of sight. Its faces are vertical, so every
  // column's slicing plane (nearly vertical here) cuts them in steep lines: the baseline finds
  // it too, if with fewer points. It is the sideways slope above that the baseline misses.
  // (The middle of the top face, farther than H_max / tan(theta_T) from any edge, has no
  // compatible point: only the faces are counted.)
  const Camera cam = makeCamera();
  const Rendered img =
      render({floorShape(), box({2.8f, 0.3f, 0.3f}, {0.25f, 0.25f, 0.3f}, deg(45.0f))}, cam);
  const cv::Mat box_px = shapePixelsAbove(img, cam, 1, 0.06f, 0.59f);
  const int n = cv::countNonZero(box_px);
  ASSERT_GT(n, 2000);
  const ObstacleDetectionResult res = detect(img, cam);
  const ObstacleDetectionResult col = detect(img, cam, ObstacleDetectionConfig(), true);
  EXPECT_EQ(countMasked(res.mask, box_px), n);
  EXPECT_LE(countMasked(col.mask, box_px), n);
  EXPECT_GT(countMasked(col.mask, box_px), n / 2);
  EXPECT_EQ(res.num_accepted, 1);
}

TEST(ObstacleDetection, MissingAndNonFinitePointsAreSkipped) {
  const Camera cam = makeCamera();
  Rendered img = render({floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f)}, cam);
  const cv::Mat pole_px = shapePixelsAbove(img, cam, 1, 0.06f);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> pick(0, 5);
  cv::Mat holes(img.id.size(), CV_8U, cv::Scalar(0));
  for (int v = 0; v < img.id.rows; ++v) {
    for (int u = 0; u < img.id.cols; ++u) {
      cv::Vec3f& p = img.xyz.at<cv::Vec3f>(v, u);
      const int k = pick(rng);
      const bool block = v >= 100 && v < 130 && u >= 150 && u < 190;
      if (block || k == 0)
        p = cv::Vec3f(kNaN, kNaN, kNaN);
      else if (k == 1 && (u + v) % 3 == 0)
        p[0] = kInfF;
      else if (k == 1 && (u + v) % 3 == 1)
        p[2] = -p[2];  // behind the camera
      else if (k == 1)
        p[1] = kNaN;
      else
        continue;
      holes.at<std::uint8_t>(v, u) = 255;
    }
  }
  const ObstacleDetectionResult res = detect(img, cam);
  EXPECT_EQ(res.valid_points,
            static_cast<std::size_t>(img.id.total() - cv::countNonZero(holes) -
                                     cv::countNonZero((img.id < 0) & (holes == 0))));
  EXPECT_EQ(countMasked(res.mask, holes), 0);
  EXPECT_EQ(cv::countNonZero((res.labels != 0) & holes), 0);
  const cv::Mat pole_seen = pole_px & (holes == 0);
  EXPECT_GT(countMasked(res.mask, pole_seen), 0.99 * cv::countNonZero(pole_seen));
  EXPECT_EQ(res.num_accepted, 1);

  // Nothing valid at all.
  cv::Mat all_nan(60, 80, CV_32FC3, cv::Scalar(kNaN, kNaN, kNaN));
  ObstacleDetector det;
  ObstacleDetectionResult none;
  ASSERT_TRUE(det.detect(all_nan, 300.0, cam.T, &none));
  EXPECT_EQ(none.valid_points, 0u);
  EXPECT_EQ(cv::countNonZero(none.mask), 0);
  EXPECT_TRUE(none.obstacles.empty());
  EXPECT_EQ(none.mask.size(), all_nan.size());
}

TEST(ObstacleDetection, FocalLengthIsEstimatedFromTheOrganisedImage) {
  const Camera cam = makeCamera(320, 240, 275.0f);
  Rendered img = render({floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f)}, cam);
  EXPECT_NEAR(ssm::estimateFocalLength(img.xyz), 275.0, 0.5);
  // Holes do not matter; too little data gives 0.
  for (int v = 0; v < 240; v += 3)
    img.xyz.row(v).setTo(cv::Scalar(kNaN, kNaN, kNaN));
  EXPECT_NEAR(ssm::estimateFocalLength(img.xyz), 275.0, 0.5);
  EXPECT_EQ(ssm::estimateFocalLength(cv::Mat(240, 320, CV_32FC3, cv::Scalar(kNaN, 0, 0))), 0.0);
  EXPECT_EQ(ssm::estimateFocalLength(cv::Mat()), 0.0);
  EXPECT_EQ(ssm::estimateFocalLength(cv::Mat(10, 10, CV_32FC1)), 0.0);
}

TEST(ObstacleDetection, BadInputIsRejectedWithoutCrashing) {
  ObstacleDetector det;
  ObstacleDetectionResult res;
  const Camera cam = makeCamera();
  const cv::Mat ok(20, 30, CV_32FC3, cv::Scalar(0.0f, 0.5f, 2.0f));
  EXPECT_FALSE(det.detect(cv::Mat(), 300.0, cam.T, &res));
  EXPECT_TRUE(res.mask.empty());
  EXPECT_FALSE(res.error.empty());
  EXPECT_FALSE(det.detect(cv::Mat(20, 30, CV_32FC1, cv::Scalar(1.0f)), 300.0, cam.T, &res));
  EXPECT_FALSE(det.detect(cv::Mat(20, 30, CV_64FC3, cv::Scalar(1.0)), 300.0, cam.T, &res));
  EXPECT_FALSE(det.detectColumnwise(cv::Mat(20, 30, CV_8UC3), 300.0, cam.T, &res));
  EXPECT_FALSE(det.detect(ok, 0.0, cam.T, &res));
  EXPECT_FALSE(det.detect(ok, NAN, cam.T, &res));
  Eigen::Isometry3f bad = cam.T;
  bad.translation().x() = NAN;
  EXPECT_FALSE(det.detect(ok, 300.0, bad, &res));
  bad = cam.T;
  bad.linear() *= 2.0f;
  EXPECT_FALSE(det.detect(ok, 300.0, bad, &res));
  EXPECT_FALSE(det.detect(ok, 300.0, cam.T, nullptr));
  // A huge or tiny focal length only changes the window; still fine.
  EXPECT_TRUE(det.detect(ok, 1e9, cam.T, &res));
  EXPECT_TRUE(det.detect(ok, 1e-9, cam.T, &res));
  EXPECT_TRUE(res.error.empty());
  // A view of a sub-image (non-continuous rows) works like a copy.
  const Rendered img = render({floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f)}, cam);
  const cv::Rect roi(40, 30, 200, 180);
  ObstacleDetectionResult a, b;
  ASSERT_TRUE(det.detect(img.xyz(roi), cam.f, cam.T, &a));
  ASSERT_TRUE(det.detect(img.xyz(roi).clone(), cam.f, cam.T, &b));
  EXPECT_EQ(cv::countNonZero(a.mask != b.mask), 0);
  EXPECT_GT(cv::countNonZero(a.mask), 100);
}

TEST(ObstacleDetection, SegmentationOffGivesTheSameMaskWithoutLabels) {
  const Camera cam = makeCamera();
  const Rendered img = render(
      {floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f), box({3.0f, -0.5f, 0.2f}, {0.2f, 0.2f, 0.2f})},
      cam);
  ObstacleDetectionConfig cfg = noRejection();
  const ObstacleDetectionResult with = detect(img, cam, cfg);
  cfg.segment = false;
  const ObstacleDetectionResult without = detect(img, cam, cfg);
  EXPECT_EQ(with.num_accepted, 2);
  EXPECT_EQ(cv::countNonZero(with.mask != without.mask), 0);
  EXPECT_EQ(cv::countNonZero(without.labels), 0);
  EXPECT_TRUE(without.obstacles.empty());
}

TEST(ObstacleDetection, ReusedDetectorGivesIdenticalResults) {
  const Camera cam = makeCamera();
  const Rendered a = render({floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f)}, cam);
  const Camera small = makeCamera(160, 120, 150.0f);
  const Rendered b = render({floorShape(), box({3.0f, -0.5f, 0.2f}, {0.2f, 0.2f, 0.2f})}, small);
  ObstacleDetector reused;
  ObstacleDetectionResult r1, r2, r3, fresh;
  ASSERT_TRUE(reused.detect(a.xyz, cam.f, cam.T, &r1));
  ASSERT_TRUE(reused.detect(b.xyz, small.f, small.T, &r2));  // other size in between
  ASSERT_TRUE(reused.detect(a.xyz, cam.f, cam.T, &r3));
  ASSERT_TRUE(ObstacleDetector().detect(b.xyz, small.f, small.T, &fresh));
  EXPECT_EQ(cv::countNonZero(r1.mask != r3.mask), 0);
  EXPECT_EQ(cv::countNonZero(r1.labels != r3.labels), 0);
  EXPECT_EQ(cv::countNonZero(r2.mask != fresh.mask), 0);
  ASSERT_EQ(r1.obstacles.size(), r3.obstacles.size());
  for (std::size_t k = 0; k < r1.obstacles.size(); ++k) {
    EXPECT_EQ(r1.obstacles[k].pixel_count, r3.obstacles[k].pixel_count);
    EXPECT_EQ(r1.obstacles[k].volume, r3.obstacles[k].volume);
  }
  EXPECT_EQ(r1.pairs_tested, r3.pairs_tested);
}

TEST(ObstacleDetection, WarmedUpDetectorDoesNotAllocate) {
  const Camera cam = makeCamera();
  const Rendered img = render(
      {floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f), box({3.0f, -0.5f, 0.2f}, {0.2f, 0.2f, 0.2f})},
      cam);
  for (bool exhaustive : {false, true}) {
    ObstacleDetectionConfig cfg;
    cfg.exhaustive_search = exhaustive;
    ObstacleDetector det(cfg);
    ObstacleDetectionResult res, col;
    ASSERT_TRUE(det.detect(img.xyz, cam.f, cam.T, &res));
    ASSERT_TRUE(det.detectColumnwise(img.xyz, cam.f, cam.T, &col));
    const std::size_t before = g_allocations;
    ASSERT_TRUE(det.detect(img.xyz, cam.f, cam.T, &res));
    ASSERT_TRUE(det.detectColumnwise(img.xyz, cam.f, cam.T, &col));
    EXPECT_EQ(g_allocations - before, 0u) << "exhaustive " << exhaustive;
    EXPECT_EQ(res.num_accepted, 2);
  }
}

TEST(ObstacleDetection, EarlyExitAndExhaustiveSearchAgree) {
  // Same obstacle points (every pixel sampled) and the same obstacles on separate objects.
  const Camera cam = makeCamera();
  const Rendered img = render({floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f),
                               box({3.0f, -0.5f, 0.2f}, {0.2f, 0.2f, 0.2f}, deg(30.0f)),
                               box({4.5f, 0.9f, 0.4f}, {0.2f, 0.3f, 0.4f})},
                              cam);
  ObstacleDetectionConfig cfg = noRejection();
  cfg.sample_spacing = 0.0;
  cfg.max_candidates_per_pixel = 0;
  const ObstacleDetectionResult fast = detect(img, cam, cfg);
  cfg.exhaustive_search = true;
  const ObstacleDetectionResult all = detect(img, cam, cfg);
  EXPECT_EQ(cv::countNonZero(fast.mask != all.mask), 0);
  EXPECT_EQ(fast.num_accepted, 3);
  EXPECT_EQ(all.num_accepted, 3);
  for (int shape = 1; shape <= 3; ++shape) {
    const cv::Mat px = shapePixelsAbove(img, cam, shape, 0.06f);
    const ObstacleInfo& a = fast.obstacles[dominantLabel(fast, px) - 1];
    const ObstacleInfo& b = all.obstacles[dominantLabel(all, px) - 1];
    EXPECT_EQ(a.pixel_count, b.pixel_count) << shape;
    EXPECT_EQ(a.bbox_max, b.bbox_max) << shape;
    EXPECT_NEAR(a.max_height, b.max_height, 1e-6f) << shape;
  }
}

TEST(ObstacleDetection, WithoutFootSearchOnlyFeetChange) {
  const Camera cam = makeCamera();
  const Rendered img = render({floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f),
                               box({3.0f, -0.5f, 0.2f}, {0.2f, 0.2f, 0.2f}, deg(30.0f))},
                              cam);
  ObstacleDetectionConfig cfg;
  const ObstacleDetectionResult all = detect(img, cam, cfg);
  cfg.search_foot_points = false;
  const ObstacleDetectionResult some = detect(img, cam, cfg);
  const cv::Mat raised_all = all.mask == ObstacleDetectionResult::kRaised;
  const cv::Mat raised_some = some.mask == ObstacleDetectionResult::kRaised;
  EXPECT_EQ(cv::countNonZero(raised_all != raised_some), 0);
  const int feet_all = cv::countNonZero(all.mask == ObstacleDetectionResult::kFoot);
  const int feet_some = cv::countNonZero(some.mask == ObstacleDetectionResult::kFoot);
  EXPECT_GT(feet_some, 0);
  EXPECT_LT(feet_some, feet_all);
  EXPECT_EQ(cv::countNonZero((some.mask != 0) & (all.mask == 0)), 0);
  EXPECT_EQ(some.num_accepted, 2);
}

TEST(ObstacleDetection, SampledSearchMarksASubsetOfTheFullOne) {
  // Every partner the lattice finds is a true partner, so sampling can only lose points.
  const Camera cam = makeCamera();
  const Rendered img = render(
      {floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f),
       box({2.8f, -0.4f, 0.3f}, {0.25f, 0.25f, 0.3f}, deg(45.0f)), ramp(4.0f, deg(89.9f), 0.08f)},
      cam);
  ObstacleDetectionConfig cfg = noRejection();
  const ObstacleDetectionResult sub = detect(img, cam, cfg);
  cfg.sample_spacing = 0.0;
  cfg.max_candidates_per_pixel = 0;
  const ObstacleDetectionResult all = detect(img, cam, cfg);
  EXPECT_GT(all.pairs_tested, sub.pairs_tested);
  EXPECT_EQ(cv::countNonZero((sub.mask != 0) & (all.mask == 0)), 0);
  EXPECT_EQ(cv::countNonZero((sub.mask == ObstacleDetectionResult::kRaised) &
                             (all.mask != ObstacleDetectionResult::kRaised)),
            0);
  // What sampling loses are a few points at the edges of the foot rings.
  const cv::Mat raised_all = all.mask == ObstacleDetectionResult::kRaised;
  EXPECT_GT(countMasked(sub.mask, raised_all), 0.98 * cv::countNonZero(raised_all));
  EXPECT_EQ(sub.num_accepted, all.num_accepted);
}

// Brute force over all pairs (003's N^2 strategy, Sec. 2) on a small image with a rolled and
// pitched camera: the exhaustive search must find exactly Definition 1's pairs, so the search
// window of Sec. 4.1 and the tile pruning lose nothing. Pairs within 1e-4 of a threshold may
// go either way (float rounding).
void checkAgainstBruteForce(bool columnwise, bool exhaustive, float pitch_deg = 22.0f,
                            float roll_deg = 8.0f, double slope_threshold_deg = 45.0) {
  const Camera cam = makeCamera(96, 72, 90.0f, 1.1f, pitch_deg, roll_deg);
  const float s60 = std::tan(deg(60.0f));
  Shape ridge;
  ridge.planes = {{Eigen::Vector3f(0, 1, 1.0f / s60), -0.45f},
                  {Eigen::Vector3f(0, -1, 0.5f), 0.9f},
                  {Eigen::Vector3f(1, 0, 0), 30.0f},
                  {Eigen::Vector3f(-1, 0, 0), -0.3f},
                  {Eigen::Vector3f(0, 0, -1), 0.01f}};
  const Rendered img = render({floorShape(), pole(2.0f, 0.5f, 0.05f, 0.8f),
                               box({3.0f, 0.2f, 0.2f}, {0.2f, 0.3f, 0.2f}, deg(30.0f)),
                               ramp(5.0f, deg(80.0f), 0.12f), ridge},
                              cam);
  ObstacleDetectionConfig cfg = noRejection();
  cfg.sample_spacing = 0.0;
  cfg.max_candidates_per_pixel = 0;
  cfg.exhaustive_search = exhaustive;
  cfg.slope_threshold_deg = slope_threshold_deg;
  // Without surface links the early-exit labels come from compatible pairs only.
  cfg.surface_link_distance = 0.0;
  const ObstacleDetectionResult res = detect(img, cam, cfg, columnwise);

  const int w = cam.width, n = cam.width * cam.height;
  std::vector<Eigen::Vector3d> p(n);
  std::vector<bool> valid(n);
  for (int i = 0; i < n; ++i) {
    const cv::Vec3f q = img.xyz.at<cv::Vec3f>(i / w, i % w);
    valid[i] = std::isfinite(q[2]);
    p[i] = cam.T.cast<double>() * Eigen::Vector3d(q[0], q[1], q[2]);
  }
  const double ht = cfg.height_threshold, hmax = cfg.max_height,
               tn = std::tan(cfg.slope_threshold_deg * M_PI / 180.0), eps = 1e-4;
  std::vector<int> definite_any(n, 0), definite_raised(n, 0), possible_any(n, 0),
      possible_raised(n, 0);
  std::vector<int> uf(n);
  std::iota(uf.begin(), uf.end(), 0);
  auto find = [&](int a) {
    while (uf[a] != a)
      a = uf[a] = uf[uf[a]];
    return a;
  };
  std::vector<std::pair<int, int>> definite_pairs;
  int num_definite = 0;
  for (int i = 0; i < n; ++i) {
    if (!valid[i]) continue;
    for (int j = i + 1; j < n; ++j) {
      if (!valid[j] || (columnwise && j % w != i % w)) continue;
      const Eigen::Vector3d d = p[j] - p[i];
      const double adz = std::fabs(d.z()), h = d.head<2>().norm();
      const bool possible = adz > ht - eps && adz < hmax + eps && adz > tn * h - eps;
      if (!possible) continue;
      const bool definite = adz > ht + eps && adz < hmax - eps && adz > tn * h + eps;
      const int upper = d.z() > 0 ? j : i;
      possible_any[i] = possible_any[j] = 1;
      possible_raised[upper] = 1;
      uf[find(i)] = find(j);
      if (definite) {
        ++num_definite;
        definite_any[i] = definite_any[j] = 1;
        definite_raised[upper] = 1;
        if (definite_pairs.size() < 200000) definite_pairs.emplace_back(i, j);
      }
    }
  }
  ASSERT_GT(num_definite, 1000);
  int missed = 0, spurious = 0, raised_missed = 0, raised_spurious = 0;
  for (int i = 0; i < n; ++i) {
    const std::uint8_t m = res.mask.at<std::uint8_t>(i / w, i % w);
    if (definite_any[i] && m == 0) ++missed;
    if (!possible_any[i] && m != 0) ++spurious;
    if (definite_raised[i] && m != ObstacleDetectionResult::kRaised) ++raised_missed;
    if (!possible_raised[i] && m == ObstacleDetectionResult::kRaised) ++raised_spurious;
  }
  EXPECT_EQ(missed, 0);
  EXPECT_EQ(spurious, 0);
  EXPECT_EQ(raised_missed, 0);
  EXPECT_EQ(raised_spurious, 0);
  if (columnwise) return;  // blob colouring is not the compatibility graph
  // Segmentation: with the exhaustive search compatible points share a label; with either, a
  // label never spans two components of the (possible) compatibility graph.
  int split = 0;
  for (const auto& ij : definite_pairs) {
    split += res.labels.at<int>(ij.first / w, ij.first % w) !=
             res.labels.at<int>(ij.second / w, ij.second % w);
  }
  if (exhaustive) {
    EXPECT_EQ(split, 0);
  }
  std::map<int, int> root_of_label;
  int merged = 0;
  for (int i = 0; i < n; ++i) {
    const int l = res.labels.at<int>(i / w, i % w);
    if (l == 0) continue;
    auto it = root_of_label.emplace(l, find(i)).first;
    merged += it->second != find(i);
  }
  EXPECT_EQ(merged, 0);
  EXPECT_GE(root_of_label.size(), 2u);
}

TEST(ObstacleDetection, ExhaustiveSearchEqualsBruteForceDefinition1) {
  checkAgainstBruteForce(false, true);
}

TEST(ObstacleDetection, SearchWindowFollowsAStronglyTiltedCamera) {
  // 003 Sec. 4.1: with the camera rolled, the vertical runs diagonally across the image, and with
  // a steep theta_T the double cone is a thin vertical spike: a window laid out for a level
  // camera (height H_max f / Z straight up, narrow sideways) misses pairs that this one finds.
  checkAgainstBruteForce(false, true, 35.0f, 35.0f, 70.0);
  checkAgainstBruteForce(false, false, 35.0f, 35.0f, 70.0);
}

TEST(ObstacleDetection, EarlyExitSearchMarksEqualBruteForceDefinition1) {
  checkAgainstBruteForce(false, false);
}

TEST(ObstacleDetection, ColumnwiseEqualsBruteForceWithinColumns) {
  checkAgainstBruteForce(true, false);
  checkAgainstBruteForce(true, true);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The stereo noise margin (noise_sigmas, 001 Sec. 4.1's error model).

namespace {

// Each pixel's depth as a stereo camera of baseline b would measure it: disparity f b / Z plus
// Gaussian noise of sigma_d pixels, the point moved along its ray to the new depth.
cv::Mat withDisparityNoise(const cv::Mat& xyz, float f, float b, float sigma_d, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, sigma_d);
  cv::Mat out = xyz.clone();
  for (int v = 0; v < out.rows; ++v) {
    for (int u = 0; u < out.cols; ++u) {
      cv::Vec3f& p = out.at<cv::Vec3f>(v, u);
      if (!(p[2] > 0.0f)) continue;
      const float d = f * b / p[2] + noise(rng);
      if (!(d > 1.0f)) {
        p = cv::Vec3f(kNaN, kNaN, kNaN);
        continue;
      }
      p *= (f * b / d) / p[2];
    }
  }
  return out;
}

// A 0.3 m box 2 m ahead on a floor seen to 8 m by `cam`, with the disparity noise of a camera of
// baseline b (sigma_d 0.5 px).
Rendered boxOnNoisyFloor(const Camera& cam, float b, unsigned seed) {
  Rendered img = render(
      {floorShape(), box(Eigen::Vector3f(2.0f, 0.0f, 0.15f), Eigen::Vector3f(0.15f, 0.2f, 0.15f))},
      cam, 8.0f);
  img.xyz = withDisparityNoise(img.xyz, cam.f, b, 0.5f, seed);
  return img;
}

}  // namespace

TEST(ObstacleDetectionNoiseMargin, FloorNoiseAtRangeIsNoObstacleTheBoxStillIs) {
  // A 0.3 m box 2 m ahead on a floor seen to 8 m, with the disparity noise of a 0.12 m baseline
  // camera (sigma_d 0.5 px). 003's constant test finds obstacles all over the far floor, where
  // crossing depth errors of pixels a few rows apart make steep "pairs"; with a 2-sigma margin
  // the floor is clear and the box is still found.
  const Camera cam = makeCamera(320, 240, 300.0f, 1.1f, 15.0f);
  const float b = 0.12f;
  Rendered img = boxOnNoisyFloor(cam, b, 7);
  const cv::Mat box_px = shapePixelsAbove(img, cam, 1, 0.1f);
  ASSERT_GT(cv::countNonZero(box_px), 300);
  // Floor pixels farther than 1 m from the box: never part of it.
  cv::Mat far_floor(img.id.size(), CV_8U, cv::Scalar(0));
  for (int v = 0; v < img.id.rows; ++v) {
    for (int u = 0; u < img.id.cols; ++u) {
      if (img.id.at<int>(v, u) != 0) continue;
      const cv::Vec3f p = img.xyz.at<cv::Vec3f>(v, u);
      const Eigen::Vector3f q = cam.T * Eigen::Vector3f(p[0], p[1], p[2]);
      if (std::isfinite(q.x()) && (q.head<2>() - Eigen::Vector2f(2.0f, 0.0f)).norm() > 1.0f) {
        far_floor.at<std::uint8_t>(v, u) = 255;
      }
    }
  }
  ASSERT_GT(cv::countNonZero(far_floor), 20000);

  ObstacleDetectionConfig paper = noRejection();
  ObstacleDetectionConfig margin = paper;
  margin.noise_sigmas = 2.0;
  margin.disparity_sigma = 0.5;
  ObstacleDetector det_paper(paper), det_margin(margin);
  ObstacleDetectionResult res_paper, res_margin, res_no_baseline;
  ASSERT_TRUE(det_paper.detect(img.xyz, cam.f, cam.T, &res_paper, b));
  ASSERT_TRUE(det_margin.detect(img.xyz, cam.f, cam.T, &res_margin, b));
  const int floor_paper =
      countMasked(res_paper.mask == ObstacleDetectionResult::kRaised, far_floor);
  const int floor_margin =
      countMasked(res_margin.mask == ObstacleDetectionResult::kRaised, far_floor);
  EXPECT_GT(floor_paper, 200) << "the noise must fool 003's constant test (else no test)";
  EXPECT_LT(floor_margin, floor_paper / 20) << floor_paper;
  const int box_paper = countMasked(res_paper.mask == ObstacleDetectionResult::kRaised, box_px);
  const int box_margin = countMasked(res_margin.mask == ObstacleDetectionResult::kRaised, box_px);
  // The margin asks a pair to stay steep with a run k s_xy longer (here ~0.15 m at 2 m), so the
  // box's lower part no longer pairs with the floor; its upper part does.
  EXPECT_GT(box_margin, cv::countNonZero(box_px) / 3) << box_paper;
  // With 003's Sec. 5 rules on (the defaults), what a user gets: obstacles all over the floor
  // without the margin, one on the box with it.
  ObstacleDetectionConfig rules;  // the defaults, 003's constants
  rules.noise_sigmas = 0.0;
  ObstacleDetectionConfig rules_margin = rules;
  rules_margin.noise_sigmas = 2.0;
  auto accepted = [&](const ObstacleDetectionConfig& cfg, int* on_box, int* elsewhere) {
    ObstacleDetector det(cfg);
    ObstacleDetectionResult res;
    ASSERT_TRUE(det.detect(img.xyz, cam.f, cam.T, &res, b));
    *on_box = *elsewhere = 0;
    for (const ssm::ObstacleInfo& o : res.obstacles) {
      if (o.rejected) continue;
      const bool near_box = (o.centroid.head<2>() - Eigen::Vector2f(2.0f, 0.0f)).norm() < 0.5f;
      ++(near_box ? *on_box : *elsewhere);
    }
  };
  int on_box = 0, elsewhere = 0;
  accepted(rules, &on_box, &elsewhere);
  EXPECT_GT(elsewhere, 5) << "003's rules alone do not stop the floor's noise (else no test)";
  accepted(rules_margin, &on_box, &elsewhere);
  EXPECT_GE(on_box, 1);
  EXPECT_EQ(elsewhere, 0);

  // Without the baseline the margin is off: 003's test exactly.
  ASSERT_TRUE(det_margin.detect(img.xyz, cam.f, cam.T, &res_no_baseline, 0.0));
  EXPECT_EQ(cv::countNonZero(res_no_baseline.mask != res_paper.mask), 0);
  // A bad baseline is refused.
  EXPECT_FALSE(det_margin.detect(img.xyz, cam.f, cam.T, &res_no_baseline, -1.0));
  EXPECT_FALSE(det_margin.detect(img.xyz, cam.f, cam.T, &res_no_baseline, NAN));
}

TEST(ObstacleDetectionDecimation, HalfResolutionFindsTheBoxAndKeepsTheNoiseMargin) {
  // The scene of FloorNoiseAtRangeIsNoObstacleTheBoxStillIs at 640x480 (f 600), detected on
  // every second pixel with f / 2 and baseline * 2 (the nodelet's ~decimation 2): the box is
  // still an accepted obstacle, the far floor stays clear with the default margin (k = 1), and
  // passing f / 2 with the true baseline (a margin twice too wide) would lose points on the box.
  const Camera cam = makeCamera(640, 480, 600.0f, 1.1f, 15.0f);
  const float b = 0.12f;
  const Rendered img = boxOnNoisyFloor(cam, b, 11);

  cv::Mat half;
  decimateRangeImage(img.xyz, 2, &half);
  ASSERT_EQ(half.rows, 240);
  ASSERT_EQ(half.cols, 320);
  for (int v = 0; v < half.rows; v += 37) {
    for (int u = 0; u < half.cols; u += 29) {
      const cv::Vec3f a = half.at<cv::Vec3f>(v, u), c = img.xyz.at<cv::Vec3f>(2 * v, 2 * u);
      EXPECT_TRUE((a[2] == c[2]) || (std::isnan(a[2]) && std::isnan(c[2])));
    }
  }
  cv::Mat same;
  decimateRangeImage(img.xyz, 1, &same);
  EXPECT_EQ(same.data, img.xyz.data);
  cv::Mat none;
  decimateRangeImage(img.xyz, 0, &none);
  EXPECT_TRUE(none.empty());
  decimateRangeImage(cv::Mat(4, 4, CV_32FC1), 2, &none);
  EXPECT_TRUE(none.empty());

  ObstacleDetector det;  // the defaults: noise_sigmas 1
  ObstacleDetectionResult full, dec, wide;
  ASSERT_TRUE(det.detect(img.xyz, cam.f, cam.T, &full, b));
  ASSERT_TRUE(det.detect(half, cam.f / 2, cam.T, &dec, b * 2));
  ASSERT_TRUE(det.detect(half, cam.f / 2, cam.T, &wide, b));
  auto onBox = [](const ObstacleDetectionResult& r, int* elsewhere) {
    int on_box = 0;
    *elsewhere = 0;
    for (const ObstacleInfo& o : r.obstacles) {
      if (o.rejected) continue;
      const bool near_box = (o.centroid.head<2>() - Eigen::Vector2f(2.0f, 0.0f)).norm() < 0.5f;
      ++(near_box ? on_box : *elsewhere);
    }
    return on_box;
  };
  int elsewhere_full = 0, elsewhere_dec = 0, elsewhere_wide = 0;
  EXPECT_GE(onBox(full, &elsewhere_full), 1);
  EXPECT_GE(onBox(dec, &elsewhere_dec), 1);
  onBox(wide, &elsewhere_wide);
  EXPECT_EQ(elsewhere_dec, elsewhere_full);
  // Raised points: a quarter of the pixels, about a quarter of the marks on the box.
  const int raised_full = cv::countNonZero(full.mask == ObstacleDetectionResult::kRaised);
  const int raised_dec = cv::countNonZero(dec.mask == ObstacleDetectionResult::kRaised);
  const int raised_wide = cv::countNonZero(wide.mask == ObstacleDetectionResult::kRaised);
  EXPECT_GT(raised_dec, raised_full / 8) << raised_full;
  EXPECT_LT(raised_dec, raised_full / 2) << raised_full;
  EXPECT_LT(raised_wide, raised_dec) << "a margin twice too wide must cost marks (else no test)";
  // The cue from the decimated image: points on the box.
  std::vector<Eigen::Vector3f> pts;
  raisedObstaclePoints(dec, half, cam.T, &pts, nullptr);
  ASSERT_FALSE(pts.empty());
  for (const Eigen::Vector3f& p : pts)
    EXPECT_LT((p.head<2>() - Eigen::Vector2f(2.0f, 0.0f)).norm(), 0.6f);
}

TEST(ObstacleDetectionNoiseMargin, MarksAreASubsetOfTheConstantTestsAndNearObstaclesStay) {
  // The margin only removes pairs: every point it marks, 003's test marks too. Without noise a
  // pole 1.5 m ahead keeps all of its points above H_T + the margin at that range (a vertical
  // pair needs a rise of k (s_z + s_xy) ~ 0.13 m there, H_T included).
  const Camera cam = makeCamera();
  const Rendered img = render({floorShape(), pole(1.5f, 0.2f, 0.05f, 1.0f)}, cam, 8.0f);
  ObstacleDetectionConfig margin = noRejection();
  margin.noise_sigmas = 2.0;
  ObstacleDetector det_paper(noRejection()), det_margin(margin);
  ObstacleDetectionResult res_paper, res_margin;
  ASSERT_TRUE(det_paper.detect(img.xyz, cam.f, cam.T, &res_paper, 0.12));
  ASSERT_TRUE(det_margin.detect(img.xyz, cam.f, cam.T, &res_margin, 0.12));
  EXPECT_EQ(cv::countNonZero((res_margin.mask != 0) & (res_paper.mask == 0)), 0);
  const cv::Mat pole_px = shapePixelsAbove(img, cam, 1, 0.2f);
  ASSERT_GT(cv::countNonZero(pole_px), 300);
  // All but a few: the sampled search (sample_spacing) may skip the few partners left.
  EXPECT_GE(countMasked(res_margin.mask == ObstacleDetectionResult::kRaised, pole_px),
            cv::countNonZero(pole_px) * 97 / 100);
}

TEST(ObstacleDetectionNoiseMargin, FloorBeyondTheMarginsReachIsNotSearched) {
  // The floor from 5 to 8 m (nearer points missing) with the disparity noise of a 0.12 m camera.
  // There k = 2 sigma of a pair's horizontal error alone exceeds H_max (0.3 m), so no pair can
  // stay steeper than 45 deg under the margin: the search prunes every pixel and tile by the
  // margin's bounds and tests no pair at all. 003's constant test searches the same image.
  const Camera cam = makeCamera(320, 240, 300.0f, 1.1f, 15.0f);
  const float b = 0.12f;
  Rendered img = render({floorShape()}, cam, 8.0f);
  img.xyz = withDisparityNoise(img.xyz, cam.f, b, 0.5f, 11);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  int kept = 0;
  for (int v = 0; v < img.xyz.rows; ++v) {
    for (int u = 0; u < img.xyz.cols; ++u) {
      cv::Vec3f& p = img.xyz.at<cv::Vec3f>(v, u);
      if (!(p[2] >= 5.0f)) {
        p = cv::Vec3f(nan, nan, nan);
      } else {
        ++kept;
      }
    }
  }
  ASSERT_GT(kept, 5000);
  ObstacleDetectionConfig paper = noRejection();
  ObstacleDetectionConfig margin = paper;
  margin.noise_sigmas = 2.0;
  ObstacleDetector det_paper(paper), det_margin(margin);
  ObstacleDetectionResult res_paper, res_margin;
  ASSERT_TRUE(det_paper.detect(img.xyz, cam.f, cam.T, &res_paper, b));
  ASSERT_TRUE(det_margin.detect(img.xyz, cam.f, cam.T, &res_margin, b));
  EXPECT_GT(res_paper.pairs_tested, static_cast<std::size_t>(kept)) << "a search to prune";
  EXPECT_EQ(res_margin.pairs_tested, 0u);
  EXPECT_EQ(cv::countNonZero(res_margin.mask), 0);
}

TEST(ObstacleDetection, RaisedObstaclePointsAreTheCue) {
  const Camera cam = makeCamera();
  const Rendered img = render({floorShape(), pole(2.5f, 0.3f, 0.05f, 1.0f)}, cam);
  const ObstacleDetectionResult res = detect(img, cam);
  std::vector<Eigen::Vector3f> points;
  std::vector<std::uint32_t> labels;
  raisedObstaclePoints(res, img.xyz, cam.T, &points, &labels);
  ASSERT_EQ(points.size(), static_cast<std::size_t>(
                               cv::countNonZero(res.mask == ObstacleDetectionResult::kRaised)));
  ASSERT_EQ(labels.size(), points.size());
  ASSERT_FALSE(points.empty());
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR((points[i].head<2>() - Eigen::Vector2f(2.5f, 0.3f)).norm(), 0.05f, 0.02f);
    EXPECT_GT(points[i].z(), 0.05f);
    EXPECT_EQ(static_cast<int>(labels[i]), res.obstacles[0].label);
  }
  // A mismatched range image gives nothing (and does not crash).
  raisedObstaclePoints(res, cv::Mat(10, 10, CV_32FC3), cam.T, &points, nullptr);
  EXPECT_TRUE(points.empty());
}
