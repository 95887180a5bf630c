#include "stereo_safety_map/core/plane_fit.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace stereo_safety_map {

namespace {
constexpr double kRadToDeg = 57.29577951308232;
}  // namespace

std::string PlaneFitConfig::validate() const {
  if (min_points < 3 || min_points > 1000000) return "min_points must be in [3, 1000000]";
  if (!std::isfinite(min_xy_stddev) || min_xy_stddev <= 0.0 || min_xy_stddev > 10.0) {
    return "min_xy_stddev must be in (0, 10] m";
  }
  if (vertical_margin < 0 || vertical_margin > 3) return "vertical_margin must be in [0, 3] voxels";
  return "";
}

void PlaneFitAccumulator::clear() {
  *this = PlaneFitAccumulator();
}

void PlaneFitAccumulator::add(const Eigen::Vector3d& p) {
  add(p, 1.0);  // 1.0 * x == x: the same sums as unweighted
}

void PlaneFitAccumulator::add(const Eigen::Vector3d& p, double weight) {
  if (!p.allFinite() || !std::isfinite(weight) || !(weight > 0.0)) return;
  if (n_ == 0) ref_ = p;
  const double x = p.x() - ref_.x(), y = p.y() - ref_.y(), z = p.z() - ref_.z();
  ++n_;
  w_ += weight;
  sx_ += weight * x;
  sy_ += weight * y;
  sz_ += weight * z;
  sxx_ += weight * x * x;
  sxy_ += weight * x * y;
  syy_ += weight * y * y;
  sxz_ += weight * x * z;
  syz_ += weight * y * z;
  szz_ += weight * z * z;
}

GroundPlane PlaneFitAccumulator::fit(const PlaneFitConfig& config) const {
  GroundPlane plane;
  plane.num_points = static_cast<std::size_t>(std::llround(w_));
  if (n_ == 0) return plane;
  const double n = w_;
  const double mx = sx_ / n, my = sy_ / n, mz = sz_ / n;
  plane.centroid = ref_ + Eigen::Vector3d(mx, my, mz);
  if (n_ < static_cast<std::size_t>(config.min_points)) return plane;

  // Centred scatter. The shift to ref_ keeps the means small compared with the spread of a
  // local segment, so these differences lose no significant digits.
  Eigen::Matrix2d A;
  A(0, 0) = sxx_ - n * mx * mx;
  A(0, 1) = A(1, 0) = sxy_ - n * mx * my;
  A(1, 1) = syy_ - n * my * my;
  const Eigen::Vector2d rhs(sxz_ - n * mx * mz, syz_ - n * my * mz);
  const double szz = szz_ - n * mz * mz;

  // Degeneracy: the smallest eigenvalue of the xy scatter is n times the variance along the
  // narrowest horizontal direction.
  const double tr = A(0, 0) + A(1, 1);
  const double det = A(0, 0) * A(1, 1) - A(0, 1) * A(0, 1);
  const double disc = std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
  const double lambda_min = 0.5 * tr - disc;
  if (!(lambda_min / n >= config.min_xy_stddev * config.min_xy_stddev)) return plane;

  // Normal equations of the centred data: the 3x3 system of (x, y, 1) is block diagonal, the
  // intercept follows from the means.
  const Eigen::Vector2d ab = A.ldlt().solve(rhs);
  if (!ab.allFinite()) return plane;
  plane.a = ab.x();
  plane.b = ab.y();
  plane.c = plane.centroid.z() - plane.a * plane.centroid.x() - plane.b * plane.centroid.y();
  plane.normal = Eigen::Vector3d(-plane.a, -plane.b, 1.0).normalized();
  plane.slope_deg = std::atan(std::hypot(plane.a, plane.b)) * kRadToDeg;
  // Residual sum of squares of the least-squares solution: S_zz - p^T S_xy,z.
  const double rss = std::max(0.0, szz - ab.dot(rhs));
  plane.residual_rms = std::sqrt(rss / n);
  plane.valid = std::isfinite(plane.c);
  return plane;
}

GroundPlane fitPlane(const std::vector<Eigen::Vector3d>& points, const PlaneFitConfig& config) {
  PlaneFitAccumulator acc;
  for (const auto& p : points)
    acc.add(p);
  return acc.fit(config);
}

PlaneFitter::PlaneFitter(const PlaneFitConfig& config) : config_(config) {
  const std::string err = config_.validate();
  if (!err.empty()) throw std::invalid_argument("PlaneFitConfig: " + err);
}

// PlaneFitConfig::mass_heights: the list points of each column of the segment at the column's
// height from every point of its surface voxels, fitted to the columns that lie near the plane:
// a robust start (the level plane at the columns' median height), then three passes that keep
// the columns within 2.5 robust standard deviations (1.4826 times the median absolute
// residual; at least l_v / 5) of the previous plane. A band also holds the columns where a lower
// or higher surface's noise reached into it (a third of a segment beside a curb, dev seed 23);
// with their true heights they would tilt the plane across the step they stand for.
GroundPlane PlaneFitter::fitSegmentMass(const VoxelGrid& grid, const GroundSegments& segments,
                                        int k) const {
  const int w = segments.segment_height[k];
  const double l = grid.config().voxel_size;
  std::vector<MassColumn>& cols = mass_columns_;
  cols.clear();
  for (const int* c = segments.cellsBegin(k); c != segments.cellsEnd(k); ++c) {
    const int u = segments.cellU(*c), v = segments.cellV(*c);
    const VoxelPointList list = grid.points(VoxelIndex{u, v, w});
    if (list.empty()) continue;
    const float zc = grid.massMeanZ(u, v, w - 1, w + 1);
    if (!std::isfinite(zc)) continue;
    double list_z = 0.0;
    for (const VoxelPoint& p : list)
      list_z += p.position.z();
    cols.push_back(
        MassColumn{u * l, v * l, zc, zc - list_z / static_cast<double>(list.size), list});
  }
  if (cols.empty()) return GroundPlane();
  std::vector<double>& r = mass_residuals_;
  auto median = [&r]() {
    const std::size_t mid = r.size() / 2;
    std::nth_element(r.begin(), r.begin() + mid, r.end());
    return r[mid];
  };
  r.clear();
  for (const MassColumn& col : cols)
    r.push_back(col.z);
  GroundPlane plane;  // the robust start: level at the median height
  plane.a = plane.b = 0.0;
  plane.c = median();
  GroundPlane best;
  for (int pass = 0; pass < 4; ++pass) {
    r.clear();
    for (const MassColumn& col : cols)
      r.push_back(std::abs(col.z - plane.heightAt(col.x, col.y)));
    const double tol = std::max(2.5 * 1.4826 * median(), 0.2 * l);
    PlaneFitAccumulator acc;
    for (const MassColumn& col : cols) {
      if (!(std::abs(col.z - plane.heightAt(col.x, col.y)) <= tol)) continue;
      for (const VoxelPoint& p : col.list)
        acc.add(Eigen::Vector3d(p.position.x(), p.position.y(), p.position.z() + col.dz));
    }
    const GroundPlane fit = acc.fit(config_);
    if (!fit.valid) return pass == 0 ? fit : best;
    plane = best = fit;
  }
  return best;
}

GroundPlane PlaneFitter::fitSegment(const VoxelGrid& grid, const GroundSegments& segments,
                                    int k) const {
  if (k < 0 || k >= segments.numSegments()) return GroundPlane();
  if (config_.mass_heights) return fitSegmentMass(grid, segments, k);
  // 000 Sec. V-B: the points of the segment's voxels, i.e. of voxel (u, v, w_k) of each column.
  const int w = segments.segment_height[k];
  auto addLayer = [&](PlaneFitAccumulator* acc, int dw, const GroundPlane* gate, double tol) {
    for (const int* c = segments.cellsBegin(k); c != segments.cellsEnd(k); ++c) {
      const VoxelIndex idx{segments.cellU(*c), segments.cellV(*c), w + dw};
      const VoxelPointList list = grid.points(idx);
      if (config_.observation_means && !list.empty()) {
        // PlaneFitConfig::observation_means: the list's points keep the voxel's xy spread, their
        // heights are moved by the difference between the mean of every point the voxel received
        // (VoxelGrid::moments) and the list's own mean, and together they weigh as many points
        // as the voxel received.
        const VoxelMoments m = grid.moments(idx);
        if (!(m.weight > 0.0f)) continue;
        double list_z = 0.0;
        for (const VoxelPoint& p : list)
          list_z += p.position.z();
        const double n = static_cast<double>(list.size);
        const double dz = m.sz / m.weight - list_z / n;
        const double weight = m.weight / n;
        for (const VoxelPoint& p : list) {
          const Eigen::Vector3d q(p.position.x(), p.position.y(), p.position.z() + dz);
          if (gate != nullptr && !(std::abs(q.z() - gate->heightAt(q.x(), q.y())) <= tol)) continue;
          acc->add(q, weight);
        }
        continue;
      }
      for (const VoxelPoint& p : list) {
        if (gate != nullptr &&
            !(std::abs(p.position.z() - gate->heightAt(p.position.x(), p.position.y())) <= tol))
          continue;
        acc->add(p.position);
      }
    }
  };
  PlaneFitAccumulator acc;
  addLayer(&acc, 0, nullptr, 0.0);
  // The two sides of a step split by GroundSegmentationConfig::split_steps are fitted with at
  // least one layer of margin: the lower side's band holds only the upper tail of its noise,
  // its body lies in the layer below.
  int margin = config_.vertical_margin;
  if (margin == 0 &&
      static_cast<int>(segments.segment_split_from.size()) == segments.numSegments()) {
    for (int j = 0; j < segments.numSegments() && margin == 0; ++j) {
      if (segments.segment_split_from[j] >= 0 && (j == k || segments.segment_split_from[j] == k))
        margin = 1;
    }
  }
  if (margin == 0) return acc.fit(config_);
  // PlaneFitConfig::vertical_margin: a first fit on the band and all the points that spilled
  // into the layers above and below (stereo noise cut off at the band's top and bottom), then
  // two refits on the band's points and those spilled points within 2.5 RMS residuals (at least
  // a quarter voxel) of the previous plane, so that the bases of obstacles and other surfaces
  // in those layers drop out again.
  PlaneFitAccumulator all = acc;
  for (int dw = 1; dw <= margin; ++dw) {
    addLayer(&all, dw, nullptr, 0.0);
    addLayer(&all, -dw, nullptr, 0.0);
  }
  GroundPlane plane = all.fit(config_);
  if (!plane.valid) return acc.fit(config_);
  const double l = grid.config().voxel_size;
  for (int pass = 0; pass < 2; ++pass) {
    const double tol = std::max(2.5 * plane.residual_rms, 0.25 * l);
    PlaneFitAccumulator gated;
    for (int dw = -margin; dw <= margin; ++dw)
      addLayer(&gated, dw, &plane, tol);
    const GroundPlane refit = gated.fit(config_);
    if (!refit.valid) break;
    plane = refit;
  }
  return plane;
}

void PlaneFitter::fitAll(const VoxelGrid& grid, const GroundSegments& segments,
                         std::vector<GroundPlane>* planes) const {
  if (planes == nullptr) return;
  planes->resize(segments.numSegments());
  for (int k = 0; k < segments.numSegments(); ++k)
    (*planes)[k] = fitSegment(grid, segments, k);
}

}  // namespace stereo_safety_map
