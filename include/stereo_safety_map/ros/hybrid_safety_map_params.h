// The hybrid safety-map nodelet's parameters (paper 001, Murarka, Modayil & Kuipers 2006:
// core/laser_grid.h, core/hybrid_safety_map.h, Sec. 2, 3, 5). The landmark filter of 001 Sec. 4.2
// runs in the safety-map nodelet; its parameters are in safety_map_params.h.
//
// As safety_map_params.h: flat names in the nodelet's private namespace, absent parameters keep the
// core's defaults, wrong types and out-of-range values are refused with one message naming the
// parameter, its value and the allowed range.
#pragma once

#include "stereo_safety_map/core/config_fields.h"
#include "stereo_safety_map/core/hybrid_safety_map.h"
#include "stereo_safety_map/core/laser_grid.h"
#include "stereo_safety_map/core/param_fields.h"

#include <ros/node_handle.h>

#include <string>
#include <vector>

namespace stereo_safety_map {

/// Settings of the hybrid safety-map nodelet that are not the core's.
struct HybridSafetyMapRosConfig {
  std::string fixed_frame = "odom";  ///< frame of the safety map and of the laser grid
  int queue_size = 5;                ///< scan subscriber / tf filter queue [messages], [1, 1000]
  /// A stereo safety map older than this (against the newest scan) is not used [s], (0, 3600].
  double vision_timeout = 1.0;
  /// While no current stereo map exists, publish the map from the laser alone (vision Unknown)
  /// at most this often [Hz], [0, 100]; 0 = publish only when a stereo map arrives.
  double laser_only_rate = 2.0;
  /// Scan stamps going back by more than this clear the laser grid (a bag restarted) [s],
  /// [0, 3600]; smaller steps back drop the scan.
  double time_jump_reset = 1.0;
  double laser_size_x = 12.0;  ///< laser grid extent along x [m], [resolution, 1000]
  double laser_size_y = 12.0;  ///< laser grid extent along y [m], [resolution, 1000]

  /// Empty when valid, otherwise a message naming the parameter and its range.
  std::string validate() const;
};

/// The hybrid nodelet's three configurations, for its one field list.
struct HybridSafetyMapParams {
  HybridSafetyMapRosConfig ros;
  LaserGridConfig laser;
  HybridSafetyMapConfig hybrid;
};
/// The nodelet's settings, the laser grid's (core/config_fields.h: laserGridFields()) and the
/// combination's (hybridSafetyMapFields()); validation fills the laser grid's width and height.
const ParamFieldList<HybridSafetyMapParams>& hybridSafetyMapParamsFields();

/// Reads the hybrid nodelet's settings, the laser grid (resolution, log-odds; width / height
/// from laser_size_x / laser_size_y) and the combination rules. Empty when valid.
std::string fromRosParam(const ros::NodeHandle& pnh, HybridSafetyMapRosConfig* ros_config,
                         LaserGridConfig* laser, HybridSafetyMapConfig* hybrid);
/// Every parameter name the hybrid nodelet reads from its private namespace.
std::vector<std::string> hybridSafetyMapParameterNames();

}  // namespace stereo_safety_map
