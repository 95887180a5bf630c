// One procedural scene of the open-world evaluation, end to end and ROS-free: the scene's
// analytic ground truth, the stereo pair rendered at the TRUE camera pose of every frame (with the
// chassis' unreported pitch and roll), the image degradations, and the core's one entry point per
// frame (StereoFrameProcessor, what the safety-map nodelet runs) fed the REPORTED pose (odometry
// with drift and scale error), each map scored against the ground truth (open_world_scoring.h).
// Several mapper variants (the default, the paper-faithful one, ablations) run on the same
// rendered frames; variants that share the first variant's disparity settings map its disparity
// (processDisparity with disparity() and disparityCamera(): the disparity nodelet's message), so
// that they differ only in what they configure.
#pragma once

#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/dataset/degradation.h"
#include "stereo_safety_map/dataset/ground_truth.h"
#include "stereo_safety_map/dataset/open_world_scoring.h"
#include "stereo_safety_map/dataset/procedural_scene.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace dataset {

struct OpenWorldVariant {
  std::string name;
  StereoFrameProcessorConfig config;
  /// Computes its own disparity (another matcher or post-filters); false: maps the first
  /// variant's disparity (its disparity settings must then equal the first variant's).
  bool own_disparity = false;
  /// Paper 003's detector on this variant's disparity every frame, as the obstacle-detection
  /// nodelet runs beside the safety map: when config.obstacle_cue is on its raised points are
  /// handed to the processor after the frame (the next maps use them: the two nodelets run in
  /// parallel, so a map usually sees the previous frame's cue), and with score_detector (or the
  /// cue) it is scored per frame (SceneScore::detection).
  ObstacleDetectionConfig detector;
  double detector_min_depth = 0.2;  ///< the nodelet's min_depth / max_depth [m]
  double detector_max_depth = 8.0;
  int detector_decimation = 2;  ///< the nodelet's decimation (decimateRangeImage), its default
  bool score_detector = false;
};

struct OpenWorldRunOptions {
  GroundTruthConfig ground_truth;  ///< robot parameters of the GT (000 Alg. 1-2 defaults)
  OpenWorldScoringConfig scoring;
  int render_threads = 1;
  int max_frames = -1;  ///< -1: the whole trajectory
  /// Pictures (map in the world | ground truth | outcomes) of these frames of every variant are
  /// written to image_dir as seed<S>_frame<F>_<variant>.png (none when empty).
  std::string image_dir;
  std::vector<int> image_frames;
  /// For development: cells (world x, y [m]) whose state every variant writes for every frame to
  /// image_dir/seed<S>_trace.txt (label, segment, memory band, the column's log-odds).
  std::vector<Eigen::Vector2d> trace_cells;
};

/// The map resampled onto the ground truth's grid through T_world_odom (nearest cell), over the
/// map's extent: the map as the world sees it, for pictures.
SafetyMap mapInWorld(const SafetyMap& map, const Eigen::Isometry2d& T_world_odom,
                     const GroundTruthMap& gt);

struct OpenWorldSceneResult {
  std::uint64_t seed = 0;
  std::string description;         ///< floor kind and hazards, one line
  std::string error;               ///< empty when the scene ran
  std::vector<SceneScore> scores;  ///< one per variant
  int frames = 0;
  double seconds = 0.0;  ///< wall time
};

/// Runs one scene under one degradation with every variant. Never throws; problems go to
/// result.error.
OpenWorldSceneResult runOpenWorldScene(const ProceduralScene& scene,
                                       const DegradationConfig& degradation,
                                       const std::vector<OpenWorldVariant>& variants,
                                       const OpenWorldRunOptions& options);

}  // namespace dataset
}  // namespace stereo_safety_map
