// Segmentation of the height map into potentially traversable ground segments (paper 000,
// Sec. V-A, Alg. 1).
//
// ROS-free. A segment is a connected set of columns with the same indexed height; segments are
// grown from the robot's cell, and a new segment may start at any cell whose height differs by at
// most w_T from a neighbour already in a segment. Columns with a height inside the planning radius
// that end up in no segment are non-traversable.
// GroundSegmentationConfig::split_steps (ours) then splits a segment at a step lower than a voxel.
#pragma once

#include "stereo_safety_map/core/height_map.h"
#include "stereo_safety_map/core/voxel_grid.h"

#include <cstdint>
#include <limits>
#include <string>
#include <utility>
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
  /// was observed is the segment seeded on the footprint alone. SafetyMapper gives a robot
  /// segment that holds footprint cells but has no plane of its own (no points, or a few in a
  /// strip) the level plane of the base. [0, 5] m.
  double footprint_radius = 0.35;
  /// The seed's height is the ground the robot stands on (ours; false = the seed rule above
  /// alone). A floor seen only from afar reads centimetres high (an unreported chassis pitch
  /// lifts it by range x tilt, the occupied voxel at the top of a column holds the upper tail of
  /// the noise), and when the robot drives onto it the columns around the base may sit one
  /// voxel above the base's index while a stray column or two still sit at the base's. The
  /// least-difference rule then seeds the robot's segment on those stray columns, and the
  /// whole floor the robot stands on is a second segment, unreachable (Non-ground): the map
  /// says the chair cannot move. With this on, the seed's indexed height is the one (within
  /// w_T of the base's) held by the most cells within footprint_radius of the robot's cell
  /// (observed cells at their height, unobserved footprint cells at the base's), ties to the
  /// one nearer the base's; the seed cell is then chosen among the cells of that height by
  /// the rule above. Under a wheelchair the footprint disk is the ground it stands on; a step
  /// beside the chair holds a few of its cells at most. Needs footprint_radius > 0; with no
  /// candidate in the disk the rule above applies alone.
  /// A support one index or more off the base's is taken only when the chair could stand on it:
  /// the median ground height of its cells in the disk (HeightMap::groundHeightAtIndex, else the
  /// surface height) lies within seed_support_max_offset [m] of the base's height (segment()'s
  /// base_z). A floor that reads farther off the wheels than that is a map whose heights
  /// cannot be trusted near the robot: low steps and boxes sit in the floor's band there, and
  /// the rule above (the floor unreachable, Non-ground) is the safe answer. [0, 1] m.
  ///
  /// Off by default (measured, docs/evaluation.md "The ground the chair stands on"): on the
  /// open-world dev split (default degradations) it took FP from 21.7 to 18.3 % but FN from
  /// 1.47 to 1.76 % and forgotten obstacle cells from 49 to 63: where the floor reads a voxel
  /// high, an 8.5 cm box and a 6 cm step up read 3-4 cm above it and join the floor's segment,
  /// Level. The whole-floor Non-ground it removes is the safe answer to heights that are off by
  /// as much as the hazards. With a perfect pose FP 11.8 -> 11.4 %, FN unchanged.
  bool seed_on_support = false;
  double seed_support_max_offset = 0.05;
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
  /// Steps inside a segment (ours; false = 000's Alg. 1 alone). A segment is a band of one
  /// indexed height, l_v = 0.1 m high, so a step lower than l_v but higher than h_T (6 cm down
  /// into a sunken area) often lies inside one band: the lower floor's points that reach into
  /// the upper floor's voxel (the upper tail of its stereo noise) make that voxel its columns'
  /// top, Alg. 1 grows one segment over both levels, and the plane fitted to it is level across
  /// the step. With this on, once Alg. 1 has finished, every segment with at least
  /// 2 split_min_cells ground-like columns (occupied voxels spanning at most one voxel and a
  /// ground height; footprint cells are not asked) is tested for a step:
  /// 1. the columns' ground heights (HeightMap::groundHeightAtIndex: the points of the top two
  ///    voxels, not cut off at the band's bottom) are split in two at Otsu's threshold (the cut
  ///    that maximises the variance between the two sides);
  /// 2. connected parts of a side smaller than split_min_cells join the other side (noise, not a
  ///    level), then each column goes to the side whose least-squares plane is nearer its ground
  ///    height, three times (an unreported chassis pitch tilts the map's floor by centimetres
  ///    over R_max: two planes follow two levels on a tilted floor, one threshold does not);
  /// 3. the side that stays is the robot's (the seed cell's side, else the side whose plane is
  ///    nearer the base's height) or, for other segments, the larger; every connected part of
  ///    the other side is judged alone: at each of its border cells the local planes of the
  ///    two sides are fitted to their columns 1 to 4 cells from the border (border columns mix
  ///    both levels' points) within 4 cells, and when their difference at the median border
  ///    cell exceeds split_min_step the part becomes a segment of its own
  ///    (GroundSegments::segment_split_from). Across a ramp the local planes agree, so a ramp is
  ///    never split.
  /// Alg. 2 then judges the new borders by the two sides' planes (fitted with one layer of
  /// vertical margin, PlaneFitConfig) and h_T, like any other border.
  bool split_steps = true;
  /// [m], (0, 10]. 0.04, below h_T: the estimate reads a 6 cm step 5-6 cm (border mixing, the
  /// 8-point voxel lists); Alg. 2's h_T test on the planes decides whether a split step is
  /// crossable (dev split: FN 4.17 -> 3.94 % with 0.05 -> 0.04, FP 21.07 -> 21.12 %).
  double split_min_step = 0.04;
  int split_min_cells = 10;  ///< [cells], [1, 100000]

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
  /// per segment: the segment it was split from at a step (GroundSegmentationConfig::
  /// split_steps), -1 when none. A split's sides have the same indexed height.
  std::vector<std::int32_t> segment_split_from;
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
  /// True when one of segments a and b was split from the other or both from the same segment
  /// (GroundSegmentationConfig::split_steps): their border is a step the split measured.
  bool splitSiblings(int a, int b) const {
    const int n = static_cast<int>(segment_split_from.size());
    if (a < 0 || b < 0 || a >= n || b >= n || a == b) return false;
    const int pa = segment_split_from[a], pb = segment_split_from[b];
    return pa == b || pb == a || (pa >= 0 && pa == pb);
  }
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
  /// base_z: the base's height [m] (seed_on_support's offset test; NaN: a support off the base's
  /// index is never taken).
  bool segment(const HeightMap& height_map, const VoxelIndex& robot, double voxel_size,
               GroundSegments* out, float base_z = std::numeric_limits<float>::quiet_NaN());

 private:
  GroundSegmentationConfig config_;
  std::vector<int> to_compare_;         // cells of the current segment whose neighbours are pending
  std::vector<int> pending_;            // L_U of Alg. 1, consumed first-in first-out
  std::vector<int> disk_;               // examined cells within footprint_radius of the robot
  std::vector<int> support_count_;      // seed_on_support: footprint cells per indexed height
  std::vector<float> support_z_;        // seed_on_support: ground heights of the support's cells
  std::vector<std::uint8_t> compared_;  // per cell: a segment's cell had it as a neighbour
  std::vector<std::uint8_t> locked_;    // per cell: compared by Alg. 1 and left out
  // split_steps: tests every segment for a step and splits it (see the config).
  void splitSteps(const HeightMap& hm, double voxel_size, GroundSegments* out);
  std::vector<int> split_cols_;                   // the tested segment's ground-like columns
  std::vector<std::pair<float, int>> split_res_;  // their ground heights, sorted
  std::vector<std::int8_t> split_side_;           // per cell: 0 low, 1 high, -1 not asked
  std::vector<int> split_stack_;                  // flood fill of a side's connected parts
  std::vector<int> split_part_;                   // per cell: connected part id, -1 none
  std::vector<int> split_part_size_;
  std::vector<int> split_part_cells_;
  std::vector<float> split_diffs_;
  std::vector<int> split_queue_;              // border cells first, then the band's
  std::vector<std::int8_t> split_dist_;       // per cell: 8-neighbour steps from the sides' border
  static constexpr int kSplitBand = 4;        // [cells] of each side fitted beside the border
  static constexpr int kSplitIterations = 3;  // two-plane reassignments after Otsu's split
  static constexpr int kSplitWindow = 4;      // [cells] half-width of a border cell's local fits
  static constexpr std::int8_t kSplitFar = 100;
};

}  // namespace stereo_safety_map
