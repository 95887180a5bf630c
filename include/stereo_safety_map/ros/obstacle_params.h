// Validated parameters of the obstacle-detection nodelet
// (stereo_safety_map/ObstacleDetectionNodelet, paper 003) and of the safety-map nodelet's obstacle
// cue (core/obstacle_cue.h), from the parameter server or, for the offline tools, from the same
// flat YAML files (config/obstacle_detection.yaml, config/safety_map.yaml).
//
// Names are the config structs' field names, flat in the private namespace, except the cue's,
// which carry an `obstacle_cue` prefix in the safety-map nodelet's namespace. Absent parameters
// keep the defaults. Every function returns an empty string when the values are valid and
// otherwise one message naming the parameter, its value and the allowed range (wrong types are
// refused, not truncated).
#pragma once

#include "stereo_safety_map/core/config_fields.h"
#include "stereo_safety_map/core/obstacle_cue.h"
#include "stereo_safety_map/core/obstacle_detection.h"
#include "stereo_safety_map/core/param_fields.h"

#include <ros/node_handle.h>

#include <string>
#include <vector>

namespace stereo_safety_map {

/// Settings of the obstacle-detection nodelet that are not the core's.
struct ObstacleDetectionRosConfig {
  std::string input = "disparity";   ///< "disparity" (DisparityImage + left CameraInfo) or "cloud"
  std::string fixed_frame = "odom";  ///< gravity: the z axis of this tf frame points up
  std::string method = "3d";         ///< "3d" (003 OD/OS Algorithm 2) or "columnwise" (baseline)
  int queue_size = 5;                ///< subscriber / tf filter / sync queue [messages]
  bool approximate_sync = false;     ///< approximate DisparityImage-CameraInfo sync
  /// Most frames processed per second [Hz]; 0 = every frame (the default since the twenty-eighth
  /// session: with the faster disparity stage the default graph keeps a 30 Hz camera on two
  /// cores with the detector on every frame, 0 lost, p95 27.9-30.3 ms in three replays, and
  /// /obstacles' own p95 falls from ~54 to ~24 ms; issue 18, docs/performance.md). A positive
  /// rate throttles it on a smaller machine; the safety map's cue lives 1 s.
  double max_rate = 0.0;
  double min_depth = 0.2;  ///< range image: nearer points are missing [m] (the grid's min_range)
  double max_depth = 8.0;  ///< range image: farther points are missing [m] (the grid's max_range)
  double focal_length = 0.0;  ///< cloud input: f [px]; 0 = estimated from the organised cloud
  /// The detector runs on every decimation-th pixel of every decimation-th row
  /// (decimateRangeImage; ours, issue 18); 1 = the full image (003). 2 by default: the same
  /// point recall and precision on datasets 1 and 4 at a quarter of the time, and the default
  /// graph keeps up at 30 Hz (docs/performance.md).
  int decimation = 2;

  std::string validate() const;
};

/// The obstacle cue of the safety-map nodelet (~obstacle_cue, ~obstacle_cue_lifetime,
/// ~obstacle_cue_min_points).
struct ObstacleCueRosConfig {
  /// Subscribe to `obstacles` (the detector's labelled obstacle cloud) and mark their cells
  /// Non-ground in the map at once. On by default since the detector's stereo noise margin
  /// (ObstacleDetectionConfig::noise_sigmas): with 003's constant thresholds its false detections
  /// on the ground cost far more safe cells than the latency gain (README, "Obstacle cue").
  bool enabled = true;
  ObstacleCueConfig cue;
};

/// Field lists of the nodelet's settings (and diagnostic_period) and of the safety-map nodelet's
/// obstacle cue; the detector's own is core/config_fields.h's obstacleDetectionFields().
const ParamFieldList<ObstacleDetectionRosConfig>& obstacleDetectionRosFields();
const ParamFieldList<ObstacleCueRosConfig>& obstacleCueFields();

std::string fromRosParam(const ros::NodeHandle& pnh, ObstacleDetectionConfig* config);
std::string fromRosParam(const ros::NodeHandle& pnh, ObstacleDetectionRosConfig* config);
std::string fromRosParam(const ros::NodeHandle& pnh, ObstacleCueRosConfig* config);

/// Every parameter name the obstacle-detection nodelet reads from its private namespace.
std::vector<std::string> obstacleDetectionParameterNames();
/// The cue's parameter names in the safety-map nodelet's namespace.
std::vector<std::string> obstacleCueParameterNames();

/// The same keys from a flat YAML file (offline tools); keys of other settings are ignored.
/// Empty on success.
std::string loadObstacleDetectionParams(const std::string& path, ObstacleDetectionConfig* config,
                                        ObstacleDetectionRosConfig* ros_config = nullptr);
std::string loadObstacleCueParams(const std::string& path, ObstacleCueRosConfig* config);

}  // namespace stereo_safety_map
