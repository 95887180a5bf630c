// Helpers shared by the rostest gtest nodes: latest-message holders, waiting, map look-ups,
// a /diagnostics watcher, the synthetic scene's publishers.
#pragma once

#include "synthetic_scene.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <chrono>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace test_util {

/// Keeps the last message of a topic and counts them (callbacks on an AsyncSpinner).
template <typename M>
class Latest {
 public:
  Latest(ros::NodeHandle& nh, const std::string& topic) {
    sub_ = nh.subscribe<M>(topic, 10, [this](const boost::shared_ptr<const M>& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      last_ = m;
      ++count_;
    });
  }
  boost::shared_ptr<const M> get() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_;
  }
  int count() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return count_;
  }
  void reset() {
    std::lock_guard<std::mutex> lock(mutex_);
    last_.reset();
    count_ = 0;
  }

 private:
  ros::Subscriber sub_;
  mutable std::mutex mutex_;
  boost::shared_ptr<const M> last_;
  int count_ = 0;
};

/// Waits (wall time) until pred() holds; false on timeout.
inline bool waitFor(const std::function<bool()>& pred, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end && ros::ok()) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return pred();
}

inline void sleepFor(double s) {
  std::this_thread::sleep_for(std::chrono::duration<double>(s));
}

/// OccupancyGrid value at fixed-frame (x, y); -128 outside the grid.
inline int costAt(const nav_msgs::OccupancyGrid& g, double x, double y) {
  const int c = static_cast<int>(std::floor((x - g.info.origin.position.x) / g.info.resolution));
  const int r = static_cast<int>(std::floor((y - g.info.origin.position.y) / g.info.resolution));
  if (c < 0 || r < 0 || c >= static_cast<int>(g.info.width) ||
      r >= static_cast<int>(g.info.height)) {
    return -128;
  }
  return g.data[r * g.info.width + c];
}

/// Cell index for (x, y) in a grid described by `info`, -1 outside.
inline int cellAt(const nav_msgs::MapMetaData& info, double x, double y) {
  const int c = static_cast<int>(std::floor((x - info.origin.position.x) / info.resolution));
  const int r = static_cast<int>(std::floor((y - info.origin.position.y) / info.resolution));
  if (c < 0 || r < 0 || c >= static_cast<int>(info.width) || r >= static_cast<int>(info.height)) {
    return -1;
  }
  return r * info.width + c;
}

/// Collects the statuses published on /diagnostics. Statuses are named
/// "<node name without the leading slash>: <task>" by diagnostic_updater; `node` below is the
/// node (nodelet) name, with or without the leading slash.
class DiagnosticsWatcher {
 public:
  explicit DiagnosticsWatcher(ros::NodeHandle& nh) {
    sub_ = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 50, [this](const diagnostic_msgs::DiagnosticArrayConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          for (const auto& s : m->status)
            statuses_.push_back(s);
          if (statuses_.size() > 2000) statuses_.erase(statuses_.begin(), statuses_.begin() + 1000);
        });
  }
  static std::string statusPrefix(const std::string& node) {
    return (!node.empty() && node[0] == '/' ? node.substr(1) : node) + ":";
  }
  /// True when a status of `node` had `level` and a message containing
  /// `text` since the last clear().
  bool seen(const std::string& node, int level, const std::string& text) const {
    const std::string prefix = statusPrefix(node);
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& s : statuses_) {
      if (s.name.compare(0, prefix.size(), prefix) == 0 && s.level == level &&
          s.message.find(text) != std::string::npos) {
        return true;
      }
    }
    return false;
  }
  /// The last value of `key` in a status of `node`, "" if none.
  std::string lastValue(const std::string& node, const std::string& key) const {
    const std::string prefix = statusPrefix(node);
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = statuses_.rbegin(); it != statuses_.rend(); ++it) {
      if (it->name.compare(0, prefix.size(), prefix) != 0) continue;
      for (const auto& kv : it->values) {
        if (kv.key == key) return kv.value;
      }
    }
    return "";
  }
  void clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    statuses_.clear();
  }

 private:
  ros::Subscriber sub_;
  mutable std::mutex mutex_;
  std::vector<diagnostic_msgs::DiagnosticStatus> statuses_;
};

/// Static tf odom -> base_link (robot at the origin) -> camera optical frame.
inline void publishSceneTf(tf2_ros::StaticTransformBroadcaster& tf) {
  std::vector<geometry_msgs::TransformStamped> ts;
  ts.push_back(synthetic_scene::toMsg(Eigen::Isometry3d::Identity(), "odom", "base_link"));
  ts.push_back(synthetic_scene::toMsg(synthetic_scene::baseToCamera(), "base_link",
                                      synthetic_scene::kCameraFrame));
  for (auto& t : ts)
    t.header.stamp = ros::Time::now();
  tf.sendTransform(ts);
}

/// Publishes the scene as disparity + CameraInfo pair and/or cloud under `ns` (e.g. "/disp").
class ScenePublisher {
 public:
  ScenePublisher(ros::NodeHandle& nh, const std::string& ns) {
    disparity_ = nh.advertise<stereo_msgs::DisparityImage>(ns + "/stereo/disparity", 10);
    left_info_ = nh.advertise<sensor_msgs::CameraInfo>(ns + "/stereo/left/camera_info", 10);
    right_info_ = nh.advertise<sensor_msgs::CameraInfo>(ns + "/stereo/right/camera_info", 10);
    cloud_ = nh.advertise<sensor_msgs::PointCloud2>(ns + "/points", 10);
    left_image_ = nh.advertise<sensor_msgs::Image>(ns + "/stereo/left/image_rect", 10);
    const Eigen::Isometry3d T = synthetic_scene::baseToCamera();
    std_msgs::Header h;
    h.frame_id = synthetic_scene::kCameraFrame;
    disparity_msg_ = synthetic_scene::disparityImage(T, h);
    cloud_msg_ = synthetic_scene::pointCloud(T, h);
    image_msg_ = synthetic_scene::leftImage(T, h);
  }

  /// Waits until the nodelet has subscribed.
  bool waitForSubscribers(double timeout_s) {
    return waitFor(
        [this] {
          return disparity_.getNumSubscribers() > 0 && left_info_.getNumSubscribers() > 0 &&
                 right_info_.getNumSubscribers() > 0;
        },
        timeout_s);
  }
  bool waitForCloudSubscriber(double timeout_s) {
    return waitFor([this] { return cloud_.getNumSubscribers() > 0; }, timeout_s);
  }

  /// One good disparity frame (with its CameraInfo pair) at `stamp`.
  void publishDisparity(const ros::Time& stamp) {
    std_msgs::Header h;
    h.stamp = stamp;
    h.frame_id = synthetic_scene::kCameraFrame;
    publishDisparity(disparity_msg_, synthetic_scene::cameraInfo(false, h),
                     synthetic_scene::cameraInfo(true, h), stamp);
    image_msg_.header = h;
    left_image_.publish(image_msg_);
  }
  /// Any disparity frame; stamps of all three are set to `stamp`.
  void publishDisparity(stereo_msgs::DisparityImage d, sensor_msgs::CameraInfo l,
                        sensor_msgs::CameraInfo r, const ros::Time& stamp) {
    d.header.stamp = d.image.header.stamp = l.header.stamp = r.header.stamp = stamp;
    publishDisparityParts(d, l, r);
  }
  /// A disparity frame's three messages as they are, each with its own stamp.
  void publishDisparityParts(const stereo_msgs::DisparityImage& d, const sensor_msgs::CameraInfo& l,
                             const sensor_msgs::CameraInfo& r) {
    left_info_.publish(l);
    right_info_.publish(r);
    disparity_.publish(d);
  }
  void publishCloud(const ros::Time& stamp) {
    sensor_msgs::PointCloud2 c = cloud_msg_;
    c.header.stamp = stamp;
    cloud_.publish(c);
  }
  void publishCloud(sensor_msgs::PointCloud2 c, const ros::Time& stamp) {
    c.header.stamp = stamp;
    cloud_.publish(c);
  }

  const stereo_msgs::DisparityImage& goodDisparity() const { return disparity_msg_; }
  const sensor_msgs::PointCloud2& goodCloud() const { return cloud_msg_; }

 private:
  ros::Publisher disparity_, left_info_, right_info_, cloud_, left_image_;
  stereo_msgs::DisparityImage disparity_msg_;
  sensor_msgs::PointCloud2 cloud_msg_;
  sensor_msgs::Image image_msg_;
};

}  // namespace test_util
