// Solids of the rostests' small known scenes (stereo_scene.h, synthetic_scene.h) in the dataset's
// types (dataset/scene.h), for dataset::StereoRenderer like every rendered dataset's scene.
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

/// A floor slab (top z = 0, 1 m thick) over floor_lo..floor_hi (x, y) and a box lo..hi on it.
inline stereo_safety_map::dataset::Scene floorWithBox(const Eigen::Vector2d& floor_lo,
                                                      const Eigen::Vector2d& floor_hi,
                                                      const Eigen::Vector3d& box_lo,
                                                      const Eigen::Vector3d& box_hi) {
  namespace ds = stereo_safety_map::dataset;
  ds::Scene sc;
  sc.addMaterial("default", ds::Material());  // index 0, every solid's until a scene sets its own
  ds::Primitive floor = alignedBox(Eigen::Vector3d(floor_lo.x(), floor_lo.y(), -1.0),
                                   Eigen::Vector3d(floor_hi.x(), floor_hi.y(), 0.0));
  floor.name = "floor";
  floor.ground = true;
  sc.add(floor);
  ds::Primitive box = alignedBox(box_lo, box_hi);
  box.name = "box";
  sc.add(box);
  return sc;
}

}  // namespace scene_solids
