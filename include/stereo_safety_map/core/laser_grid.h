// 2D log-odds occupancy grid from a planar laser range-finder (paper 001, Sec. 3).
//
// 001 uses the lasers for "localization and mapping of obstacles in the 2D laser plane" and
// takes from that process "a 2D occupancy grid map of the world with uncertain (unknown) regions
// marked". This is that grid: each beam is ray cast from the laser's position over the cells it
// crosses (free) to the cell of its return (occupied), in log-odds (000 Sec. IV uses the same
// update for its voxels). The grid uses the cell convention of the safety map, so that the two
// align cell for cell: cell (u, v) is centred at (u * resolution, v * resolution) in the fixed
// frame (000 Eq. (1)), and the window [min_u, min_u + width) x [min_v, min_v + height) scrolls
// with the robot in a ring buffer (no memory moves; cells that leave are cleared).
//
// Each beam is projected on the fixed frame's xy plane, which assumes a laser mounted about
// level, as on 001's robot. Input is a sensor_msgs/LaserScan in plain arrays (the ROS layer
// passes msg.ranges straight through): NaN and readings below range_min are skipped, +inf and
// readings at or beyond range_max are "no return" and, when clear_no_return is set, clear the
// beam up to range_max (REP 117).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

/// Geometry and sensor model. 001 gives no laser-grid numbers (its grid comes from [15]); the
/// geometry defaults match 000's 10 x 10 m map at l_v = 0.1 m, the log-odds are the common
/// p_hit = 0.7, p_miss = 0.4.
struct LaserGridConfig {
  double resolution = 0.1;      ///< cell side [m], (0, inf); use the safety map's l_v (000 Sec. IV)
  int width = 100;              ///< cells along x (u), [1, 100000]
  int height = 100;             ///< cells along y (v), [1, 100000]
  double log_odds_hit = 0.85;   ///< added to the return's cell, logit(0.7), (0, inf)
  double log_odds_miss = -0.4;  ///< added to each crossed cell, logit(0.4), (-inf, 0)
  double log_odds_min = -2.0;   ///< clamp, (-inf, free_threshold]
  double log_odds_max = 3.5;    ///< clamp, [occupied_threshold, inf)
  double occupied_threshold = 0.5;  ///< Occupied at log-odds >= this, (0, log_odds_max]
  double free_threshold = -0.3;     ///< Free at log-odds <= this, [log_odds_min, 0)
  bool clear_no_return = true;      ///< beams without a return clear free space to range_max

  /// Empty when valid, otherwise a message naming the first offending parameter and its range.
  std::string validate() const;
};

enum class LaserCellState : std::uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

/// The geometry fields of a sensor_msgs/LaserScan. Beam i points at angle_min + i *
/// angle_increment in the laser frame's xy plane, counter-clockwise from x.
struct LaserScanInfo {
  double angle_min = 0.0;        ///< [rad]
  double angle_increment = 0.0;  ///< [rad], non-zero
  double range_min = 0.0;        ///< [m], >= 0
  double range_max = 0.0;        ///< [m], > range_min
};

/// Counters of one integrate() call.
struct LaserIntegrationStats {
  std::size_t beams = 0;
  std::size_t returns = 0;         ///< beams with a valid return (range_min <= r < range_max)
  std::size_t no_return = 0;       ///< +inf or >= range_max
  std::size_t invalid = 0;         ///< NaN, -inf or below range_min: skipped
  std::size_t cells_occupied = 0;  ///< cells given a hit update (once per scan)
  std::size_t cells_freed = 0;     ///< cells given a miss update (once per scan)
  bool rejected = false;           ///< bad scan geometry or non-finite pose: nothing changed
};

class LaserGrid {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty. The window starts at
  /// min_u = -width / 2, min_v = -height / 2 (centred on the origin).
  explicit LaserGrid(const LaserGridConfig& config = LaserGridConfig());

  const LaserGridConfig& config() const { return config_; }
  int minU() const { return min_u_; }
  int minV() const { return min_v_; }
  int width() const { return config_.width; }
  int height() const { return config_.height; }
  double resolution() const { return config_.resolution; }

  /// Cell of a fixed-frame coordinate: round(x / resolution) (000 Eq. (1)).
  int cellU(double x) const;
  int cellV(double y) const;
  bool inside(int u, int v) const {
    return u >= min_u_ && v >= min_v_ && u < min_u_ + config_.width && v < min_v_ + config_.height;
  }

  /// Scrolls the window to start at (min_u, min_v); cells that leave it are cleared and reused
  /// for those that enter. Returns the number of cells cleared.
  std::size_t moveTo(int min_u, int min_v);
  /// Scrolls the window so that (x, y) is in its centre cell.
  std::size_t recenter(double x, double y);
  /// Clears every cell; keeps the window.
  void clear();

  /// Integrates one scan taken from T_fixed_laser (laser frame to fixed frame). A cell is
  /// updated at most once per scan, and a return wins over a beam crossing it.
  LaserIntegrationStats integrate(const LaserScanInfo& scan, const std::vector<float>& ranges,
                                  const Eigen::Isometry3f& T_fixed_laser);

  /// Log-odds of a cell; 0 outside the window.
  float logOdds(int u, int v) const;
  /// Occupied / Free by the thresholds, otherwise (or outside the window) Unknown.
  LaserCellState state(int u, int v) const;
  LaserCellState stateAt(double x, double y) const { return state(cellU(x), cellV(y)); }

  /// Sets a cell's log-odds (clamped); ignored outside the window. For tests and external cues.
  void setLogOdds(int u, int v, float log_odds);

 private:
  std::size_t storageIndex(int u, int v) const;  // (u, v) inside the window
  void clearColumn(int u);                       // global u, inside the window
  void clearRow(int v);                          // global v, inside the window
  // Ray from a to b in cell coordinates (cell u spans [u, u + 1)); marks crossed cells free,
  // the end cell too unless end_is_hit.
  void castRay(double ax, double ay, double bx, double by, bool end_is_hit,
               LaserIntegrationStats* stats);
  void applyMiss(int u, int v, LaserIntegrationStats* stats);

  LaserGridConfig config_;
  int min_u_ = 0, min_v_ = 0;
  std::vector<float> log_odds_;
  std::vector<std::uint32_t> hit_scan_;   // scan in which the cell last got its hit update
  std::vector<std::uint32_t> miss_scan_;  // scan in which the cell last got its miss update
  std::uint32_t scan_ = 0;

  struct Endpoint {
    float x, y;  // cell coordinates
    bool hit;
  };
  std::vector<Endpoint> endpoints_;  // reused per scan
};

}  // namespace stereo_safety_map
