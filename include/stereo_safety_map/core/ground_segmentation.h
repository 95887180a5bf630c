// Segmentation of the height map into potentially traversable ground segments (paper 000,
// Sec. V-A, Alg. 1).
//
// ROS-free. A segment is a connected set of columns with the same indexed height; segments are
// grown from the robot's cell, and a new segment may start at any cell whose height differs by at
// most w_T from a neighbour already in a segment. Columns with a height inside the planning radius
// that end up in no segment are non-traversable.
#pragma once

#include "stereo_safety_map/core/height_map.h"
#include "stereo_safety_map/core/voxel_grid.h"

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct GroundSegmentationConfig {
  double planning_radius = 4.0;  ///< R_max [m] (000, Alg. 1 step 3)
  int height_tolerance = 1;      ///< w_T [voxels] (000, Alg. 1 step 13)
  /// Cell neighbourhood of the flood fill, 4 or 8. The paper does not say which; 8 matches the
  /// 8-neighbourhood used for interior / boundary cells in Sec. VI.
  int connectivity = 8;
  /// Seed rule (not in the paper): the camera cannot see under the robot, so its own cell has
  /// usually no height. The seed of the robot's segment is the cell within seed_radius [m] of the
  /// robot's cell whose height differs least from the robot's base indexed height (at most
  /// w_T), the nearest among equals. No such cell: no robot segment and no segments at all.
  double seed_radius = 1.0;
  /// The robot stands on ground (ours; 0 = 000's seed rule alone). The camera cannot see under
  /// the chair, and where the floor has little texture it may not see the floor near it for a
  /// long time; with the seed rule alone there is then no robot segment and the whole map is
  /// unreachable (Non-ground). The cells within footprint_radius [m] of the robot's cell that
  /// have no observed height are ground at the base's indexed height (GroundSegments::footprint):
  /// they belong to the robot's segment. Observed ground at the base's height within
  /// seed_radius still seeds it (as in 000) and the footprint joins that segment; only when none
  /// was observed is the segment seeded on the footprint alone (and SafetyMapper gives a robot
  /// segment without points of its own the level plane of the base). [0, 5] m.
  double footprint_radius = 0.35;
  /// Island segments (ours; false = 000's Alg. 1 alone). Sparse stereo breaks the observed
  /// ground into islands separated by unobserved cells. Alg. 1 grows segments only from the
  /// robot's island, so every column of the others is non-traversable, i.e. Non-ground, though
  /// nothing was seen there but ground. With this on, once Alg. 1 has finished, every column
  /// within R_max that has a height, was never compared with a segment's cell (Alg. 1 steps
  /// 9-16) and looks like ground (its occupied voxels span at most island_max_span voxels, so it
  /// is not the face of an obstacle, and no observed 8-neighbour differs from it by more than
  /// w_T, so it is not beside an obstacle's edge or under a table's) seeds a new segment grown
  /// by the same rules over such columns only, never absorbing a column that Alg. 1 compared
  /// and left out. Alg. 2 judges island segments like
  /// any other: small or thin ones are Unknown, unreachable ones Non-ground.
  bool segment_islands = true;
  int island_max_span = 1;  ///< [voxels], [0, 1000]

  /// Empty when valid, otherwise a message naming the offending parameter and its range.
  std::string validate() const;
};

/// Output of Alg. 1 over a height map's window (cells row-major as in HeightMap / SafetyMap).
struct GroundSegments {
  int min_u = 0, min_v = 0, width = 0, height = 0;
  VoxelIndex robot;        ///< robot's voxel (Eq. (1)); (u, v) is the robot's cell
  int seed_cell = -1;      ///< cell the robot's segment was grown from, -1 when none
  int robot_segment = -1;  ///< 0 when a seed was found (the robot's segment is S_1), else -1

  std::vector<std::int32_t> segment_of;  ///< per cell: segment id, -1 when in none
  std::vector<std::uint8_t> examined;    ///< per cell: 1 within R_max (0 = "not to be examined")
  /// Cells of segment k are segment_cells[segment_begin[k] .. segment_begin[k + 1]).
  std::vector<int> segment_begin;
  std::vector<int> segment_cells;
  std::vector<std::int32_t> segment_height;  ///< indexed height w of each segment
  std::vector<std::uint8_t> segment_island;  ///< per segment: 1 when grown as an island
  /// per cell: 1 on a footprint cell taken as ground at the base's height (no observed height;
  /// GroundSegmentationConfig::footprint_radius). The height map itself is not changed.
  std::vector<std::uint8_t> footprint;
  std::vector<int> non_traversable;  ///< cells with a height, within R_max, in no segment

  int numSegments() const { return static_cast<int>(segment_height.size()); }
  int segmentSize(int k) const { return segment_begin[k + 1] - segment_begin[k]; }
  const int* cellsBegin(int k) const { return segment_cells.data() + segment_begin[k]; }
  const int* cellsEnd(int k) const { return segment_cells.data() + segment_begin[k + 1]; }
  int numCells() const { return width * height; }
  int index(int u, int v) const { return (v - min_v) * width + (u - min_u); }
  bool inside(int u, int v) const {
    return u >= min_u && v >= min_v && u < min_u + width && v < min_v + height;
  }
  int cellU(int cell) const { return min_u + cell % width; }
  int cellV(int cell) const { return min_v + cell / width; }
};

class GroundSegmentation {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit GroundSegmentation(const GroundSegmentationConfig& config = GroundSegmentationConfig());

  const GroundSegmentationConfig& config() const { return config_; }

  /// Alg. 1 (000, Sec. V-A). `robot` is the robot base's voxel index (Eq. (1)); it may lie outside
  /// the height map's window (then no segment is found unless the seed radius reaches into it).
  /// Distances to R_max and the seed radius are measured between cell centres, l_v = voxel_size.
  /// `out`'s buffers are reused. Returns false (out empty, every cell unexamined) when voxel_size
  /// is not positive and finite or out is null.
  bool segment(const HeightMap& height_map, const VoxelIndex& robot, double voxel_size,
               GroundSegments* out);

 private:
  GroundSegmentationConfig config_;
  std::vector<int> to_compare_;         // cells of the current segment whose neighbours are pending
  std::vector<int> pending_;            // L_U of Alg. 1, consumed first-in first-out
  std::vector<std::uint8_t> compared_;  // per cell: a segment's cell had it as a neighbour
  std::vector<std::uint8_t> locked_;    // per cell: compared by Alg. 1 and left out
};

}  // namespace stereo_safety_map
