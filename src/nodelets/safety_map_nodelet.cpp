// stereo_safety_map/SafetyMapNodelet: a thin wrapper around SafetyMapRos (see its header for the
// topics, parameters and threading model).
#include "stereo_safety_map/ros/safety_map_ros.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace stereo_safety_map {

class SafetyMapNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    impl_ = std::make_unique<SafetyMapRos>(getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<SafetyMapRos> impl_;
};

}  // namespace stereo_safety_map

PLUGINLIB_EXPORT_CLASS(stereo_safety_map::SafetyMapNodelet, nodelet::Nodelet)
