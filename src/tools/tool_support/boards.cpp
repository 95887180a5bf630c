#include "stereo_safety_map/tools/boards.h"

#include <cmath>

namespace stereo_safety_map {

bool boardInView(const BoardBox& b, const Eigen::Isometry3d& T_fixed_sensor,
                 const StereoCameraModel& cam) {
  const Eigen::Vector3d p = T_fixed_sensor.inverse() * b.center;
  if (p.z() <= 0.1) return false;
  const double x = cam.fx * p.x() / p.z() + cam.cx, y = cam.fy * p.y() / p.z() + cam.cy;
  return x >= 0 && x < cam.width && y >= 0 && y < cam.height;
}

double distanceToBoardFace(const BoardBox& b, const Eigen::Vector3d& camera) {
  int thin = 0;
  for (int k = 1; k < 3; ++k)
    if (b.half_size[k] < b.half_size[thin]) thin = k;
  const Eigen::Vector3d n = b.rotation.col(thin);
  Eigen::Vector3d d = b.center - camera;
  d.z() = 0.0;
  return std::abs(d.dot(n)) - b.half_size[thin];
}

}  // namespace stereo_safety_map
