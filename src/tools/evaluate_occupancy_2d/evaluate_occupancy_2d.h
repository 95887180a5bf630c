// evaluate_occupancy_2d's units (main.cpp: options and main; run.cpp: one dataset through the four
// 2D grids and the safety map; score.cpp: the rates, the GT's Non-ground causes; report.cpp:
// metrics.json, report.md, evaluate_safety_map's numbers beside ours). What they share: the
// options, the per-dataset results and the set-up.
#pragma once

#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/occupancy_grid_2d.h"
#include "stereo_safety_map/core/occupancy_grid_2d_evaluation.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/tools/dataset_reader.h"

#include <array>
#include <chrono>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace ssm = stereo_safety_map;
using Clock = std::chrono::steady_clock;

namespace evaluate_occupancy_2d {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------
// Options

struct Options {
  std::vector<std::string> bags;          // benchmark datasets
  std::vector<std::string> compare_bags;  // repeating-texture scenes (ghost obstacles)
  std::vector<std::string> latency_bags;
  std::string out = "out/evaluation/occupancy_2d";
  std::string params = "config/occupancy_grid_2d.yaml";
  std::string core_params = "config/safety_map.yaml";
  std::string scenes = "scenes";  // where scene files named relatively in dataset.yaml are
  std::vector<std::string> sets;
  double radius = -1.0;  // < 0: the safety map's planning radius
  int every = 1;
  long max_frames = -1;
  int images = 2;
  std::string safety_metrics;
  bool safety_map = true;
  bool quiet = false;
  std::string command;
};

// ---------------------------------------------------------------------------------------------
// Results

// The four grids run side by side (002 Sec. 4.2 spike removal x Sec. 4.3 accuracy preservation).
struct Variant {
  const char* name;
  bool spikes;
  bool preservation;
};
constexpr Variant kVariants[] = {
    {"spike removal + accuracy preservation", true, true},
    {"spike removal only", true, false},
    {"accuracy preservation only", false, true},
    {"neither", false, false},
};
constexpr int kNumVariants = 4;

struct Latency {
  std::string board;
  double start_distance = kNaN;
  int appear_frame = -1;
  std::vector<double> coverage;
  int frames_to_50 = -1;
  int frames_to_90 = -1;
};

// One mapper's results on one dataset.
struct MapperResult {
  ssm::ConfusionCounts counts;
  ssm::UnsafeCauseCounts causes;
  ssm::DropOffEdgeCounts edges;
  std::vector<Latency> latency;
  int maps = 0;  // maps evaluated (the safety map skips stationary frames)
};

enum class Kind { kBenchmark, kCompare, kLatency };
inline const char* kindName(Kind k) {
  return k == Kind::kBenchmark ? "benchmark" : k == Kind::kCompare ? "compare" : "latency";
}

struct DatasetResult {
  std::string name;
  Kind kind = Kind::kBenchmark;
  bool causes_ok = false;
  std::array<int, ssm::kNumUnsafeCauses> gt_cause_cells{};
  int gt_edge_cells = 0;
  std::string note;
  int pairs = 0;
  int rejected = 0;
  std::map<std::string, int> problems;
  std::array<MapperResult, kNumVariants> grid;
  MapperResult safety;
  bool safety_ran = false;
  std::vector<double> disparity_ms, grid_ms, safety_ms;
  std::vector<std::string> images;
};

// ---------------------------------------------------------------------------------------------
// Ground truth causes: the dataset's own GT code run again from its scene file, for the per-cell
// information the label file does not keep (obstacle, slope, reachability).

// Per GT cell: why it is Non-ground, and whether it is a drop-off edge (a safe cell with an
// 8-neighbour whose ground is lower by at least h_T, 000 Sec. VI; cells next to the end of the
// ground, e.g. at a wall's foot, are not counted as drop-off edges here).
struct GtExtras {
  std::vector<ssm::UnsafeCause> causes;
  std::vector<std::uint8_t> edge;
  std::array<int, ssm::kNumUnsafeCauses> cause_cells{};  // in the whole GT map
  int edge_cells = 0;
};

// Setup: the 2D grid's and the core's parameters, the radius evaluated.
struct Setup {
  ssm::OccupancyGrid2DConfig grid;
  ssm::StereoFrameProcessorConfig core;  // disparity (with spike removal) and safety map
  double radius = 4.0;
};

// ---------------------------------------------------------------------------------------------
// evaluate_safety_map's metrics.json (optional): its decr = 1 counts and latency per dataset.
struct SafetyReference {
  bool loaded = false;
  std::map<std::string, ssm::ConfusionCounts> counts;
  std::map<std::string, std::pair<int, int>> latency;  // dataset -> frames to 50 / 90 (board 0)
};

// ---------------------------------------------------------------------------------------------
// score.cpp

double ratio(std::uint64_t a, std::uint64_t b);
double recallOf(const ssm::ConfusionCounts& c);
double precisionOf(const ssm::ConfusionCounts& c);
double fpRateOf(const ssm::ConfusionCounts& c);
double percentile(std::vector<double> v, double p);
double mean(const std::vector<double>& v);
/// The GT's Non-ground causes and drop-off edges, from the dataset's scene file.
std::string computeCauses(const ssm::Dataset& d, const std::string& scenes_dir, GtExtras* x);
/// Sum over the benchmark datasets of one grid variant's (or the safety map's) causes.
ssm::UnsafeCauseCounts sumCauses(const std::vector<DatasetResult>& all, int variant, bool safety);

// ---------------------------------------------------------------------------------------------
// run.cpp

/// One dataset: the four grids and the safety map on every stereo pair.
std::string evaluateDataset(const Options& opt, const Setup& setup, const std::string& bag,
                            Kind kind, DatasetResult* res);

// ---------------------------------------------------------------------------------------------
// report.cpp

SafetyReference loadSafetyReference(const std::string& path);
std::string writeJson(const Options& opt, const Setup& s, const std::vector<DatasetResult>& all);
std::string writeReport(const Options& opt, const Setup& s, const std::vector<DatasetResult>& all,
                        const SafetyReference& ref, double wall_s);

}  // namespace evaluate_occupancy_2d
