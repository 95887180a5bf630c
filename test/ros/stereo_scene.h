// A synthetic rectified stereo pair for the disparity rostests, known by construction: a textured
// level floor (z = 0 in odom, x in [-1, 6] m, |y| <= 4 m) with a textured box on it (x 2.0..2.6,
// y -0.3..0.3, z 0..0.5 m), seen by a camera 1.1 m above the robot's base, pitched down 30 deg,
// looking along +x; 320x240, f = 250 px, baseline 0.12 m. Both images and the left camera's
// depth are made by the datasets' renderer (dataset::StereoRenderer: the same ray casting,
// texturing, blur and image noise as every rendered dataset); the floor and the box are lit
// evenly (ambient only), so their grey levels are the texture alone. Above the floor's far edge
// the background is uniform grey: no texture, no true disparity.
//
// The analytic disparity of the left image is f B / Z of the renderer's depth of each pixel.
// A 5x5 px textured patch is pasted into that background with its own disparity (10 px): a
// small surface that no larger surface supports, i.e. what 002 Sec. 4.2 calls a spike. It is
// drawn into the images after rendering, not part of the 3D scene.
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
#include <sensor_msgs/image_encodings.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace stereo_scene {

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

/// The stereo head (scene_camera.h), with image noise of about the +-2 grey levels of a uniform
/// sensor noise and a little optical blur.
inline const stereo_safety_map::dataset::StereoHeadConfig& head() {
  static const stereo_safety_map::dataset::StereoHeadConfig h = [] {
    stereo_safety_map::dataset::StereoHeadConfig c = scene_camera::head(kCameraHeight, 200.0);
    c.noise_sigma = 1.2;
    c.blur_sigma = 0.5;
    return c;
  }();
  return h;
}

/// The renderer's camera model (cx = (width - 1) / 2, f = kF to rounding).
inline stereo_safety_map::StereoCameraModel cameraModel() {
  return scene_camera::cameraModel(head());
}

inline sensor_msgs::CameraInfo cameraInfo(bool right, const std_msgs::Header& header) {
  return scene_camera::cameraInfo(head(), right, header);
}

/// base_link -> left optical frame (x right, y down, z forward), pitched down.
inline Eigen::Isometry3d baseToCamera() {
  return head().baseToLeftOptical();
}

/// The scene in the dataset's types (dataset/scene.h): the floor a slab whose top is z = 0 over
/// kFloorMin..kFloorMax, the box exactly at kBoxMin..kBoxMax (scene_solids.h: faces on the
/// constants to the bit), both of a dense noise texture (features 3-10 cm at the floor's range
/// give the matcher texture in every 9x9 window) under an even light, the background grey.
inline const stereo_safety_map::dataset::Scene& scene() {
  namespace ds = stereo_safety_map::dataset;
  static const ds::Scene s = [] {
    ds::Scene sc = scene_solids::floorWithBox(Eigen::Vector2d(kFloorMin[0], kFloorMin[1]),
                                              Eigen::Vector2d(kFloorMax[0], kFloorMax[1]),
                                              Eigen::Vector3d(kBoxMin[0], kBoxMin[1], kBoxMin[2]),
                                              Eigen::Vector3d(kBoxMax[0], kBoxMax[1], kBoxMax[2]));
    ds::Material m;
    m.texture = ds::TextureKind::kNoise;
    m.scale = 0.1;
    m.contrast = 0.75;
    m.colour = Eigen::Vector3f::Constant(0.5f);
    m.seed = 11u;
    const int floor_material = sc.addMaterial("stereo_scene_floor", m);
    m.seed = 23u;
    const int box_material = sc.addMaterial("stereo_scene_box", m);
    for (ds::Primitive& p : sc.primitives) {
      p.material = p.ground ? floor_material : box_material;
      p.side_material = -1;
    }
    sc.lighting.ambient = 1.0;
    sc.lighting.diffuse = 0.0;
    sc.sky_horizon = sc.sky_zenith = Eigen::Vector3f::Constant(kBackground / 255.0f);
    return sc;
  }();
  return s;
}

/// One rendering of the scene: the two images (mono8, the patch pasted in) and the left depth.
struct Rendering {
  cv::Mat left, right;  ///< CV_8UC1
  cv::Mat depth;        ///< CV_32F, +inf where the background is seen
};

inline const Rendering& rendering() {
  static const Rendering r = [] {
    Rendering out;
    stereo_safety_map::dataset::StereoRenderer renderer(scene(), head(), 77u);
    renderer.render(baseToCamera(), 0, &out.left, &out.right, &out.depth);
    // The floating patch, shifted by its disparity in the right image.
    for (int v = kPatchV0; v < kPatchV0 + kPatchSize; ++v) {
      for (int u = kPatchU0; u < kPatchU0 + kPatchSize; ++u) {
        const std::uint32_t h = (static_cast<std::uint32_t>(u) * 2654435761u) ^
                                (static_cast<std::uint32_t>(v) * 2246822519u);
        const std::uint8_t value = ((h >> 13) & 1u) ? 230 : 30;
        out.left.at<std::uint8_t>(v, u) = value;
        out.right.at<std::uint8_t>(v, u - kPatchDisparity) = value;
      }
    }
    return out;
  }();
  return r;
}

/// Analytic disparity of every left-image pixel (f B / Z of the renderer's depth), NaN where
/// the background is seen. The patch is not included (it is not part of the 3D scene).
inline std::vector<float> analyticDisparity() {
  const cv::Mat& depth = rendering().depth;
  const double f = cameraModel().fx;
  std::vector<float> d(kWidth * kHeight, std::numeric_limits<float>::quiet_NaN());
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const float z = depth.at<float>(v, u);
      if (std::isfinite(z) && z > 0.0f) d[v * kWidth + u] = static_cast<float>(f * kBaseline / z);
    }
  }
  return d;
}

inline bool inPatch(int u, int v, int margin) {
  return u >= kPatchU0 - margin && u < kPatchU0 + kPatchSize + margin && v >= kPatchV0 - margin &&
         v < kPatchV0 + kPatchSize + margin;
}

/// The left (right = false) or right image as a mono8 message.
inline sensor_msgs::Image imageMsg(bool right, const std_msgs::Header& header) {
  const cv::Mat& m = right ? rendering().right : rendering().left;
  sensor_msgs::Image img;
  img.header = header;
  img.width = kWidth;
  img.height = kHeight;
  img.encoding = sensor_msgs::image_encodings::MONO8;
  img.step = kWidth;
  img.data.assign(m.data, m.data + static_cast<std::size_t>(kWidth) * kHeight);
  return img;
}

/// Static tf odom -> base_link (robot at the origin) -> left optical frame.
inline std::vector<geometry_msgs::TransformStamped> sceneTransforms() {
  return {toMsg(Eigen::Isometry3d::Identity(), "odom", "base_link"),
          toMsg(baseToCamera(), "base_link", kCameraFrame)};
}

}  // namespace stereo_scene
