// Evaluation metrics of a safety map against ground truth, ROS-free: the error rates of paper 000
// Sec. VII-A, the safe-class precision / recall / F1 of paper 001 Sec. 5, the plane accuracy of
// 000 Sec. VII-C and the board-width coverage behind the frame latency of 000 Sec. VII-B.
//
// Conventions (000 Sec. VII-A). A cell is *safe* when labelled Level or Inclined, *unsafe* when
// Non-ground; Unknown and Unexamined are *unclassified*. Unsafe is the positive class:
//   TP  unsafe in the map, unsafe in the GT      FP  unsafe in the map, safe in the GT
//   FN  safe in the map, unsafe in the GT        TN  safe in the map, safe in the GT
// A cell counts only when both maps classify it. Rates of a dataset come from sums over all of its
// maps (FN rate = sum FN / sum (TP + FN)), never from averaging per-frame rates; datasets are then
// averaged with their standard deviation.
//
// 001 Sec. 5 counts the *safe* class as positive: its A (safe in both) is 000's TN, its B (safe in
// the map, unsafe in the GT) is 000's FN and its C (unsafe in the map, safe in the GT) is 000's FP.
#pragma once

#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/core/voxel_grid.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

// ---------------------------------------------------------------------------------------------
// Error rates (000 Sec. VII-A) and precision / recall / F1 (001 Sec. 5)

enum class SafetyClass : std::uint8_t { kUnclassified = 0, kSafe = 1, kUnsafe = 2 };
SafetyClass safetyClassOf(SafetyLabel label);

/// Outcome of one cell, unsafe being the positive class (000 Sec. VII-A).
enum class CellOutcome : std::uint8_t {
  kUnclassified = 0,  ///< unclassified in the map or in the GT (or outside the GT)
  kTruePositive = 1,
  kFalsePositive = 2,
  kFalseNegative = 3,
  kTrueNegative = 4,
};
CellOutcome cellOutcome(SafetyLabel mapped, SafetyLabel truth);
const char* toString(CellOutcome outcome);

/// A ground-truth label grid on the global cell indexing of Eq. (1) (000 Sec. IV): cell (u, v)
/// centred at (u l_v, v l_v), row-major index (v - min_v) * width + (u - min_u), like SafetyMap.
struct LabelGrid {
  int min_u = 0;
  int min_v = 0;
  int width = 0;
  int height = 0;
  double resolution = 0.1;
  std::vector<SafetyLabel> labels;

  int index(int u, int v) const { return (v - min_v) * width + (u - min_u); }
  bool inside(int u, int v) const {
    return u >= min_u && v >= min_v && u < min_u + width && v < min_v + height;
  }
  /// Unknown outside the grid.
  SafetyLabel at(int u, int v) const {
    return inside(u, v) ? labels[index(u, v)] : SafetyLabel::kUnknown;
  }
  /// Empty when consistent (sizes, finite positive resolution), else why not.
  std::string validate() const;
};

/// Cell counts of one map or of a sum of maps.
struct ConfusionCounts {
  std::uint64_t tp = 0;
  std::uint64_t fp = 0;
  std::uint64_t fn = 0;
  std::uint64_t tn = 0;
  std::uint64_t unclassified_in_map = 0;  ///< classified in the GT, not in the map
  std::uint64_t unclassified_in_gt = 0;   ///< classified in the map, not in (or outside) the GT
  std::uint64_t maps = 0;                 ///< number of maps summed

  std::uint64_t unsafeCells() const { return tp + fn; }  ///< unsafe in the GT, classified in both
  std::uint64_t safeCells() const { return tn + fp; }    ///< safe in the GT, classified in both
  std::uint64_t classified() const { return tp + fp + fn + tn; }
  ConfusionCounts& operator+=(const ConfusionCounts& o);
};

/// Rates in [0, 1]; NaN when the denominator is zero (no unsafe or no safe cell).
struct ErrorRates {
  double fn = 0.0;  ///< FN / (TP + FN)
  double fp = 0.0;  ///< FP / (FP + TN)
  double tp = 0.0;  ///< TP / (TP + FN) = 1 - fn
  double tn = 0.0;  ///< TN / (FP + TN) = 1 - fp
};
ErrorRates errorRates(const ConfusionCounts& counts);

/// 001 Sec. 5, safe class positive; NaN when the denominator is zero.
struct SafeClassScores {
  double precision = 0.0;  ///< A / (A + B) = TN / (TN + FN)
  double recall = 0.0;     ///< A / (A + C) = TN / (TN + FP)
  double f1 = 0.0;         ///< 2A / (2A + B + C)
};
SafeClassScores safeClassScores(const ConfusionCounts& counts);

/// Counts the cells of `map` against `truth` cell by cell on the shared (u, v) indexing; map cells
/// outside the GT grid are unclassified in the GT. When `outcomes` is not null it receives one
/// outcome per map cell (map's row-major order; resized, reused). Adds to *counts (maps += 1).
/// Returns an error (and counts nothing) when a grid is inconsistent or the resolutions differ.
std::string countConfusion(const SafetyMap& map, const LabelGrid& truth, ConfusionCounts* counts,
                           std::vector<CellOutcome>* outcomes = nullptr);

/// Mean and standard deviation of values (NaNs skipped). stddev is the sample standard
/// deviation (n - 1 in the denominator; the paper does not say which), 0 for one value; mean and
/// stddev are NaN when no value is finite.
struct MeanStd {
  double mean = 0.0;
  double stddev = 0.0;
  int n = 0;
};
MeanStd meanStd(const std::vector<double>& values);

// ---------------------------------------------------------------------------------------------
// Plane accuracy (000 Sec. VII-C)

/// A ground-truth plane z = a x + b y + c of one ground surface over its (convex) footprint.
struct ReferencePlane {
  std::string name;
  double a = 0.0;
  double b = 0.0;
  double c = 0.0;
  std::vector<Eigen::Vector2d> footprint;  ///< convex polygon in xy, either orientation

  double heightAt(double x, double y) const { return a * x + b * y + c; }
  Eigen::Vector3d normal() const { return Eigen::Vector3d(-a, -b, 1.0).normalized(); }
  /// Inside the footprint, borders included (tolerance eps [m]).
  bool contains(double x, double y, double eps = 1e-6) const;
};

/// Index of the reference plane that is the top ground surface at (x, y), -1 when none.
int topReferencePlane(const std::vector<ReferencePlane>& planes, double x, double y);

struct PlaneAccuracy {
  bool matched = false;        ///< a reference plane lies under at least one footprint cell
  int reference = -1;          ///< the reference under most footprint cells
  int cells = 0;               ///< footprint cells
  int cells_on_reference = 0;  ///< footprint cells whose top GT surface is that reference
  double angle_deg = 0.0;      ///< angle between the detected and the reference normal
  /// Mean over the footprint cells of the distance from the detected plane's point above the
  /// cell centre to the reference plane (perpendicular to it) [m].
  double mean_distance = 0.0;
  double max_distance = 0.0;
};

/// Compares one detected plane with the reference plane under most of its footprint (the cells
/// of its segment in `map`). Unmatched (matched = false) when the plane is invalid, the footprint
/// is empty or no reference plane lies under it.
PlaneAccuracy comparePlane(const GroundPlane& detected, const std::vector<int>& footprint_cells,
                           const SafetyMap& map, const std::vector<ReferencePlane>& references);

// ---------------------------------------------------------------------------------------------
// Frame latency (000 Sec. VII-B)

/// An upright board (an oriented box): the object whose detection is timed.
struct BoardBox {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< columns: the box axes in world
  Eigen::Vector3d half_size = Eigen::Vector3d::Zero();     ///< along those axes [m]

  /// Finite, with no negative half size.
  bool valid() const {
    return center.allFinite() && rotation.allFinite() && half_size.allFinite() &&
           !(half_size.array() < 0.0).any();
  }
};

/// The board's axes (indices into BoardBox::rotation's columns): the most vertical is the
/// height; of the other two the longer is the width, the shorter the thickness. Every board
/// coverage below uses these.
struct BoardAxes {
  int height = 2, width = 0, thickness = 1;
};
BoardAxes boardAxes(const BoardBox& board);

struct BoardCoverage {
  int bins = 0;     ///< width samples, one per l_v
  int covered = 0;  ///< samples with an occupied voxel on the board
  double fraction() const { return bins > 0 ? static_cast<double>(covered) / bins : 0.0; }
};

/// How much of the board's width is occupied in the 3D grid (000 Sec. VII-B: "N % of the width of
/// the board is visible in the occupancy grid"). The width axis is the longer of the box's two
/// most horizontal axes. The width is sampled every l_v (at the centres of equal bins); a sample
/// is covered when an occupied voxel whose extent along the width contains it overlaps the box
/// (tested on the box's three axes with the voxel's extent projected on each, and one extra voxel
/// of slack across the board's thickness for stereo's depth error) and the voxel's centre is more
/// than l_v above the board's lowest point, so that the floor under the board does not count.
/// `covered_bins` (optional) receives one entry per sample, 1 where covered.
BoardCoverage boardWidthCoverage(const VoxelGrid& grid, const BoardBox& board,
                                 std::vector<std::uint8_t>* covered_bins = nullptr);

/// The same width samples (one per map.resolution) covered by marked cells of a 2D map, e.g. the
/// cells an obstacle cue marked (obstacle_cue.h): a sample is covered when a marked cell holds a
/// point of the board's footprint at the sample's position along the width (the footprint taken
/// with one cell of slack across the board's thickness, as the 3D test allows one voxel).
/// `marked` has one entry per map cell (non-zero = marked). Covered samples are OR-ed into
/// `covered_bins` (resized to the bin count when its size differs), so that the grid's and the
/// cue's coverage combine.
BoardCoverage boardWidthCoverageOfCells(const SafetyMap& map,
                                        const std::vector<std::uint8_t>& marked,
                                        const BoardBox& board,
                                        std::vector<std::uint8_t>* covered_bins = nullptr);

/// 1-based index of the first entry of `coverage` (one per camera frame from the board's
/// appearance) that reaches `fraction`; -1 when none does.
int framesUntilCoverage(const std::vector<double>& coverage, double fraction);

}  // namespace stereo_safety_map
