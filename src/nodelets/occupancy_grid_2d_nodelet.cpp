// stereo_safety_map/OccupancyGrid2DNodelet: a thin wrapper around OccupancyGrid2DRos (see its
// header for the topics, parameters and threading model). stereo_safety_map/Occupancy2DNodelet,
// its name before issue 17, still loads the same nodelet with a deprecation warning.
#include "stereo_safety_map/ros/occupancy_grid_2d_ros.h"

#include <nodelet/nodelet.h>
#include <ros/console.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

namespace stereo_safety_map {

class OccupancyGrid2DNodelet : public nodelet::Nodelet {
 protected:
  void onInit() override {
    impl_ = std::make_unique<OccupancyGrid2DRos>(getNodeHandle(), getPrivateNodeHandle());
  }

 private:
  std::unique_ptr<OccupancyGrid2DRos> impl_;
};

/// Deprecated: the plugin name users' launch files loaded before the rename.
class Occupancy2DNodelet : public OccupancyGrid2DNodelet {
 private:
  void onInit() override {
    ROS_WARN_NAMED("occupancy_grid_2d",
                   "%s: stereo_safety_map/Occupancy2DNodelet is deprecated, load "
                   "stereo_safety_map/OccupancyGrid2DNodelet instead (the same nodelet)",
                   getName().c_str());
    OccupancyGrid2DNodelet::onInit();
  }
};

}  // namespace stereo_safety_map

PLUGINLIB_EXPORT_CLASS(stereo_safety_map::OccupancyGrid2DNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(stereo_safety_map::Occupancy2DNodelet, nodelet::Nodelet)
