// One stereo frame through the whole core pipeline of paper 000, ROS-free: rectified pair ->
// disparity and its post-filters (Sec. III, disparity_pipeline.h) -> 3D points in the camera
// frame (stereo_camera_model.h) -> voxel grid update, segmentation, plane fit and labelling
// (Sec. IV-VI, safety_mapper.h).
//
// The offline evaluator and the ROS nodelets share this class so that a frame read from a bag and
// a frame arriving on a topic go through the same code: the evaluator calls processImages(); the
// safety-map nodelet, which receives a disparity image, can call processDisparity() (the
// reprojection range is the grid's [min_range, max_range] and `disparity_step` subsamples rows
// and columns, exactly as the nodelet does).
#pragma once

#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/core/safety_mapper.h"
#include "stereo_safety_map/core/stereo_camera_model.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct StereoFrameProcessorConfig {
  DisparityPipelineConfig disparity;
  SafetyMapperConfig mapper;
  int disparity_step =
      1;  ///< reproject every n-th row and column, [1, 16] (nodelet's ~disparity_step)

  /// Empty when valid, otherwise a message naming the parameter and its range.
  std::string validate() const;
};

/// Wall-clock time of the stages of one frame [ms].
struct StereoFrameTimings {
  double disparity_ms = 0.0;  ///< matching and post-filters (0 for processDisparity)
  double reproject_ms = 0.0;
  StageTimings mapper;  ///< update, height map, segmentation, fit, labelling
  double total_ms = 0.0;
};

struct StereoFrameResult {
  FrameResult mapper;        ///< status of the grid update (kIntegrated, kStationary, ...)
  DisparityStats disparity;  ///< per-step counts (empty for processDisparity)
  std::size_t points = 0;    ///< reprojected points handed to the mapper
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
  /// input or camera model, or the mapper's FrameStatus (stationary frames included).
  bool processImages(const cv::Mat& left, const cv::Mat& right, const StereoCameraModel& camera,
                     const Eigen::Isometry3f& T_fixed_sensor,
                     const Eigen::Vector3f& robot_base_position, StereoFrameResult* result,
                     std::string* error);

  /// Same from a CV_32FC1 disparity image (pixels, invalid <= 0 or non-finite) of `camera`.
  bool processDisparity(const cv::Mat& disparity, const StereoCameraModel& camera,
                        const Eigen::Isometry3f& T_fixed_sensor,
                        const Eigen::Vector3f& robot_base_position, StereoFrameResult* result,
                        std::string* error);

  /// Disparity and points of the last frame (the disparity is empty after processDisparity).
  const cv::Mat& disparity() const { return disparity_; }
  const std::vector<Eigen::Vector3f>& points() const { return points_; }

  SafetyMapper& mapper() { return mapper_; }
  const SafetyMapper& mapper() const { return mapper_; }
  DisparityPipeline& disparityPipeline() { return pipeline_; }

  /// Forgets the map (the next frame counts as the first).
  void reset() { mapper_.reset(); }

 private:
  bool integrate(const cv::Mat& disparity, const StereoCameraModel& camera,
                 const Eigen::Isometry3f& T_fixed_sensor,
                 const Eigen::Vector3f& robot_base_position, StereoFrameResult* result,
                 std::string* error);

  StereoFrameProcessorConfig config_;
  DisparityPipeline pipeline_;
  SafetyMapper mapper_;
  cv::Mat disparity_;
  std::vector<Eigen::Vector3f> points_;
};

}  // namespace stereo_safety_map
