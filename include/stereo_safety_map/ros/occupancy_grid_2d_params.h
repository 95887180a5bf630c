// Validated parameters of the 2D occupancy-grid nodelet (stereo_safety_map/OccupancyGrid2DNodelet,
// paper 002) from its private namespace, and the same keys from a YAML file for the offline
// evaluation (evaluate_occupancy_2d), so that both run the grid with the same settings.
//
// Names are the fields of OccupancyGrid2DConfig (core/occupancy_grid_2d.h) and of
// OccupancyGrid2DRosConfig below, flat in the private namespace (~k, ~floor_clearance, ...), as in
// config/occupancy_grid_2d.yaml. Absent keys keep the defaults (002's values where it gives one);
// every function returns an empty string when the values are valid, else one message naming the
// parameter, its value and the allowed range (wrong types are refused, not truncated).
#pragma once

#include "stereo_safety_map/core/config_fields.h"
#include "stereo_safety_map/core/occupancy_grid_2d.h"
#include "stereo_safety_map/core/param_fields.h"

#include <ros/node_handle.h>

#include <string>
#include <vector>

namespace stereo_safety_map {

/// Settings of the 2D occupancy-grid nodelet that are not the core's.
struct OccupancyGrid2DRosConfig {
  std::string fixed_frame = "odom";           ///< frame the grid is built and published in
  std::string base_frame = "base_footprint";  ///< robot frame, origin on the floor (REP 120)
  int queue_size = 5;                         ///< subscriber / tf filter / sync queue [messages]
  bool approximate_sync = false;  ///< approximate instead of exact DisparityImage-CameraInfo sync
  double max_rate = 0.0;          ///< most frames processed per second [Hz]; 0 = every frame
  double tf_timeout = 0.1;        ///< wait for the base frame's transform [s]
  double time_jump_reset = 1.0;   ///< stamps going back by more than this reset the grid [s]
  bool scroll_with_robot = true;  ///< keep the window centred on the robot

  /// Empty when valid, otherwise a message naming the parameter and its range.
  std::string validate() const;
};

/// The field list of the nodelet's settings (and diagnostic_period); the grid's is
/// core/config_fields.h's occupancyGrid2DFields().
const ParamFieldList<OccupancyGrid2DRosConfig>& occupancyGrid2DRosFields();

std::string fromRosParam(const ros::NodeHandle& pnh, OccupancyGrid2DConfig* config);
std::string fromRosParam(const ros::NodeHandle& pnh, OccupancyGrid2DRosConfig* config);

/// Every parameter name the nodelet reads from its private namespace (for the unknown-parameter
/// warning, param_reader.h's unknownParameters()).
std::vector<std::string> occupancyGrid2DParameterNames();

/// The core keys of a YAML file such as config/occupancy_grid_2d.yaml applied to `config` and
/// validated; the nodelet's own keys (frames, queues) are accepted and ignored, any other key is
/// an error. Empty on success.
std::string loadOccupancyGrid2DParamsFile(const std::string& path, OccupancyGrid2DConfig* config);
/// One `key=value` of the same core keys (for --set). Empty on success.
std::string setOccupancyGrid2DParam(const std::string& assignment, OccupancyGrid2DConfig* config);

}  // namespace stereo_safety_map
