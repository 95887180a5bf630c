// stereo_safety_map/DisparityNodelet: a thin wrapper around DisparityRos (see its header for the
// topics, parameters and threading model). A drop-in for stereo_image_proc/disparity.
#include "stereo_safety_map/ros/disparity_ros.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace stereo_safety_map {

class DisparityNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    impl_ = std::make_unique<DisparityRos>(getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<DisparityRos> impl_;
};

}  // namespace stereo_safety_map

PLUGINLIB_EXPORT_CLASS(stereo_safety_map::DisparityNodelet, nodelet::Nodelet)
