// Floor seen under an overhang (ours; not in the papers). ROS-free.
//
// Paper 000 calls a column Non-ground when its highest occupied voxel below the robot's top is
// not ground (Sec. V-A): a table top or a shelf board whose voxels are occupied makes the floor
// under it an obstacle. Stereo rarely fills a thin top seen at a grazing angle: the camera of a
// wheelchair (1.1-1.3 m) sees a top at 0.9-1.2 m almost edge-on, block matching finds its front
// edge and sometimes its back edge, and the rays over the top towards the floor and walls beyond
// it clear the top's voxels (000 Sec. IV). The floor under it is seen well, through the gap
// under the front edge, so 000's map calls the floor under the table Level: a chair driving
// there hits the top with the user's knees or chest.
//
// The rule: a safe cell is Non-ground when the camera sees its floor under the top of an
// overhang column at most `max_span` before it on the line of sight (the sight line to the
// floor passes below that column's top). How deep the top reaches behind its front edge is not
// seen (its back edge, at the same grazing angle, is mostly lost too), so the floor seen under
// it is an obstacle for `max_span` behind the edge: a safety map errs on the safe side. An
// "overhang column" has its top at least `min_clearance` above the robot's base and, between
// the floor's band (the base's voxel and the one above it) and the top, at most one more
// occupied voxel (a thick top or a front face) and at least `min_free_voxels` voxels observed
// free (log-odds below the prior: rays passed under the top), so a wall, a pole or a box
// (occupied further down, or never reached below the top) is none. The line of sight is that
// of the last integrated frame. Requiring the top's back edge as well (tried on the open-world
// dev split) almost never fired.
//
// Object permanence for the floor under a roof (`remember`, ours): the line of sight moves with
// the robot, and a cell whose floor was seen under a front edge from one place is seen past it, or
// not at all (hidden by the top), from nearer. With SafetyMapperConfig::obstacle_memory a marked
// cell keeps Non-ground for as long as the top voxel of the roof column that marked it stays
// occupied (issue 15, "object permanence": until free space is observed where the obstacle was):
// rays that clear the roof's own voxel are the free-space evidence that forgets it.
#pragma once

#include "stereo_safety_map/core/height_map.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/core/voxel_grid.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct OverhangRoofConfig {
  bool enabled = true;         ///< SafetyMapperConfig::overhang_roof (ours; false = 000)
  double min_clearance = 0.3;  ///< a roof's top stands at least this above the base [m]
  double max_span = 1.0;       ///< floor this far behind a front edge is under the top [m]
  int min_free_voxels = 2;     ///< voxels observed free below an overhang column's top
  bool remember = true;        ///< marked cells join the obstacle memory (see above; ours)

  std::string validate() const;
};

/// A cell marked by markFloorUnderOverhangs() and the roof column that marked it (grid indices).
struct OverhangRoofMark {
  int cell = -1;                                    ///< index of the marked cell in the map
  std::int32_t roof_u = 0, roof_v = 0, roof_w = 0;  ///< the roof column's top voxel
};

/// Buffers reused from frame to frame.
struct OverhangRoofScratch {
  std::vector<float> roof_z;  ///< per cell: the overhang column's top [m], NaN when none
  std::vector<std::int32_t> top_w;
  std::vector<OverhangRoofMark> marks;  ///< the last call's marked cells, in cell order
};

/// Marks the safe cells of `map` (laid out as `hm`) whose floor `camera` (fixed frame) sees
/// under an overhang's top (see above) Non-ground, clearing their drop-off flag.
/// `base_z` is the robot base's height. Returns the number of cells marked; scratch->marks lists
/// them with their roof columns.
int markFloorUnderOverhangs(const VoxelGrid& grid, const HeightMap& hm,
                            const Eigen::Vector3f& camera, float base_z,
                            const OverhangRoofConfig& config, SafetyMap* map,
                            OverhangRoofScratch* scratch);

}  // namespace stereo_safety_map
