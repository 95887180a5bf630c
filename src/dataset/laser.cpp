#include "stereo_safety_map/dataset/laser.h"

#include <cmath>
#include <limits>
#include <random>

namespace stereo_safety_map {
namespace dataset {

std::string LaserConfig::validate() const {
  if (!std::isfinite(mount_x) || !std::isfinite(mount_y) || !std::isfinite(mount_z))
    return "laser.mount must be finite";
  if (!(angle_increment_deg > 0.0 && angle_increment_deg <= 45.0))
    return "laser.angle_increment_deg must be in (0, 45]";
  if (!(angle_min_deg >= -180.0 && angle_max_deg <= 180.0 && angle_min_deg < angle_max_deg))
    return "laser.angle_min_deg < laser.angle_max_deg, both in [-180, 180]";
  if (!(range_min >= 0.0 && range_max > range_min && range_max <= 1000.0))
    return "laser.range_min in [0, range_max), laser.range_max in (range_min, 1000] [m]";
  if (!(noise_sigma >= 0.0 && noise_sigma <= 1.0)) return "laser.noise_sigma must be in [0, 1] [m]";
  return "";
}

int LaserConfig::beamCount() const {
  return static_cast<int>(
             std::floor((angle_max_deg - angle_min_deg) / angle_increment_deg + 1e-9)) +
         1;
}

Eigen::Isometry3d LaserConfig::baseToLaser() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(mount_x, mount_y, mount_z);
  return T;
}

void simulateScan(const Scene& scene, const LaserConfig& config,
                  const Eigen::Isometry3d& T_world_laser, std::uint64_t seed, std::uint64_t frame,
                  std::vector<float>* ranges) {
  const int n = config.beamCount();
  ranges->resize(static_cast<std::size_t>(n));
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + frame * 0xBF58476D1CE4E5B9ull + 0x1a5e);
  Ray ray;
  ray.origin = T_world_laser.translation();
  for (int i = 0; i < n; ++i) {
    const double a = (config.angle_min_deg + i * config.angle_increment_deg) * M_PI / 180.0;
    ray.dir = T_world_laser.linear() * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
    Hit hit;
    // Two uniform draws per beam whatever happens, so that beams keep their noise sample.
    const double u1 = (static_cast<double>(rng() >> 11) + 1.0) / 9007199254740993.0;
    const double u2 = static_cast<double>(rng() >> 11) / 9007199254740992.0;
    float r = std::numeric_limits<float>::infinity();
    if (scene.intersect(ray, config.range_min, config.range_max, &hit)) {
      const double g = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
      const double noisy = hit.t + config.noise_sigma * g;
      if (noisy >= config.range_min && noisy <= config.range_max) r = static_cast<float>(noisy);
    }
    (*ranges)[i] = r;
  }
}

}  // namespace dataset
}  // namespace stereo_safety_map
