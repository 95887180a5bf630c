// A synthetic rectified stereo pair for the disparity rostests, known by construction: a textured
// level floor (z = 0 in odom, x in [-1, 6] m, |y| <= 4 m) with a textured box on it (x 2.0..2.6,
// y -0.3..0.3, z 0..0.5 m), seen by a camera 1.1 m above the robot's base, pitched down 30 deg,
// looking along +x; 320x240, f = 250 px, baseline 0.12 m. Both images are rendered by ray casting
// from their own optical centre (so occlusions and perspective are exact), 3x3 supersampled, with
// a 3D value-noise texture fixed to the surfaces and +-2 grey levels of sensor noise. Above the
// floor's far edge the background is uniform grey: no texture, no true disparity. The solids are
// the dataset's (dataset/scene.h), hit by Scene::intersect, the renderer's own intersection; only
// the texture and noise are this file's (dataset::StereoRenderer shades and lights otherwise,
// and the disparity rostests' thresholds are tuned to these images, pixel for pixel).
//
// The analytic disparity of the left image is f B / Z of the ray through each pixel centre.
// A 5x5 px textured patch floats in that background with its own disparity (10 px): a small
// surface that no larger surface supports, i.e. what 002 Sec. 4.2 calls a spike.
#pragma once

#include "scene_camera.h"
#include "scene_solids.h"

#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/dataset/scene.h"
#include "stereo_safety_map/ros/conversions.h"

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace stereo_scene {

// The camera (scene_camera.h), at its own height.
using scene_camera::cameraInfo;
using scene_camera::cameraModel;
using scene_camera::kBaseline;
using scene_camera::kCameraFrame;
using scene_camera::kCx;
using scene_camera::kCy;
using scene_camera::kF;
using scene_camera::kHeight;
using scene_camera::kWidth;
using scene_camera::toMsg;
constexpr double kCameraHeight = 1.1;

constexpr double kFloorMin[2] = {-1.0, -4.0};
constexpr double kFloorMax[2] = {6.0, 4.0};
constexpr double kBoxMin[3] = {2.0, -0.3, 0.0};
constexpr double kBoxMax[3] = {2.6, 0.3, 0.5};
constexpr int kBackground = 90;  // grey level of the untextured background

// The floating patch (left-image pixels [u0, u0 + size) x [v0, v0 + size)) and its disparity.
constexpr int kPatchU0 = 150;
constexpr int kPatchV0 = 10;
constexpr int kPatchSize = 5;
constexpr int kPatchDisparity = 10;

/// base_link -> left optical frame (x right, y down, z forward), pitched down.
inline Eigen::Isometry3d baseToCamera() {
  return scene_camera::baseToCamera(kCameraHeight);
}

/// The scene in the dataset's types (dataset/scene.h): the floor a slab whose top is z = 0 over
/// kFloorMin..kFloorMax, the box exactly at kBoxMin..kBoxMax (scene_solids.h: faces on the
/// constants to the bit).
inline const stereo_safety_map::dataset::Scene& scene() {
  namespace ds = stereo_safety_map::dataset;
  static const ds::Scene s = scene_solids::floorWithBox(
      Eigen::Vector2d(kFloorMin[0], kFloorMin[1]), Eigen::Vector2d(kFloorMax[0], kFloorMax[1]),
      Eigen::Vector3d(kBoxMin[0], kBoxMin[1], kBoxMin[2]),
      Eigen::Vector3d(kBoxMax[0], kBoxMax[1], kBoxMax[2]));
  return s;
}

/// Ray parameter (= optical depth, as the direction has z = 1 in the camera) of the first hit of
/// the ray o + t d, t > 0, with the floor or the box (Scene::intersect, the renderer's);
/// infinity when nothing is hit.
inline double castRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  return scene_camera::castRay(scene(), o, d);
}

inline double hash01(std::int64_t x, std::int64_t y, std::int64_t z, std::uint32_t seed) {
  std::uint64_t h = static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^
                    static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^
                    static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ull ^ seed;
  h ^= h >> 33;
  h *= 0xFF51AFD7ED558CCDull;
  h ^= h >> 33;
  h *= 0xC4CEB9FE1A85EC53ull;
  h ^= h >> 33;
  return static_cast<double>(h >> 11) / static_cast<double>(1ull << 53);
}

/// Trilinear value noise in [0, 1] with lattice spacing `cell` [m].
inline double valueNoise(const Eigen::Vector3d& p, double cell, std::uint32_t seed) {
  const Eigen::Vector3d q = p / cell;
  const double fx = std::floor(q.x()), fy = std::floor(q.y()), fz = std::floor(q.z());
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy),
             iz = static_cast<std::int64_t>(fz);
  const double ax = q.x() - fx, ay = q.y() - fy, az = q.z() - fz;
  double v = 0.0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double w = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay) * (dz ? az : 1 - az);
    v += w * hash01(ix + dx, iy + dy, iz + dz, seed);
  }
  return v;
}

/// Grey level of the surface texture at a world point.
inline double texture(const Eigen::Vector3d& p) {
  return 128.0 + 95.0 * (0.65 * (2.0 * valueNoise(p, 0.03, 11u) - 1.0) +
                         0.35 * (2.0 * valueNoise(p, 0.1, 23u) - 1.0));
}

/// Optical centre of the left (right = false) or right camera in odom.
inline Eigen::Vector3d cameraCentre(bool right) {
  const Eigen::Isometry3d T = baseToCamera();
  const Eigen::Vector3d offset(right ? kBaseline : 0.0, 0.0, 0.0);
  return T.translation() + T.linear() * offset;
}

inline Eigen::Vector3d rayDirection(double u, double v) {
  return scene_camera::rayDirection(baseToCamera().linear(), u, v);
}

/// Renders one image (row-major mono8).
inline std::vector<std::uint8_t> renderImage(bool right) {
  const Eigen::Vector3d o = cameraCentre(right);
  std::vector<std::uint8_t> img(kWidth * kHeight);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      double sum = 0.0;
      for (int sy = -1; sy <= 1; ++sy) {
        for (int sx = -1; sx <= 1; ++sx) {
          const Eigen::Vector3d d = rayDirection(u + sx / 3.0, v + sy / 3.0);
          const double t = castRay(o, d);
          sum += std::isfinite(t) ? texture(o + t * d) : kBackground;
        }
      }
      const double noise = 4.0 * hash01(u, v, right ? 1 : 0, 77u) - 2.0;  // sensor noise +-2
      img[v * kWidth + u] =
          static_cast<std::uint8_t>(std::clamp(std::lround(sum / 9.0 + noise), 0L, 255L));
    }
  }
  // The floating patch, shifted by its disparity in the right image.
  for (int v = kPatchV0; v < kPatchV0 + kPatchSize; ++v) {
    for (int u = kPatchU0; u < kPatchU0 + kPatchSize; ++u) {
      const std::uint8_t value = hash01(u, v, 5, 99u) < 0.5 ? 30 : 230;
      img[v * kWidth + (right ? u - kPatchDisparity : u)] = value;
    }
  }
  return img;
}

/// Analytic disparity of every left-image pixel (f B / Z), NaN where the background is seen.
/// The patch is not included (it is not part of the 3D scene).
inline std::vector<float> analyticDisparity() {
  const Eigen::Vector3d o = cameraCentre(false);
  std::vector<float> d(kWidth * kHeight, std::numeric_limits<float>::quiet_NaN());
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const double t = castRay(o, rayDirection(u, v));
      if (std::isfinite(t)) d[v * kWidth + u] = static_cast<float>(kF * kBaseline / t);
    }
  }
  return d;
}

inline bool inPatch(int u, int v, int margin) {
  return u >= kPatchU0 - margin && u < kPatchU0 + kPatchSize + margin && v >= kPatchV0 - margin &&
         v < kPatchV0 + kPatchSize + margin;
}

inline sensor_msgs::Image imageMsg(const std::vector<std::uint8_t>& pixels,
                                   const std_msgs::Header& header) {
  sensor_msgs::Image img;
  img.header = header;
  img.width = kWidth;
  img.height = kHeight;
  img.encoding = sensor_msgs::image_encodings::MONO8;
  img.step = kWidth;
  img.data = pixels;
  return img;
}

/// Static tf odom -> base_link (robot at the origin) -> left optical frame.
inline std::vector<geometry_msgs::TransformStamped> sceneTransforms() {
  return {toMsg(Eigen::Isometry3d::Identity(), "odom", "base_link"),
          toMsg(baseToCamera(), "base_link", kCameraFrame)};
}

}  // namespace stereo_scene
