// The laser + stereo hybrid local safety map (paper 001, Sec. 2 and 5).
//
// 001 Sec. 2.1 classes the world as Obstacle, Hazard (overhangs, drop-offs, steep inclines),
// Caution (inclines, narrow regions), Unknown and Safe. Sec. 5 builds the merged map as:
// obstacles are seen by the lasers and by vision, hazards are invisible to the lasers but seen
// by vision (a table top over legs the laser sees), safe is clear to the lasers with ground seen
// by vision, unknown is unknown to both. Vision here is paper 000's SafetyMap (Alg. 2 labels,
// on the same (u, v) cells); the laser is the LaserGrid of 001 Sec. 3.
//
// Merged map, per cell (vision label of 000 across, laser state of 001 Sec. 3 down):
//
//   laser \ vision | Non-ground | Inclined   | Level       | Unknown / Unexamined
//   ---------------+------------+------------+-------------+---------------------
//   Occupied       | Obstacle   | Obstacle   | Obstacle    | Obstacle
//   Free           | Hazard     | Caution    | Safe        | Unknown   (a)
//   Unknown        | Hazard     | Caution(b) | Safe (b)    | Unknown
//
//   - Occupied is an Obstacle whatever vision says: the laser is the more accurate sensor
//     (001 Sec. 5) and sees what stereo misses (glass, thin poles, textureless walls; 001
//     Table 1). With vision Non-ground it is 001's "seen by both".
//   - Non-ground not seen by the laser is a Hazard: 000's Non-ground holds overhangs below robot
//     height, slopes beyond theta_max and unreachable (lower) ground, i.e. the vision-only
//     obstacles, drop-offs and steep inclines of 001 Sec. 2.1.
//   - Inclined (theta_T < slope <= theta_max, 000 Alg. 2 step 28) is Caution (001 Sec. 2.1;
//     001's own experiments assumed level floors and had no Caution class).
//   - (a) The laser cannot see drop-offs (001 Sec. 1), so laser-free space that vision has not
//     examined stays Unknown unless laser_free_vision_unknown_is_safe is set.
//   - (b) Vision sees the ground and everything up to robot height in the column; a laser that
//     has no information there (outside its field of view, in its shadow) adds nothing, so the
//     cell keeps its vision class. laser_free_required_for_safe makes these cells Unknown, 001's
//     literal "clear to the lasers and ... ground plane" reading.
// Then, on the result:
//   - Safe and Caution cells on a Potential Drop-off Edge (000 Sec. VI) become Hazard when
//     drop_off_edges_are_hazard is set (default, ours), else Safe ones become Caution when
//     drop_off_edges_are_caution is set: 000 asks for them to be treated as needing observation.
//   - Safe cells in a passage narrower than min_passage_width become Caution (001 Sec. 2.1,
//     "narrow regions", e.g. doorways): along one of the directions 0, 45, 90 or 135 degrees,
//     the run of cells through the cell that are neither Obstacle nor Hazard is closed by
//     Obstacle / Hazard cells at both ends and shorter than min_passage_width. (A distance
//     transform opening, "no robot-sized disc fits here", misses the canonical case, a doorway
//     in a thin wall, which discs from both rooms reach into; a passage crossed at an angle
//     between the four directions measures up to 1 / cos(22.5 deg) = 8 % wide.)
//
// The single-sensor maps of 001 Sec. 5 use the same classes, so that all three can be scored
// against one ground truth:
//   - laser-only: Occupied -> Obstacle, Free -> Safe ("since the lasers cannot see the ground,
//     clear areas are considered safe"), Unknown -> Unknown;
//   - stereo-only: Non-ground -> Obstacle (001 does "not distinguish between hazards and
//     obstacles" there), Inclined -> Caution, Level -> Safe, Unknown / Unexamined -> Unknown;
// the narrow-passage rule applies to all three (with each map's own Obstacle / Hazard cells as
// walls), the drop-off rule to the two that have vision.
#pragma once

#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/laser_grid.h"
#include "stereo_safety_map/core/safety_map.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

/// Cell classes of 001 Sec. 2.1. Values are stable (they may travel in messages and files).
enum class HybridLabel : std::uint8_t {
  kUnknown = 0,   ///< insufficient data
  kSafe = 1,      ///< traversable
  kCaution = 2,   ///< traversable with care: inclines, narrow passages, drop-off edges
  kHazard = 3,    ///< seen by vision only: overhangs, drop-offs, steep inclines
  kObstacle = 4,  ///< in the laser plane (and usually seen by vision too)
};

const char* toString(HybridLabel label);
struct HybridSafetyMapConfig;
/// nav_msgs/OccupancyGrid value of a class, one explicit table: Unknown -1, Safe 0, Caution
/// `caution_cost` (50), Hazard `hazard_cost` (100: lethal, 001 Sec. 2.1's hazards, drop-offs
/// among them, are as dangerous as obstacles), Obstacle 100.
std::int8_t toOccupancyValue(HybridLabel label, const HybridSafetyMapConfig& config);
/// Safe and Caution cells may be driven on.
inline bool isTraversable(HybridLabel l) {
  return l == HybridLabel::kSafe || l == HybridLabel::kCaution;
}

/// Which sensors a map is built from (001 Sec. 5 compares all three).
enum class HybridSource : std::uint8_t { kMerged = 0, kLaserOnly = 1, kStereoOnly = 2 };

/// A hybrid safety map on the (u, v) cells of 000's SafetyMap: row-major,
/// index = (v - min_v) * width + (u - min_u), cell (u, v) centred at (u, v) * resolution.
struct HybridSafetyMap {
  int min_u = 0;
  int min_v = 0;
  int width = 0;
  int height = 0;
  double resolution = 0.1;
  std::vector<HybridLabel> labels;

  int index(int u, int v) const { return (v - min_v) * width + (u - min_u); }
  bool inside(int u, int v) const {
    return u >= min_u && v >= min_v && u < min_u + width && v < min_v + height;
  }
  /// Unknown outside the map.
  HybridLabel labelAt(int u, int v) const {
    return inside(u, v) ? labels[index(u, v)] : HybridLabel::kUnknown;
  }
};

struct HybridSafetyMapConfig {
  /// Turn Safe cells of passages narrower than min_passage_width into Caution.
  bool detect_narrow_passages = true;
  /// [m], (0, 100]. 0.915 m = 36 in, the ADA minimum clear width for continuous wheelchair
  /// passage (001 cites the ADA standards, [17]).
  double min_passage_width = 0.915;
  /// Safe cells on 000's Potential Drop-off Edges become Caution (with
  /// drop_off_edges_are_hazard off).
  bool drop_off_edges_are_caution = true;
  /// Safe and Caution cells on 000's Potential Drop-off Edges become Hazard (ours; the safe
  /// default: a Caution cost reads as free to a trinary costmap, and a chair must not roll onto
  /// an edge it has not observed; false = Caution as 000 Sec. VI's "needs observation").
  bool drop_off_edges_are_hazard = true;
  /// Footnote (b) of the table: Level / Inclined need laser Free to be Safe / Caution.
  bool laser_free_required_for_safe = false;
  /// Footnote (a) of the table: laser Free with no vision information is Safe, not Unknown.
  bool laser_free_vision_unknown_is_safe = false;
  /// OccupancyGrid value of Hazard cells, [1, 100]; 100 = lethal (001 Sec. 2.1: overhangs,
  /// drop-offs, steep inclines). Below 100 a costmap needs trinary_costmap: false.
  int hazard_cost = 100;
  /// OccupancyGrid value of Caution cells, [0, 99] (001 Sec. 2.1: drivable with care).
  int caution_cost = 50;

  /// Empty when valid, otherwise a message naming the first offending parameter and its range.
  std::string validate() const;
};

class HybridSafetyMapBuilder {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit HybridSafetyMapBuilder(const HybridSafetyMapConfig& config = HybridSafetyMapConfig());

  const HybridSafetyMapConfig& config() const { return config_; }

  /// Builds the map of `source` (see the table above) into `out`, on the cells of `vision`;
  /// when `vision` is empty or inconsistent (labels.size() != width * height), on the cells of
  /// `laser` with every vision label Unknown. Laser states are looked up at each cell's centre,
  /// so the laser grid need not share the map's window or resolution. `out` is reused.
  void build(HybridSource source, const SafetyMap& vision, const LaserGrid& laser,
             HybridSafetyMap* out);

 private:
  void markNarrowPassages(HybridSafetyMap* map);

  HybridSafetyMapConfig config_;
  // Reused buffers of markNarrowPassages().
  std::vector<std::uint8_t> narrow_, bounded_back_, bounded_fwd_;
  std::vector<std::int32_t> run_back_, run_fwd_;
};

/// The evaluation class of a hybrid label (evaluation_metrics.h): Safe and Caution are safe
/// (traversable, as 000 counts Level and Inclined), Obstacle and Hazard unsafe, Unknown
/// unclassified.
SafetyClass safetyClassOf(HybridLabel label);

/// Counts `map` against `ground_truth` cell by cell on the shared (u, v) indexing, with the
/// conventions of countConfusion() in evaluation_metrics.h (unsafe positive; a cell counts only
/// when both classify it; map cells outside the ground truth are unclassified in it), so that
/// safeClassScores(*counts) gives the precision / recall / F1 of 001 Sec. 5, Table 2, for the
/// merged, laser-only and stereo-only maps alike. Adds to *counts (maps += 1). Returns an error
/// (and counts nothing) when a map is inconsistent or the resolutions differ.
std::string countHybridConfusion(const HybridSafetyMap& map, const HybridSafetyMap& ground_truth,
                                 ConfusionCounts* counts);

}  // namespace stereo_safety_map
