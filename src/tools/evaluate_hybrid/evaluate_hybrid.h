// evaluate_hybrid's units (main.cpp: options and main; run.cpp: the Table 2 run and the landmark
// filter run over a bag, the bag's scans and ground-truth depth; score.cpp: ground truth as hybrid
// classes, the cells the laser cannot see, ghost points, statistics; report.cpp: metrics.json and
// report.md). What they share: the options, the three maps' names, the per-bag results.
#pragma once

#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/hybrid_safety_map.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/tools/dataset_reader.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <chrono>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace ssm = stereo_safety_map;

namespace evaluate_hybrid {

using ssm::ConfusionCounts;
using ssm::HybridLabel;
using ssm::HybridSafetyMap;
using ssm::HybridSource;

using Clock = std::chrono::steady_clock;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The three maps of 001 Table 2, and the merged map with laser_free_vision_unknown_is_safe
// (laser-free cells that vision has not examined count as Safe), one reading of how 001's merged
// map gained recall over stereo ("because lasers help").
constexpr int kSources = 4;
const HybridSource kSourceOrder[kSources] = {HybridSource::kLaserOnly, HybridSource::kStereoOnly,
                                             HybridSource::kMerged, HybridSource::kMerged};
const char* const kSourceNames[kSources] = {"laser", "stereo", "merged",
                                            "merged_laser_fills_unknown"};

inline double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// ---------------------------------------------------------------------------------------------
// Options

struct Options {
  std::vector<std::string> bags;
  std::vector<std::string> overhang_bags;
  std::vector<std::string> noisy_bags;
  std::string out = "out/evaluation/hybrid";
  std::vector<std::string> params;
  std::vector<std::string> sets;
  int every = 1;
  long max_frames = -1;
  double ghost_px = 2.0;
  bool quiet = false;
};

// Ground-truth Non-ground cells the laser cannot see by construction, in GT cell indices (u, v),
// three kinds: under obstacles whose bottom lies between the laser plane and the robot's height
// (overhangs: table tops, shelves), in obstacles whose top lies below the laser plane (low
// obstacles), and Non-ground cells with no obstacle within `margin` (ground hazards: below a
// drop-off, too steep, unreachable). Cells within `margin` of an obstacle that reaches into the
// laser plane are left out (the laser sees those).
constexpr int kBlindKinds = 3;
const char* const kBlindNames[kBlindKinds] = {"overhangs above the laser plane",
                                              "obstacles below the laser plane",
                                              "ground hazards (drop-offs, steep or unreachable)"};
const char* const kBlindKeys[kBlindKinds] = {"overhang", "low", "ground"};

struct LaserBlindCells {
  std::vector<std::pair<int, int>> cells[kBlindKinds];
  std::vector<std::string> names[kBlindKinds];  ///< obstacles that gave cells
};

// How each map labels a set of cells, summed over frames: counts[source][label].
struct CellClassCounts {
  std::uint64_t counts[kSources][5] = {};
  void add(const HybridSafetyMap (&maps)[kSources], const std::vector<std::pair<int, int>>& cells) {
    for (int s = 0; s < kSources; ++s) {
      for (const auto& c : cells) {
        if (!maps[s].inside(c.first, c.second)) continue;
        ++counts[s][static_cast<int>(maps[s].labelAt(c.first, c.second))];
      }
    }
  }
  std::uint64_t classified(int s) const {
    return counts[s][1] + counts[s][2] + counts[s][3] + counts[s][4];
  }
  double fraction(int s, std::initializer_list<HybridLabel> labels) const {
    const std::uint64_t n = classified(s);
    if (n == 0) return kNaN;
    std::uint64_t k = 0;
    for (HybridLabel l : labels)
      k += counts[s][static_cast<int>(l)];
    return static_cast<double>(k) / n;
  }
};

struct Stats {
  double mean = kNaN, median = kNaN, max = kNaN;
};

// ---------------------------------------------------------------------------------------------
// Table 2 run: laser-only, stereo-only and merged maps of every integrated frame.

struct FusionResult {
  std::string name;
  std::string scene;
  int pairs = 0;
  int integrated = 0;
  int scans = 0;
  double laser_z = kNaN;
  ConfusionCounts own[kSources], common[kSources];
  LaserBlindCells blind;
  CellClassCounts blind_counts[kBlindKinds];
  std::vector<double> laser_ms, build_ms, frame_ms;
  std::vector<std::string> images;
};

// ---------------------------------------------------------------------------------------------
// Landmark filter off / on on the same disparity images.

struct LandmarkRun {
  int integrated = 0;
  ConfusionCounts map;
  std::uint64_t points_reprojected = 0, points_to_grid = 0;
  std::uint64_t checked_to_grid = 0, ghosts_to_grid = 0;
  std::vector<double> landmark_ms, landmark_cpu_ms, frame_ms;
  std::size_t permanent = 0;
};

struct LandmarkResult {
  std::string name;
  std::string disparity;  ///< which disparity post-filters ran
  bool has_depth = false;
  int pairs = 0;
  LandmarkRun off, on;
};

// ---------------------------------------------------------------------------------------------
// score.cpp

/// 000's ground-truth labels as hybrid classes.
HybridSafetyMap hybridTruth(const ssm::LabelGrid& gt);
/// The three maps with a cell's class kept only where all of them classify it.
void commonCells(const HybridSafetyMap (&in)[kSources], HybridSafetyMap (*out)[kSources]);
LaserBlindCells laserBlindCells(const ssm::Dataset& d, double laser_z, double robot_height,
                                double margin = 0.1);
/// Ghost points (001 Sec. 4) among camera-frame points, against the ground-truth depth.
void countGhosts(const std::vector<Eigen::Vector3f>& points, const cv::Mat& depth,
                 const ssm::StereoCameraModel& cam, double ghost_px, std::uint64_t* checked,
                 std::uint64_t* ghosts);
Stats statsOf(std::vector<double> v);

// ---------------------------------------------------------------------------------------------
// run.cpp

/// Table 2 of 001 on one bag: laser-only, stereo-only and merged maps of every integrated frame.
std::string runFusion(const std::string& bag, const ssm::StereoFrameProcessorConfig& config,
                      const Options& opt, bool pictures, FusionResult* r);
/// The landmark filter (001 Sec. 4.2) off / on, on the same disparity images of one bag.
std::string runLandmarks(const std::string& bag, const ssm::StereoFrameProcessorConfig& config,
                         const Options& opt, LandmarkResult* r);

// ---------------------------------------------------------------------------------------------
// report.cpp

/// metrics.json and report.md (also printed).
void writeOutputs(const Options& opt, const std::string& command, double wall_s,
                  const std::vector<FusionResult>& fusion,
                  const std::vector<LandmarkResult>& landmarks);

}  // namespace evaluate_hybrid
