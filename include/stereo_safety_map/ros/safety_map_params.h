// The safety-map nodelet's parameters: validated loading of the core configs (the mapper, paper
// 001's landmark filter in front of it) and of the nodelet's own settings from the parameter
// server (after voxblox's ros_params.h: validate as you read).
//
// Parameter names are the names of the field lists (core/config_fields.h, safetyMapRosFields()
// below), flat in the nodelet's private namespace (~decr, ~max_slope_deg, ...), as in
// config/safety_map.yaml, cfg/SafetyMap.cfg and the validate() messages. A parameter that is absent
// keeps the struct's default (the paper's value). Every function returns an empty string when the
// values are valid and otherwise one message naming the parameter, its value and the allowed range
// (wrong types too: an integer parameter given as 0.5 or a string is refused, not truncated).
#pragma once

#include "stereo_safety_map/core/config_fields.h"
#include "stereo_safety_map/core/landmark_filter.h"
#include "stereo_safety_map/core/map_costs.h"
#include "stereo_safety_map/core/param_fields.h"
#include "stereo_safety_map/core/safety_mapper.h"

#include <ros/node_handle.h>

#include <string>
#include <vector>

namespace stereo_safety_map {

/// The mapper's fields (core/config_fields.h: safetyMapperFields()), validated.
std::string fromRosParam(const ros::NodeHandle& pnh, SafetyMapperConfig* config);

/// Settings of the safety-map nodelet that are not the core's.
struct SafetyMapRosConfig {
  std::string input = "disparity";   ///< "disparity" (DisparityImage + CameraInfo) or "cloud"
  std::string fixed_frame = "odom";  ///< frame the map is built in (000 Sec. III)
  /// Robot frame, origin on the ground under the robot (REP 120's footprint frame).
  std::string base_frame = "base_footprint";
  /// input cloud: the frame rays start from (the sensor's origin) when the cloud is already
  /// transformed into another frame (the robot's, odom); empty = the cloud's own frame.
  std::string sensor_frame;
  int queue_size = 5;             ///< subscriber / tf filter / sync queue [messages]
  bool approximate_sync = false;  ///< approximate instead of exact DisparityImage-CameraInfo sync
  double max_rate = 0.0;          ///< most frames processed per second [Hz]; 0 = every frame
  double tf_timeout = 0.1;        ///< wait for the base frame's transform [s]
  int disparity_step = 1;         ///< use every n-th pixel in rows and columns
  RowGapFillConfig row_gap_fill;  ///< the safety map's copy of the disparity (core)
  double time_jump_reset = 1.0;   ///< stamps going back by more than this reset the map [s]
  /// ~save writes only under this directory (absolute; created when missing).
  std::string save_directory = "/tmp/stereo_safety_map";
  /// ~save without a path_prefix; relative to save_directory (an absolute one must lie in it).
  std::string save_prefix = "map";
  /// Drop a frame whose data are byte for byte the previous frame's (a frozen camera or driver
  /// re-sending its last buffer); off for noiseless simulators that repeat frames.
  bool reject_frozen_input = true;
  /// A frame whose transform arrived more than this after the frame [s] is dropped: its pose
  /// would be interpolated across a gap in tf (odometry stalled), not measured.
  double max_tf_wait = 1.0;
  /// Frames that may wait for the worker, 1..10: 1 = the newest only; 2 absorbs one frame whose
  /// map took longer than the camera period instead of dropping it (frame_slot.h).
  int frame_queue = 2;
  /// Diagnostics WARN when no input arrived, or none was used, for this long [s]; after this long
  /// without a frame integrated (by the ROS clock, against the map's stamp) the published
  /// OccupancyGrid turns all Unknown.
  double stale_input_timeout = 2.0;
  /// The OccupancyGrid's cost table (core/map_costs.h).
  CostTable costs;
  /// Height of the safety_obstacles points above the robot's base [m].
  double obstacles_cloud_height = 0.1;

  /// Empty when valid, otherwise a message naming the parameter and its range.
  std::string validate() const;
};
/// The field list of SafetyMapRosConfig (and diagnostic_updater's diagnostic_period).
const ParamFieldList<SafetyMapRosConfig>& safetyMapRosFields();
std::string fromRosParam(const ros::NodeHandle& pnh, SafetyMapRosConfig* config);

/// Every parameter name the safety-map nodelet reads from its private namespace (all its field
/// lists, ros/nodelet_params.h).
std::vector<std::string> safetyMapParameterNames();

/// The safety-map nodelet's landmark-filter parameters: use_landmark_filter and the
/// LandmarkFilterConfig fields prefixed with landmark_ (landmark_gate_chi2, ...; the depth range
/// and the stationary-frame thresholds are the mapper's, see LandmarkStreamConfig::forMapper()).
std::string fromRosParam(const ros::NodeHandle& pnh, LandmarkStreamConfig* config);
/// The names read by the function above (core/config_fields.h: landmarkStreamFields()).
std::vector<std::string> landmarkParameterNames();

}  // namespace stereo_safety_map
