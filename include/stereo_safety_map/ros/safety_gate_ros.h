// The velocity safety gate's ROS class: between the joystick (or teleop, or move_base) and the
// base, it stops or slows each command so that the chair's footprint never enters a hazard of the
// safety map (core/safety_gate.h). Wrapped by src/nodelets/safety_gate_nodelet.cpp
// (stereo_safety_map/SafetyGateNodelet).
//
// In: cmd_vel_in (geometry_msgs/Twist), safety_map_labels (stereo_safety_map/SafetyMap), tf
// fixed_frame -> footprint_frame. Out: cmd_vel (the gated twist), gate_state
// (stereo_safety_map/GateState), gate_markers (visualization_msgs/MarkerArray, when subscribed),
// /diagnostics.
//
// Each command is gated when it arrives, against the latest map and the latest transform of the
// footprint: a zero command is forwarded at once (no tf lookup); without a map, with a map older
// than max_map_age or from another frame, or without a current transform (older than max_tf_age:
// dead tf), the output is zero and gate_state says why. A watchdog publishes a zero twist once
// when no command came for cmd_timeout, and zero when the map goes stale while the last command
// was moving.
//
// Threading: callbacks and the watchdog share one mutex; the work per command (one sweep of the
// footprint, well under a millisecond) is done in the callback; the tf lookup uses the latest
// transform and waits on the wall clock only while no transform exists at all (tf_timeout).
#pragma once

#include "stereo_safety_map/core/safety_gate.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/ros/msgs.h"
#include "stereo_safety_map/ros/nodelet_shell.h"
#include "stereo_safety_map/ros/safety_gate_params.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/Twist.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <string>

namespace stereo_safety_map {

class SafetyGateRos : public NodeletShell {
 public:
  /// Reads and validates the parameters in `pnh`. With an invalid configuration the object logs
  /// the error, reports it as an ERROR diagnostic, publishes nothing and subscribes to nothing.
  SafetyGateRos(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~SafetyGateRos();

 private:
  void mapCb(const SafetyMapMsg::ConstPtr& msg);
  void cmdCb(const geometry_msgs::Twist::ConstPtr& msg);
  void watchdogCb(const ros::TimerEvent& e);
  /// Gates `cmd` at time `now` and publishes (mutex_ held).
  void gate(const geometry_msgs::Twist& cmd, const ros::Time& now);
  /// The footprint's planar pose in fixed_frame; false (and `why`) when there is none or it is
  /// older than max_tf_age.
  bool footprintPose(const ros::Time& now, Pose2D* pose, double* z, std::string* why);
  /// Publishes the decision on cmd_vel and gate_state, and the markers when subscribed.
  void publish(const GateDecision& d, const ros::Time& now, double map_age, double z);
  void publishMarkers(const GateDecision& d, const ros::Time& now, double z);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);

  SafetyGateRosConfig ros_config_;
  SafetyGateConfig gate_config_;

  std::shared_ptr<tf2_ros::Buffer> tf_buffer_;
  std::shared_ptr<tf2_ros::TransformListener> tf_listener_;
  ros::Subscriber cmd_sub_;
  ros::Subscriber map_sub_;
  ros::Publisher cmd_pub_;
  ros::Publisher state_pub_;
  ros::Publisher markers_pub_;
  ros::Timer watchdog_;

  // Guarded by mutex_.
  std::mutex mutex_;
  std::unique_ptr<SafetyGate> gate_;
  SafetyMap map_;          ///< the latest valid map (width 0: none)
  SafetyMap scratch_map_;  ///< conversion target, swapped with map_ when valid
  ros::Time map_stamp_;    ///< its stamp
  GateReason map_problem_ = GateReason::kNoMap;  ///< kClear when the latest map was usable
  std::string map_problem_text_ = "no safety map received yet";
  GateDecision decision_;           ///< the last decision
  geometry_msgs::Twist last_cmd_;   ///< the last command received
  ros::Time last_cmd_time_;         ///< when it arrived (zero: none yet)
  bool moving_ = false;             ///< the last published twist was not zero
  bool timeout_published_ = false;  ///< the watchdog's zero for the current silence is out
  double last_map_age_ = std::numeric_limits<double>::quiet_NaN();
  double last_tf_age_ = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t cmds_received_ = 0;
  std::uint64_t maps_received_ = 0;
  std::uint64_t maps_rejected_ = 0;
  std::uint64_t count_allowed_ = 0, count_slowed_ = 0, count_stopped_ = 0;
  std::uint64_t timeouts_ = 0;
  double gate_ms_last_ = 0.0;
  ros::WallTime rate_window_start_;
  std::uint64_t window_cmds_ = 0, window_maps_ = 0;
  double cmd_rate_ = 0.0, map_rate_ = 0.0;
};

}  // namespace stereo_safety_map
