// Height map of the voxel grid: per (u, v) column the indexed height w of the highest occupied
// voxel the robot could not pass under (paper 000, Sec. V-A and Alg. 1 step 1).
//
// ROS-free. The map covers the grid's (u, v) window; cells are row-major like SafetyMap:
// index = (v - min_v) * width + (u - min_u).
#pragma once

#include "stereo_safety_map/core/voxel_grid.h"

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct HeightMapConfig {
  /// Robot height above its base [m]. Occupied voxels whose centre is at or above
  /// base z + robot_height are ignored: the robot can travel under them (000, Sec. V-A).
  double robot_height = 1.5;
  /// Column heights from every point (ours; false = the point lists of 000 Sec. IV). The
  /// surface and ground heights below are means of points. A voxel's list keeps the
  /// point_list_capacity points nearest to the camera, and a list weighs the same whether its
  /// voxel saw 8 points or 800. Both bias a floor's height: along a ray the nearest points are
  /// the ones in front of the surface (a level floor's top voxel reads +2 cm), and where a floor
  /// straddles a voxel boundary the few points of its noise tail in the other voxel fill that
  /// voxel's list and count as much as the floor's own (a level floor seen for 90 frames reads
  /// 2 cm low, one seen for 10 reads 2 cm high: perfect-pose dev seed 5, a 6.1 cm step measured
  /// 3.6 cm). With this on the heights are the means of the voxels' running moments
  /// (VoxelGrid::moments): every point counts once. Off by default: measured on the dev split
  /// together with PlaneFitConfig::observation_means (docs/evaluation.md, "Heights from capped
  /// point lists"), not alone enough to make it the default.
  bool observation_means = false;
  /// The near view decides a floor's voxel (ours; 0 = 000 Sec. V-A's highest occupied voxel).
  /// The vertical error of a stereo point grows with its range (squared for the disparity's
  /// error, 001 Sec. 4.1; linearly for an unreported chassis pitch or roll): a floor seen from
  /// 3-4 m leaves the upper tail of its points in the voxel above its own, and the increments
  /// of many frames make that voxel occupied. When the chair drives there, the floor seen from
  /// 1.3-2 m puts its points in its own voxel only, but the log-odds of the voxel above (incr_H
  /// per hit, decr per passing ray) do not fall for many frames: the column stands one voxel
  /// (l_v) above the floor, and a floor the chair stands on is a step away from it (the whole
  /// map unreachable, docs/evaluation.md "The ground the chair stands on"). With this > 0, a
  /// column's highest occupied voxel that sits directly on another occupied voxel is passed
  /// over when the nearest observation of its points is more than near_view_ratio times as far
  /// as the nearest of the voxel below (both from the voxels' closest-first point lists): the
  /// surface seen from nearer is the column's surface. The intent: a surface in the upper voxel
  /// seen from near puts its points there, and a camera looking down sees an obstacle's top
  /// from as near as its face. Measured (docs/evaluation.md, "The far views' noise tail"):
  /// above 1.5 it almost never fires (one near point among the upper list's eight nearest keeps
  /// the voxel); at 1.1 it cut the open-world dev split's FP 21.7 -> 18.3 % but forgotten
  /// obstacle cells rose 49 -> 87 and missed obstacles 15 -> 18 of 66: it also passes over some
  /// low obstacles' tops. Off by default. 0 or [1, 100].
  double near_view_ratio = 0.0;
  /// A noise tail is not a surface (ours; 0 = 000 Sec. V-A's highest occupied voxel). 000
  /// Sec. IV updates a voxel with one point per frame, so the voxel above a floor that the
  /// upper tail of the floor's stereo noise reaches with a stray point or two a frame (an
  /// unreported chassis pitch lifts it further at range) reaches occ_t as fast as the floor's
  /// own voxel with hundreds: dense disparity makes the whole floor read a voxel high and the
  /// floor the chair stands on a step away from it. With this > 0, a column's highest occupied
  /// voxel that sits directly on another occupied voxel is passed over when it received fewer
  /// than tail_share times as many points as the voxel below (VoxelGrid::hitMass, every
  /// point counted) and their mean lies within half a voxel of the mean of the points below
  /// (a tail hugs its surface): the surface is where the points are. A step's upper surface or
  /// an obstacle's top puts its points into its own voxel and keeps it, and so does the foot of a
  /// wall seen edge-on, whose few points spread over its voxel. Only the top voxel is tested,
  /// once. [0, 1].
  double tail_share = 0.0;
  /// Column heights from every point of the surface's voxels (ours; false = the top voxel's
  /// points, 000 Sec. IV-V). The measured surface height (and the ground height) of a column is
  /// the mean height of every point (VoxelGrid::massMeanZ, not one per frame, not the closest
  /// few) of its top voxel and the voxels just below and above it. A surface's stereo noise
  /// spreads over its voxel and the neighbours; the top voxel alone holds the part above a
  /// voxel boundary: a floor 5.6 cm below the robot's, whose upper tail reaches the band of the
  /// robot's floor, read 1.5 cm below it there and was crossed (dev seed 49).
  bool mass_heights = false;
  /// With mass_heights, a column's indexed height is the voxel its measured surface lies in
  /// (never above its highest nor below its lowest occupied voxel) rather than its highest
  /// occupied voxel (ours; false = 000 Sec. V-A).
  bool mass_bands = false;
  /// Thin columns at the edge of what was seen are not measured ground (ours, on 002 Sec. 4.1's
  /// occlusion boundaries; 0 = off, 000 Sec. V-A takes every column). A column that borders an
  /// unobserved 4-neighbour (no height) and received fewer than this share of the points
  /// (VoxelGrid::hitMass of its top voxel and the voxels just below and above it) of the
  /// 4-neighbour on the opposite side, at that neighbour's height within one voxel (a line
  /// across the edge: a one-column stripe between unobserved columns is kept), is taken as not
  /// observed: Unknown, never a segment's ground. Block matching carries the disparity of a near
  /// surface over the first pixels of a farther one beside it (foreground fattening): the street
  /// seen in a narrow strip beyond a curb running along the field of view's edge receives 40-90
  /// points per column at the curb top's height while the sidewalk's columns receive 1000-3000
  /// (dev seed 44), and with mass_heights the strip joins the sidewalk as Level. A column only
  /// partly in view keeps its share of the points (a fifth in view keeps about 0.2). A column
  /// more than a voxel above the neighbour (an obstacle's top) or below it (a drop) is kept; one
  /// voxel lower is cleared (Unknown, not Non-ground: still not safe). Reads the hit masses
  /// (VoxelGrid::setHitMassTracking). [0, 1].
  double sparse_edge_share = 0.0;

  /// Empty when valid, otherwise a message naming the offending parameter and its range.
  std::string validate() const;
};

class HeightMap {
 public:
  /// Marks a column without any occupied voxel below the robot's top.
  static constexpr std::int32_t kNoHeight = std::numeric_limits<std::int32_t>::min();

  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit HeightMap(const HeightMapConfig& config = HeightMapConfig());

  const HeightMapConfig& config() const { return config_; }

  /// Alg. 1 step 1 (000, Sec. V-A) over the whole (u, v) window of `grid`. `robot_base_z` is the
  /// fixed-frame height of the robot's base. Returns false (and leaves every column without a
  /// height) when robot_base_z is not finite.
  bool build(const VoxelGrid& grid, float robot_base_z);

  /// Sizes the map to a window with no heights (for tests and for other sources of heights).
  /// Negative sizes are treated as 0.
  void reset(int min_u, int min_v, int width, int height);
  /// Sets one column's indexed height (kNoHeight clears it), its lowest occupied voxel too;
  /// ignored outside the window.
  void set(int u, int v, std::int32_t w);
  /// Sets a column's height w and its lowest occupied voxel w_low (<= w).
  void set(int u, int v, std::int32_t w, std::int32_t w_low);
  /// Sets a column's measured surface height [m] (NaN: none); ignored outside the window.
  void setSurfaceHeight(int u, int v, float z);
  /// Sets a column's ground height [m] (NaN: none; see groundHeightAtIndex); ignored outside.
  void setGroundHeight(int u, int v, float z);

  int minU() const { return min_u_; }
  int minV() const { return min_v_; }
  int width() const { return width_; }
  int height() const { return height_; }
  int numCells() const { return width_ * height_; }
  bool inside(int u, int v) const {
    return u >= min_u_ && v >= min_v_ && u < min_u_ + width_ && v < min_v_ + height_;
  }
  int index(int u, int v) const { return (v - min_v_) * width_ + (u - min_u_); }
  /// Indexed height of column (u, v); kNoHeight when it has none or is outside the window.
  std::int32_t at(int u, int v) const { return inside(u, v) ? w_[index(u, v)] : kNoHeight; }
  std::int32_t atIndex(int cell) const { return w_[cell]; }
  /// Indexed height of the lowest occupied voxel below the robot's top in the column (kNoHeight
  /// when none). at() - lowestAt() is the column's vertical extent: 0 for a floor seen as one
  /// layer, many voxels for the face of an obstacle or a floor under an overhang.
  std::int32_t lowestAt(int u, int v) const {
    return inside(u, v) ? w_low_[index(u, v)] : kNoHeight;
  }
  std::int32_t lowestAtIndex(int cell) const { return w_low_[cell]; }
  /// Measured height of the surface in the column [m]: the mean z of the points of its highest
  /// occupied voxel (its list, 000 Sec. IV, or its moments, HeightMapConfig::observation_means),
  /// NaN when the column has no height or no points. Unlike the indexed height it is not quantised
  /// to l_v, so a ramp's columns differ by its slope times their spacing, not by whole voxels.
  float surfaceHeightAtIndex(int cell) const { return surface_z_[cell]; }
  /// Ground height of the column [m] (ours, for GroundSegmentationConfig::split_steps): the mean
  /// z of the points (as above) of its highest occupied voxel and of the voxel just below it, NaN
  /// when the column has no height or none of them has points. A surface that lies in the lower
  /// part of a voxel leaves only the upper tail of its stereo noise in the voxel above: the top
  /// voxel's mean (surfaceHeightAtIndex) then stands above the surface, by up to about half a
  /// voxel, and a sunken floor 6 cm below the robot's reads 3-4 cm below it. The two voxels
  /// together hold the whole spread of the noise.
  float groundHeightAtIndex(int cell) const { return ground_z_[cell]; }
  /// Columns the last build() took as not observed (HeightMapConfig::sparse_edge_share).
  int sparseEdgeColumns() const { return sparse_edge_columns_; }
  const std::vector<std::int32_t>& data() const { return w_; }
  /// Highest indexed height considered by the last build() (the robot's top), for diagnostics.
  int topIndex() const { return top_w_; }

 private:
  HeightMapConfig config_;
  int min_u_ = 0, min_v_ = 0, width_ = 0, height_ = 0;
  int top_w_ = 0;
  std::vector<std::int32_t> w_;
  std::vector<std::int32_t> w_low_;
  std::vector<float> surface_z_;
  std::vector<float> ground_z_;
  std::vector<float> mass_;                 // sparse_edge_share: points of each column's surface
  std::vector<std::int32_t> sparse_cells_;  // sparse_edge_share: columns to clear
  int sparse_edge_columns_ = 0;

  void clearSparseEdges();
};

}  // namespace stereo_safety_map
