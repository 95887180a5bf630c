// stereo_safety_map/ObstacleDetectionNodelet: a thin wrapper around ObstacleDetectionRos (see its
// header for the topics, parameters and threading model): 3D obstacle detection and segmentation
// in the range image, paper 003.
#include "stereo_safety_map/ros/obstacle_detection_ros.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace stereo_safety_map {

class ObstacleDetectionNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    impl_ = std::make_unique<ObstacleDetectionRos>(getNodeHandle(), getPrivateNodeHandle());
  }
  std::unique_ptr<ObstacleDetectionRos> impl_;
};

}  // namespace stereo_safety_map

PLUGINLIB_EXPORT_CLASS(stereo_safety_map::ObstacleDetectionNodelet, nodelet::Nodelet)
