// The field lists of the core's configurations (param_fields.h): the one place a core parameter
// is declared. The nodelets' own settings (frames, queues) have their lists next to their
// structs in the ROS layer (ros/safety_map_params.h, ros/disparity_params.h, ...), and
// ros/nodelet_params.h puts each nodelet's lists together in README order.
//
// To add a core parameter: one add(...) line in the list of its config struct
// (src/core/safety_map_fields.cpp for the safety map, src/core/config_fields.cpp for the
// others), with its range as the struct's validate() checks it and a doc citing the paper or
// "(ours)"; then the key in config/<nodelet>.yaml and, if live, its line in cfg/<Nodelet>.cfg.
// test_param_fields and test_nodelet_params say what is missing (DEVELOPERS.md, "How to add a
// parameter").
#pragma once

#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/core/hybrid_safety_map.h"
#include "stereo_safety_map/core/landmark_filter.h"
#include "stereo_safety_map/core/laser_grid.h"
#include "stereo_safety_map/core/obstacle_detection.h"
#include "stereo_safety_map/core/occupancy_grid_2d.h"
#include "stereo_safety_map/core/param_fields.h"
#include "stereo_safety_map/core/safety_mapper.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"

#include <cstdint>
#include <string>

namespace stereo_safety_map {

/// dynamic_reconfigure levels of cfg/SafetyMap.cfg (test_nodelet_params compares them).
struct SafetyMapLevel {
  /// Height map / segmentation / plane fit / labelling / frame skipping / aging: applied to the
  /// next map, the 3D model is kept.
  static constexpr uint32_t kStage = 1;
  /// The voxel grid's sensor model: the grid is rebuilt, the map starts again.
  static constexpr uint32_t kGrid = 2;
  /// Nodelet settings.
  static constexpr uint32_t kRos = 4;
};

/// dynamic_reconfigure levels of cfg/Disparity.cfg.
struct DisparityLevel {
  static constexpr uint32_t kMatcher = 1;  ///< the matchers are rebuilt
  static constexpr uint32_t kFilter = 2;   ///< post-filter settings, applied to the next frame
};

/// Paper 000's mapper: voxel grid, height map, segmentation, plane fit, labelling, frames.
/// Validation: each part's validate() (unprefixed, as the nodelet has always reported them),
/// then the mapper's own.
const ParamFieldList<SafetyMapperConfig>& safetyMapperFields();

/// The row gap fill of the safety map's disparity (disparity_gap_fill.h): row_gap_fill*, in the
/// safety-map nodelet's own list (it runs where the nodelet reprojects) and the offline
/// processor's.
const ParamFieldList<RowGapFillConfig>& rowGapFillFields();

/// 001's landmark filter in front of the grid: use_landmark_filter and landmark_* (the depth
/// range and stationary-frame thresholds are the mapper's, LandmarkStreamConfig::forMapper()).
/// Validation: the filter's, its field names with the landmark_ prefix.
const ParamFieldList<LandmarkStreamConfig>& landmarkStreamFields();

/// The disparity pipeline (matcher and post-filters) under the disparity nodelet's flat names.
/// texture_window_size is 0 while the texture window follows block_size (002 Sec. 2.2 measures
/// texture over the matching window), and block_size carries a following window along.
/// Validation: the ranges of cfg/Disparity.cfg, then the core's, in parameter names.
const ParamFieldList<DisparityPipelineConfig>& disparityPipelineFields();

/// What the offline tools read from config/safety_map.yaml and config/disparity.yaml
/// (loadCoreParams, setCoreParam): the mapper, disparity_step, the landmark filter and the
/// disparity pipeline. Validation: StereoFrameProcessorConfig::validate().
const ParamFieldList<StereoFrameProcessorConfig>& stereoFrameProcessorFields();

/// Paper 003's detector (config/obstacle_detection.yaml).
const ParamFieldList<ObstacleDetectionConfig>& obstacleDetectionFields();

/// Paper 002's 2D occupancy grid (config/occupancy_grid_2d.yaml).
const ParamFieldList<OccupancyGrid2DConfig>& occupancyGrid2DFields();

/// Paper 001's laser grid: resolution and log-odds (its width and height come from the hybrid
/// nodelet's laser_size_x / laser_size_y). Validation: LaserGridConfig::validate().
const ParamFieldList<LaserGridConfig>& laserGridFields();
/// Paper 001's combination rules (config/hybrid_safety_map.yaml).
const ParamFieldList<HybridSafetyMapConfig>& hybridSafetyMapFields();

/// "bm" / "sgbm" <-> StereoMatcherType.
const char* matcherName(StereoMatcherType type);
bool matcherFromName(const std::string& name, StereoMatcherType* type);
/// "full" / "opencv" <-> LeftRightMode.
const char* leftRightModeName(LeftRightMode mode);
bool leftRightModeFromName(const std::string& name, LeftRightMode* mode);

/// The parameter texture_window_size of a pipeline configuration: 0 while the texture window
/// follows the block size.
int textureWindowParameter(const DisparityPipelineConfig& c);

/// Ranges of the disparity pipeline's parameters (the ones cfg/Disparity.cfg uses) and the
/// core's own checks, with the core's names translated to parameter names; the first failure.
std::string validateDisparityParameters(const DisparityPipelineConfig& config);

/// Replaces the core's nested names in a validate() message (texture.window_size) with the
/// parameter names (texture_window_size).
std::string toParameterNames(const std::string& core_message);

}  // namespace stereo_safety_map
