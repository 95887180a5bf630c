// The latency boards of the offline evaluators (000 Sec. VII-B): when a board counts as in view,
// and how far the camera is from it. One definition, so that evaluate_safety_map,
// evaluate_obstacles and evaluate_occupancy_2d count the same frames.
#pragma once

#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/stereo_camera_model.h"

#include <Eigen/Geometry>

namespace stereo_safety_map {

/// The board's centre is in front of the camera (> 0.1 m) and projects into the image.
bool boardInView(const BoardBox& b, const Eigen::Isometry3d& T_fixed_sensor,
                 const StereoCameraModel& cam);

/// Distance along the horizontal from the optical centre `camera` to the nearer face of the
/// board (its thinnest axis) [m].
double distanceToBoardFace(const BoardBox& b, const Eigen::Vector3d& camera);

}  // namespace stereo_safety_map
