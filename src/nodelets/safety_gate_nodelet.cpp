// stereo_safety_map/SafetyGateNodelet: a thin wrapper around SafetyGateRos (see its header for
// the topics, parameters and threading model).
#include "stereo_safety_map/ros/safety_gate_ros.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace stereo_safety_map {

class SafetyGateNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    impl_ = std::make_unique<SafetyGateRos>(getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<SafetyGateRos> impl_;
};

}  // namespace stereo_safety_map

PLUGINLIB_EXPORT_CLASS(stereo_safety_map::SafetyGateNodelet, nodelet::Nodelet)
