// The 2D occupancy-grid ROS class (paper 002, Murray & Little 1998): stereo disparity and tf in,
// the core's OccupancyGrid2D (core/occupancy_grid_2d.h: column maxima in a height band, trapezoid
// sensor model, +/-K update, accuracy preservation) updated, nav_msgs/OccupancyGrid out in the
// fixed frame. Wrapped by src/nodelets/occupancy_grid_2d_nodelet.cpp
// (stereo_safety_map/OccupancyGrid2DNodelet). The disparity's own validation and spike removal (002
// Sec. 2.2, 4.2) happen upstream, in the disparity nodelet.
//
// Inputs are synchronised as in the safety-map nodelet (the shared ros/stereo_input.h, without
// its message checks): the DisparityImage passes a tf2_ros::MessageFilter (its frame must be
// transformable into fixed_frame at its stamp), then an exact (or approximate) sync with the
// left / right CameraInfo. Threading as there too: callbacks
// only fill a one-slot queue (newest frame wins, replaced frames are counted as drops); one worker
// thread converts, updates the grid and publishes; the grid is guarded by core_mutex_, which
// ~reset takes as well.
#pragma once

#include "stereo_safety_map/core/occupancy_grid_2d.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/ros/nodelet_shell.h"
#include "stereo_safety_map/ros/occupancy_grid_2d_params.h"
#include "stereo_safety_map/ros/stereo_input.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>
#include <std_srvs/Empty.h>

#include <opencv2/core.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace stereo_safety_map {

class OccupancyGrid2DRos : public FrameNodeletShell<StereoFrame> {
 public:
  /// Reads and validates the parameters in `pnh`. With an invalid configuration the object logs
  /// the error (naming the parameter and its range), publishes it as an ERROR diagnostic and
  /// subscribes to nothing: see ok() / configError().
  OccupancyGrid2DRos(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~OccupancyGrid2DRos();

 private:
  using Clock = std::chrono::steady_clock;
  using Frame = StereoFrame;

  void setUpInputs();
  void processFrame(const Frame& frame);
  bool resetSrv(std_srvs::Empty::Request& req, std_srvs::Empty::Response& res);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);

  OccupancyGrid2DRosConfig ros_config_;
  OccupancyGrid2DConfig grid_config_;

  std::unique_ptr<StereoInput> input_;  ///< (stereo_input.h)

  ros::Publisher grid_pub_;
  ros::ServiceServer reset_srv_;

  // Worker-only buffers, reused from frame to frame.
  cv::Mat disparity_;
  cv::Mat image_;
  StereoCameraModel camera_;
  ros::Time last_stamp_;

  // The core (guarded by core_mutex_).
  std::mutex core_mutex_;
  std::unique_ptr<OccupancyGrid2D> grid_;

  // Counters and diagnostics (guarded by stats_mutex_, with the shell's counts_).
  std::uint64_t map_resets_ = 0;
  Grid2DUpdateStats last_update_;
};

}  // namespace stereo_safety_map
