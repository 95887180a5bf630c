// Helpers shared by the stereo rostests: a publisher of the stereo pair of stereo_scene.h (or
// of any frame) on <ns>/{left,right}/{image_rect,camera_info}, the messages of a pair rendered by
// dataset/renderer.h, and reading a DisparityImage.
#pragma once

#include "stereo_scene.h"
#include "test_util.h"

#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/ros/conversions.h"

#include <cv_bridge/cv_bridge.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <ros/ros.h>
#include <stereo_msgs/DisparityImage.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace disparity_test {

/// One stereo frame: the four messages, stamped together by StereoPublisher::publish().
struct StereoFrame {
  sensor_msgs::Image left, right;
  sensor_msgs::CameraInfo left_info, right_info;
};

/// The messages of a rectified mono8 pair (e.g. dataset::StereoRenderer's) stamped and framed by
/// `header`, with the CameraInfo of `camera` (toCameraInfo, the one builder; for the renderer's
/// head: dataset::stereoCameraModel(head)).
inline StereoFrame stereoFrame(const cv::Mat& left, const cv::Mat& right,
                               const stereo_safety_map::StereoCameraModel& camera,
                               const std_msgs::Header& header) {
  StereoFrame f;
  f.left = *cv_bridge::CvImage(header, sensor_msgs::image_encodings::MONO8, left).toImageMsg();
  f.right = *cv_bridge::CvImage(header, sensor_msgs::image_encodings::MONO8, right).toImageMsg();
  f.left_info = stereo_safety_map::toCameraInfo(camera, false, header);
  f.right_info = stereo_safety_map::toCameraInfo(camera, true, header);
  return f;
}

/// The rendered scene (rendering takes a moment: do it once).
inline const StereoFrame& sceneFrame() {
  static const StereoFrame frame = [] {
    std_msgs::Header h;
    h.frame_id = stereo_scene::kCameraFrame;
    StereoFrame f;
    f.left = stereo_scene::imageMsg(false, h);
    f.right = stereo_scene::imageMsg(true, h);
    f.left_info = stereo_scene::cameraInfo(false, h);
    f.right_info = stereo_scene::cameraInfo(true, h);
    return f;
  }();
  return frame;
}

class StereoPublisher {
 public:
  StereoPublisher(ros::NodeHandle& nh, const std::string& ns) {
    left_ = nh.advertise<sensor_msgs::Image>(ns + "/left/image_rect", 10);
    right_ = nh.advertise<sensor_msgs::Image>(ns + "/right/image_rect", 10);
    left_info_ = nh.advertise<sensor_msgs::CameraInfo>(ns + "/left/camera_info", 10);
    right_info_ = nh.advertise<sensor_msgs::CameraInfo>(ns + "/right/camera_info", 10);
  }
  /// Waits until `n` subscribers listen to every input topic.
  bool waitForSubscribers(unsigned n, double timeout_s) {
    return test_util::waitFor(
        [&] {
          return left_.getNumSubscribers() >= n && right_.getNumSubscribers() >= n &&
                 left_info_.getNumSubscribers() >= n && right_info_.getNumSubscribers() >= n;
        },
        timeout_s);
  }
  unsigned subscribers() const { return left_.getNumSubscribers(); }
  void publish(StereoFrame f, const ros::Time& stamp) {
    f.left.header.stamp = f.right.header.stamp = f.left_info.header.stamp =
        f.right_info.header.stamp = stamp;
    left_info_.publish(f.left_info);
    right_info_.publish(f.right_info);
    left_.publish(f.left);
    right_.publish(f.right);
  }
  void publishScene(const ros::Time& stamp) { publish(sceneFrame(), stamp); }

 private:
  ros::Publisher left_, right_, left_info_, right_info_;
};

/// The disparities of a DisparityImage, NaN where invalid by the message's convention (below
/// min_disparity, above max_disparity, not finite or <= 0).
inline std::vector<float> disparities(const stereo_msgs::DisparityImage& msg) {
  const sensor_msgs::Image& img = msg.image;
  std::vector<float> d(static_cast<std::size_t>(img.width) * img.height,
                       std::numeric_limits<float>::quiet_NaN());
  if (img.encoding != "32FC1" || img.data.size() < img.step * img.height) return d;
  for (unsigned v = 0; v < img.height; ++v) {
    for (unsigned u = 0; u < img.width; ++u) {
      float x;
      std::memcpy(&x, &img.data[v * img.step + u * sizeof(float)], sizeof(float));
      if (std::isfinite(x) && x > 0.0f && x >= msg.min_disparity && x <= msg.max_disparity) {
        d[v * img.width + u] = x;
      }
    }
  }
  return d;
}

/// Calls <node>/set_parameters with the given values; returns the configuration in force.
inline bool reconfigure(const std::string& node, const dynamic_reconfigure::Config& values,
                        dynamic_reconfigure::Config* result = nullptr) {
  dynamic_reconfigure::Reconfigure srv;
  srv.request.config = values;
  if (!ros::service::waitForService(node + "/set_parameters", 10000)) return false;
  if (!ros::service::call(node + "/set_parameters", srv)) return false;
  if (result != nullptr) *result = srv.response.config;
  return true;
}

inline dynamic_reconfigure::Config boolConfig(const std::string& name, bool value) {
  dynamic_reconfigure::Config c;
  dynamic_reconfigure::BoolParameter p;
  p.name = name;
  p.value = value;
  c.bools.push_back(p);
  return c;
}

inline dynamic_reconfigure::Config intConfig(const std::string& name, int value) {
  dynamic_reconfigure::Config c;
  dynamic_reconfigure::IntParameter p;
  p.name = name;
  p.value = value;
  c.ints.push_back(p);
  return c;
}

inline dynamic_reconfigure::Config strConfig(const std::string& name, const std::string& value) {
  dynamic_reconfigure::Config c;
  dynamic_reconfigure::StrParameter p;
  p.name = name;
  p.value = value;
  c.strs.push_back(p);
  return c;
}

/// The value of an int / bool parameter in a returned configuration (-1 if absent).
inline int intValue(const dynamic_reconfigure::Config& c, const std::string& name) {
  for (const auto& p : c.ints) {
    if (p.name == name) return p.value;
  }
  for (const auto& p : c.bools) {
    if (p.name == name) return p.value ? 1 : 0;
  }
  return -1;
}

}  // namespace disparity_test
