// Validated loading of the disparity nodelet's parameters (stereo_safety_map/DisparityNodelet)
// from its private namespace, after voxblox's ros_params.h: validate as you read.
//
// The core's DisparityPipelineConfig nests one struct per filter (texture.window_size, ...);
// the parameters are flat (texture_window_size, ...) because dynamic_reconfigure
// (cfg/Disparity.cfg) shares the names and cannot nest. The field list
// (core/config_fields.h: disparityPipelineFields()) is the one translation between the two;
// validation messages name the parameter as it is set.
//
// Every function returns an empty string when the values are valid, and otherwise one message
// naming the parameter, its value and the allowed range. Wrong types are refused (an integer
// parameter given as 2.5 or a string), not truncated; absent parameters keep the defaults.
#pragma once

#include "stereo_safety_map/core/config_fields.h"
#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/core/param_fields.h"

#include <ros/node_handle.h>

#include <string>
#include <utility>
#include <vector>

namespace stereo_safety_map {

/// Settings of the disparity nodelet that are not the core pipeline's.
struct DisparityRosConfig {
  int queue_size = 5;             ///< subscriber and synchronizer queue [messages], [1, 1000]
  bool approximate_sync = false;  ///< approximate instead of exact image / CameraInfo sync
  double cloud_max_depth = 10.0;  ///< points2: farther points are NaN [m], (0, 1000]
  /// Degraded-camera checks (core/stereo_input_check.h): images with a grey-level std dev below
  /// this are refused [grey levels], [0, 128], 0 = off; images repeating the previous pair
  /// byte for byte are refused unless reject_frozen_images is false.
  double min_image_contrast = 2.0;
  bool reject_frozen_images = true;
  /// Stereo pairs that may wait for the worker (frame_slot.h), [1, 10]: 1 = the newest pair
  /// only; 2 (default) absorbs one pair that took longer than the camera period instead of
  /// dropping it, at one frame of latency then (issue 18).
  int frame_queue = 2;

  std::string validate() const;
};

/// The field list of the nodelet's settings (and diagnostic_period). The pipeline's is
/// core/config_fields.h's disparityPipelineFields(), with matcherName(), matcherFromName(),
/// validateDisparityParameters() and toParameterNames().
const ParamFieldList<DisparityRosConfig>& disparityRosFields();

/// Reads the pipeline parameters (matcher, window sizes, each filter's switch and settings) and
/// checks them: every parameter against its range (also a disabled filter's, as
/// dynamic_reconfigure clamps to the same ranges), then DisparityPipelineConfig::validate().
/// texture_window_size = 0 (the default) makes the texture window follow block_size, as 002
/// Sec. 2.2 measures the texture over the matching window.
std::string fromRosParam(const ros::NodeHandle& pnh, DisparityPipelineConfig* config);
std::string fromRosParam(const ros::NodeHandle& pnh, DisparityRosConfig* config);

/// Every parameter name the disparity nodelet reads from its private namespace (for the
/// unknown-parameter warning, param_reader.h's unknownParameters()).
std::vector<std::string> disparityParameterNames();

}  // namespace stereo_safety_map
