// Hand labels of a camera image and the score of a single-frame safety map against them, ROS-free.
//
// The real-data check (real_pair_check.h) used to level the camera on the floor and then check that
// the floor came out Level, which is circular. This unit scores the map against labels drawn by
// hand on the left image instead (test/data/real_labels/, README there): polygons of floor,
// obstacle, overhang, drop-off and ignore in pixel coordinates. Every pixel with a valid disparity
// reprojects to a 3D point, i.e. to a map cell; its hand label votes for that cell's truth, and the
// map's labels are counted against those truths with the rates of paper 000 Sec. VII-A (Non-ground
// is the positive class; Level / Inclined safe; Unknown / Unexamined unclassified), plus coverage
// and per-class recall.
//
// Label file format (one polygon per line, '#' starts a comment):
//   size 640 480                      # image size, once, before the first polygon
//   floor 0,300 640,300 640,480 0,480  # <class> x1,y1 x2,y2 x3,y3 ... (>= 3 vertices)
// Classes: floor, obstacle, overhang, drop_off, ignore. Vertices are integer pixel coordinates in
// [0, width] x [0, height] (the image border may be named as 640 / 480). Later polygons are drawn
// over earlier ones.
#pragma once

#include "stereo_safety_map/core/evaluation_metrics.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/core/stereo_camera_model.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

/// Values of the rasterised label image (CV_8U). Stable: they are the pixel values.
enum class ImageLabel : std::uint8_t {
  kNone = 0,      ///< not labelled: never scored
  kFloor = 1,     ///< drivable ground: safe
  kObstacle = 2,  ///< stands on the floor below robot height: unsafe
  kOverhang = 3,  ///< surface 0.5-1.5 m above the floor with floor under it: unsafe
  kDropOff = 4,   ///< ground lower than the surrounding floor by more than h_T = 5 cm: unsafe
  kIgnore = 5,    ///< sky, far background, ambiguous: never scored
};
constexpr int kNumImageLabels = 6;

const char* toString(ImageLabel label);
/// "floor", "obstacle", "overhang", "drop_off", "ignore" (the file's class names). False for
/// anything else.
bool imageLabelFromString(const std::string& name, ImageLabel* label);
/// The safety class a label stands for: floor safe; obstacle, overhang, drop_off unsafe; none and
/// ignore unclassified (000 Sec. VII-A classes).
SafetyClass safetyClassOf(ImageLabel label);

struct LabelPolygon {
  ImageLabel label = ImageLabel::kNone;
  std::vector<cv::Point> vertices;
  int line = 0;  ///< line of the file it came from (1-based)
};

/// The contents of one label file.
struct ImageLabels {
  int width = 0;  ///< image size of the `size` line
  int height = 0;
  std::vector<LabelPolygon> polygons;  ///< in file order (later ones on top)
};

/// Parses the format above. Returns an empty string on success, else the first problem as
/// "line N: ..." (unknown class, malformed or out-of-image vertex, fewer than 3 vertices, missing
/// or repeated size line, polygon before the size line). `out` is only written on success.
std::string parseImageLabels(const std::string& text, ImageLabels* out);

/// Reads and parses a file; errors are prefixed with the path.
std::string loadImageLabels(const std::string& path, ImageLabels* out);

/// Rasterises the polygons into a CV_8U image of the labels' size (ImageLabel values, kNone where
/// no polygon), each filled with cv::fillPoly in file order so that later polygons override
/// earlier ones. Returns an empty string on success.
std::string rasteriseImageLabels(const ImageLabels& labels, cv::Mat* image);

/// How a label image is turned into per-cell truths and scored.
struct LabelScoringConfig {
  /// A cell gets a truth when at least this many labelled pixels with a valid disparity vote for
  /// it (ignore pixels do not vote), [1, 1000000]. One pixel is too easily a stereo outlier.
  int min_pixels = 3;
  /// Chebyshev radius [cells] of the tolerant score, [0, 10]: a map error on a truth cell is
  /// tolerated when a truth cell within this radius has the map's class (label boundaries are
  /// drawn by hand and a 10 cm cell straddles them).
  int tolerance_cells = 1;
  /// Only pixels whose depth Z lies in [min_depth, max_depth] [m] vote: the points the map was
  /// built from (set them to the grid's min_range / max_range, see forGrid()).
  double min_depth = 0.2;
  double max_depth = 8.0;

  /// The grid's reprojection range (StereoFrameProcessor reprojects to [min_range, max_range]).
  static LabelScoringConfig forGrid(double min_range, double max_range);

  std::string validate() const;
};

/// Per hand-label class (indexed by ImageLabel).
struct LabelClassScore {
  std::uint64_t pixels = 0;                 ///< labelled pixels in the image
  std::uint64_t pixels_with_disparity = 0;  ///< of those, with a valid disparity
  std::uint64_t pixels_voting = 0;  ///< of those, within the depth range (they vote for a cell)
  int cells = 0;           ///< truth cells of this class inside the examined area of the map
  int cells_beyond = 0;    ///< truth cells of this class outside it (Unexamined / off the grid)
  int map_safe = 0;        ///< of `cells`: Level or Inclined in the map
  int map_non_ground = 0;  ///< Non-ground in the map
  int map_unknown = 0;     ///< Unknown in the map (examined, unclassified)
  int hits = 0;            ///< cells the map got right (see recall())
  int hits_tolerant = 0;   ///< hits plus errors tolerated at label boundaries

  /// Share of `cells` the map labels as the class requires: floor -> safe, obstacle and overhang
  /// -> Non-ground, drop_off -> not safe (Non-ground or Unknown). Unknown counts as a miss for
  /// floor, obstacle and overhang, so a map that hedges loses recall. NaN when cells == 0.
  double recall() const;
  double recallTolerant() const;
};

/// Score of one map against one label image.
struct ImageLabelScore {
  std::array<LabelClassScore, kNumImageLabels> classes;  ///< indexed by ImageLabel
  /// 000 Sec. VII-A counts over truth cells inside the examined area that the map classifies:
  /// unsafe is positive. unclassified_in_map = truth cells the map leaves Unknown;
  /// unclassified_in_gt = map-classified cells without a truth.
  ConfusionCounts exact;
  /// The same with the tolerance: a tolerated FN counts as TP and a tolerated FP as TN (the cell
  /// keeps its truth class, so the rates keep their denominators; only errors are forgiven).
  ConfusionCounts tolerant;
  int truth_cells = 0;          ///< cells with a truth inside the examined area
  int covered_cells = 0;        ///< of those, classified by the map (safe or Non-ground)
  int truth_cells_beyond = 0;   ///< cells with a truth outside it (beyond R_max or the grid)
  int cells_tied = 0;           ///< cells with enough votes but a tie between classes
  int cells_too_few_votes = 0;  ///< cells with 1 .. min_pixels - 1 votes
  /// Per map cell (the map's row-major order): the truth (kNone where none), for pictures.
  std::vector<ImageLabel> truth;
  /// Per map cell: the exact outcome (unclassified where no truth, outside the examined area or
  /// Unknown in the map), for pictures (map_image.h).
  std::vector<CellOutcome> outcomes;

  /// covered_cells / truth_cells (NaN when no truth cell): a map that hedges to Unknown covers
  /// less.
  double coverage() const;
};

/// Scores `map` against the rasterised `label_image` (CV_8U, ImageLabel values, the disparity's
/// size). Each pixel with a valid disparity (> 0, finite, in front of the camera) whose depth is in
/// the configured range is reprojected with `camera`, moved to the map's fixed frame with
/// `T_fixed_camera` and put into cell (round(x / l_v), round(y / l_v)) (000 Eq. (1)); its height
/// does not matter (a floor pixel that stereo put far from the floor is still floor). A cell's
/// truth is the label with the most votes among floor / obstacle / overhang / drop_off when it has
/// at least min_pixels votes (ties: no truth). The examined area is the map's grid minus its
/// Unexamined cells (beyond R_max, 000 Alg. 1 step 3). Returns an empty string on success.
std::string scoreAgainstImageLabels(const cv::Mat& label_image, const cv::Mat& disparity,
                                    const StereoCameraModel& camera,
                                    const Eigen::Isometry3d& T_fixed_camera, const SafetyMap& map,
                                    const LabelScoringConfig& config, ImageLabelScore* score);

/// The truths as a LabelGrid on the map's cells, for map_image.h: floor -> Level, obstacle /
/// overhang / drop_off -> Non-ground, no truth -> Unknown.
LabelGrid truthLabelGrid(const SafetyMap& map, const std::vector<ImageLabel>& truth);

}  // namespace stereo_safety_map
