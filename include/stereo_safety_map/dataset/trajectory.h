// Planar robot trajectories for the synthetic datasets: in-place turns, straight drives (forwards
// or in reverse) and pauses,
// sampled at the camera frame rate. Pauses give stationary frames, which the pipeline must skip
// (000 Sec. IV; 10 to 20 percent of the frames in 000 Sec. VII-A). The robot stays on level
// ground like the paper's 3-DOF robot (000 Sec. I-A). ROS-free.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

/// One motion command of a trajectory.
struct TrajectoryStep {
  /// kGo: turn in place to face the target, then drive forwards to it. kBack: turn in place so
  /// that the rear faces the target (no turn when it lies straight behind), then reverse to it
  /// in a straight line: the heading is kept, the robot never faces the target (a wheelchair
  /// backing out of a corner or away from an edge).
  enum class Kind { kPause, kGo, kTurnTo, kTurnBy, kBack };
  Kind kind = Kind::kPause;
  double x = 0.0;  ///< kGo, kBack: target [m]
  double y = 0.0;
  double value = 0.0;  ///< kPause: duration [s]; kTurnTo: yaw [deg]; kTurnBy: yaw change [deg]
  double speed = 0.0;  ///< kGo, kBack: [m/s], 0 = TrajectoryConfig::speed
};

struct TrajectoryConfig {
  double rate_hz = 15.0;  ///< camera frame rate
  double start_x = 0.0;   ///< base_link start pose in odom [m]
  double start_y = 0.0;
  double start_yaw_deg = 0.0;
  double base_z = 0.0;          ///< height of base_link (the floor under the robot) [m]
  double speed = 0.4;           ///< default driving speed [m/s] (wheelchair walking pace)
  double turn_rate_deg = 30.0;  ///< in-place turn rate [deg/s]
  std::vector<TrajectoryStep> steps;

  std::string validate() const;
};

/// Base pose at one camera frame.
struct RobotPose {
  double t = 0.0;  ///< time since the first frame [s]
  double x = 0.0, y = 0.0, z = 0.0;
  double yaw = 0.0;         ///< [rad]
  double v = 0.0;           ///< forward speed [m/s], negative when reversing
  double omega = 0.0;       ///< yaw rate [rad/s]
  bool stationary = false;  ///< same pose as the previous frame
};

/// Total duration of the trajectory [s].
double trajectoryDuration(const TrajectoryConfig& config);

/// Pose at time t (clamped to [0, duration]).
RobotPose poseAt(const TrajectoryConfig& config, double t);

/// Poses at t = i / rate_hz for i = 0 .. floor(duration * rate_hz). Empty when invalid.
std::vector<RobotPose> sampleTrajectory(const TrajectoryConfig& config);

/// Indices of `count` frames evenly spread over [0, total) (all of them when count >= total),
/// for the small test versions of a dataset.
std::vector<std::size_t> subsampleFrames(std::size_t total, std::size_t count);

}  // namespace dataset
}  // namespace stereo_safety_map
