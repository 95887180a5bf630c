// evaluate_safety_map's units (main.cpp: options and main; run.cpp: the core or the recorded
// maps over each dataset; score.cpp: confusion, planes and targets; report.cpp: metrics.json,
// report.md, the per-frame CSVs; model_3d.cpp: the 3D model picture). What they share: the
// options, the per-frame and per-dataset records and the run's summary.
#pragma once

#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/map_image.h"
#include "stereo_safety_map/core/safety_mapper.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/tools/dataset_reader.h"
#include "stereo_safety_map/tools/series.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <string>
#include <vector>

namespace ssm = stereo_safety_map;

namespace evaluate_safety_map {

using ssm::SafetyLabel;
using Clock = std::chrono::steady_clock;
using ssm::fileExists;
using ssm::labelColour;
using ssm::makeDirs;
using ssm::mapBesideGroundTruth;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------
// Options

struct Options {
  std::vector<std::string> bags;
  std::vector<std::string> latency_bags;
  std::string out = "out/evaluation";
  std::vector<int> decr = {1};
  int every = 1;
  long max_frames = -1;
  int images = 3;
  int plane_frames = 5;
  unsigned seed = 1;
  std::vector<std::string> params;
  std::vector<std::string> sets;
  std::string recorded;
  std::string fixed_frame = "odom";
  std::string base_frame = "base_link";
  std::string camera = "stereo";
  bool model = true;
  bool quiet = false;
  int dump_frame = -1;
  std::string scenes = "scenes";  // where to look for scene files (local-horizon GT)  // print the
                                  // segments of this stereo pair's map (first dataset, first decr)
};

// ---------------------------------------------------------------------------------------------
// Statistics

using ssm::tools::Series;  // tools/series.h

inline constexpr const char* kStageNames[] = {"disparity",  "reproject",    "update",
                                              "height_map", "segmentation", "plane_fit",
                                              "labelling",  "mapper_total", "frame_total"};
constexpr int kStages = 9;

struct PlaneSample {
  int frame = 0;
  std::string reference;
  double angle_deg = 0.0;
  double distance = 0.0;
  int cells = 0;
  SafetyLabel label = SafetyLabel::kLevel;
};

struct LatencyResult {
  std::string board;
  double start_distance = kNaN;  // optical centre to the board's face at the first frame [m]
  int appear_frame = -1;         // first frame with the board in view (0-based)
  std::vector<double> coverage;  // per camera frame from the appearance
  int frames_to_50 = -1;
  int frames_to_90 = -1;
  int frames_available = 0;
};

struct FrameRecord {
  int index = 0;
  double stamp = 0.0;
  std::string status;
  bool robot_segment = false;
  ssm::ConfusionCounts counts;
  std::size_t points = 0;
  double ms[kStages] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
};

struct DatasetResult {
  std::string name;
  bool latency_only = false;
  int pairs = 0;       // stereo pairs read
  int integrated = 0;  // maps evaluated
  int stationary = 0;
  int rejected = 0;  // no tf, bad images, ...
  int without_robot_segment = 0;
  // Where the false positives are (diagnostics): cells of ground segments labelled Non-ground
  // (unreachable or too steep, Alg. 2), columns in no segment (heights unlike their neighbours),
  // and all FPs of maps without the robot's segment.
  std::uint64_t fp_in_segment = 0, fp_no_segment = 0, fp_without_robot_segment = 0;
  ssm::ConfusionCounts sum;
  ssm::ConfusionCounts seeded;  // maps in which the robot's segment was found
  // Against the local-horizon GT: the scene's GT relabelled at every frame with reachability
  // from the robot's position within R_max (what the robot could know), when the scene file
  // is found; `local_maps` counts the maps compared.
  ssm::ConfusionCounts local;
  int local_maps = 0;
  Series stage_ms[kStages];
  std::vector<PlaneSample> planes_all;
  std::vector<PlaneSample> planes_protocol;
  std::vector<int> protocol_frames;
  std::vector<LatencyResult> latency;
  std::vector<FrameRecord> frames;
  std::vector<std::string> images;
  double bag_seconds = 0.0;
  double wall_seconds = 0.0;
  std::map<std::string, int> problems;
};

struct Run {
  std::string label;  // "decr=1" or "recorded"
  int decr = 1;
  std::vector<DatasetResult> datasets;
};

// ---------------------------------------------------------------------------------------------
// Scores (score.cpp)

struct PlaneSummary {
  ssm::MeanStd angle, distance;
};
struct RunSummary {
  ssm::MeanStd fn, fp, tp, tn, precision, recall, f1;
  ssm::MeanStd seeded_fn, seeded_fp;
  ssm::MeanStd local_fn, local_fp;  // over the datasets with a local-horizon GT
  PlaneSummary planes_protocol, planes_all;
  Series stage_ms[kStages];
  int datasets = 0;
  int maps = 0;
  int without_robot_segment = 0;
  double bag_seconds = 0.0, wall_seconds = 0.0;
};

struct Target {
  std::string name;
  double measured;
  double limit;
  std::string unit;
  std::string paper;
  bool pass() const { return std::isfinite(measured) && measured <= limit; }
};

/// One map against the dataset's GT: confusion counts, where the FPs are, planes (000 Sec. VII).
void evaluateFrameMap(const ssm::Dataset& ds, const ssm::SafetyMap& map, int frame, double stamp,
                      bool protocol_frame, FrameRecord* rec, DatasetResult* res,
                      std::vector<ssm::CellOutcome>* outcomes);
PlaneSummary summarize(const std::vector<PlaneSample>& v);
RunSummary summarize(const Run& run);
/// The targets at the default parameters (decr = 1).
std::vector<Target> targets(const std::vector<Run>& runs);

// ---------------------------------------------------------------------------------------------
// Runs (run.cpp)

/// The core on each stereo pair of each dataset, one mapper per --decr value.
std::string evaluateOffline(const Options& opt, const ssm::StereoFrameProcessorConfig& base,
                            const std::vector<ssm::Dataset>& datasets, std::vector<Run>* runs);
/// --recorded: the SafetyMap messages the nodelets published while the bag was replayed.
std::string evaluateRecorded(const Options& opt, const ssm::Dataset& ds, std::vector<Run>* runs);

// ---------------------------------------------------------------------------------------------
// Output (report.cpp, model_3d.cpp)

std::string writeFrameCsv(const std::string& path, const DatasetResult& r, const std::string& run);
/// metrics.json and report.md.
std::string writeOutputs(const Options& opt, const ssm::StereoFrameProcessorConfig& config,
                         const std::vector<Run>& runs, const std::string& command);
std::string fmtPm(const ssm::MeanStd& m, double scale, int prec = 1);
/// The hybrid 3D model of 000 Fig. 4(b) seen from behind and above the robot.
cv::Mat render3dModel(const ssm::SafetyMapper& mapper, const Eigen::Vector3d& robot, double yaw);

}  // namespace evaluate_safety_map
