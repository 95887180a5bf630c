// The local safety map: a 2D grid of safety labels over the voxel grid's (u, v) cells, with the
// ground segments and their planes (paper 000, Sec. VI, Fig. 4(a)).
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace stereo_safety_map {

/// Cell and segment labels of 000 Sec. I-A / Alg. 2. Values are stable: they travel in
/// stereo_safety_map/SafetyMap messages and in saved files.
enum class SafetyLabel : std::uint8_t {
  kUnexamined = 0,  ///< beyond the planning radius R_max (000 Alg. 1 step 3)
  kUnknown = 1,     ///< no or too little information (no data, small or thin segments)
  kLevel = 2,       ///< safe, slope <= theta_T
  kInclined = 3,    ///< safe, theta_T < slope <= theta_max
  kNonGround = 4,   ///< obstacle, overhang below robot height, too steep, or unreachable
};

inline bool isSafe(SafetyLabel l) {
  return l == SafetyLabel::kLevel || l == SafetyLabel::kInclined;
}
const char* toString(SafetyLabel l);

/// A least-squares plane z = a x + b y + c fitted to one ground segment (000 Sec. V-B).
struct GroundPlane {
  bool valid = false;  ///< false when the segment had too few / degenerate points
  double a = 0.0;      ///< p_s1
  double b = 0.0;      ///< p_s2
  double c = 0.0;      ///< p_s3
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, pointing up
  double slope_deg = 0.0;                             ///< angle between the normal and the vertical
  double residual_rms = 0.0;                          ///< RMS of z residuals [m]
  std::size_t num_points = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< of the fitted points
  /// Not fitted: the base's level plane that SafetyMapper gives a robot segment that holds the
  /// footprint but has no plane of its own (GroundSegmentationConfig::footprint_radius).
  bool from_base = false;

  double heightAt(double x, double y) const { return a * x + b * y + c; }
};

/// One ground segment of Alg. 1 and its label from Alg. 2.
struct SegmentInfo {
  int id = -1;
  int indexed_height = 0;  ///< w of the segment's columns
  std::vector<int> cells;  ///< cell indices (row-major in the map, see SafetyMap)
  int num_interior = 0;    ///< 8-neighbourhood interior cells (000 Sec. VI)
  int num_boundary = 0;
  GroundPlane plane;
  SafetyLabel label = SafetyLabel::kUnexamined;
  bool reachable = false;  ///< reached from the robot's segment in Alg. 2
  bool island = false;     ///< grown as an island (GroundSegmentationConfig::segment_islands)
  /// Non-ground as the top of an obstacle (SafetyLabellingConfig::small_obstacles), not for
  /// its slope or reachability.
  bool obstacle = false;
  /// A fragment of the floor's noise labelled as this safe segment, whose plane it carries
  /// (SafetyLabellingConfig::floor_fragments); -1 otherwise.
  int merged_into = -1;
};

/// The result of one labelling pass. Cells are row-major: index = (v - min_v) * width + (u -
/// min_u), cell (u, v) centred at (u * l_v, v * l_v) in the fixed frame (Eq. (1)).
struct SafetyMap {
  int min_u = 0;
  int min_v = 0;
  int width = 0;            ///< cells along u (x)
  int height = 0;           ///< cells along v (y)
  double resolution = 0.1;  ///< l_v [m]
  int robot_u = 0;          ///< robot's cell
  int robot_v = 0;
  int robot_segment = -1;  ///< segment the robot stands on, -1 when none was found

  std::vector<SafetyLabel> labels;     ///< per cell
  std::vector<std::int32_t> segment;   ///< per cell, -1 when in no segment
  std::vector<std::uint8_t> drop_off;  ///< per cell, 1 on a potential drop-off edge (000 Sec. VI)
  std::vector<std::int16_t> column_height;  ///< per cell, indexed height w, kNoHeight if none
  std::vector<SegmentInfo> segments;

  static constexpr std::int16_t kNoHeight = INT16_MIN;

  int index(int u, int v) const { return (v - min_v) * width + (u - min_u); }
  bool inside(int u, int v) const {
    return u >= min_u && v >= min_v && u < min_u + width && v < min_v + height;
  }
  SafetyLabel labelAt(int u, int v) const { return labels[index(u, v)]; }
  /// Fixed-frame xy of the cell centre.
  Eigen::Vector2d cellCenter(int u, int v) const { return {u * resolution, v * resolution}; }
};

}  // namespace stereo_safety_map
