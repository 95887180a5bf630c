// Analytic ground truth of a synthetic scene: the GT safety map (Level / Inclined / Non-ground /
// Unknown per 0.1 m cell, 000 Sec. VI-VII), GT planes of every ground surface (000 Sec. VII-C) and
// GT obstacles. The labels follow the labeller's rules with the same robot parameters: a ground
// cell is safe only when it is reachable from the robot's start through transitions the robot can
// drive (height step < h_T, slope <= theta_max, 000 Alg. 2), so a lower area reached by a ramp is
// safe and one reached only over a curb is not. ROS-free.
#pragma once

#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/dataset/scene.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

/// Robot parameters of the ground truth; defaults are the labeller's (000 Alg. 1-2).
struct GroundTruthConfig {
  double resolution = 0.1;      ///< cell side l_v [m] (000 Sec. IV)
  double theta_max_deg = 10.0;  ///< steepest drivable slope (000 Alg. 2 step 2)
  double theta_t_deg = 3.0;     ///< Level / Inclined threshold theta_T (000 Alg. 2 step 28)
  double h_t = 0.05;            ///< largest drivable height step h_T [m] (000 Alg. 2 step 17)
  double robot_height = 1.5;    ///< objects below this above the ground are obstacles or
                                ///< overhangs; higher ones are driven under (000 Sec. V-A)
  double clearance = 0.02;      ///< objects lower than this above the ground are ignored [m]
  int samples_per_cell = 5;     ///< obstacle test samples per cell side (a 5 x 5 lattice)
  double margin = 0.5;          ///< map border around the scene's ground surfaces [m]

  std::string validate() const;
};

/// The GT map on the global grid of Eq. (1): cell (u, v) is centred at (u * l_v, v * l_v),
/// row-major index (v - min_v) * width + (u - min_u), like core's SafetyMap.
struct GroundTruthMap {
  int min_u = 0;
  int min_v = 0;
  int width = 0;
  int height = 0;
  double resolution = 0.1;
  int start_u = 0;  ///< the robot's start cell, the source of reachability
  int start_v = 0;

  std::vector<SafetyLabel> labels;      ///< Level / Inclined / Non-ground / Unknown
  std::vector<float> ground_height;     ///< top ground surface at the cell centre, NaN if none
  std::vector<float> slope_deg;         ///< of that surface, NaN if none
  std::vector<std::int32_t> ground;     ///< its primitive index, -1 if none
  std::vector<std::uint8_t> obstacle;   ///< 1 when something below robot height stands on it
  std::vector<std::uint8_t> reachable;  ///< 1 when reached from the start cell
  std::vector<std::uint8_t> drop_off;   ///< 1 on safe cells next to ground lower by >= h_T
                                        ///< or next to a cell without ground (000 Sec. VI)

  int index(int u, int v) const { return (v - min_v) * width + (u - min_u); }
  bool inside(int u, int v) const {
    return u >= min_u && v >= min_v && u < min_u + width && v < min_v + height;
  }
  SafetyLabel labelAt(int u, int v) const { return labels[index(u, v)]; }
  /// Label of the cell containing world point (x, y); Unknown outside the map.
  SafetyLabel labelAtPoint(double x, double y) const;
  Eigen::Vector2d cellCenter(int u, int v) const { return {u * resolution, v * resolution}; }
  int cellOf(double x) const;  ///< round(x / l_v), Eq. (1)
};

/// GT plane of one ground surface: z = a x + b y + c over its footprint (000 Sec. V-B form).
struct GroundTruthPlane {
  std::string name;
  std::string group;
  double a = 0.0, b = 0.0, c = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, up
  double slope_deg = 0.0;
  std::vector<Eigen::Vector3d> polygon;       ///< top face corners, counter-clockwise from above
  SafetyLabel label = SafetyLabel::kUnknown;  ///< majority label of the cells it is top of
  int cells = 0;                              ///< cells it is the top ground surface of
};

/// GT obstacle: a non-ground solid (or one part of a table, railing, ...).
struct GroundTruthObstacle {
  std::string name;
  std::string group;
  std::string type;
  std::string shape;  ///< "box" (convex solid, obb exact for boxes) or "cylinder"
  OrientedBox obb;
  Eigen::AlignedBox3d bounds;
  double radius = 0.0;  ///< cylinders
};

/// Builds the GT map of `scene` for a robot starting at `start` (x, y). Returns an error message
/// (empty on success); on error `map` is left empty. A start cell without drivable ground is an
/// error.
std::string computeGroundTruth(const Scene& scene, const GroundTruthConfig& config,
                               const Eigen::Vector2d& start, GroundTruthMap* map);

/// Redoes the reachability and the labels of a computed map from another robot position,
/// examining only cells within `planning_radius` of it (R_max of 000 Alg. 1 step 3; <= 0 means
/// everywhere; farther cells become Unexamined). For per-frame local GT maps.
std::string relabelGroundTruth(const GroundTruthConfig& config, const Eigen::Vector2d& robot,
                               double planning_radius, GroundTruthMap* map);

/// The GT map of a rendered dataset computed again from its scene file, for the per-cell facts
/// the label file does not keep (ground height, obstacle, slope, reachability): reads
/// <gt_dir>/dataset.yaml (scene_file, variant), takes the scene file where make_dataset read it
/// or, failing that, the file of that name in `scenes_dir`, and runs computeGroundTruth() from
/// the trajectory's start with `config` (make_dataset uses the default config). `scene_path`
/// (optional) receives the file used. Returns an error message, empty on success.
std::string recomputeDatasetGroundTruth(const std::string& gt_dir, const std::string& scenes_dir,
                                        const GroundTruthConfig& config, GroundTruthMap* gt,
                                        std::string* scene_path = nullptr);

std::vector<GroundTruthPlane> groundTruthPlanes(const Scene& scene, const GroundTruthMap& map);
std::vector<GroundTruthObstacle> groundTruthObstacles(const Scene& scene);

/// Grey levels of the labels in gt_map.pgm (map_server "trinary" mode reads Level and Inclined
/// as free, Non-ground as occupied, Unknown and Unexamined as unknown).
std::uint8_t labelGrey(SafetyLabel l);

/// Writes dir/gt_map.pgm + gt_map.yaml (map_server format, label table included),
/// gt_labels.pgm (raw SafetyLabel values), gt_drop_off.pgm, gt_planes.yaml and gt_obstacles.yaml.
/// `dir` must exist. Returns an error message, empty on success.
std::string writeGroundTruthFiles(const std::string& dir, const Scene& scene,
                                  const GroundTruthConfig& config, const GroundTruthMap& map,
                                  const std::vector<GroundTruthPlane>& planes,
                                  const std::vector<GroundTruthObstacle>& obstacles);

}  // namespace dataset
}  // namespace stereo_safety_map
