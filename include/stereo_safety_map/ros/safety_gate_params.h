// Validated loading of the safety gate's parameters (core/safety_gate.h and the nodelet's own).
//
// As params.h: flat names in the nodelet's private namespace, the same as the config structs'
// field names; absent parameters keep the defaults; wrong types and out-of-range values are
// refused with one message naming the parameter, its value and the allowed range.
#pragma once

#include "stereo_safety_map/core/safety_gate.h"

#include <ros/node_handle.h>

#include <string>
#include <vector>

namespace stereo_safety_map {

/// Settings of the safety-gate nodelet that are not the core's.
struct SafetyGateRosConfig {
  /// Frame of the safety map and of the footprint's pose; a map in another frame stops the chair.
  std::string fixed_frame = "odom";
  /// The robot's footprint frame (REP 120: base_footprint, on the ground under the robot).
  std::string footprint_frame = "base_footprint";
  /// No command on cmd_vel_in for this long [s], (0, 60]: a zero twist is published once (a
  /// joystick driver that dies must not leave the chair moving).
  double cmd_timeout = 0.5;
  /// Wall-clock wait for a transform fixed_frame -> footprint_frame that does not exist yet [s],
  /// [0, 1]; the gate looks up the latest transform, so this matters at start only.
  double tf_timeout = 0.05;
  /// The latest transform older than this (ROS time) is a dead tf [s], (0, 60]: stop.
  double max_tf_age = 0.5;
  /// Subscriber queues [messages], [1, 100].
  int queue_size = 1;

  /// Empty when valid, otherwise a message naming the parameter and its range.
  std::string validate() const;
};

/// Reads the nodelet's settings and the core's SafetyGateConfig. `footprint` is a list of
/// [x, y] pairs (YAML) or the same as a string ("[[0.75, 0.35], [-0.45, 0.35], ...]", as
/// costmap_2d takes it). Empty when valid.
std::string fromRosParam(const ros::NodeHandle& pnh, SafetyGateRosConfig* ros_config,
                         SafetyGateConfig* gate);
/// Every parameter name the safety-gate nodelet reads from its private namespace.
std::vector<std::string> safetyGateParameterNames();

}  // namespace stereo_safety_map
