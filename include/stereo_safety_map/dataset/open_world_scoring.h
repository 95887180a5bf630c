// Scoring of safety maps against the analytic ground truth of a procedural scene, for the
// open-world evaluation (scripts/evaluate, evaluate_open_world; docs/evaluation.md). ROS-free.
//
// Beside the error rates of paper 000 Sec. VII-A (FN / FP, unsafe = Non-ground positive, Unknown
// and Unexamined unclassified), it measures what a map that hedges or forgets could hide:
//  - the rates with 0 and with 1 cell of tolerance at label boundaries: a map cell is only an
//    error when no ground-truth cell within one cell (Chebyshev) agrees with its class, so that
//    a label boundary shifted by one cell (stereo noise, the 0.1 m grid) is not counted;
//  - coverage: the share of ground-truth cells (safe or unsafe) within R_max of the robot and in
//    the field of view swept so far (cells whose ground the left camera has seen, occlusions
//    removed with the rendered depth) that the map classifies: a map that says Unknown where it
//    has seen the ground does not look better;
//  - per hazard class (procedural_scene.h HazardClass), FN and FP on the cells of that class;
//  - the share of maps without a robot segment (after a grace time), and of maps in which the
//    chair is stuck: the safe ground a planner could reach from the robot's footprint
//    (reachableSafeArea; through safe cells, and through Unknown ones whose ground the camera
//    never saw) is smaller than `stuck_area` (a robot segment of one cell counts as found, yet
//    the chair cannot move);
//  - forgotten obstacles: map cells over a ground-truth obstacle that were Non-ground in an
//    earlier map and are Level or Inclined later (a real obstacle gives no free-space evidence);
//  - obstacle checks: every obstacle at least `obstacle_min_width` wide and
//    `obstacle_min_height` high, once it was in view (rendered pixels in the left image) from
//    within R_max, must be Non-ground in at least one cell of its footprint (one cell of
//    tolerance) in every later map in which it lies within R_max, and no cell inside its
//    footprint may be Level or Inclined.
//
// Maps live in the odometry frame the mapper was given; the ground truth in the world. With
// odometry error the two differ: every map is compared through T_world_odom of its frame
// (true base pose composed with the inverse of the reported one), i.e. in the robot's local
// frame, where a local map is used.
#pragma once

#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/obstacle_detection.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/dataset/procedural_scene.h"
#include "stereo_safety_map/dataset/scene.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

struct OpenWorldScoringConfig {
  double planning_radius = 4.0;  ///< R_max [m] (000 Alg. 1 step 3)
  double min_range = 0.2;        ///< camera range of the swept field of view [m]
  double max_range = 8.0;
  double robot_height = 1.5;          ///< as the ground truth (000 Sec. V-A)
  double clearance = 0.02;            ///< as the ground truth
  double obstacle_min_width = 0.05;   ///< [m], the obstacle checks' smallest obstacle
  double obstacle_min_height = 0.10;  ///< [m]
  /// Rendered pixels of an obstacle in the left image for it to be "in view".
  int obstacle_min_pixels = 20;
  /// The lenient obstacle check starts after the obstacle was in view in this many frames
  /// (the voxel grid's confirmation latency, 000 Sec. VII-B); the strict one after the first.
  int obstacle_lenient_frames = 5;
  /// Maps before this time [s] are not asked for a robot segment.
  double segment_grace_s = 2.0;
  /// A map after the grace time is "stuck" when the safe ground reachable from the robot's
  /// footprint (reachableSafeArea with footprint_radius) is smaller than this [m^2]: 1 m^2 is
  /// about one wheelchair length of travel in any direction. The ground truth asked the same is
  /// never stuck (maps_stuck_truth 0 on the report split, twentieth session).
  double stuck_area = 1.0;
  double footprint_radius = 0.35;  ///< [m], as GroundSegmentationConfig::footprint_radius

  std::string validate() const;
};

/// Paper 003's detector scored frame by frame (the "per-frame precision / recall"): its
/// raised points (the obstacle cue) against the rendered truth of their pixels, and the
/// qualifying obstacles in view against its detections. Sums over frames.
struct DetectionScore {
  int frames = 0;                     ///< frames the detector ran on
  std::uint64_t raised_points = 0;    ///< raised points of accepted obstacles
  std::uint64_t raised_true = 0;      ///< of which on an obstacle or unsafe GT (one cell)
  std::uint64_t raised_no_truth = 0;  ///< of which nothing was rendered at their pixel
  int accepted = 0;                   ///< accepted obstacles (summed over frames)
  int accepted_false = 0;             ///< of which less than half of the raised points true
  int checks = 0;                     ///< (qualifying obstacle in view within R_max, frame) pairs
  int checks_detected = 0;            ///< of which with a raised point on that obstacle

  double precision() const;  ///< raised_true / (raised_points - raised_no_truth), NaN if none
  double recall() const;     ///< checks_detected / checks, NaN if none
  DetectionScore& operator+=(const DetectionScore& o);
};

/// Everything measured on one scene for one mapper variant. Sums over the scene's maps.
struct SceneScore {
  ConfusionCounts tol0;
  ConfusionCounts tol1;
  /// One cell of tolerance against the local-horizon ground truth: reachability from the
  /// robot's position of the frame within R_max only (relabelGroundTruth), what a map limited
  /// to R_max (000 Alg. 1 step 3) can know. The scene's ground truth (000 Sec. VII-A) calls a
  /// lower level safe when a ramp 6 m away reaches it; this one does not.
  ConfusionCounts local_tol1;
  std::array<ConfusionCounts, kHazardClassCount> by_class;  ///< one cell of tolerance
  std::uint64_t coverage_cells = 0;       ///< GT-classified cells in R_max and swept view
  std::uint64_t coverage_classified = 0;  ///< of which the map classifies
  int maps = 0;
  int maps_after_grace = 0;
  int maps_without_robot_segment = 0;  ///< of those after the grace time
  /// Maps after the grace time in which the reachable safe area is below stuck_area; and the
  /// same asked of the ground truth at the true robot position (a check of the scenes: 0).
  int maps_stuck = 0;
  int maps_stuck_truth = 0;
  int forgotten_events = 0;          ///< obstacle cells Non-ground -> safe
  int forgotten_cells = 0;           ///< distinct map cells forgotten at least once
  int obstacles = 0;                 ///< qualifying obstacles in the scene
  int obstacles_in_view = 0;         ///< of which seen from within R_max
  int obstacles_missed_strict = 0;   ///< ever missed after the first frame in view
  int obstacles_missed_lenient = 0;  ///< ever missed after obstacle_lenient_frames in view
  int obstacle_maps_strict = 0;      ///< (obstacle, map) checks, strict
  int obstacle_maps_missed_strict = 0;
  int obstacle_maps_lenient = 0;
  int obstacle_maps_missed_lenient = 0;
  int obstacle_safe_cells = 0;  ///< cells inside an obstacle's footprint labelled safe (lenient)
  /// Where the false positives (tol 1) come from, for development: the map cell's segment was
  /// not safe (kFpUnsafeSegment: unreached or too steep, 000 Alg. 2), it was safe but the cell
  /// was overridden (kFpSafeSegment: drop-off margin, obstacle memory or cue), or the cell is in
  /// no segment (kFpNoSegment: a non-traversable column, memory or cue); and by the cell's
  /// distance from the true robot position (kFpRangeBins bins of 1 m from 0.5 m, the last open).
  enum FpSource { kFpUnsafeSegment = 0, kFpSafeSegment = 1, kFpNoSegment = 2, kFpSourceCount = 3 };
  static constexpr int kFpRangeBins = 4;
  std::array<std::uint64_t, kFpSourceCount * kFpRangeBins> fp_sources{};
  std::vector<std::string> misses;     ///< a few lines naming missed obstacles (first per obstacle)
  std::vector<std::string> forgotten;  ///< a few lines naming forgotten cells (first per cell)
  DetectionScore detection;            ///< when the variant ran 003's detector
  /// The camera tilt the map used against the true one, over the integrated frames: how well
  /// the re-levelling (SafetyMapperConfig::relevel) removes the unreported chassis pitch and
  /// roll. Per frame the small rotation from the used to the true camera pose, its components
  /// about the camera heading's lateral axis (pitch) and forward axis (roll) [deg]; sums and sums
  /// of squares, for the bias (the constant part) and the RMS. `reported`: the same for the
  /// odometry's pose as reported (no levelling).
  struct TiltError {
    double pitch = 0.0, roll = 0.0, pitch2 = 0.0, roll2 = 0.0;
    TiltError& operator+=(const TiltError& o);
  };
  int tilt_frames = 0;
  TiltError tilt_used, tilt_reported;

  SceneScore& operator+=(const SceneScore& o);
};

/// The area [m^2] of the safe (Level or Inclined) cells of `map` that a planner could reach from
/// the robot: the safe cells within footprint_radius of the robot's cell (centre distance) and
/// every safe cell 8-connected to them through safe cells. `unseen` (optional, one entry per map
/// cell): 1 where the camera never saw the cell's ground; an Unknown or Unexamined cell there
/// may be passed through (not counted): no map can know it (the blind zone in front of a chair
/// at rest). Non-ground never is. 0 when the footprint has no passable cell. Potential
/// drop-off edges (SafetyMap::drop_off) count as safe here although the cost table makes them
/// lethal: the measure is a lower bound on how often the chair is stuck.
double reachableSafeArea(const SafetyMap& map, double footprint_radius,
                         const std::vector<std::uint8_t>* unseen = nullptr);

/// Per-scene scorer: the ground truth's look-up tables, the swept field of view and the
/// obstacles' visibility (shared by all variants), and each variant's memory of Non-ground cells.
class OpenWorldScorer {
 public:
  /// `classes` has one entry per GT cell (hazardClassMap()). Throws std::invalid_argument for
  /// an invalid config or a size mismatch.
  OpenWorldScorer(const Scene& scene, const GroundTruthMap& gt,
                  const std::vector<HazardClass>& classes, const OpenWorldScoringConfig& config,
                  int variants);

  /// Once per rendered frame: the true left optical frame pose, the camera, the rendered depth
  /// (CV_32F, Z along the optical axis, +inf where nothing is hit) and primitive ids (CV_32S) of
  /// the left image, the true robot position. Marks the GT cells seen and the obstacles in view.
  void observeFrame(const Eigen::Isometry3d& T_world_camera, const StereoCameraModel& camera,
                    const cv::Mat& depth, const cv::Mat& ids, const Eigen::Vector2d& robot);

  /// The local-horizon ground truth of the current frame (same grid as the scene's), or null.
  void setLocalGroundTruth(const GroundTruthMap* local) { local_ = local; }

  /// One map of variant `variant` made at time `t` [s since the first frame], in the odometry
  /// frame; `T_world_odom` maps its cells into the world (2D), `robot` is the true position.
  void scoreMap(int variant, const SafetyMap& map, double t, const Eigen::Isometry2d& T_world_odom,
                const Eigen::Vector2d& robot, SceneScore* score);

  /// One frame of paper 003's detector, run on the frame last given to observeFrame(): each
  /// raised point of an accepted obstacle is true when its pixel shows a qualifying obstacle
  /// (the rendered primitive ids) or its rendered surface point lies within one cell of an
  /// unsafe ground-truth cell or an obstacle's column; every qualifying obstacle in view from
  /// within R_max in that frame is detected when some raised point shows it.
  void scoreDetection(const ObstacleDetectionResult& result, DetectionScore* score) const;

  /// Fills the per-scene obstacle counts of `score` (after the last map of the variant).
  void finish(SceneScore* score) const;

  /// Qualifying obstacles (groups) of the scene.
  int obstacleCount() const { return static_cast<int>(obstacles_.size()); }

 private:
  struct Obstacle {
    std::string group;
    std::vector<int> cells;          // GT cells whose column it occupies
    std::vector<int> cells_dilated;  // with one cell around
    int frames_in_view = 0;
    bool missed_strict = false, missed_lenient = false;  // per variant: see missed_ below
  };
  struct VariantState {
    std::unordered_map<std::int64_t, std::uint8_t> non_ground;  // odom cells Non-ground over an
                                                                // obstacle, 1 = later forgotten
    std::vector<std::uint8_t> missed_strict, missed_lenient;    // per obstacle
  };

  int gtIndexOf(const Eigen::Vector2d& world) const;  // -1 outside
  SafetyClass gtClass(int g) const { return safetyClassOf(gt_.labels[g]); }

  OpenWorldScoringConfig config_;
  const GroundTruthMap& gt_;
  const GroundTruthMap* local_ = nullptr;
  std::vector<HazardClass> classes_;
  std::vector<std::uint8_t> seen_;         // per GT cell: ground seen by the camera
  std::vector<std::uint8_t> unseen_;       // per map cell of the scored map: never seen (stuck)
  SafetyMap truth_map_;                    // the ground truth's labels as a map (stuck check)
  std::vector<std::int32_t> obstacle_of_;  // per GT cell: index into obstacles_ (the kept
                                           // ones), -1 none
  std::vector<std::uint8_t> in_view_now_;  // per obstacle: in view within R_max, last frame
  // The last observed frame (scoreDetection): pose, camera, rendered depth and ids.
  Eigen::Isometry3d frame_T_world_camera_ = Eigen::Isometry3d::Identity();
  StereoCameraModel frame_camera_;
  cv::Mat frame_depth_, frame_ids_;
  std::vector<std::uint8_t> obstacle_cell_;  // per GT cell: any non-ground solid stands there
  std::vector<Obstacle> obstacles_;
  std::vector<int> group_of_primitive_;  // obstacle index per scene primitive, -1
  std::vector<VariantState> variants_;
};

}  // namespace dataset
}  // namespace stereo_safety_map
