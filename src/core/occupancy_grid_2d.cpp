#include "stereo_safety_map/core/occupancy_grid_2d.h"

#include "stereo_safety_map/core/disparity_filters.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

constexpr float kInfF = std::numeric_limits<float>::infinity();

bool finite(double v) {
  return std::isfinite(v);
}

int positiveMod(int a, int n) {
  const int r = a % n;
  return r < 0 ? r + n : r;
}

Grid2DStatus checkModel(const StereoCameraModel& m) {
  return m.validate().empty() ? Grid2DStatus::kOk : Grid2DStatus::kBadCameraModel;
}

bool poseFinite(const Eigen::Isometry3f& T) {
  return T.matrix().allFinite();
}

// Row spans [i0, i1] (inclusive, clipped to the nx x ny window) of every cell that the convex
// polygon overlaps at all, in continuous cell coordinates where cell (i, j) is [i, i+1) x [j, j+1).
// Conservative so that a close-range trapezoid much smaller than a cell still marks the cell it
// lies in (its true obstacle is there). f(j, i0, i1) returns false to stop.
template <typename F>
void forEachOverlappedSpan(const Eigen::Vector2f* p, int n, int nx, int ny, F&& f) {
  float ymin = p[0].y(), ymax = p[0].y();
  for (int k = 1; k < n; ++k) {
    ymin = std::min(ymin, p[k].y());
    ymax = std::max(ymax, p[k].y());
  }
  if (!(ymax >= 0.0f) || !(ymin < static_cast<float>(ny))) return;
  const int j0 = static_cast<int>(std::floor(std::max(ymin, 0.0f)));
  const int j1 = static_cast<int>(std::floor(std::min(ymax, static_cast<float>(ny - 1))));
  for (int j = j0; j <= j1; ++j) {
    const float ya = std::max(static_cast<float>(j), ymin);
    const float yb = std::min(static_cast<float>(j + 1), ymax);
    float xmin = kInfF, xmax = -kInfF;
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector2f& a = p[k];
      const Eigen::Vector2f& b = p[(k + 1) % n];
      const float elo = std::min(a.y(), b.y());
      const float ehi = std::max(a.y(), b.y());
      if (ehi < ya || elo > yb) continue;
      if (ehi == elo) {
        xmin = std::min(xmin, std::min(a.x(), b.x()));
        xmax = std::max(xmax, std::max(a.x(), b.x()));
        continue;
      }
      // The polygon inside the strip is bounded by its vertices in the strip and the edges'
      // crossings of the strip lines: the edge clipped to the strip covers both.
      const float slope = (b.x() - a.x()) / (b.y() - a.y());
      const float x0 = a.x() + (std::max(ya, elo) - a.y()) * slope;
      const float x1 = a.x() + (std::min(yb, ehi) - a.y()) * slope;
      xmin = std::min(xmin, std::min(x0, x1));
      xmax = std::max(xmax, std::max(x0, x1));
    }
    if (!(xmax >= 0.0f) || !(xmin < static_cast<float>(nx))) continue;
    const int i0 = static_cast<int>(std::floor(std::max(xmin, 0.0f)));
    const int i1 = static_cast<int>(std::floor(std::min(xmax, static_cast<float>(nx - 1))));
    if (i0 <= i1 && !f(j, i0, i1)) return;
  }
}

// Row spans of the cells whose centre (i + 0.5, j + 0.5) lies inside the convex polygon. Used
// for the clear region: a cell is cleared only when the sensed free wedge covers its centre.
template <typename F>
void forEachCentreSpan(const Eigen::Vector2f* p, int n, int nx, int ny, F&& f) {
  float ymin = p[0].y(), ymax = p[0].y();
  for (int k = 1; k < n; ++k) {
    ymin = std::min(ymin, p[k].y());
    ymax = std::max(ymax, p[k].y());
  }
  if (!(ymax >= 0.0f) || !(ymin < static_cast<float>(ny))) return;
  const int j0 = static_cast<int>(std::ceil(std::max(ymin - 0.5f, 0.0f)));
  const int j1 = static_cast<int>(std::floor(std::min(ymax - 0.5f, static_cast<float>(ny - 1))));
  for (int j = j0; j <= j1; ++j) {
    const float yc = static_cast<float>(j) + 0.5f;
    float xl = kInfF, xr = -kInfF;
    int crossings = 0;
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector2f& a = p[k];
      const Eigen::Vector2f& b = p[(k + 1) % n];
      // Half-open rule: a vertex on the scan line counts for exactly one of its edges.
      if ((a.y() <= yc) == (b.y() <= yc)) continue;
      const float x = a.x() + (yc - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
      xl = std::min(xl, x);
      xr = std::max(xr, x);
      ++crossings;
    }
    if (crossings < 2) continue;
    if (!(xr >= 0.0f) || !(xl < static_cast<float>(nx))) continue;
    const int i0 = static_cast<int>(std::ceil(std::max(xl - 0.5f, 0.0f)));
    const int i1 = static_cast<int>(std::floor(std::min(xr - 0.5f, static_cast<float>(nx - 1))));
    if (i0 <= i1 && !f(j, i0, i1)) return;
  }
}

}  // namespace

std::string OccupancyGrid2DConfig::validate() const {
  std::ostringstream e;
  if (!finite(resolution) || resolution <= 0.0 || resolution > 10.0) {
    e << "resolution must be in (0, 10] m, got " << resolution;
  } else if (!finite(size_x) || size_x < resolution || size_x / resolution > 20000.0) {
    e << "size_x must be in [resolution, 20000 * resolution] m, got " << size_x;
  } else if (!finite(size_y) || size_y < resolution || size_y / resolution > 20000.0) {
    e << "size_y must be in [resolution, 20000 * resolution] m, got " << size_y;
  } else if ((size_x / resolution) * (size_y / resolution) > 1e8) {
    e << "size_x * size_y / resolution^2 must be at most 1e8 cells";
  } else if (k < 1 || k > 255) {
    e << "k must be in [1, 255], got " << k;
  } else if (free_threshold < 0 || free_threshold > OccupancyGrid2D::kUnknownValue) {
    // A cell never seen (128) must not count as free, nor as occupied (002 Sec. 3.4).
    e << "free_threshold must be in [0, 128] (unknown = 128 must not be free), got "
      << free_threshold;
  } else if (occupied_threshold < OccupancyGrid2D::kUnknownValue || occupied_threshold > 255) {
    e << "occupied_threshold must be in [128, 255] (unknown = 128 must not be occupied), got "
      << occupied_threshold;
  } else if (!finite(floor_clearance)) {
    e << "floor_clearance must be finite, got " << floor_clearance;
  } else if (!finite(robot_height) || robot_height <= floor_clearance) {
    e << "robot_height must be finite and > floor_clearance (" << floor_clearance << "), got "
      << robot_height;
  } else if (!finite(disparity_half_width) || disparity_half_width <= 0.0 ||
             disparity_half_width > 10.0) {
    e << "disparity_half_width must be in (0, 10] px, got " << disparity_half_width;
  }
  return e.str();
}

const char* toString(Grid2DStatus s) {
  switch (s) {
    case Grid2DStatus::kOk:
      return "ok";
    case Grid2DStatus::kEmptyImage:
      return "empty disparity image";
    case Grid2DStatus::kWrongImageType:
      return "disparity image is not CV_32FC1";
    case Grid2DStatus::kBadCameraModel:
      return "bad camera model (StereoCameraModel::validate() failed)";
    case Grid2DStatus::kImageSizeMismatch:
      return "disparity image or row size differs from the camera model's";
    case Grid2DStatus::kBadPose:
      return "non-finite camera pose, floor height or height band";
  }
  return "unknown status";
}

bool computeUncertaintyTrapezoid(const StereoCameraModel& model, double x, double d,
                                 double half_width, UncertaintyTrapezoid* out) {
  if (out == nullptr || checkModel(model) != Grid2DStatus::kOk || !finite(x) || !finite(d) ||
      !finite(half_width) || half_width < 0.0) {
    return false;
  }
  const double d_eff = d - (model.cx - model.cx_right);
  if (!(d_eff > 0.0)) return false;
  // Eq. (1) and Z(d) = fB / d: the depth interval of a quantised disparity (002 Sec. 3.2).
  const double z_near = model.depthFromDisparity(d + half_width);
  const double z_far = d_eff - half_width > 0.0 ? model.depthFromDisparity(d - half_width)
                                                : std::numeric_limits<double>::infinity();
  // X = (x +/- 0.5) Z / f, x measured from the principal point (002 Sec. 3.2, Fig. 4).
  const double u_left = x - 0.5 - model.cx;
  const double u_right = x + 0.5 - model.cx;
  out->z_near = z_near;
  out->z_far = z_far;
  out->x_near_left = u_left * z_near / model.fx;
  out->x_near_right = u_right * z_near / model.fx;
  out->x_far_left = u_left * z_far / model.fx;
  out->x_far_right = u_right * z_far / model.fx;
  return true;
}

bool projectUncertaintyRegion(const StereoCameraModel& model, double x, double y, double d,
                              double half_width, const Eigen::Isometry3f& T_fixed_camera,
                              double max_ground_range, GroundRegion* out) {
  UncertaintyTrapezoid tr;
  if (out == nullptr || !finite(y) || !poseFinite(T_fixed_camera) ||
      !computeUncertaintyTrapezoid(model, x, d, half_width, &tr)) {
    return false;
  }
  const Eigen::Matrix3d R = T_fixed_camera.linear().cast<double>();
  const Eigen::Vector3d t = T_fixed_camera.translation().cast<double>();
  const double ny = (y - model.cy) / model.fy;
  // Rays of the pixel's two vertical edges at the winning row, per unit depth Z: every corner is
  // t + ray * Z, i.e. the paper's (X, Y, Z) moved to the fixed frame.
  const Eigen::Vector3d ray_l = R * Eigen::Vector3d((x - 0.5 - model.cx) / model.fx, ny, 1.0);
  const Eigen::Vector3d ray_r = R * Eigen::Vector3d((x + 0.5 - model.cx) / model.fx, ny, 1.0);
  double z_far = tr.z_far;
  if (finite(max_ground_range) && max_ground_range > 0.0) {
    // Truncate only beyond the depth at which both far corners are max_ground_range away on
    // the ground, so that no cell of the window can change.
    const double h = std::min(ray_l.head<2>().norm(), ray_r.head<2>().norm());
    const double z_cap = std::max(tr.z_near, max_ground_range / std::max(h, 1e-6));
    z_far = std::min(z_far, z_cap);
  }
  if (!finite(z_far)) return false;
  const Eigen::Vector3d nl = t + ray_l * tr.z_near;
  const Eigen::Vector3d nr = t + ray_r * tr.z_near;
  const Eigen::Vector3d fl = t + ray_l * z_far;
  const Eigen::Vector3d fr = t + ray_r * z_far;
  if (!nl.allFinite() || !nr.allFinite() || !fl.allFinite() || !fr.allFinite()) return false;
  out->camera = t.head<2>().cast<float>();
  out->near_left = nl.head<2>().cast<float>();
  out->near_right = nr.head<2>().cast<float>();
  out->far_right = fr.head<2>().cast<float>();
  out->far_left = fl.head<2>().cast<float>();
  return true;
}

namespace {

Grid2DStatus checkImageInputs(const cv::Mat& disparity, const StereoCameraModel& model,
                              const Eigen::Isometry3f& T_fixed_camera) {
  if (disparity.empty() || disparity.rows <= 0 || disparity.cols <= 0) {
    return Grid2DStatus::kEmptyImage;
  }
  if (disparity.type() != CV_32FC1) return Grid2DStatus::kWrongImageType;
  const Grid2DStatus s = checkModel(model);
  if (s != Grid2DStatus::kOk) return s;
  if (model.width != disparity.cols || model.height != disparity.rows) {
    return Grid2DStatus::kImageSizeMismatch;
  }
  if (!poseFinite(T_fixed_camera)) return Grid2DStatus::kBadPose;
  return Grid2DStatus::kOk;
}

}  // namespace

Grid2DStatus reduceToClosestObstacleRow(const cv::Mat& disparity, const StereoCameraModel& model,
                                        const Eigen::Isometry3f& T_fixed_camera, float floor_z,
                                        float floor_clearance, float robot_height,
                                        std::vector<ColumnReading>* row) {
  if (row == nullptr) return Grid2DStatus::kEmptyImage;
  const Grid2DStatus s = checkImageInputs(disparity, model, T_fixed_camera);
  if (s != Grid2DStatus::kOk) return s;
  if (!std::isfinite(floor_z) || !std::isfinite(floor_clearance) || !std::isfinite(robot_height)) {
    return Grid2DStatus::kBadPose;
  }

  // Height above the floor of pixel (x, y) with disparity d: h = Z a(x, y) + t', where
  // Z = fB / d_eff, a(x, y) = r20 (x - cx) / fx + r21 (y - cy) / fy + r22 is the vertical
  // component of the pixel's ray per unit depth and t' the camera's height above the floor.
  // Multiplying the band test by d_eff > 0 removes the division:
  //   (floor_clearance - t') d_eff <= fB a(x, y) <= (robot_height - t') d_eff.
  const Eigen::Matrix3f R = T_fixed_camera.linear();
  const float fx = static_cast<float>(model.fx);
  const float fy = static_cast<float>(model.fy);
  const float cx = static_cast<float>(model.cx);
  const float cy = static_cast<float>(model.cy);
  const float doff = static_cast<float>(model.cx - model.cx_right);
  const float fb = static_cast<float>(model.fx * model.baseline);
  const float ax = R(2, 0) / fx;
  const float ay = R(2, 1) / fy;
  const float a0 = R(2, 2) - R(2, 0) * cx / fx - R(2, 1) * cy / fy;
  const float t_above = T_fixed_camera.translation().z() - floor_z;
  const float lo = floor_clearance - t_above;
  const float hi = robot_height - t_above;
  // Valid means > 0 (image convention) and a positive depth (d > cx - cx_right).
  const float d_min = std::max(0.0f, doff);

  const int w = disparity.cols;
  row->resize(static_cast<std::size_t>(w));
  ColumnReading* out = row->data();
  for (int x = 0; x < w; ++x)
    out[x] = ColumnReading{d_min, -1};

  // 002 Sec. 3.3: the maximum valid disparity per column is the closest obstacle.
  for (int y = 0; y < disparity.rows; ++y) {
    const float* p = disparity.ptr<float>(y);
    const float a_row = ay * static_cast<float>(y) + a0;
    for (int x = 0; x < w; ++x) {
      const float d = p[x];
      ColumnReading& c = out[x];
      // Cheapest test first: most pixels do not beat their column's current maximum.
      if (!(d > c.disparity) || !isValidDisparity(d)) continue;
      const float d_eff = d - doff;
      const float lhs = fb * (ax * static_cast<float>(x) + a_row);
      if (lhs < lo * d_eff || lhs > hi * d_eff) continue;
      c.disparity = d;
      c.row = y;
    }
  }
  for (int x = 0; x < w; ++x) {
    if (out[x].row < 0) out[x].disparity = 0.0f;
  }
  return Grid2DStatus::kOk;
}

// ---------------------------------------------------------------------------------------------

OccupancyGrid2D::OccupancyGrid2D(const OccupancyGrid2DConfig& config) : config_(config) {
  const std::string err = config_.validate();
  if (!err.empty()) throw std::invalid_argument("OccupancyGrid2DConfig: " + err);
  nu_ = std::max(1, static_cast<int>(std::lround(config_.size_x / config_.resolution)));
  nv_ = std::max(1, static_cast<int>(std::lround(config_.size_y / config_.resolution)));
  min_ = GridCell2D{-nu_ / 2, -nv_ / 2};
  const std::size_t n = static_cast<std::size_t>(nu_) * static_cast<std::size_t>(nv_);
  value_.assign(n, kUnknownValue);
  disparity_.assign(n, 0.0f);
  stamp_.assign(n, 0u);
  mark_.assign(n, 0u);
  pending_disp_.assign(n, 0.0f);
  touched_.reserve(n);
}

GridCell2D OccupancyGrid2D::indexOf(const Eigen::Vector2f& xy) const {
  // Clamped so that any coordinate (even 1e30, fuzzing found it) converts to int and the
  // difference of two indices still fits one; a clamped index is far outside any window.
  static constexpr double kLimit = 1 << 28;
  const double inv = 1.0 / config_.resolution;
  auto index = [inv](float x) {
    const double s = std::floor(x * inv + 0.5);
    return static_cast<int>(std::isnan(s) ? 0.0 : std::clamp(s, -kLimit, kLimit));
  };
  return GridCell2D{index(xy.x()), index(xy.y())};
}

Eigen::Vector2f OccupancyGrid2D::centerOf(const GridCell2D& c) const {
  return Eigen::Vector2f(static_cast<float>(c.u * config_.resolution),
                         static_cast<float>(c.v * config_.resolution));
}

bool OccupancyGrid2D::contains(const GridCell2D& c) const {
  return c.u >= min_.u && c.v >= min_.v && c.u < min_.u + nu_ && c.v < min_.v + nv_;
}

std::size_t OccupancyGrid2D::linear(int u, int v) const {
  return static_cast<std::size_t>(positiveMod(v, nv_)) * static_cast<std::size_t>(nu_) +
         static_cast<std::size_t>(positiveMod(u, nu_));
}

void OccupancyGrid2D::resetStorageColumn(int su) {
  for (int sv = 0; sv < nv_; ++sv) {
    const std::size_t k = static_cast<std::size_t>(sv) * nu_ + su;
    value_[k] = kUnknownValue;
    disparity_[k] = 0.0f;
  }
}

void OccupancyGrid2D::resetStorageRow(int sv) {
  const std::size_t base = static_cast<std::size_t>(sv) * nu_;
  std::fill(value_.begin() + base, value_.begin() + base + nu_, kUnknownValue);
  std::fill(disparity_.begin() + base, disparity_.begin() + base + nu_, 0.0f);
}

void OccupancyGrid2D::clear() {
  std::fill(value_.begin(), value_.end(), kUnknownValue);
  std::fill(disparity_.begin(), disparity_.end(), 0.0f);
}

std::size_t OccupancyGrid2D::recenter(const Eigen::Vector2f& robot_xy) {
  if (!robot_xy.allFinite()) return 0;
  const GridCell2D c = indexOf(robot_xy);
  const GridCell2D new_min{c.u - nu_ / 2, c.v - nv_ / 2};
  const int du = new_min.u - min_.u;
  const int dv = new_min.v - min_.v;
  if (du == 0 && dv == 0) return 0;
  const std::size_t total = value_.size();
  if (std::abs(du) >= nu_ || std::abs(dv) >= nv_) {
    clear();
    min_ = new_min;
    return total;
  }
  // Ring buffer: storage of cells leaving on one side is reused for those entering on the other.
  if (du > 0) {
    for (int u = min_.u; u < min_.u + du; ++u)
      resetStorageColumn(positiveMod(u, nu_));
  } else {
    for (int u = min_.u + nu_ + du; u < min_.u + nu_; ++u)
      resetStorageColumn(positiveMod(u, nu_));
  }
  if (dv > 0) {
    for (int v = min_.v; v < min_.v + dv; ++v)
      resetStorageRow(positiveMod(v, nv_));
  } else {
    for (int v = min_.v + nv_ + dv; v < min_.v + nv_; ++v)
      resetStorageRow(positiveMod(v, nv_));
  }
  min_ = new_min;
  const std::size_t kept =
      static_cast<std::size_t>(nu_ - std::abs(du)) * static_cast<std::size_t>(nv_ - std::abs(dv));
  return total - kept;
}

std::uint8_t OccupancyGrid2D::value(const GridCell2D& c) const {
  return contains(c) ? value_[linear(c.u, c.v)] : kUnknownValue;
}

float OccupancyGrid2D::storedDisparity(const GridCell2D& c) const {
  return contains(c) ? disparity_[linear(c.u, c.v)] : 0.0f;
}

void OccupancyGrid2D::setCell(const GridCell2D& c, std::uint8_t value, float disparity) {
  if (!contains(c)) return;
  const std::size_t k = linear(c.u, c.v);
  value_[k] = value;
  disparity_[k] = std::isfinite(disparity) ? disparity : 0.0f;
}

void OccupancyGrid2D::toImage(cv::Mat* out) const {
  if (out == nullptr) return;
  out->create(nv_, nu_, CV_8UC1);
  for (int r = 0; r < nv_; ++r) {
    std::uint8_t* dst = out->ptr<std::uint8_t>(r);
    const std::size_t base = static_cast<std::size_t>(positiveMod(min_.v + r, nv_)) * nu_;
    int su = positiveMod(min_.u, nu_);
    for (int c = 0; c < nu_; ++c) {
      dst[c] = value_[base + su];
      if (++su == nu_) su = 0;
    }
  }
}

Grid2DUpdateStats OccupancyGrid2D::update(const cv::Mat& disparity, const StereoCameraModel& model,
                                          const Eigen::Isometry3f& T_fixed_camera, float floor_z) {
  Grid2DUpdateStats stats;
  stats.status = reduceToClosestObstacleRow(disparity, model, T_fixed_camera, floor_z,
                                            static_cast<float>(config_.floor_clearance),
                                            static_cast<float>(config_.robot_height), &row_);
  if (!stats.ok()) return stats;
  return updateFromRow(row_, model, T_fixed_camera);
}

void OccupancyGrid2D::mark(std::size_t k, Mark m, float d) {
  // One +K or -K per cell and sensor reading; +K (and "explained, keep") win over -K.
  if (stamp_[k] != frame_) {
    stamp_[k] = frame_;
    mark_[k] = m;
    pending_disp_[k] = d;
    touched_.push_back(static_cast<std::uint32_t>(k));
  } else if (m > mark_[k]) {
    mark_[k] = m;
    pending_disp_[k] = d;
  } else if (m == mark_[k] && d > pending_disp_[k]) {
    pending_disp_[k] = d;
  }
}

bool OccupancyGrid2D::explainedByBetterEvidence(const Eigen::Vector2f* quad, float d) const {
  // 002 Sec. 4.3: the hypothesis "an obstacle lies in this region" is already explained when a
  // cell of the region leans occupied (G above the 50 % value) and was raised by a reading of
  // higher disparity, i.e. better depth resolution. Above 50 % rather than above the planning
  // threshold, so that an obstacle seen once at close range is already protected.
  bool found = false;
  forEachOverlappedSpan(quad, 4, nu_, nv_, [&](int j, int i0, int i1) {
    const std::size_t base = static_cast<std::size_t>(positiveMod(min_.v + j, nv_)) * nu_;
    int su = positiveMod(min_.u + i0, nu_);
    for (int i = i0; i <= i1; ++i) {
      const std::size_t k = base + su;
      if (value_[k] > kUnknownValue && disparity_[k] > d) {
        found = true;
        return false;
      }
      if (++su == nu_) su = 0;
    }
    return true;
  });
  return found;
}

Grid2DUpdateStats OccupancyGrid2D::updateFromRow(const std::vector<ColumnReading>& row,
                                                 const StereoCameraModel& model,
                                                 const Eigen::Isometry3f& T_fixed_camera) {
  Grid2DUpdateStats stats;
  stats.columns = static_cast<int>(row.size());
  stats.status = checkModel(model);
  if (!stats.ok()) return stats;
  if (static_cast<int>(row.size()) != model.width) {
    stats.status = Grid2DStatus::kImageSizeMismatch;
    return stats;
  }
  if (!poseFinite(T_fixed_camera)) {
    stats.status = Grid2DStatus::kBadPose;
    return stats;
  }

  if (++frame_ == 0) {  // stamp wrap-around: forget all stamps once every 2^32 updates
    std::fill(stamp_.begin(), stamp_.end(), 0u);
    frame_ = 1;
  }
  touched_.clear();

  // Window in continuous cell coordinates: g = xy / res + 0.5 - min, cell i spans [i, i + 1).
  const float inv_res = static_cast<float>(1.0 / config_.resolution);
  const Eigen::Vector2f offset(0.5f - static_cast<float>(min_.u),
                               0.5f - static_cast<float>(min_.v));
  const auto toGrid = [&](const Eigen::Vector2f& p) -> Eigen::Vector2f {
    return p * inv_res + offset;
  };
  // Ground range beyond which nothing lies in the window (for truncating unbounded far edges).
  const Eigen::Vector2f cam = T_fixed_camera.translation().head<2>();
  double reach = 0.0;
  for (int corner = 0; corner < 4; ++corner) {
    const Eigen::Vector2f p((min_.u + ((corner & 1) ? nu_ : 0) - 0.5f) * config_.resolution,
                            (min_.v + ((corner & 2) ? nv_ : 0) - 0.5f) * config_.resolution);
    reach = std::max(reach, static_cast<double>((p - cam).norm()));
  }
  reach += config_.resolution;

  const auto markSpan = [&](int j, int i0, int i1, Mark m, float d) {
    const std::size_t base = static_cast<std::size_t>(positiveMod(min_.v + j, nv_)) * nu_;
    int su = positiveMod(min_.u + i0, nu_);
    for (int i = i0; i <= i1; ++i) {
      mark(base + su, m, d);
      if (++su == nu_) su = 0;
    }
  };

  for (std::size_t x = 0; x < row.size(); ++x) {
    const ColumnReading& r = row[x];
    if (!r.valid() || !isValidDisparity(r.disparity)) continue;
    GroundRegion g;
    if (!projectUncertaintyRegion(model, static_cast<double>(x), static_cast<double>(r.row),
                                  r.disparity, config_.disparity_half_width, T_fixed_camera, reach,
                                  &g)) {
      continue;
    }
    ++stats.columns_with_reading;
    const Eigen::Vector2f quad[4] = {toGrid(g.near_left), toGrid(g.near_right), toGrid(g.far_right),
                                     toGrid(g.far_left)};
    const Eigen::Vector2f tri[3] = {toGrid(g.camera), quad[0], quad[1]};
    // An explained region is left as it is: no +K, and no -K from other columns' clear
    // triangles of this reading either (the map and the hypothesis agree there).
    Mark m = kMarkOccupied;
    if (config_.accuracy_preservation && explainedByBetterEvidence(quad, r.disparity)) {
      m = kMarkKeep;
      ++stats.columns_explained;
    }
    // OCC(r): the trapezoid of uncertainty (002 Sec. 3.2, 3.4).
    forEachOverlappedSpan(quad, 4, nu_, nv_, [&](int j, int i0, int i1) {
      markSpan(j, i0, i1, m, r.disparity);
      return true;
    });
    // CLEAR(r): the triangle between the camera and the near corners (002 Sec. 3.2, 3.4).
    forEachCentreSpan(tri, 3, nu_, nv_, [&](int j, int i0, int i1) {
      markSpan(j, i0, i1, kMarkClear, 0.0f);
      return true;
    });
  }

  // 002 Sec. 3.4: G += K in OCC(r), G -= K in CLEAR(r), clipped to [0, 255].
  const int k = config_.k;
  for (const std::uint32_t c : touched_) {
    switch (mark_[c]) {
      case kMarkOccupied:
        value_[c] = static_cast<std::uint8_t>(std::min(255, value_[c] + k));
        disparity_[c] = pending_disp_[c];  // 002 Sec. 4.3 second grid value
        ++stats.cells_raised;
        break;
      case kMarkClear:
        value_[c] = static_cast<std::uint8_t>(std::max(0, value_[c] - k));
        ++stats.cells_lowered;
        break;
      default:
        break;
    }
  }
  return stats;
}

}  // namespace stereo_safety_map
