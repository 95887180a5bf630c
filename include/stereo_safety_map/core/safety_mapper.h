// Per-frame pipeline of paper 000: voxel grid update (Sec. IV), height map and ground
// segmentation (Sec. V-A, Alg. 1), plane fit (Sec. V-B), safety labelling (Sec. VI, Alg. 2).
//
// ROS-free. One instance per camera. Buffers are members and reused, so a steady stream of
// frames does not allocate (except when the number of segments grows).
#pragma once

#include "stereo_safety_map/core/frame_levelling.h"
#include "stereo_safety_map/core/ground_segmentation.h"
#include "stereo_safety_map/core/height_map.h"
#include "stereo_safety_map/core/observation_age.h"
#include "stereo_safety_map/core/overhang_roof.h"
#include "stereo_safety_map/core/plane_fit.h"
#include "stereo_safety_map/core/safety_labelling.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/core/voxel_grid.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace stereo_safety_map {

struct SafetyMapperConfig {
  VoxelGridConfig grid;
  HeightMapConfig height_map;
  GroundSegmentationConfig segmentation;
  PlaneFitConfig plane_fit;
  SafetyLabellingConfig labelling;

  /// 000 Sec. IV: frames taken while the robot is stationary are discarded whole, their range
  /// readings being highly correlated with the previous ones. A frame is stationary when the
  /// camera moved less than both thresholds since the last integrated frame (values not in the
  /// paper). The first frame is always integrated.
  bool skip_stationary_frames = true;
  /// [m]. 1 cm: a chair moving at 0.15 m/s or more with a 15 Hz camera is never stationary
  /// (with 2 cm, 0.3 m/s at 15 Hz skipped every third or fourth frame of a drive).
  double stationary_translation = 0.01;
  double stationary_rotation_deg = 1.0;  ///< [deg]
  /// Stationary frames are integrated all the same until the grid has integrated this many
  /// frames since it was (re)started (ours; 0 = 000 Sec. IV, every stationary frame skipped).
  /// A chair that is switched on at rest otherwise holds only its first frame's evidence, on
  /// which no voxel reaches occ_t (a voxel needs occ_t / incr_H = 10 hits, 000 Sec. IV), and
  /// every obstacle in view stays Unknown until the chair has driven ten frames. 10 = occ_t /
  /// incr_H: a voxel seen in every frame from rest reaches occ_t. Once the grid holds that many
  /// frames, a stationary camera's repeated mismatches are kept out of it as 000 intends.
  int stationary_warmup_frames = 10;

  /// Keep the grid centred on the robot (000 Sec. IV: "we can have the grid move while centered
  /// on the robot"). When false the window is placed by the first frame and stays there.
  bool scroll_with_robot = true;
  /// The window is centred this far ahead of the robot along the camera's heading [m] (ours;
  /// 0 = centred on the robot, 000 Sec. IV). The camera looks ahead: with the default 10 m grid
  /// and look-ahead 1 m the window reaches 6 m ahead, so that what the camera sees at 5-6 m
  /// gathers evidence before it comes within R_max, and still 4 m = R_max behind and beside.
  /// Must leave R_max around the robot inside the window: [0, min(size_x, size_y) / 2 - R_max].
  double grid_look_ahead = 1.0;

  /// Cells not re-observed for longer than this [s] can no longer be vouched for: Level /
  /// Inclined cells fall back to Unknown, nothing else changes (policy in observation_age.h;
  /// ours, not in the paper). Only frames passed with a stamp age the map. 0 = off.
  double max_cell_age = 30.0;

  /// Object permanence (ours; false = 000, whose map is recomputed from the grid each frame).
  /// A cell that held an obstacle (a non-traversable column: the face of an obstacle or an
  /// overhang, 000 Sec. V-A; or the top of a small obstacle, SafetyLabellingConfig::
  /// small_obstacles) keeps Non-ground until free space is observed there: until none of the
  /// voxels of its column that were occupied then is occupied any more. Occupancy falls only
  /// through the free-space decrements of rays passing through (000 Sec. IV), so a later
  /// segmentation that happens to take the column into a safe segment (a stereo gap, an island,
  /// a changed seed) cannot forget the obstacle; a cell leaving the grid's window is forgotten
  /// with its voxels. Aging (max_cell_age) never makes such a cell safe either. Only what rises
  /// above the robot's base counts as an obstacle (the voxels of the column above its lowest
  /// occupied one, or the one voxel of a single-voxel column): a column of lower ground is
  /// Non-ground for its reachability, which may change. And only a column whose measured
  /// surface stands more than h_T above the safe ground around it: the ground's own noise (stereo
  /// at range, an unreported pitch) that reaches into the voxel above it makes a column
  /// non-traversable for this map but is not remembered.
  bool obstacle_memory = true;

  /// What "free space observed" means to obstacle_memory (ours): a remembered cell is forgotten
  /// once every voxel of its band has a log-odds at or below grid.occ_threshold minus this
  /// margin. 1 (default): as soon as no voxel of the band is occupied any more. occ_threshold:
  /// only when the passing rays' decrements (000 Sec. IV) have taken the band back to the prior
  /// (0). That keeps a sparse face whose voxels grazing rays have thinned (a wall seen at a
  /// shallow angle), but it also keeps a removed obstacle for many frames: with decr 1 a
  /// well-seen voxel needs hundreds of passing rays. Range [1, occ_threshold - lop_min].
  int obstacle_memory_clear_margin = 1;

  /// obstacle_memory takes a column only while it lies within this horizontal distance of the
  /// robot [m] (ours; 0 = at any range). Stereo's depth error grows with the square of the range
  /// (001 Sec. 4.1): beyond a few metres the floor's outliers make columns that stand above h_T
  /// for a frame, and remembering them would keep that noise. A far obstacle is Non-ground
  /// while it is measured so, and remembered once the robot has come this near.
  double obstacle_memory_max_range = 0.0;

  /// Re-levelling of each frame on the ground the robot stands on (frame_levelling.h; ours,
  /// enabled false = 000, which takes the pose from odometry as it is): the previous map's robot
  /// segment and its plane are the reference.
  FrameLevellingConfig relevel;

  /// Floor seen under an overhang (overhang_roof.h; ours, enabled false = 000): a safe cell
  /// whose floor the camera sees under the top of an overhang column at most max_span before it
  /// is Non-ground: the table top or shelf board that stereo saw only at its front edge.
  OverhangRoofConfig overhang_roof;

  /// An overhang that stereo did not measure (ours; 0 = off, 000 labels the floor alone). A
  /// table top or shelf board seen edge-on whose front edge block matching does not match gives
  /// no point, while the rays to the floor beyond pass under it and the rays to the wall behind
  /// pass over it (docs/evaluation.md, "A table top that stereo does not see"): its voxels stay
  /// at or near the prior, not seen, between voxels seen (VoxelGrid::hiddenBelowObserved, with
  /// unseen_overhang_free_lop). With this > 0 [m], a
  /// Level or Inclined cell outside the robot's footprint whose column, from this height above
  /// its ground voxel up to the robot's top, holds such a hidden voxel is no longer safe:
  /// Unknown, or Non-ground with unseen_overhang_non_ground. Open space above the camera's view
  /// is not hidden (nothing was observed above it). Default 0.3 m: docs/evaluation.md, "A table
  /// top that stereo does not see".
  double unseen_overhang_min_height = 0.3;
  /// unseen_overhang_min_height's cells are Non-ground instead of Unknown (ours).
  bool unseen_overhang_non_ground = false;
  /// unseen_overhang_min_height: a voxel is seen free once passing rays took its log-odds to
  /// -this or below (ours; VoxelGrid::hiddenBelowObserved). A 4 cm top in a 10 cm voxel lets a
  /// few rays graze the voxel under and over it. [1, -lop_min].
  int unseen_overhang_free_lop = 10;
  /// unseen_overhang_min_height: only hidden cells that belong to a square of this side [cells]
  /// hidden throughout count (a morphological opening; ours; 1 = every hidden cell). A top
  /// hides a layer across its extent; the voxels the rays happen to miss (a wall seen at a
  /// grazing angle: one ray per voxel and frame, 000 Sec. IV) lie in scattered cells and thin
  /// stripes. [1, 9].
  int unseen_overhang_min_width = 2;
  /// Floor whose space above was never seen (ours; 0 = off): a Level or Inclined cell outside
  /// the robot's footprint none of whose voxels 1 .. this many above its ground voxel was ever
  /// seen free (log-odds at or below -unseen_overhang_free_lop) is Unknown. Ground points that
  /// stereo's noise at range pushes behind an obstacle's face make a floor cell inside the
  /// obstacle, above which no ray ever passed. Off while grid.decr is 0 (nothing is ever seen
  /// free). [0, 10] voxels; default 2: docs/evaluation.md, "Floor nothing was seen above".
  int unseen_floor_band = 2;
  /// unseen_floor_band applies from this horizontal distance of the robot [m] on (ours): near
  /// the chair stereo's depth error is a small fraction of a cell (001 Sec. 4.1), and a floor
  /// of sparse matches there leaves the voxels above some cells without a passing ray. Default
  /// 2 m: there sigma_Z = Z^2 sigma_d / (f b) is ~2 cm, a fifth of a cell, for the procedural
  /// head (f b = 66.5 px m, sigma_d ~0.3 px).
  double unseen_floor_min_range = 2.0;

  /// Empty when valid, otherwise a message naming the offending parameter and its range.
  std::string validate() const;
};

/// Paper 000 as published: `config` with every switch marked "(ours)" set to the paper's rule
/// (islands, gaps between segments, the measured step test, the drop-off margin, the plane fit's
/// vertical margin, the grid's look-ahead and neighbour rules, cell aging, and the safe-by-default
/// rules of the open-world work), everything else kept. The open-world evaluation's
/// "paper-faithful" row.
SafetyMapperConfig paperFaithful(const SafetyMapperConfig& config);

/// SafetyMapperConfig::obstacle_memory's test of what is an obstacle to remember: whether the
/// measured surface of cell `c` of `map` (the mean z of its top voxel's points, HeightMap::
/// surfaceHeightAtIndex; the map's cells and the height map's are the same window) stands more
/// than `min_rise` [m] above the ground around it: the lowest measured surface of the Level /
/// Inclined cells within `radius` cells, or `fallback_ground_z` (the robot's base) where none
/// is. True when the cell has no measured surface (an obstacle is not forgotten for want of
/// points).
bool risesAboveLocalGround(const SafetyMap& map, const HeightMap& height_map, int c,
                           float fallback_ground_z, double min_rise, int radius = 2);

/// Wall-clock time of each stage of the last processed frame [ms].
struct StageTimings {
  double integrate_ms = 0.0;
  double height_map_ms = 0.0;
  double segmentation_ms = 0.0;
  double plane_fit_ms = 0.0;
  double labelling_ms = 0.0;
  double total_ms = 0.0;
};

/// What integrateFrame() did with a frame.
enum class FrameStatus : std::uint8_t {
  kIntegrated = 0,
  kStationary,            ///< camera has not moved since the last integrated frame
  kEmptyInput,            ///< no points
  kInvalidPose,           ///< non-finite or non-rigid T_fixed_sensor
  kInvalidRobotPosition,  ///< non-finite robot base position
  kCameraOutsideGrid,     ///< camera origin outside the (recentred) grid window
};
const char* toString(FrameStatus s);

struct FrameResult {
  FrameStatus status = FrameStatus::kIntegrated;
  IntegrationStats integration;     ///< zeros when not integrated
  std::size_t voxels_scrolled = 0;  ///< voxels cleared by recentring the grid
  std::size_t cells_aged = 0;       ///< safe cells turned Unknown by max_cell_age (stamped frames)
  FrameLevellingResult levelling;   ///< the frame's re-levelling (SafetyMapperConfig::relevel)
  StageTimings timings;             ///< zeros when not integrated
};

class SafetyMapper {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit SafetyMapper(const SafetyMapperConfig& config = SafetyMapperConfig());

  const SafetyMapperConfig& config() const { return config_; }

  /// Processes one frame: checks it, recentres the grid on the robot (first frame, or every
  /// frame when scrolling), integrates the points (sensor frame, `T_fixed_sensor` maps them to
  /// the fixed frame) and recomputes the safety map for `robot_base_position` (fixed frame,
  /// the point of the robot's base on the ground). Returns false when the frame was skipped;
  /// `out->status` says why, no point is integrated and the map is left as it was (only for
  /// kCameraOutsideGrid has the grid already been recentred on the valid robot position).
  bool integrateFrame(const std::vector<Eigen::Vector3f>& points_sensor,
                      const Eigen::Isometry3f& T_fixed_sensor,
                      const Eigen::Vector3f& robot_base_position, FrameResult* out = nullptr);
  /// The same for a frame taken at time `stamp` [s]: the columns its points fall into are
  /// observed at `stamp` (also when the frame is skipped as stationary: the camera still sees
  /// them), and the map is aged at the latest stamp seen (max_cell_age, observation_age.h).
  /// A stationary frame may so change the map (FrameResult::cells_aged). Points from index
  /// `first_no_carve` on are occupancy evidence only (VoxelGrid::integrate).
  bool integrateFrame(const std::vector<Eigen::Vector3f>& points_sensor,
                      const Eigen::Isometry3f& T_fixed_sensor,
                      const Eigen::Vector3f& robot_base_position, double stamp,
                      FrameResult* out = nullptr,
                      std::size_t first_no_carve = VoxelGrid::kAllCarve);

  /// f b [px m] of the stereo camera behind the next frames' points (VoxelGrid::
  /// setStereoGeometry, for VoxelGridConfig::neighbour_sigmas); 0 = unknown.
  void setStereoGeometry(double focal_times_baseline) {
    grid_.setStereoGeometry(focal_times_baseline);
  }

  /// Whether integrateFrame() would skip a frame from `T_fixed_sensor` as stationary (000 Sec.
  /// IV): skipping is on, a frame was integrated before, and the camera has moved less than both
  /// thresholds since. Lets a filter in front of the grid (LandmarkStreamFilter) see the same
  /// frames as the grid.
  bool isStationary(const Eigen::Isometry3f& T_fixed_sensor) const;

  /// Height map, segmentation, plane fit and labelling of the current grid for a robot at
  /// `robot_base_position` (no grid update). A non-finite position gives a map with every cell
  /// Unknown and no segments.
  const SafetyMap& computeSafetyMap(const Eigen::Vector3f& robot_base_position);

  /// Ages the current map at time `now` [s] without recomputing it (max_cell_age; e.g. while no
  /// frame arrives): returns the number of safe cells that fell back to Unknown. `now` older than
  /// the latest stamp seen is replaced by it. 0 when aging is off or no stamp was ever given.
  std::size_t ageSafetyMap(double now);
  /// Cells of the last map that the obstacle memory kept Non-ground against the labelling.
  std::size_t cellsRemembered() const { return cells_remembered_; }
  /// Safe cells of the last map made Non-ground as floor seen under an overhang (overhang_roof).
  int cellsUnderOverhangs() const { return cells_under_overhangs_; }
  /// Safe cells of the last map under a hidden layer (unseen_overhang_min_height).
  int cellsUnderUnseenOverhangs() const { return cells_unseen_overhang_; }
  /// Safe cells of the last map made Unknown as floor nothing was seen above (unseen_floor_band).
  int cellsUnseenFloor() const { return cells_unseen_floor_; }
  /// Cells the obstacle memory holds (those it keeps Non-ground and those the labelling calls
  /// Non-ground itself).
  std::size_t obstacleMemorySize() const { return obstacle_memory_.size(); }
  /// Whether the obstacle memory holds cell (u, v) (global indices); its band of indexed
  /// heights in *lo, *hi when it does (either may be null).
  bool rememberedObstacle(int u, int v, int* lo, int* hi) const;
  /// Cells the memory holds as floor seen under a roof (OverhangRoofConfig::remember).
  std::size_t roofMemorySize() const { return roof_memory_.size(); }
  /// Cells the memory holds as an obstacle's face cells (obstacle_face_margin).
  std::size_t faceMemorySize() const { return face_memory_.size(); }
  /// Safe cells of the current map turned Unknown by aging since it was computed.
  std::size_t cellsAged() const { return cells_aged_; }
  /// Latest frame stamp / aging time seen; NaN when none since the start or the last reset.
  double latestTime() const { return latest_time_; }
  const ObservationAge& observationAge() const { return observation_age_; }

  /// Applies a new configuration in place and returns "" (or config.validate()'s message, then
  /// nothing changes). A change of the grid's configuration (sensor model, size) starts a new
  /// grid, as reset() does (*grid_reset true); otherwise the 3D model, observation times and
  /// last pose are kept and the next computeSafetyMap() uses the new stage parameters.
  std::string reconfigure(const SafetyMapperConfig& config, bool* grid_reset = nullptr);

  /// The last computed map (empty before the first).
  const SafetyMap& safetyMap() const { return map_; }
  /// The same, writable: for cues fused after the labelling (obstacle_cue.h). The next
  /// integrateFrame() or computeSafetyMap() recomputes the map from the grid alone.
  SafetyMap& mutableSafetyMap() { return map_; }
  /// Timings of the last integrateFrame() / computeSafetyMap().
  const StageTimings& lastTimings() const { return timings_; }

  /// Clears the grid and the map and forgets the last pose: the next frame counts as the first
  /// (always integrated; places the window even when not scrolling).
  void reset();

  const VoxelGrid& grid() const { return grid_; }
  /// Mutable access, e.g. to fuse external cues with setLogOdds().
  VoxelGrid& grid() { return grid_; }
  const HeightMap& heightMap() const { return height_map_; }
  const GroundSegments& segments() const { return segments_; }
  const std::vector<GroundPlane>& planes() const { return planes_; }
  std::uint32_t framesIntegrated() const { return frames_integrated_; }

 private:
  SafetyMapperConfig config_;
  VoxelGrid grid_;
  HeightMap height_map_;
  GroundSegmentation segmentation_;
  PlaneFitter plane_fitter_;
  SafetyLabelling labelling_;

  GroundSegments segments_;
  std::vector<GroundPlane> planes_;
  SafetyMap map_;
  StageTimings timings_;

  void observe(const std::vector<Eigen::Vector3f>& points_sensor,
               const Eigen::Isometry3f& T_fixed_sensor, const Eigen::Vector3f& robot_base_position,
               double stamp);
  bool integrate(const std::vector<Eigen::Vector3f>& points_sensor,
                 const Eigen::Isometry3f& T_fixed_sensor,
                 const Eigen::Vector3f& robot_base_position, double stamp, FrameResult* out,
                 std::size_t first_no_carve = VoxelGrid::kAllCarve);

  // SafetyMapperConfig::obstacle_memory: cells (by their global (u, v)) that held an obstacle,
  // and the band of indexed heights [lo, hi] of their occupied voxels then.
  struct ObstacleMark {
    std::int32_t lo;
    std::int32_t hi;
  };
  std::unordered_map<std::int64_t, ObstacleMark> obstacle_memory_;
  // A remembered cell's witness: the voxel (global indices) whose staying occupied keeps the
  // cell Non-ground (the roof's or the face's top voxel).
  struct ColumnVoxelMark {
    std::int32_t u;
    std::int32_t v;
    std::int32_t w;
  };
  // OverhangRoofConfig::remember: cells (global (u, v)) marked as floor under a roof, with the
  // top voxel of the roof column that marked them last.
  std::unordered_map<std::int64_t, ColumnVoxelMark> roof_memory_;
  // SafetyLabellingConfig::obstacle_face_margin under obstacle_memory: floor cells marked as
  // holding an obstacle's face, with the top voxel of the face's column that marked them last.
  std::unordered_map<std::int64_t, ColumnVoxelMark> face_memory_;
  std::vector<std::int64_t> memory_drop_;  // scratch
  std::size_t cells_remembered_ = 0;       // cells of the last map kept Non-ground by it
  FrameLevellingScratch levelling_scratch_;
  // SafetyMapperConfig::overhang_roof: the camera of the last integrated frame (fixed frame).
  OverhangRoofScratch overhang_scratch_;
  Eigen::Vector3f last_camera_ = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  int cells_under_overhangs_ = 0;
  int cells_unseen_overhang_ = 0;
  int cells_unseen_floor_ = 0;
  std::vector<std::uint8_t> unseen_hidden_, unseen_core_;  // markUnseenOverhangs() scratch
  void markUnseenOverhangs();
  // FrameLevellingConfig::filter_frames: the last accepted per-frame estimates (roll and pitch
  // about the camera heading's axes [rad], dz [m]), oldest first, and a scratch for medians.
  std::vector<Eigen::Vector3d> levelling_history_;
  std::vector<double> levelling_sorted_;
  Eigen::Isometry3f relevelPose(const std::vector<Eigen::Vector3f>& points_sensor,
                                const Eigen::Isometry3f& T_fixed_sensor,
                                const Eigen::Vector3f& robot_base_position,
                                FrameLevellingResult* result);
  void applyObstacleMemory(std::int32_t robot_w, float robot_z);

  ObservationAge observation_age_;
  double latest_time_;  // NaN when unknown
  std::size_t cells_aged_ = 0;

  bool has_last_pose_ = false;
  bool grid_placed_ = false;
  Eigen::Isometry3f last_pose_ = Eigen::Isometry3f::Identity();
  std::uint32_t frames_integrated_ = 0;
};

}  // namespace stereo_safety_map
