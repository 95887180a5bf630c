// 2D stereo occupancy grid of Murray & Little (paper 002, Sec. 3 and 4.3).
//
// ROS-free. One disparity image is reduced to one "row": per image column the largest valid
// disparity, i.e. the closest obstacle (002 Sec. 3.3). Each column reading becomes a trapezoid
// region of uncertainty bounded by Z(d +/- 0.5) and the pixel's edges, plus the clear triangle
// between the camera and the trapezoid's near corners (002 Sec. 3.2). Cells inside the trapezoid
// get +K, cells in the clear triangle -K, clipped to 0..255 (002 Sec. 3.4). A second per-cell
// value keeps the disparity of the reading that last raised the cell, so that a low-quality
// (far, small-disparity) reading whose region already holds better evidence is not applied
// (accuracy preservation, 002 Sec. 4.3).
//
// Input: the disparity stage's output (disparity_pipeline.h / disparity_filters.h: the texture
// and match-uniqueness validation of 002 Sec. 2.2 and the spike removal of 002 Sec. 4.2), with
// their convention: CV_32FC1, valid = finite and > 0 (isValidDisparity()). This unit does not
// filter disparities itself.
//
// Deviations from the paper, all because the paper's camera looks horizontally and ours is
// tilted on a wheelchair:
// - Height band. With a pitched camera the floor would give the largest disparity of nearly
//   every column, so the column maximum is taken only over points whose height above the floor
//   (in the fixed frame, z up) lies in [floor_clearance, robot_height] - the 3D volume the robot
//   body sweeps, which is what 002 Sec. 3.3 projects to the floor.
// - Ground projection. The paper's trapezoid lies in the camera's horizontal XZ plane. Here its
//   four corners are built in 3D at the row of the pixel that won the column: near / far depth
//   Z(d +/- 0.5), lateral X = (x - cx +/- 0.5) Z / fx, Y = (y - cy) Z / fy. They are moved to the
//   fixed frame with the camera pose and dropped onto the xy plane (z discarded). Corners of one
//   pixel edge lie on one ray through the camera, so the projected region is still a trapezoid
//   whose sides point back at the camera, and the clear triangle (camera xy + near corners) joins
//   it seamlessly. For a level camera this is exactly the paper's construction.
// - Far edge at infinity. When d - 0.5 <= 0 the far edge Z(d - 0.5) is unbounded; it is then
//   truncated at a depth whose ground projection lies beyond the grid window, which changes no
//   cell. This is not a range horizon (002 Sec. 4.3 rejects those): the reading is still used.
//
// Rasterisation: the trapezoid marks every cell it overlaps (a close-range trapezoid is much
// smaller than a cell and must still mark the cell its obstacle is in); the clear triangle marks
// the cells whose centre it contains. All columns of one image form one sensor reading: each
// cell gets at most one +K or -K per image, +K winning where regions of different columns meet.
//
// Cells: global integer indices (u, v) = (round(x / res), round(y / res)) as in the voxel grid
// and the safety map (000 Eq. (1)); cell (u, v) is centred at (u res, v res). The window scrolls
// with the robot over a ring buffer, so recentering moves no memory.
#pragma once

#include "stereo_safety_map/core/stereo_camera_model.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

/// Parameters of the 2D stereo occupancy grid. Defaults are paper 002's values where it gives
/// one; the others are marked.
struct OccupancyGrid2DConfig {
  double resolution = 0.1;        ///< cell size [m]; 002 gives none, 0.1 m matches 000's l_v
  double size_x = 20.0;           ///< window extent along x [m] (not in 002: a robot-local window)
  double size_y = 20.0;           ///< window extent along y [m]
  int k = 20;                     ///< K of the +/-K update (002 Sec. 3.4)
  int free_threshold = 50;        ///< G < this is free (002 Sec. 3.4 planning value), [0, 128]
  int occupied_threshold = 150;   ///< G > this is occupied (002 Sec. 3.4), [128, 255]
  double floor_clearance = 0.10;  ///< lower edge of the obstacle band above the floor [m]; not
                                  ///< in 002 (level camera). Above 000's h_T = 0.05 m step with a
                                  ///< margin for the height noise of far floor points.
  double robot_height = 1.5;      ///< upper edge of the band [m]: wheelchair with seated driver
                                  ///< (not in the papers); the robot passes under anything higher
  double disparity_half_width = 0.5;  ///< Eq. (1): P(d|Z) = 1 for Z(d + 0.5)..Z(d - 0.5) (002
                                      ///< Sec. 3.2, integer disparities without sub-pixel)
  bool accuracy_preservation = true;  ///< 002 Sec. 4.3

  /// Empty when valid, otherwise a message naming the first offending parameter and its range.
  std::string validate() const;
};

/// Global cell index, (round(x / res), round(y / res)).
struct GridCell2D {
  int u = 0;
  int v = 0;
  bool operator==(const GridCell2D& o) const { return u == o.u && v == o.v; }
  bool operator!=(const GridCell2D& o) const { return !(*this == o); }
};

/// The reading of one image column (002 Sec. 3.3, Fig. 5(c)): largest valid in-band disparity
/// and the image row it came from; row < 0 when the column has none.
struct ColumnReading {
  float disparity = 0.0f;
  int row = -1;
  bool valid() const { return row >= 0; }
};

/// Why an update was refused; a refused update leaves the grid unchanged.
enum class Grid2DStatus : std::uint8_t {
  kOk = 0,
  kEmptyImage,         ///< no pixels
  kWrongImageType,     ///< not CV_32FC1
  kBadCameraModel,     ///< StereoCameraModel::validate() not empty
  kImageSizeMismatch,  ///< image (or row) size differs from the model's width / height
  kBadPose,            ///< non-finite camera pose, floor height or band
};
const char* toString(Grid2DStatus s);

/// Counters of one update.
struct Grid2DUpdateStats {
  Grid2DStatus status = Grid2DStatus::kOk;
  int columns = 0;               ///< readings handed in (image width)
  int columns_with_reading = 0;  ///< valid in-band reading
  int columns_explained = 0;     ///< +K skipped by accuracy preservation (002 Sec. 4.3)
  int cells_raised = 0;          ///< cells that got +K this update
  int cells_lowered = 0;         ///< cells that got -K this update
  bool ok() const { return status == Grid2DStatus::kOk; }
};

/// Region of uncertainty of one reading in the camera's XZ plane (002 Sec. 3.2, Fig. 4):
/// Z = Z(d +/- h) = fB / (d +/- h - (cx - cx_right)), X = (x - cx +/- 0.5) Z / fx, where x is the
/// pixel column (its edges at x +/- 0.5) and h the disparity half-width. "left" is the x - 0.5
/// edge.
struct UncertaintyTrapezoid {
  double z_near = 0.0;  ///< Z(d + h)
  double z_far = 0.0;   ///< Z(d - h), +infinity when d - h has no positive depth
  double x_near_left = 0.0;
  double x_near_right = 0.0;
  double x_far_left = 0.0;   ///< undefined when z_far is infinite
  double x_far_right = 0.0;  ///< undefined when z_far is infinite
};

/// Fills `out` and returns true when d gives a positive depth (d - (cx - cx_right) > 0) and the
/// model is valid; otherwise returns false and leaves `out` alone.
bool computeUncertaintyTrapezoid(const StereoCameraModel& model, double x, double d,
                                 double half_width, UncertaintyTrapezoid* out);

/// A reading's regions projected onto the fixed frame's xy plane: the trapezoid near_left,
/// near_right, far_right, far_left (convex, in that order) and the clear triangle camera,
/// near_left, near_right.
struct GroundRegion {
  Eigen::Vector2f camera = Eigen::Vector2f::Zero();
  Eigen::Vector2f near_left = Eigen::Vector2f::Zero();
  Eigen::Vector2f near_right = Eigen::Vector2f::Zero();
  Eigen::Vector2f far_right = Eigen::Vector2f::Zero();
  Eigen::Vector2f far_left = Eigen::Vector2f::Zero();
};

/// Projects the region of pixel (x, y) with disparity d onto the ground (see the file comment).
/// T_fixed_camera maps the left optical frame (x right, y down, z forward) to the fixed frame
/// (z up). When the far edge is unbounded or farther than needed, it is truncated so that its
/// ground projection is at least `max_ground_range` from the camera's xy. Returns false (out
/// untouched) when the trapezoid is undefined or a corner is not finite.
bool projectUncertaintyRegion(const StereoCameraModel& model, double x, double y, double d,
                              double half_width, const Eigen::Isometry3f& T_fixed_camera,
                              double max_ground_range, GroundRegion* out);

/// 002 Sec. 3.3 with the height band: per column the largest valid disparity (finite, > 0 and
/// giving positive depth) over pixels whose 3D point lies between floor_clearance and
/// robot_height above floor_z in the fixed frame. `row` is resized to the image width (reused,
/// no allocation once sized). On a refused input (or a null `row`) `row` is left unchanged.
Grid2DStatus reduceToClosestObstacleRow(const cv::Mat& disparity, const StereoCameraModel& model,
                                        const Eigen::Isometry3f& T_fixed_camera, float floor_z,
                                        float floor_clearance, float robot_height,
                                        std::vector<ColumnReading>* row);

class OccupancyGrid2D {
 public:
  /// The initial 50 % value (002 Sec. 3.1 / 3.4: middle of 0..255).
  static constexpr std::uint8_t kUnknownValue = 128;

  /// Throws std::invalid_argument when config.validate() is not empty. The window starts
  /// centred on the fixed frame's origin.
  explicit OccupancyGrid2D(const OccupancyGrid2DConfig& config = OccupancyGrid2DConfig());

  const OccupancyGrid2DConfig& config() const { return config_; }

  int sizeU() const { return nu_; }  ///< cells along x
  int sizeV() const { return nv_; }  ///< cells along y
  /// Smallest global index inside the window; the window is [min, min + size).
  GridCell2D minIndex() const { return min_; }

  GridCell2D indexOf(const Eigen::Vector2f& xy) const;
  Eigen::Vector2f centerOf(const GridCell2D& c) const;
  bool contains(const GridCell2D& c) const;

  /// Moves the window by whole cells so that the robot's cell is at its centre. Cells leaving
  /// the window are reset (unknown, no stored disparity). Returns the number of cells reset.
  std::size_t recenter(const Eigen::Vector2f& robot_xy);
  /// Resets every cell to unknown; keeps the window.
  void clear();

  /// One stereo frame: reduce (002 Sec. 3.3), then update (002 Sec. 3.2, 3.4, 4.3). floor_z is
  /// the floor height in the fixed frame (e.g. the robot base's z) that the band is measured
  /// from. Refused inputs leave the grid unchanged (see Grid2DStatus).
  Grid2DUpdateStats update(const cv::Mat& disparity, const StereoCameraModel& model,
                           const Eigen::Isometry3f& T_fixed_camera, float floor_z = 0.0f);

  /// The update from an already reduced row (entry i is image column i). All readings of one
  /// call form one sensor reading r of 002 Sec. 3.4: a cell gets at most one +K or -K per call,
  /// +K winning over -K where regions of different columns overlap.
  Grid2DUpdateStats updateFromRow(const std::vector<ColumnReading>& row,
                                  const StereoCameraModel& model,
                                  const Eigen::Isometry3f& T_fixed_camera);

  /// Grid value G in 0..255; kUnknownValue outside the window.
  std::uint8_t value(const GridCell2D& c) const;
  bool isFree(const GridCell2D& c) const { return value(c) < config_.free_threshold; }
  bool isOccupied(const GridCell2D& c) const { return value(c) > config_.occupied_threshold; }
  /// Neither free nor occupied for planning.
  bool isUnknown(const GridCell2D& c) const { return !isFree(c) && !isOccupied(c); }
  /// Disparity of the reading that last raised the cell (002 Sec. 4.3); 0 when none.
  float storedDisparity(const GridCell2D& c) const;
  /// Sets a cell directly (outside the window: ignored). For tests and fusing external cues.
  void setCell(const GridCell2D& c, std::uint8_t value, float disparity = 0.0f);

  /// The window as a CV_8UC1 image, row r = v - min.v, column c = u - min.u.
  void toImage(cv::Mat* out) const;

  /// The row reduced by the last update() (empty before the first).
  const std::vector<ColumnReading>& lastRow() const { return row_; }

 private:
  enum Mark : std::uint8_t { kMarkClear = 1, kMarkKeep = 2, kMarkOccupied = 3 };

  std::size_t linear(int u, int v) const;  // ring-buffer address; (u, v) must be contained
  void resetStorageColumn(int su);
  void resetStorageRow(int sv);
  void mark(std::size_t k, Mark m, float d);
  bool explainedByBetterEvidence(const Eigen::Vector2f* quad, float d) const;

  OccupancyGrid2DConfig config_;
  int nu_ = 0, nv_ = 0;
  GridCell2D min_;
  std::uint32_t frame_ = 0;
  std::vector<std::uint8_t> value_;     // G per cell
  std::vector<float> disparity_;        // 002 Sec. 4.3 second grid value
  std::vector<std::uint32_t> stamp_;    // frame in which the cell was last marked
  std::vector<std::uint8_t> mark_;      // Mark of this frame (valid when stamp_ == frame_)
  std::vector<float> pending_disp_;     // largest disparity raising the cell this frame
  std::vector<std::uint32_t> touched_;  // cells marked this frame, capacity = cell count
  std::vector<ColumnReading> row_;      // reduced row, reused
};

}  // namespace stereo_safety_map
