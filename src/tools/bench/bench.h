// bench_pipeline's studies (src/tools/bench/): what they share (the options, the rendered input,
// the results every study adds to) and one function per study, called by main in this order
// (bench_pipeline.cpp). The order matters: the registry lists the series in the order they are
// first measured, and that is the order of bench.md's and bench.json's stages.
#pragma once

#include "bench_support.h"

#include "stereo_safety_map/core/ground_segmentation.h"
#include "stereo_safety_map/core/height_map.h"
#include "stereo_safety_map/core/plane_fit.h"
#include "stereo_safety_map/core/safety_labelling.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/core/safety_mapper.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene_loader.h"
#include "stereo_safety_map/dataset/trajectory.h"

#include <sched.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstddef>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace bench {

namespace ds = stereo_safety_map::dataset;

struct Options {
  std::string scene = "scenes/dataset1_rail_dropoff_ramp.yaml";
  std::string json;
  int frames = 20;  // measured frames
  int warmup = 30;  // frames integrated first so that the map has grown (2 s at 15 Hz)
  int stride = 1;   // take every stride-th moving frame of the trajectory
  int passes = 2;   // passes over the measured frames for the stateless stages
  int scaling_frames = 6;
  int cpu = -1;  // -1 = the core the program starts on
  bool pin = true;
  bool quick = false;
  bool scaling = true;
};

// ---------------------------------------------------------------------------------------------
// Input: frames of the dataset rendered in-process.

struct Frame {
  std::size_t index = 0;  // frame number in the trajectory
  cv::Mat left, right;
  Eigen::Isometry3f T_fixed_left = Eigen::Isometry3f::Identity();
  Eigen::Vector3f base = Eigen::Vector3f::Zero();
  double stamp = 0.0;  // [s], the trajectory's time
};

// Image-size sweep: the first measured poses at three resolutions (640x480 reuses the frames).
struct SizedFrames {
  int width, height;
  ds::StereoHeadConfig head;
  std::vector<Frame> frames;
};

// ---------------------------------------------------------------------------------------------
// Results.

struct Comparison {
  std::string ours, peer, what;
};

struct Target {
  Target(std::string n, std::string u) : name(std::move(n)), unit(std::move(u)) {}
  std::string name, unit;
  double wall = std::numeric_limits<double>::quiet_NaN();
  double cpu = std::numeric_limits<double>::quiet_NaN();
  double limit = 0.0;
  int limit_digits = 0;  // decimals of the limit as printed
  bool at_most = true;   // value <= limit (else >= limit)
  std::string note;
  bool metBy(double v) const { return std::isfinite(v) && (at_most ? v <= limit : v >= limit); }
};

struct ScalingPoint {
  std::string sweep;  // "image_size", "map_size", "voxel_size"
  double x = 0.0;
  std::string label;
  std::map<std::string, double> wall_median;  // stage -> median wall [ms]
  double cpu_total_median = std::numeric_limits<double>::quiet_NaN();
  double points_median = std::numeric_limits<double>::quiet_NaN();
  double mallocs_median = std::numeric_limits<double>::quiet_NaN();
  int frames = 0;
  std::string error;
};

// What the map stages worked on, and how our plane fit compares with PCL's on it. The stage
// objects are our own instances with the mapper's configuration, kept across frames so that
// their buffers are reused as in SafetyMapper.
struct MapStudy {
  MapStudy(std::string s, std::string w) : suffix(std::move(s)), what(std::move(w)) {}
  std::string suffix;  // "" for the pipeline's map, "_dense" for the dense one
  std::string what;
  std::vector<double> fit_angle, fit_points, inlier_fraction, segments, columns, seed;
  std::unique_ptr<ssm::HeightMap> height_map;
  std::unique_ptr<ssm::GroundSegmentation> segmentation;
  std::unique_ptr<ssm::PlaneFitter> fitter;
  std::unique_ptr<ssm::SafetyLabelling> labelling;
  ssm::GroundSegments segs;
  std::vector<ssm::GroundPlane> planes;
  ssm::SafetyMap map;
};

// ---------------------------------------------------------------------------------------------
// One run: the input, the machine, and what the studies found.

struct Bench {
  Options opt;
  // Input (input.cpp).
  ds::SceneFile sf;
  std::vector<ds::RobotPose> poses;
  std::vector<std::size_t> chosen;
  ds::StereoHeadConfig head;
  std::vector<Frame> frames;    // warm-up + measured
  std::vector<Frame> measured;  // frames after the warm-up
  std::vector<SizedFrames> sized;
  double render_s = 0.0;
  ssm::StereoCameraModel cam;
  ssm::StereoFrameProcessorConfig pcfg;  // package defaults
  // Machine.
  double t_start = 0.0;
  std::string load_start, load_end;
  double rss_start = 0.0, rss_end = 0.0, rss_peak = 0.0;
  double run_s = 0.0, proc_cpu_s = 0.0;
  cpu_set_t start_mask;  // every core the program may use, for the two-thread disparity variant
  int pinned_cpu = -1;
  // Results.
  Registry reg;
  std::vector<Comparison> comparisons;
  std::map<std::string, double> extra;                        // scalar facts for the JSON / tables
  std::vector<std::string> problems;                          // functional failures: non-zero exit
  std::vector<std::string> pending;                           // measurements not made in this run
  std::vector<std::vector<Eigen::Vector3f>> points_of;        // pipeline points, per frame
  std::vector<std::vector<Eigen::Vector3f>> dense_points_of;  // dense SGBM points, per frame
  std::vector<cv::Mat> disparity_of;                          // pipeline disparity, measured
  int not_integrated = 0;
  MapStudy pipeline_map{"", "the pipeline's map"};
  MapStudy dense_map{"_dense", "dense map, SGBM points"};
  std::map<std::string, std::vector<double>> density;
  std::vector<std::pair<std::string, Sample>> disparity_allocs;
  std::vector<ScalingPoint> scaling;
  std::vector<Target> targets;

  /// Median wall (or thread CPU) time of the series `id` [ms]; NaN when there is none.
  double med(const std::string& id, bool cpu) const { return medianOf(reg, id, cpu); }
};

// ---------------------------------------------------------------------------------------------
// The steps of a run, in main's order.

/// Options from the command line; false with `*exit_code` set when the program should stop
/// (--help: 0, a bad option: 2).
bool parseOptions(int argc, char** argv, Options* opt, int* exit_code);
/// Loads the scene and renders the frames (input.cpp). False (said on stderr) when it cannot.
bool prepareInput(Bench* b);
/// One thread, one core: cv::setNumThreads(1) and the measuring thread pinned (input.cpp).
void pinMeasuringThread(Bench* b);

/// 1. The whole pipeline per frame, StereoFrameProcessor with BM + filters (study_map.cpp).
void studyPipeline(Bench* b);
/// 1b. A dense map: the same frames through OpenCV SGBM without any filter (study_map.cpp).
void studyDenseMap(Bench* b);
/// 2. Disparity: ours vs OpenCV alone vs stereo_image_proc (study_disparity.cpp).
void studyDisparity(Bench* b);
/// 3. Reprojection: ours vs image_geometry (study_voxel_grid.cpp).
void studyReprojection(Bench* b);
/// 4. Voxel grid update: ours vs OctoMap (study_voxel_grid.cpp).
void studyVoxelGrid(Bench* b);
/// 5. Scaling sweeps over image, map and voxel size (study_scaling.cpp).
void studyScaling(Bench* b);

/// The targets (medians against the limits; report.cpp).
void computeTargets(Bench* b);
/// The Markdown tables on stdout; also takes the end-of-run machine facts (report.cpp).
void printMarkdown(Bench* b);
/// bench.json. False when it cannot be written (report.cpp).
bool writeJson(Bench* b, int argc, char** argv);

}  // namespace bench
