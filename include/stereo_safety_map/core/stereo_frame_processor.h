// The one core entry point per frame of the safety map, ROS-free: every frame, whether it arrives
// on a topic (the safety-map nodelet), is read from a bag (the offline evaluators), rendered in
// memory (the open-world evaluation, the bench) or made up by a fuzzer, goes through this class,
// so that the offline numbers are the nodelet's numbers by construction.
//
//   processImages():    rectified pair -> the disparity nodelet's input check (covered, black,
//                       frozen camera; stereo_input_check.h) -> disparity and its post-filters
//                       (000 Sec. III, 002 Sec. 2.2 / 4.2, disparity_pipeline.h) -> the
//                       disparity as the safety-map nodelet reads it from the disparity
//                       nodelet's message (stereo_camera_model.h DisparityMessageGeometry: f and
//                       T in float32, the valid range) -> processDisparity()
//   processDisparity(): disparity -> 3D points in the camera frame (002 Sec. 3.2,
//                       stereo_camera_model.h; the grid's [min_range, max_range], every
//                       `disparity_step`-th row and column) -> [landmark filter] -> the mapper
//   processPoints():    points in the sensor frame (a depth sensor's cloud) -> the mapper
//   the mapper:         voxel grid update, height map, segmentation, plane fit, labelling
//                       (000 Sec. IV-VI, safety_mapper.h), cell aging at the frame's stamp
//   [obstacle cue]:     the live single-frame obstacle cues of paper 003 mark their cells
//                       Non-ground in each new map (obstacle_cue.h)
//
// Optional stages: paper 001's landmark filter (Sec. 4.2, landmark_filter.h) between the
// reprojection and the voxel grid (`landmark_filter.enabled`: only points confirmed by a permanent
// landmark reach the grid; disparity input only, it needs the camera; it runs on the frames the
// grid integrates, not on stationary ones), and the obstacle cue (`obstacle_cue`; cues are handed
// in with addObstacleCue()).
//
// A stationary frame (000 Sec. IV) leaves the grid alone, but while cues are live or the map
// still shows cue marks, the map is recomputed from the unchanged grid with the cues of the
// frame's stamp (ours): an obstacle that 003's detector reports while the chair stands still
// reaches the map the nodelet republishes, and a cue that expired leaves it.
// StereoFrameResult::map_refreshed says so; the frame's status stays kStationary.
//
// Every frame carries its stamp [s]: the mapper ages the map with it (max_cell_age) and the
// landmark filter and the obstacle cue need it. With kNoStamp the frame is not aged and no cue
// applies (the landmark filter refuses it).
#pragma once

#include "stereo_safety_map/core/disparity_gap_fill.h"
#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/core/landmark_filter.h"
#include "stereo_safety_map/core/obstacle_cue.h"
#include "stereo_safety_map/core/safety_mapper.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/stereo_input_check.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct StereoFrameProcessorConfig {
  /// The disparity nodelet's check of the pair before matching (processImages only).
  bool check_input = true;
  StereoInputCheckConfig input_check;
  DisparityPipelineConfig disparity;
  SafetyMapperConfig mapper;
  int disparity_step =
      1;  ///< reproject every n-th row and column, [1, 16] (nodelet's ~disparity_step)
  /// Row gap fill of the disparity before the reprojection (ours, disparity_gap_fill.h): the
  /// safety map's own copy, the disparity() and the disparity nodelet's message stay unfilled.
  RowGapFillConfig row_gap_fill;
  /// The coarse fill's readings (DisparityPipelineConfig::coarse_fill_levels) carve free space
  /// like any reading (true, the first rule) or are occupancy evidence alone (false, ours;
  /// VoxelGrid::integrate's first_no_carve). The coarse window fattens a far surface over a
  /// near thin edge (a table top, a wall's foot seen edge-on, a curb's edge), and the rays of
  /// those readings carved the near surface's voxels free (docs/evaluation.md). Without them the
  /// readings still build the floor's voxels; free space comes from full-resolution rays.
  bool coarse_free_space = true;
  /// 001's landmark filter in front of the voxel grid (off by default). Its depth range and
  /// stationary-frame thresholds are the mapper's (LandmarkStreamConfig::forMapper()).
  LandmarkStreamConfig landmark_filter;
  /// Paper 003's single-frame obstacle cue fused into every new map (obstacle_cue.h; on by
  /// default, the nodelet's ~obstacle_cue; it acts only on cues handed in with addObstacleCue(),
  /// see the README's "Obstacle cue").
  bool obstacle_cue = true;
  ObstacleCueConfig cue;

  /// Empty when valid, otherwise a message naming the parameter and its range.
  std::string validate() const;
};

/// Wall-clock time of the stages of one frame [ms].
struct StereoFrameTimings {
  double disparity_ms = 0.0;  ///< matching and post-filters (0 for processDisparity)
  double reproject_ms = 0.0;
  double landmark_ms = 0.0;      ///< the landmark filter (0 when off or not run)
  double landmark_cpu_ms = 0.0;  ///< its thread CPU time
  StageTimings mapper;           ///< update, height map, segmentation, fit, labelling
  double total_ms = 0.0;
};

struct StereoFrameResult {
  FrameResult mapper;        ///< status of the grid update (kIntegrated, kStationary, ...)
  DisparityStats disparity;  ///< per-step counts (empty for processDisparity)
  std::size_t points = 0;    ///< reprojected points handed to the mapper
  int gap_filled = 0;        ///< disparity pixels the row gap fill added (0 when off)
  std::size_t points_reprojected = 0;  ///< before the landmark filter (== points when off)
  bool landmark_filter_ran = false;    ///< the filter ran on this frame (on, not stationary)
  LandmarkFilterStats landmarks;       ///< its counters when it ran
  bool cue_applied = false;            ///< the obstacle cue marked this frame's map
  bool map_refreshed = false;          ///< stationary frame: the map recomputed with the live cues
  ObstacleCueStats cue;                ///< what it did when applied
  StereoFrameTimings timings;
};

/// Configuration for evaluating one isolated stereo pair (the real-data check): 000's occupancy
/// threshold occ_t = 100 needs ten hits of incr_H = 10, i.e. many frames, so a single pair would
/// leave the grid empty. This mode lowers occ_t to one hit (incr_H) and turns off free-space
/// decrements (decr = 0: within one frame a ray that clears a voxel comes from the same image and
/// is not independent evidence against it, 000 Sec. IV), and lets the robot's segment be seeded up
/// to `seed_radius` metres away, since a single camera does not see the ground within a metre of
/// the robot. Everything else keeps the paper's values.
SafetyMapperConfig singleFrameMapperConfig(const SafetyMapperConfig& base, double seed_radius);

class StereoFrameProcessor {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit StereoFrameProcessor(const StereoFrameProcessorConfig& config = {});

  const StereoFrameProcessorConfig& config() const { return config_; }

  /// Rectified pair (see DisparityPipeline::compute for the accepted types) of a camera whose
  /// left optical frame is at `T_fixed_sensor`, robot base at `robot_base_position` (fixed frame),
  /// taken at `stamp` [s] (kNoStamp: no aging and no cue for this frame; the landmark filter
  /// refuses it).
  /// Returns true when the frame was integrated. On false, *error (when non-null) says why: bad
  /// input or camera model, or the mapper's FrameStatus (stationary frames included; with the
  /// landmark filter on, a frame of which it confirms no point gives the mapper's "empty input"
  /// and `result->landmark_filter_ran`).
  bool processImages(const cv::Mat& left, const cv::Mat& right, const StereoCameraModel& camera,
                     const Eigen::Isometry3f& T_fixed_sensor,
                     const Eigen::Vector3f& robot_base_position, double stamp,
                     StereoFrameResult* result, std::string* error);

  /// Same from a CV_32FC1 disparity image (pixels, invalid <= 0 or non-finite) of `camera`.
  /// `coarse` (optional, CV_32FC1 of the same size, or empty): readings of the coarse fill
  /// kept apart (coarseDisparity()), integrated after `disparity`'s and, with coarse_free_space
  /// false, as occupancy evidence alone. The disparity nodelet publishes the merged output, so
  /// the safety-map nodelet has no coarse image and coarse_free_space false is offline-only.
  bool processDisparity(const cv::Mat& disparity, const StereoCameraModel& camera,
                        const Eigen::Isometry3f& T_fixed_sensor,
                        const Eigen::Vector3f& robot_base_position, double stamp,
                        StereoFrameResult* result, std::string* error,
                        const cv::Mat& coarse = cv::Mat());

  /// Same from points in the sensor frame (non-finite points are skipped by the grid). The
  /// landmark filter does not run (it works in the image); the obstacle cue does.
  bool processPoints(const std::vector<Eigen::Vector3f>& points_sensor,
                     const Eigen::Isometry3f& T_fixed_sensor,
                     const Eigen::Vector3f& robot_base_position, double stamp,
                     StereoFrameResult* result, std::string* error);

  /// Hands in the obstacle points of one frame of the detector (fixed frame) taken at `stamp`
  /// (obstacle_cue.h): the next maps use them while they live. False when the cue is off or the
  /// stamp is not finite.
  bool addObstacleCue(double stamp, const std::vector<Eigen::Vector3f>& points_fixed);
  /// Cells the cue marked in the last map (one entry per map cell, 1 = marked; empty when the
  /// cue is off, did not run on the last map or held no live cue).
  const std::vector<std::uint8_t>& cueMarked() const { return cue_marked_; }
  /// Live cues held, and what the cue did to the last map.
  int cueCount() const { return cue_ ? cue_->size() : 0; }
  const ObstacleCueStats& lastCueStats() const { return cue_stats_; }

  /// Recomputes the map of the current grid for a robot at `robot_base_position` (e.g. after a
  /// stage parameter changed) with the live cues of `stamp`, as a new frame's map would be.
  const SafetyMap& recompute(const Eigen::Vector3f& robot_base_position, double stamp);

  /// Applies a new mapper configuration (SafetyMapper::reconfigure); a new grid also forgets the
  /// landmarks and the cues. Returns "" or why the configuration is refused (nothing changes).
  std::string reconfigureMapper(const SafetyMapperConfig& config, bool* grid_reset = nullptr);

  static constexpr double kNoStamp = std::numeric_limits<double>::quiet_NaN();

  /// Disparity and points of the last frame: the disparity after processImages() as the safety
  /// map reads it (the disparity nodelet's message values, DisparityMessageGeometry; empty after
  /// processDisparity / processPoints), with disparityCamera() its camera model (pass both to
  /// another processor's processDisparity() to map the same frame again); the points are those
  /// handed to the mapper (after the landmark filter when it ran).
  const cv::Mat& disparity() const { return disparity_; }
  /// The coarse fill's readings of the last processImages() when coarse_free_space is off
  /// (empty when it is on, the fill is off or gave none): with them disparity() holds the
  /// full-resolution readings alone. Pass both to another processor's processDisparity() to map
  /// the same frame again. With coarse_free_space on, disparity() is the merged output, the
  /// disparity nodelet's message.
  const cv::Mat& coarseDisparity() const { return coarse_disparity_; }
  const StereoCameraModel& disparityCamera() const { return disparity_camera_; }
  const std::vector<Eigen::Vector3f>& points() const { return points_; }

  SafetyMapper& mapper() { return mapper_; }
  const SafetyMapper& mapper() const { return mapper_; }
  DisparityPipeline& disparityPipeline() { return pipeline_; }
  /// The landmark filter (its permanent landmarks are 001's 3D model); idle when off.
  const LandmarkStreamFilter& landmarkFilter() const { return landmarks_; }

  /// Forgets the map, the landmarks and the cues (the next frame counts as the first).
  void reset();

 private:
  /// `disparity`, or its row-gap-filled copy in filled_ when row_gap_fill is on.
  const cv::Mat& gapFilled(const cv::Mat& disparity, const StereoCameraModel& camera,
                           StereoFrameResult* r);
  // Paper 003's cue on the current map (obstacle_cue.h), when on and the stamp is finite.
  void applyCue(const Eigen::Vector3f& robot_base_position, double stamp, StereoFrameResult* r);
  // A stationary frame: the map recomputed with the cues of `stamp` while any is live or the
  // map still shows cue marks (see the top of this file).
  void refreshAtRest(const Eigen::Vector3f& robot_base_position, double stamp,
                     StereoFrameResult* r);
  // The shared tail of every entry point: landmark filter (when `camera` is given), mapper,
  // obstacle cue, on points_.
  // Reprojects `disparity` (and `coarse` after it) into points_, the coarse points from
  // first_no_carve_ on when coarse_free_space is off.
  void reproject(const cv::Mat& disparity, const cv::Mat& coarse, const StereoCameraModel& camera,
                 StereoFrameResult* r);
  bool integrate(const StereoCameraModel* camera, const Eigen::Isometry3f& T_fixed_sensor,
                 const Eigen::Vector3f& robot_base_position, double stamp,
                 StereoFrameResult* result, std::string* error);

  StereoFrameProcessorConfig config_;
  DisparityPipeline pipeline_;
  StereoInputCheck input_check_;
  SafetyMapper mapper_;
  LandmarkStreamFilter landmarks_;
  std::unique_ptr<ObstacleCueFusion> cue_;  // null when the cue is off
  std::vector<std::uint8_t> cue_marked_;
  ObstacleCueStats cue_stats_;
  cv::Mat disparity_;
  cv::Mat coarse_disparity_;                           ///< coarseDisparity()
  std::size_t first_no_carve_ = VoxelGrid::kAllCarve;  ///< of points_, for the mapper
  std::vector<Eigen::Vector3f> coarse_points_;         ///< buffer of the coarse reprojection
  cv::Mat filled_;  ///< the row-gap-filled copy that is reprojected (row_gap_fill on)
  std::vector<float> fill_above_;  ///< fillRowGaps' column buffer
  StereoCameraModel disparity_camera_;
  std::vector<Eigen::Vector3f> points_;
};

}  // namespace stereo_safety_map
