// Least-squares plane z = a x + b y + c fitted to the points of a ground segment (paper 000,
// Sec. V-B).
//
// ROS-free. The fit is done on data shifted to a reference point taken from the data itself and
// then centred, in double precision, so that segments far from the map origin (large x, y, z) fit
// as well as segments near it. With centred data the intercept decouples from the slopes and the
// normal equations reduce to a 2x2 symmetric system in (a, b).
#pragma once

#include "stereo_safety_map/core/ground_segmentation.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/core/voxel_grid.h"

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct PlaneFitConfig {
  /// Fewest points for a valid plane (not in the paper). Three points determine a plane exactly
  /// and leave no residual to judge it by; six, the size of the smallest segment Alg. 2 keeps
  /// (n_small), is the least that averages any stereo noise.
  int min_points = 6;
  /// Smallest standard deviation [m] of the points' xy positions along their narrowest horizontal
  /// direction (not in the paper). Below it the points are (nearly) collinear in xy, or on a
  /// vertical surface, and z = a x + b y + c is not determined. A one-voxel-wide strip of points
  /// spread over its 0.1 m cells has about 0.029 m, well above the default.
  double min_xy_stddev = 0.005;
  /// Voxel layers above and below the segment's indexed height whose points join the fit (ours;
  /// 0 = only the voxels at the segment's height, 000 Sec. V-B read literally). A segment is a
  /// band one voxel high; on a ramp its points are cut off at the band's top and bottom, and the
  /// stereo noise that crossed those cuts is missing from the fit, which flattens the slope
  /// (a 4.8 deg ramp fitted as 2 deg). The points that spilled into the layers above and below
  /// and lie near the band's own plane (2.5 RMS residuals, at least l_v / 4) restore the
  /// untruncated distribution; obstacle bases in those layers stay out. Off by default: on
  /// the real pairs of ../shared/data/real a small noisy carpet patch (bumblebee2 chair02) came
  /// out 16 deg with it (Non-ground) where the band alone gives a level floor, and on the
  /// datasets it changed the error rates by less than 0.1 % (docs/evaluation.md).
  int vertical_margin = 0;
  /// Fit to every point (ours; false = the point lists of 000 Sec. IV). A list holds the
  /// point_list_capacity points nearest to the camera, i.e. those in front of the surface along
  /// their rays, and weighs the same for 8 observations as for 800, so two segments' planes can
  /// differ by centimetres at a step whose sides sit differently in their voxels
  /// (HeightMapConfig::observation_means). With this switch each voxel's list points keep their
  /// xy spread, are moved in z by the difference between the mean of every point the voxel
  /// received (VoxelGrid::moments) and the list's mean, and together weigh that many points.
  /// (The first version, one mean point per voxel, had no spread across a segment one cell wide:
  /// such a strip got no plane and turned Unknown.) Off by default: on the dev split it moved
  /// FN / FP by less than 0.1 % alone (docs/evaluation.md, "Heights from capped point lists").
  bool observation_means = false;
  /// Planes at the columns' heights from every point (ours; false = 000 Sec. V-B's lists). Each
  /// voxel's list points keep their xy spread and are moved in z so that their mean is the
  /// column's height from every point of the surface's voxels (VoxelGrid::massMeanZ over the
  /// segment's voxel and those just below and above it, HeightMapConfig::mass_heights): the
  /// segment's band holds only the part of the surface's noise that falls into it, and Alg. 2
  /// compares two segments' planes at their border against h_T. Columns whose height lies far
  /// off the plane (at least l_v / 5) are left out: a band also holds the columns where a lower
  /// or higher surface's noise reached into it, and with their true
  /// heights they would tilt the plane across the step they stand for. The fit starts level at
  /// the columns' median height and keeps, in three passes, the columns within 2.5 robust
  /// standard deviations of the previous plane.
  bool mass_heights = false;

  /// Empty when valid, otherwise a message naming the offending parameter and its range.
  std::string validate() const;
};

/// Accumulates points and fits z = a x + b y + c by linear least squares (000, Sec. V-B).
/// Non-finite points are ignored. No allocation.
class PlaneFitAccumulator {
 public:
  void clear();
  void add(const Eigen::Vector3d& p);
  void add(const Eigen::Vector3f& p) { add(Eigen::Vector3d(p.cast<double>())); }
  /// A point that stands for `weight` points (the mean of a voxel's moments, VoxelMoments):
  /// weighted least squares. Counts once towards min_points; num_points is the total weight.
  /// Non-finite points and weights <= 0 are ignored.
  void add(const Eigen::Vector3d& p, double weight);
  std::size_t count() const { return n_; }
  /// The least-squares plane; `valid` is false for fewer than config.min_points points or
  /// degenerate (collinear in xy) geometry, and then only num_points and centroid are filled.
  GroundPlane fit(const PlaneFitConfig& config) const;

 private:
  std::size_t n_ = 0;
  double w_ = 0;                                   // total weight (n_ when unweighted)
  Eigen::Vector3d ref_ = Eigen::Vector3d::Zero();  // first point: shifts the data near zero
  double sx_ = 0, sy_ = 0, sz_ = 0;                // sums of shifted coordinates
  double sxx_ = 0, sxy_ = 0, syy_ = 0, sxz_ = 0, syz_ = 0, szz_ = 0;
};

/// Fits a plane to a set of points (000, Sec. V-B).
GroundPlane fitPlane(const std::vector<Eigen::Vector3d>& points,
                     const PlaneFitConfig& config = PlaneFitConfig());

class PlaneFitter {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit PlaneFitter(const PlaneFitConfig& config = PlaneFitConfig());

  const PlaneFitConfig& config() const { return config_; }

  /// Plane of one segment from the point lists of its voxels at the segment's indexed height
  /// (000, Sec. V-B). An out-of-range segment id gives an invalid plane.
  GroundPlane fitSegment(const VoxelGrid& grid, const GroundSegments& segments, int k) const;

  /// Planes of all segments; planes->size() becomes segments.numSegments() (buffer reused).
  void fitAll(const VoxelGrid& grid, const GroundSegments& segments,
              std::vector<GroundPlane>* planes) const;

 private:
  GroundPlane fitSegmentMass(const VoxelGrid& grid, const GroundSegments& segments, int k) const;
  // PlaneFitConfig::mass_heights: a column's centre, height from every point, the shift of its
  // list's points to that height, and the list. Buffers reused from segment to segment.
  struct MassColumn {
    double x, y, z, dz;
    VoxelPointList list;
  };
  PlaneFitConfig config_;
  mutable std::vector<MassColumn> mass_columns_;
  mutable std::vector<double> mass_residuals_;
};

}  // namespace stereo_safety_map
