// Scene files (YAML) of the synthetic datasets: geometry, materials, lighting, the stereo head, the
// laser and the robot's trajectory, with optional named variants (e.g. the board distances of the
// latency experiment, 000 Sec. VII-B). The format is documented in scenes/README.md. ROS-free;
// uses yaml-cpp.
#pragma once

#include "stereo_safety_map/dataset/laser.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene.h"
#include "stereo_safety_map/dataset/trajectory.h"

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

/// Everything a scene file describes.
struct SceneFile {
  Scene scene;  ///< name gets "_<variant>" appended when a variant is chosen
  StereoHeadConfig camera;
  LaserConfig laser;
  TrajectoryConfig trajectory;  ///< base_z = ground height under the start when not given
  std::uint64_t seed = 1;
  std::string variant;                ///< the variant applied, empty for none
  std::vector<std::string> variants;  ///< variants the file offers, in file order
};

/// Parses a scene from YAML text. `variant` (empty = none) merges the named entry of the file's
/// `variants` map over the document before parsing. Returns an error message naming the offending
/// key (empty on success); `out` is valid only on success.
std::string loadSceneFromString(const std::string& yaml, const std::string& variant,
                                SceneFile* out);

/// Same from a file.
std::string loadSceneFromFile(const std::string& path, const std::string& variant, SceneFile* out);

/// Height of the highest ground top face above (x, y), false when there is none.
bool groundHeightAt(const Scene& scene, double x, double y, double* z);

}  // namespace dataset
}  // namespace stereo_safety_map
