// The camera of the rostests' small known scenes (stereo_scene.h: images; synthetic_scene.h: the
// exact DisparityImage / PointCloud2): the datasets' stereo head (dataset/renderer.h) at 320x240,
// f = 250 px, baseline 0.12 m, on the robot's axis, pitched down 30 deg and looking along +x from
// `height` above the robot's base; its tf. Everything it sees is made by dataset::StereoRenderer.
#pragma once

#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/ros/conversions.h"

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <tf2_eigen/tf2_eigen.h>

#include <Eigen/Geometry>

#include <cmath>
#include <string>

namespace scene_camera {

constexpr int kWidth = 320;
constexpr int kHeight = 240;
constexpr double kF = 250.0;
constexpr double kCx = 0.5 * (kWidth - 1);  // the renderer's principal point
constexpr double kCy = 0.5 * (kHeight - 1);
constexpr double kBaseline = 0.12;
constexpr double kPitchDeg = 30.0;
constexpr char kCameraFrame[] = "stereo_left_optical";

/// The head: the field of view that gives f = kF at kWidth, the left optical centre on the
/// robot's axis `height` above its base; hits beyond `max_depth` are background.
inline stereo_safety_map::dataset::StereoHeadConfig head(double height, double max_depth) {
  stereo_safety_map::dataset::StereoHeadConfig c;
  c.width = kWidth;
  c.height = kHeight;
  c.hfov_deg = 2.0 * std::atan(0.5 * kWidth / kF) * 180.0 / M_PI;
  c.baseline = kBaseline;
  c.mount_x = 0.0;
  c.mount_y = 0.0;
  c.mount_z = height;
  c.pitch_deg = kPitchDeg;
  c.max_depth = max_depth;
  return c;
}

/// The head's camera model (the renderer's: cx = (width - 1) / 2) and its CameraInfo.
inline stereo_safety_map::StereoCameraModel cameraModel(
    const stereo_safety_map::dataset::StereoHeadConfig& h) {
  return stereo_safety_map::dataset::stereoCameraModel(h);
}

inline sensor_msgs::CameraInfo cameraInfo(const stereo_safety_map::dataset::StereoHeadConfig& h,
                                          bool right, const std_msgs::Header& header) {
  return stereo_safety_map::toCameraInfo(cameraModel(h), right, header);
}

inline geometry_msgs::TransformStamped toMsg(const Eigen::Isometry3d& T, const std::string& parent,
                                             const std::string& child) {
  geometry_msgs::TransformStamped t = tf2::eigenToTransform(T);
  t.header.frame_id = parent;
  t.child_frame_id = child;
  return t;
}

}  // namespace scene_camera
