// The camera of the rostests' small known scenes (stereo_scene.h: images; synthetic_scene.h: the
// exact DisparityImage / PointCloud2): 320x240, f = 250 px, baseline 0.12 m, pitched down 30 deg
// and looking along +x from `height` above the robot's base; its model, CameraInfo (conversions.h'
// toCameraInfo), tf and the ray through a pixel, hit with Scene::intersect (the renderer's).
#pragma once

#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/dataset/scene.h"
#include "stereo_safety_map/ros/conversions.h"

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <tf2_eigen/tf2_eigen.h>

#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <string>

namespace scene_camera {

constexpr int kWidth = 320;
constexpr int kHeight = 240;
constexpr double kF = 250.0;
constexpr double kCx = 160.0;
constexpr double kCy = 120.0;
constexpr double kBaseline = 0.12;
constexpr double kPitchDeg = 30.0;
constexpr char kCameraFrame[] = "stereo_left_optical";

/// base_link -> left optical frame (x right, y down, z forward), pitched down, `height` above.
inline Eigen::Isometry3d baseToCamera(double height) {
  Eigen::Matrix3d level;  // optical axes in base_link: x -> -y, y -> -z, z -> +x
  level << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Eigen::Matrix3d pitch =
      Eigen::AngleAxisd(kPitchDeg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = pitch * level;
  T.translation() = Eigen::Vector3d(0.0, 0.0, height);
  return T;
}

inline geometry_msgs::TransformStamped toMsg(const Eigen::Isometry3d& T, const std::string& parent,
                                             const std::string& child) {
  geometry_msgs::TransformStamped t = tf2::eigenToTransform(T);
  t.header.frame_id = parent;
  t.child_frame_id = child;
  return t;
}

inline stereo_safety_map::StereoCameraModel cameraModel() {
  stereo_safety_map::StereoCameraModel m;
  m.fx = m.fy = kF;
  m.cx = m.cx_right = kCx;
  m.cy = kCy;
  m.baseline = kBaseline;
  m.width = kWidth;
  m.height = kHeight;
  return m;
}

inline sensor_msgs::CameraInfo cameraInfo(bool right, const std_msgs::Header& header) {
  return stereo_safety_map::toCameraInfo(cameraModel(), right, header);
}

/// Direction of the ray through pixel (u, v) of a camera whose rotation (camera -> world) is
/// `R`; its camera z is 1, so that the ray parameter is the depth.
inline Eigen::Vector3d rayDirection(const Eigen::Matrix3d& R, double u, double v) {
  return R * Eigen::Vector3d((u - kCx) / kF, (v - kCy) / kF, 1.0);
}

/// Depth (ray parameter) of the first hit of the ray from `origin` along `dir` with `scene`
/// within max_depth (Scene::intersect, the renderer's); infinity when nothing is hit.
inline double castRay(const stereo_safety_map::dataset::Scene& scene, const Eigen::Vector3d& origin,
                      const Eigen::Vector3d& dir,
                      double max_depth = std::numeric_limits<double>::infinity()) {
  stereo_safety_map::dataset::Ray ray;
  ray.origin = origin;
  ray.dir = dir;
  stereo_safety_map::dataset::Hit hit;
  return scene.intersect(ray, 0.0, max_depth, &hit) ? hit.t
                                                    : std::numeric_limits<double>::infinity();
}

}  // namespace scene_camera
