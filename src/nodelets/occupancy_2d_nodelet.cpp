// stereo_safety_map/Occupancy2DNodelet: a thin wrapper around Occupancy2DRos (see its header for
// the topics, parameters and threading model).
#include "stereo_safety_map/ros/occupancy_2d_ros.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace stereo_safety_map {

class Occupancy2DNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    impl_ = std::make_unique<Occupancy2DRos>(getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<Occupancy2DRos> impl_;
};

}  // namespace stereo_safety_map

PLUGINLIB_EXPORT_CLASS(stereo_safety_map::Occupancy2DNodelet, nodelet::Nodelet)
