// One stereo frame through the whole core pipeline of paper 000, ROS-free: rectified pair ->
// disparity and its post-filters (Sec. III, disparity_pipeline.h) -> 3D points in the camera
// frame (stereo_camera_model.h) -> voxel grid update, segmentation, plane fit and labelling
// (Sec. IV-VI, safety_mapper.h).
//
// Optionally, paper 001's landmark filter (Sec. 4.2, landmark_filter.h) sits between the
// reprojection and the voxel grid: with `landmark_filter.enabled` only points confirmed by a
// permanent landmark reach the grid. It runs on the frames the grid integrates (not on stationary
// ones) and needs each frame's stamp.
//
// The offline evaluator and the ROS nodelets share this class so that a frame read from a bag and
// a frame arriving on a topic go through the same code: the evaluator calls processImages(); the
// safety-map nodelet, which receives a disparity image, can call processDisparity() (the
// reprojection range is the grid's [min_range, max_range] and `disparity_step` subsamples rows
// and columns, exactly as the nodelet does).
#pragma once

#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/core/landmark_filter.h"
#include "stereo_safety_map/core/safety_mapper.h"
#include "stereo_safety_map/core/stereo_camera_model.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct StereoFrameProcessorConfig {
  DisparityPipelineConfig disparity;
  SafetyMapperConfig mapper;
  int disparity_step =
      1;  ///< reproject every n-th row and column, [1, 16] (nodelet's ~disparity_step)
  /// 001's landmark filter in front of the voxel grid (off by default). Its depth range and
  /// stationary-frame thresholds are the mapper's (LandmarkStreamConfig::forMapper()).
  LandmarkStreamConfig landmark_filter;

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
  std::size_t points_reprojected = 0;  ///< before the landmark filter (== points when off)
  bool landmark_filter_ran = false;    ///< the filter ran on this frame (on, not stationary)
  LandmarkFilterStats landmarks;       ///< its counters when it ran
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
  /// left optical frame is at `T_fixed_sensor`, robot base at `robot_base_position` (fixed frame).
  /// Returns true when the frame was integrated. On false, *error (when non-null) says why: bad
  /// input or camera model, or the mapper's FrameStatus (stationary frames included; with the
  /// landmark filter on, frames of which it confirms no point give the mapper's "empty input").
  /// `stamp` [s] is needed by the landmark filter only (a non-finite stamp is then an error).
  bool processImages(const cv::Mat& left, const cv::Mat& right, const StereoCameraModel& camera,
                     const Eigen::Isometry3f& T_fixed_sensor,
                     const Eigen::Vector3f& robot_base_position, StereoFrameResult* result,
                     std::string* error, double stamp = kNoStamp);

  /// Same from a CV_32FC1 disparity image (pixels, invalid <= 0 or non-finite) of `camera`.
  bool processDisparity(const cv::Mat& disparity, const StereoCameraModel& camera,
                        const Eigen::Isometry3f& T_fixed_sensor,
                        const Eigen::Vector3f& robot_base_position, StereoFrameResult* result,
                        std::string* error, double stamp = kNoStamp);

  static constexpr double kNoStamp = std::numeric_limits<double>::quiet_NaN();

  /// Disparity and points of the last frame (the disparity is empty after processDisparity); the
  /// points are those handed to the mapper (after the landmark filter when it ran).
  const cv::Mat& disparity() const { return disparity_; }
  const std::vector<Eigen::Vector3f>& points() const { return points_; }

  SafetyMapper& mapper() { return mapper_; }
  const SafetyMapper& mapper() const { return mapper_; }
  DisparityPipeline& disparityPipeline() { return pipeline_; }
  /// The landmark filter (its permanent landmarks are 001's 3D model); idle when off.
  const LandmarkStreamFilter& landmarkFilter() const { return landmarks_; }

  /// Forgets the map and the landmarks (the next frame counts as the first).
  void reset() {
    mapper_.reset();
    landmarks_.reset();
  }

 private:
  bool integrate(const cv::Mat& disparity, const StereoCameraModel& camera,
                 const Eigen::Isometry3f& T_fixed_sensor,
                 const Eigen::Vector3f& robot_base_position, double stamp,
                 StereoFrameResult* result, std::string* error);

  StereoFrameProcessorConfig config_;
  DisparityPipeline pipeline_;
  SafetyMapper mapper_;
  LandmarkStreamFilter landmarks_;
  cv::Mat disparity_;
  std::vector<Eigen::Vector3f> points_;
};

}  // namespace stereo_safety_map
