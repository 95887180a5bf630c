// Evaluation of the 2D stereo occupancy grid of paper 002 against a safety-map ground truth, with
// the conventions of the safety map's evaluation (evaluation_metrics.h, 000 Sec. VII), so that
// the two mappers are measured on the same cells with the same counts. ROS-free.
//
// The grid is read with the paper's planning thresholds (002 Sec. 3.4): a cell is *occupied*
// when G > occupied_threshold, *free* when G < free_threshold, and unclassified in between.
// Occupied plays the part of Non-ground (unsafe, the positive class), free that of Level (safe):
//   TP  occupied, GT Non-ground      FP  occupied, GT Level / Inclined
//   FN  free,     GT Non-ground      TN  free,     GT Level / Inclined
// so obstacle recall = TP / (TP + FN) = 1 - FN rate and precision = TP / (TP + FP). Cells are
// matched by their global index (u, v), centred at (u l, v l) in both grids (000 Eq. (1)).
//
// A 2D obstacle grid only sees things standing in the height band; GT Non-ground cells also come
// from terrain the robot must not enter (drop-offs, steps up, ramps too steep, 000 Alg. 2). The
// per-cause counts say which of them the grid misses or even calls free.
#pragma once

#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/occupancy_grid_2d.h"
#include "stereo_safety_map/core/safety_map.h"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

/// The window of `grid` as a SafetyMap (labels only): occupied -> Non-ground, free -> Level,
/// neither -> Unknown; cells whose centre is farther than `radius` from `robot_xy` -> Unexamined
/// (radius <= 0 or not finite: no limit), like the safety map's R_max (000 Alg. 1 step 3).
/// `out` is resized and reused; segments, drop-off edges and heights stay empty / unset.
void occupancyGridAsSafetyMap(const OccupancyGrid2D& grid, const Eigen::Vector2f& robot_xy,
                              double radius, SafetyMap* out);

/// Why a ground-truth cell is Non-ground (000 Alg. 2 labels, as the dataset's ground truth
/// derives them). kNotUnsafe for cells that are not Non-ground.
enum class UnsafeCause : std::uint8_t {
  kNotUnsafe = 0,
  kObstacle = 1,      ///< something between clearance and robot height stands on the cell
  kTooSteep = 2,      ///< ground steeper than theta_max (000 Alg. 2 step 2)
  kLowerGround = 3,   ///< unreachable ground lower than the robot's: the low side of a drop-off
  kRaisedGround = 4,  ///< unreachable ground higher than the robot's: a step or curb up
  kUnreachable = 5,   ///< unreachable ground at the robot's height (enclosed)
};
constexpr int kNumUnsafeCauses = 6;
const char* toString(UnsafeCause cause);

/// Outcome counts of GT Non-ground cells split by cause (indexed by UnsafeCause). "free" is the
/// dangerous miss: the grid tells the planner it may drive there.
struct UnsafeCauseCounts {
  std::array<std::uint64_t, kNumUnsafeCauses> occupied{};      ///< TP
  std::array<std::uint64_t, kNumUnsafeCauses> free{};          ///< FN
  std::array<std::uint64_t, kNumUnsafeCauses> unclassified{};  ///< neither (or Unexamined)
  UnsafeCauseCounts& operator+=(const UnsafeCauseCounts& o);
};

/// Adds the outcomes of `map` (as from countConfusion(map, truth, ...)) to `counts` by the
/// cause of each GT cell. `causes` is indexed like truth.labels (one per GT cell). Map cells that
/// are Unexamined (outside the evaluated radius) are not counted. Returns an error (and counts
/// nothing) when the sizes do not match.
std::string countUnsafeCauses(const SafetyMap& map, const LabelGrid& truth,
                              const std::vector<UnsafeCause>& causes, UnsafeCauseCounts* counts);

/// How a map treats the GT's drop-off edges: safe cells next to ground lower by at least h_T
/// (000 Sec. VI "potential drop-off edges"). A 2D obstacle grid has no way to mark them: it can
/// only call them free, occupied or unknown; the safety map marks them (SafetyMap::drop_off).
struct DropOffEdgeCounts {
  std::uint64_t marked = 0;         ///< safe in the map and marked as a potential drop-off edge
  std::uint64_t safe_unmarked = 0;  ///< safe (free) in the map without a mark: the dangerous case
  std::uint64_t unsafe = 0;         ///< Non-ground (occupied) in the map
  std::uint64_t unclassified = 0;   ///< Unknown in the map
  std::uint64_t total() const { return marked + safe_unmarked + unsafe + unclassified; }
  DropOffEdgeCounts& operator+=(const DropOffEdgeCounts& o);
};

/// Adds how `map` labels the GT cells with edge[k] != 0 (indexed like truth.labels). Unexamined
/// map cells and GT cells outside the map are not counted. Empty on success.
std::string countDropOffEdges(const SafetyMap& map, const LabelGrid& truth,
                              const std::vector<std::uint8_t>& edge, DropOffEdgeCounts* counts);

/// 002's counterpart of boardWidthCoverage() (000 Sec. VII-B latency): how much of the board's
/// width is occupied in the 2D grid. The width is sampled every grid cell (bin centres); a sample
/// is covered when the grid cell under it is occupied, or one within one cell in front of or
/// behind the board (stereo's depth error, the slack of the 3D version): the sample is probed
/// every half cell across the board's thickness plus that slack.
BoardCoverage boardWidthCoverage2D(const OccupancyGrid2D& grid, const BoardBox& board);

}  // namespace stereo_safety_map
