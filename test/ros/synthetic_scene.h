// A small synthetic stereo scene for the rostests, known by construction: a level floor (z = 0 in
// odom) with a box on it, seen by a camera 1 m above the robot's base, pitched down 30 deg and
// looking along +x. Makes the DisparityImage + CameraInfo pair and the equivalent PointCloud2 of
// the exact depth of each pixel, and publishes the static tf odom -> base_link -> camera. The
// scene is built of the dataset's solids (dataset/scene.h) and its depth is cast by the datasets'
// renderer (dataset::StereoRenderer::renderDepth: the rays every rendered dataset casts).
#pragma once

#include "scene_camera.h"
#include "scene_solids.h"

#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene.h"
#include "stereo_safety_map/ros/conversions.h"

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <stereo_msgs/DisparityImage.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <vector>

namespace synthetic_scene {

// The camera (scene_camera.h), at its own height.
using scene_camera::kBaseline;
using scene_camera::kCameraFrame;
using scene_camera::kCx;
using scene_camera::kCy;
using scene_camera::kF;
using scene_camera::kHeight;
using scene_camera::kWidth;
using scene_camera::toMsg;
constexpr double kCameraHeight = 1.0;
constexpr double kMaxDepth = 7.5;

/// The stereo head (scene_camera.h); nothing is seen beyond kMaxDepth.
inline const stereo_safety_map::dataset::StereoHeadConfig& head() {
  static const stereo_safety_map::dataset::StereoHeadConfig h =
      scene_camera::head(kCameraHeight, kMaxDepth);
  return h;
}

inline stereo_safety_map::StereoCameraModel cameraModel() {
  return scene_camera::cameraModel(head());
}

inline sensor_msgs::CameraInfo cameraInfo(bool right, const std_msgs::Header& header) {
  return scene_camera::cameraInfo(head(), right, header);
}

// The box: x in [2.0, 2.6], y in [-0.3, 0.3], z in [0, 0.5] (odom).
constexpr double kBoxMin[3] = {2.0, -0.3, 0.0};
constexpr double kBoxMax[3] = {2.6, 0.3, 0.5};

/// base_link -> optical frame (x right, y down, z forward), pitched down.
inline Eigen::Isometry3d baseToCamera() {
  return head().baseToLeftOptical();
}

/// The scene in the dataset's types: the floor a slab whose top is z = 0 (1 km wide: every ray
/// down within kMaxDepth ends on it), the box exactly at kBoxMin..kBoxMax (scene_solids.h: faces
/// on the constants to the bit).
inline const stereo_safety_map::dataset::Scene& scene() {
  namespace ds = stereo_safety_map::dataset;
  static const ds::Scene s =
      scene_solids::floorWithBox(Eigen::Vector2d(-500.0, -500.0), Eigen::Vector2d(500.0, 500.0),
                                 Eigen::Vector3d(kBoxMin[0], kBoxMin[1], kBoxMin[2]),
                                 Eigen::Vector3d(kBoxMax[0], kBoxMax[1], kBoxMax[2]));
  return s;
}

/// Depth (optical z, CV_32F) of every pixel for a camera at T_odom_camera; NaN where nothing is
/// hit within kMaxDepth. One renderer for all callers (the publishing threads share it).
inline cv::Mat depthImage(const Eigen::Isometry3d& T_odom_camera) {
  static std::mutex mutex;
  static stereo_safety_map::dataset::StereoRenderer renderer(scene(), head(), 1u);
  cv::Mat depth;
  {
    std::lock_guard<std::mutex> lock(mutex);
    renderer.renderDepth(T_odom_camera, &depth);
  }
  depth.setTo(std::numeric_limits<float>::quiet_NaN(),
              depth == std::numeric_limits<float>::infinity());
  return depth;
}

/// Invalid pixels are -1 (below min_disparity = 0.5), as stereo_image_proc marks them.
inline stereo_msgs::DisparityImage disparityImage(const Eigen::Isometry3d& T_odom_camera,
                                                  const std_msgs::Header& header) {
  stereo_msgs::DisparityImage msg;
  msg.header = header;
  msg.f = kF;
  msg.T = kBaseline;
  msg.min_disparity = 0.5f;
  msg.max_disparity = 128.0f;
  msg.delta_d = 1.0f / 16;
  sensor_msgs::Image& img = msg.image;
  img.header = header;
  img.width = kWidth;
  img.height = kHeight;
  img.encoding = sensor_msgs::image_encodings::TYPE_32FC1;
  img.step = kWidth * sizeof(float);
  img.data.resize(img.step * kHeight);
  const cv::Mat depth = depthImage(T_odom_camera);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const double z = depth.at<float>(v, u);
      const float d = std::isfinite(z) ? static_cast<float>(kF * kBaseline / z) : -1.0f;
      std::memcpy(&img.data[(v * kWidth + u) * sizeof(float)], &d, sizeof(float));
    }
  }
  msg.valid_window.width = kWidth;
  msg.valid_window.height = kHeight;
  return msg;
}

/// The same scene as an organised cloud in the camera frame, NaN where nothing is hit.
inline sensor_msgs::PointCloud2 pointCloud(const Eigen::Isometry3d& T_odom_camera,
                                           const std_msgs::Header& header) {
  sensor_msgs::PointCloud2 cloud;
  cloud.header = header;
  sensor_msgs::PointCloud2Modifier mod(cloud);
  mod.setPointCloud2FieldsByString(1, "xyz");
  mod.resize(kWidth * kHeight);
  cloud.width = kWidth;
  cloud.height = kHeight;
  cloud.row_step = cloud.width * cloud.point_step;
  cloud.is_dense = false;
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  const cv::Mat depths = depthImage(T_odom_camera);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u, ++x, ++y, ++z) {
      const double depth = depths.at<float>(v, u);
      *x = static_cast<float>((u - kCx) / kF * depth);
      *y = static_cast<float>((v - kCy) / kF * depth);
      *z = static_cast<float>(depth);
    }
  }
  return cloud;
}

/// A grey left image (the floor's checker pattern) for rviz's Image display.
inline sensor_msgs::Image leftImage(const Eigen::Isometry3d& T_odom_camera,
                                    const std_msgs::Header& header) {
  sensor_msgs::Image img;
  img.header = header;
  img.width = kWidth;
  img.height = kHeight;
  img.encoding = sensor_msgs::image_encodings::MONO8;
  img.step = kWidth;
  img.data.resize(kWidth * kHeight);
  const cv::Mat depth = depthImage(T_odom_camera);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const double z = depth.at<float>(v, u);
      img.data[v * kWidth + u] =
          std::isfinite(z) ? static_cast<std::uint8_t>(255 - std::min(200.0, z * 25.0)) : 30;
    }
  }
  return img;
}

}  // namespace synthetic_scene
