// stereo_safety_map/HybridSafetyMapNodelet: a thin wrapper around HybridSafetyMapRos (see its
// header for the topics, parameters and threading model).
#include "stereo_safety_map/ros/hybrid_safety_map_ros.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace stereo_safety_map {

class HybridSafetyMapNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    impl_ = std::make_unique<HybridSafetyMapRos>(getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<HybridSafetyMapRos> impl_;
};

}  // namespace stereo_safety_map

PLUGINLIB_EXPORT_CLASS(stereo_safety_map::HybridSafetyMapNodelet, nodelet::Nodelet)
