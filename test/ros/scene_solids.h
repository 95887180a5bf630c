// Solids of the rostests' small known scenes (stereo_scene.h, synthetic_scene.h) in the dataset's
// types (dataset/scene.h), hit with Scene::intersect like the renderer's scenes.
#pragma once

#include "stereo_safety_map/dataset/scene.h"

#include <Eigen/Core>

#include <vector>

namespace scene_solids {

/// The axis-aligned box lo..hi as six half-spaces n . x <= d written out (rather than
/// dataset::makeBox's centre +- size / 2), so that its faces lie on the given bounds to the bit.
inline stereo_safety_map::dataset::Primitive alignedBox(const Eigen::Vector3d& lo,
                                                        const Eigen::Vector3d& hi) {
  namespace ds = stereo_safety_map::dataset;
  std::vector<ds::HalfSpace> planes;
  for (int a = 0; a < 3; ++a) {
    ds::HalfSpace upper, lower;
    upper.n = Eigen::Vector3d::Unit(a);
    upper.d = hi[a];
    lower.n = -Eigen::Vector3d::Unit(a);
    lower.d = -lo[a];
    planes.push_back(upper);
    planes.push_back(lower);
  }
  return ds::makeConvex(planes);
}

}  // namespace scene_solids
