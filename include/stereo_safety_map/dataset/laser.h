// Simulated horizontal laser range-finder of the synthetic datasets: ray casting of the same scene
// the cameras see. Like the wheelchair's horizontal laser (001 Sec. 2-3, 000 Fig. 5) it sees walls,
// posts and table legs but not drop-offs or table tops above its plane. ROS-free.
#pragma once

#include "stereo_safety_map/dataset/scene.h"

#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

struct LaserConfig {
  double mount_x = 0.3;  ///< laser origin in base_link [m]
  double mount_y = 0.0;
  double mount_z = 0.3;
  double angle_min_deg = -90.0;  ///< first beam, counter-clockwise from forward [deg]
  double angle_max_deg = 90.0;
  double angle_increment_deg = 0.5;
  double range_min = 0.05;    ///< [m]
  double range_max = 20.0;    ///< [m]
  double noise_sigma = 0.01;  ///< Gaussian range noise [m]

  std::string validate() const;
  int beamCount() const;
  Eigen::Isometry3d baseToLaser() const;
};

/// One scan from the laser pose `T_world_laser` (x forward, z up). Beams that hit nothing within
/// range_max get +inf (REP 117). `frame` and `seed` select the range noise. `ranges` is resized
/// to beamCount() (no allocation when it already has that size).
void simulateScan(const Scene& scene, const LaserConfig& config,
                  const Eigen::Isometry3d& T_world_laser, std::uint64_t seed, std::uint64_t frame,
                  std::vector<float>* ranges);

}  // namespace dataset
}  // namespace stereo_safety_map
