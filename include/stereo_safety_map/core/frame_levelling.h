// Re-levelling of each frame on the ground the robot stands on (ours; not in the papers). ROS-free.
//
// Paper 000 takes the camera's pose from the robot's odometry (Sec. IV). A wheelchair's odometry
// knows no pitch or roll: the chassis bobs on its suspension and tyres (a few tenths of a degree
// from frame to frame) and may sit tilted on them, and tf does not say so. At 4 m a pitch error
// of 0.5 deg puts the floor 3.5 cm too high or too low, so the grid's columns and planes smear
// over a voxel and ramps and drops are mis-measured. The floor the robot stands on and is about
// to drive on is known: the previous map's robot segment (Alg. 1's segment grown from the
// robot, 000 Sec. V-A) and its plane (Sec. V-B). This unit finds the small rotation about the
// camera's optical centre (about the fixed frame's x and y axes) and the vertical offset that
// put the frame's points over that ground onto its plane, in the least-squares sense with
// points gated to the plane's neighbourhood, and corrects the camera pose with it. Only that
// ground is used: a ramp, a drop or an obstacle ahead is another segment and does not pull
// the frame. Corrections beyond a few degrees are refused (the frame keeps its pose): such a
// pose error is not chassis bobbing.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <functional>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct FrameLevellingConfig {
  bool enabled = false;             ///< SafetyMapperConfig::relevel (ours; false = 000)
  double max_correction_deg = 3.0;  ///< larger rotations are refused [deg], (0, 20]
  double max_offset = 0.10;         ///< larger vertical offsets are refused [m], (0, 1]
  double max_range = 4.0;           ///< points farther from the camera are not used [m]
  double gate = 0.10;               ///< points farther from the plane are not used [m]
  int min_points = 200;             ///< fewer gated points: no correction
  double min_extent = 1.0;          ///< forward / lateral spread of the points needed [m]
  int stride = 3;                   ///< every stride-th point is tried, [1, 100]
  /// The reference ground (SafetyMapper). 0: the previous map's robot-segment cells whose
  /// measured surface lies on the base's level plane (the first rule, ours). > 0: the base's
  /// level plane over every cell within this horizontal distance [m] of the robot's base: the
  /// chair stands on that ground, whatever the map made of it. The map's own cells are no
  /// absolute reference: they were built from frames with the same tilt, so a correction
  /// measured against them stays near zero. [0, 10] m.
  double near_radius = 0.0;
  /// 0: each frame is corrected by its own estimate. N > 0: by the per-component median of the
  /// last N accepted estimates, expressed in the camera's heading frame (a tilt of the mount or
  /// the seat turns with the chair): the constant part of an unreported tilt (seat load, tyre
  /// pressure, a mount calibrated a little off) is removed, and a ramp or a drop ahead that
  /// pulls a few frames' estimates does not move the median. [0, 1000].
  int filter_frames = 0;
  /// Estimate the vertical offset dz together with the rotation (true, the first rule) or keep
  /// the camera's height and estimate the rotation alone (false, ours). A chassis tilts about
  /// its wheels' contact line: the camera, a metre above it and a few decimetres ahead, moves
  /// by millimetres, while the ground the camera sees spans only 1-2 m along its heading, over
  /// which a small pitch and a vertical offset shift the points' heights almost alike. With
  /// the offset free the pitch is poorly determined; pinned, each ground point's height error
  /// is its distance times the tilt.
  bool estimate_offset = true;

  std::string validate() const;
};

struct FrameLevellingResult {
  bool applied = false;
  double roll_deg = 0.0;    ///< rotation applied about the fixed frame's x axis [deg]
  double pitch_deg = 0.0;   ///< about its y axis [deg]
  double dz = 0.0;          ///< vertical offset applied [m]
  int points = 0;           ///< points used in the last iteration
  double rms_before = 0.0;  ///< RMS distance of those points to the plane [m]
  double rms_after = 0.0;
};

/// Reference ground: for a fixed-frame (x, y), the height of the robot's ground there, NaN where
/// there is none.
using GroundReference = std::function<float(float x, float y)>;

/// Buffers reused from frame to frame (keep one per caller: no allocation once grown).
struct FrameLevellingScratch {
  std::vector<Eigen::Vector3d> q;
  std::vector<double> e;
};

/// `T_fixed_sensor` rotated about its own origin by `roll` about the fixed frame's x axis and
/// `pitch` about its y axis [rad], then moved up by `dz` [m]: the correction levelFrame() applies.
Eigen::Isometry3f levelledPose(const Eigen::Isometry3f& T_fixed_sensor, double roll, double pitch,
                               double dz);

/// Estimates the correction of `T_fixed_sensor` (points_sensor in the sensor frame, whose origin
/// is the camera) that puts the points over the reference ground onto it. On success writes the
/// corrected pose to *T_corrected and returns true; otherwise *T_corrected = T_fixed_sensor.
bool levelFrame(const std::vector<Eigen::Vector3f>& points_sensor,
                const Eigen::Isometry3f& T_fixed_sensor, const GroundReference& reference,
                const FrameLevellingConfig& config, Eigen::Isometry3f* T_corrected,
                FrameLevellingResult* result = nullptr, FrameLevellingScratch* scratch = nullptr);

}  // namespace stereo_safety_map
