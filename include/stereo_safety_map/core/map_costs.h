// What a planner reads from the safety map: the one cost table from 000's labels to
// nav_msgs/OccupancyGrid values, the same costs as map_server's raw PGM (~save), the lethal cells
// (the safety_obstacles cloud), what costmap_2d's static layer makes of a value, and the check
// that keeps ~save inside its directory. ROS-free: the nodelet (ros/conversions.h) and the tests
// call these.
//
// The table (defaults; CostTable holds the configurable rows):
//
//   label / annotation             value         why
//   Level                          cost_level (0)              safe (000 Sec. I-A)
//   Inclined                       cost_inclined_low (10) at theta_T rising linearly with the
//                                  plane's slope to cost_inclined_high (50) at theta_max; safe
//                                  (000 Sec. I-A, Alg. 2 step 28) and always below lethal (<= 99)
//   potential drop-off edge        cost_drop_off (100)         000 Sec. I-A / VI: "a drop-off is
//   (on Level / Inclined)                                      expected in the vicinity"; falling
//                                                              off is catastrophic (000 Sec. I), so
//                                                              lethal until observed further
//   Non-ground                     100 (fixed)                 unsafe (000 Sec. I-A): obstacle,
//                                                              overhang, lower than nearby ground
//   Unknown, Unexamined            -1 (fixed)                  insufficient information
//
// Safe default: nothing hazardous reads as free. costmap_2d's static layer with its default
// trinary_costmap: true turns every value below lethal_cost_threshold (100) into free space, so
// drop-off edges and Non-ground are 100; a cost_drop_off below 100 needs trinary_costmap: false.
#pragma once

#include "stereo_safety_map/core/safety_map.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

/// The configurable rows of the cost table (parameters cost_level, cost_inclined_low,
/// cost_inclined_high, cost_drop_off of the safety-map nodelet).
struct CostTable {
  static constexpr int kLethal = 100;    ///< Non-ground; OccupancyGrid's "occupied"
  static constexpr int kUnknown = -1;    ///< Unknown and Unexamined
  static constexpr int kMaxGraded = 99;  ///< highest non-lethal cost

  int level = 0;           ///< [0, 99]
  int inclined_low = 10;   ///< [level, 99]: Inclined at theta_T
  int inclined_high = 50;  ///< [inclined_low, 99]: Inclined at theta_max
  int drop_off = 100;      ///< [1, 100]: potential drop-off edges (000 Sec. VI)

  /// Empty when valid, otherwise a message naming the parameter and its range.
  std::string validate() const;
};

/// OccupancyGrid value of one cell. `slope_deg` is the slope of the cell's segment plane (used by
/// Inclined; a non-finite slope reads as theta_T), `level_slope_deg` / `max_slope_deg` are
/// theta_T / theta_max. A label outside the enum reads as Unknown.
std::int8_t cellCost(const CostTable& table, SafetyLabel label, bool drop_off, double slope_deg,
                     double level_slope_deg, double max_slope_deg);

/// The costs of every cell of `map`, in the map's row-major order (the OccupancyGrid's data).
/// `out` is reused.
void safetyMapCosts(const SafetyMap& map, const CostTable& table, double level_slope_deg,
                    double max_slope_deg, std::vector<std::int8_t>* out);

/// The same costs as a binary PGM for map_server's `mode: raw` (pixel = value, 255 = -1; image
/// row 0 is the map's top row, largest y), so that map_server serves exactly the live map.
std::string costsToRawPgm(const std::vector<std::int8_t>& costs, int width, int height);

/// Reads a PGM as map_server's raw mode does (value = pixel, as int8: 255 -> -1; rows flipped
/// back). Empty string on success. For tests and tools.
std::string rawPgmToCosts(const std::string& pgm, std::vector<std::int8_t>* costs, int* width,
                          int* height);

/// Centres of the cells whose cost is lethal (>= 100), at height `z`, fixed frame: the
/// safety_obstacles cloud a costmap's obstacle layer marks (and ray-traces to). `out` is reused.
void lethalCellPoints(const SafetyMap& map, const std::vector<std::int8_t>& costs, float z,
                      std::vector<Eigen::Vector3f>* out);

// ---------------------------------------------------------------------------------------------
// costmap_2d's static layer (StaticLayer::interpretValue, navigation 1.16/1.17), for the tests and
// the README: what a costmap makes of an OccupancyGrid value.

struct StaticLayerSettings {
  bool trinary_costmap = true;
  int lethal_cost_threshold = 100;
  int unknown_cost_value = -1;
  bool track_unknown_space = true;
};
constexpr unsigned char kCostmapFreeSpace = 0;
constexpr unsigned char kCostmapLethal = 254;
constexpr unsigned char kCostmapNoInformation = 255;

/// The static layer's cost of a map value: NO_INFORMATION for the unknown value (FREE_SPACE
/// without track_unknown_space), LETHAL at or above the threshold, FREE_SPACE below it when
/// trinary, else value / threshold * 254. Values are compared as unsigned char, as it does.
unsigned char staticLayerCost(std::int8_t value, const StaticLayerSettings& settings);

// ---------------------------------------------------------------------------------------------
// ~save's files stay under save_directory.

/// Resolves a ~save prefix against `directory` (absolute): a relative prefix is under it, an
/// absolute one must lie inside it. Symlinks in the existing part of the path are followed, and
/// a prefix whose directory leaves `directory` (`..`, an absolute path elsewhere, a symlink out)
/// is refused, as is a prefix without a file name. On success `*resolved` is the absolute prefix
/// (its directory may not exist yet) and the return value is empty; otherwise a message.
std::string resolveSavePrefix(const std::string& directory, const std::string& prefix,
                              std::string* resolved);

}  // namespace stereo_safety_map
