// Validated loading of the parameters of paper 001's parts (Murarka, Modayil & Kuipers 2006):
// the landmark filter of the safety-map nodelet's point stream (core/landmark_filter.h, Sec. 4.2)
// and the hybrid safety-map nodelet (core/laser_grid.h, core/hybrid_safety_map.h, Sec. 2, 3, 5).
//
// As params.h: flat names in the nodelet's private namespace, absent parameters keep the core's
// defaults, wrong types and out-of-range values are refused with one message naming the
// parameter, its value and the allowed range.
#pragma once

#include "stereo_safety_map/core/config_fields.h"
#include "stereo_safety_map/core/hybrid_safety_map.h"
#include "stereo_safety_map/core/landmark_filter.h"
#include "stereo_safety_map/core/laser_grid.h"
#include "stereo_safety_map/core/param_fields.h"

#include <ros/node_handle.h>

#include <string>
#include <vector>

namespace stereo_safety_map {

/// The safety-map nodelet's landmark-filter parameters: use_landmark_filter and the
/// LandmarkFilterConfig fields prefixed with landmark_ (landmark_gate_chi2, ...; the depth range
/// and the stationary-frame thresholds are the mapper's, see LandmarkStreamConfig::forMapper()).
std::string fromRosParam(const ros::NodeHandle& pnh, LandmarkStreamConfig* config);
/// The names read by the function above (core/config_fields.h: landmarkStreamFields()).
std::vector<std::string> landmarkParameterNames();

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
