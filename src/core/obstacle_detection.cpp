// 3D obstacle detection and segmentation in a range image (paper 003). See obstacle_detection.h.
//
// Why one file of ~1070 lines (issue 17 asks for a reason above ~800): it is one algorithm, 003
// Sec. 2-5, in the order a frame runs it: prepare the range image (range, tiles, windows), the
// compatible-pair test (Definition 1, Sec. 2, with the stereo noise margin of 001 Sec. 4.1),
// the two pair searches (all pairs, and the first partner per tile bounded by the cone's window),
// the union-find that links pairs into obstacles, and finalize (boxes, rejections). Every step
// reads the tile grid and the union-find state that ObstacleDetector keeps as members, and the
// searches are the hot path (they inline the pair test); a split would put that private state in a
// shared header for no reader's gain.
#include "stereo_safety_map/core/obstacle_detection.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

// Side of the square tiles whose 3D bounds prune the search. 8 keeps the bounds tight around
// obstacles while the per-tile work stays small next to the per-pixel work.
constexpr int kTile = 8;
// Tiles per side of a block: the early-exit search first prunes whole blocks, then their tiles,
// which keeps the pruning cost low for the large windows of nearby points.
constexpr int kBlock = 4;
// Tiles per side of a group of points that share one list of candidate tiles.
constexpr int kGroup = 2;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr double kRadToDeg = 180.0 / M_PI;
// tan^2 of a vertical pair (no horizontal offset): above any threshold, atan gives 90 deg.
constexpr float kVerticalTan2 = 1e12f;
constexpr std::uint8_t kMarkObstacle = 1;
constexpr std::uint8_t kMarkRaised = 2;
// Below 1 so that a bound built from one point's error stays under the float value of the
// pair's error that clearOfNoise computes (sqrt(a^2 + b^2) >= a up to rounding).
constexpr float kMarginBound = 0.999f;

inline int floorDiv(int a, int b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}
inline int ceilDiv(int a, int b) {
  return -floorDiv(-a, b);
}
inline int roundUpTo(int a, int b) {
  return ceilDiv(a, b) * b;
}

// atan(sqrt(t2)) for t2 >= 0 in radians, within 0.0015 rad (0.09 deg): slopes only feed the
// Sec. 5 measures, and std::atan per obstacle point is a visible share of the frame time.
inline float slopeFromTan2(float t2) {
  const float t = std::sqrt(t2);
  const bool inv = t > 1.0f;
  const float x = inv ? 1.0f / t : t;                                         // in [0, 1]
  const float a = 0.7853982f * x - x * (x - 1.0f) * (0.2447f + 0.0663f * x);  // Rajan et al.
  return inv ? 1.5707964f - a : a;
}

// Largest |a . d| over the double cone of Definition 1 around a point: axis `up`, height h_max,
// rim radius r_max = h_max / tan(theta_T). A linear function peaks on a rim circle, where it is
// the centre's value plus the radius times the norm of a's component orthogonal to the axis.
inline float coneExtent(float ax, float ay, float az, const Eigen::Vector3f& up, float h_max,
                        float r_max) {
  const float along = ax * up.x() + ay * up.y() + az * up.z();
  const float norm2 = ax * ax + ay * ay + az * az;
  return h_max * std::fabs(along) + r_max * std::sqrt(std::max(0.0f, norm2 - along * along));
}

}  // namespace

std::string ObstacleDetectionConfig::validate() const {
  std::ostringstream err;
  auto finite = [](double v) { return std::isfinite(v); };
  if (!finite(height_threshold) || height_threshold <= 0.0) {
    err << "height_threshold (H_T) must be > 0 m, got " << height_threshold;
  } else if (!finite(max_height) || max_height <= height_threshold) {
    err << "max_height (H_max) must be finite and > height_threshold (" << height_threshold
        << " m), got " << max_height;
  } else if (!finite(slope_threshold_deg) || slope_threshold_deg <= 0.0 ||
             slope_threshold_deg >= 90.0) {
    err << "slope_threshold_deg (theta_T) must be in (0, 90) deg, got " << slope_threshold_deg;
  } else if (!finite(noise_sigmas) || noise_sigmas < 0.0 || noise_sigmas > 10.0) {
    err << "noise_sigmas must be in [0, 10] (0 = off), got " << noise_sigmas;
  } else if (!finite(disparity_sigma) || disparity_sigma <= 0.0 || disparity_sigma > 10.0) {
    err << "disparity_sigma must be in (0, 10] px, got " << disparity_sigma;
  } else if (!finite(sample_spacing) || sample_spacing < 0.0) {
    err << "sample_spacing must be >= 0 m (0 = every pixel), got " << sample_spacing;
  } else if (max_candidates_per_pixel < 0) {
    err << "max_candidates_per_pixel must be >= 0 (0 = unbounded), got "
        << max_candidates_per_pixel;
  } else if (!finite(surface_link_distance) || surface_link_distance < 0.0) {
    err << "surface_link_distance must be >= 0 m (0 = off), got " << surface_link_distance;
  } else if (!finite(surface_link_pixels) || surface_link_pixels < 0.0) {
    err << "surface_link_pixels must be >= 0, got " << surface_link_pixels;
  } else if (!finite(min_avg_slope_deg) || min_avg_slope_deg < 0.0 || min_avg_slope_deg > 90.0) {
    err << "min_avg_slope_deg must be in [0, 90] deg, got " << min_avg_slope_deg;
  } else if (!finite(min_max_slope_deg) || min_max_slope_deg < 0.0 || min_max_slope_deg > 90.0) {
    err << "min_max_slope_deg must be in [0, 90] deg, got " << min_max_slope_deg;
  } else if (!finite(min_avg_height) || min_avg_height < 0.0) {
    err << "min_avg_height must be >= 0 m, got " << min_avg_height;
  } else if (!finite(min_max_height) || min_max_height < 0.0) {
    err << "min_max_height must be >= 0 m, got " << min_max_height;
  } else if (!finite(min_bbox_perimeter) || min_bbox_perimeter < 0.0) {
    err << "min_bbox_perimeter must be >= 0 m, got " << min_bbox_perimeter;
  } else if (!finite(min_volume) || min_volume < 0.0) {
    err << "min_volume must be >= 0 m^3, got " << min_volume;
  }
  return err.str();
}

const char* toString(ObstacleRejection r) {
  switch (r) {
    case ObstacleRejection::kNone:
      return "none";
    case ObstacleRejection::kSmallPerimeter:
      return "small bounding-box perimeter";
    case ObstacleRejection::kLowAverageSlope:
      return "low average slope";
    case ObstacleRejection::kLowMaxSlope:
      return "low maximum slope";
    case ObstacleRejection::kLowAverageHeight:
      return "low average height";
    case ObstacleRejection::kLowMaxHeight:
      return "low maximum height";
    case ObstacleRejection::kSmallVolume:
      return "small bounding volume";
  }
  return "unknown";
}

double estimateFocalLength(const cv::Mat& range_image) {
  if (range_image.empty() || range_image.type() != CV_32FC3) return 0.0;
  // Every pixel of a sparse lattice (at most ~4000 samples): the fit needs few.
  const int step = std::max(1, static_cast<int>(std::sqrt(range_image.total() / 4000.0)));
  double n = 0.0, su = 0.0, sr = 0.0, suu = 0.0, srr = 0.0, sur = 0.0;
  int u_min = range_image.cols, u_max = -1;
  for (int v = 0; v < range_image.rows; v += step) {
    const cv::Vec3f* row = range_image.ptr<cv::Vec3f>(v);
    for (int u = 0; u < range_image.cols; u += step) {
      const float x = row[u][0], z = row[u][2];
      if (!(z > 0.0f) || !std::isfinite(x) || !std::isfinite(z)) continue;
      const double r = static_cast<double>(x) / z;
      n += 1.0;
      su += u;
      sr += r;
      suu += static_cast<double>(u) * u;
      srr += r * r;
      sur += u * r;
      u_min = std::min(u_min, u);
      u_max = std::max(u_max, u);
    }
  }
  if (n < 100.0 || u_max - u_min < 10) return 0.0;
  const double var_r = srr - sr * sr / n, cov = sur - su * sr / n;
  if (!(var_r > 0.0)) return 0.0;
  const double f = cov / var_r;
  return std::isfinite(f) && f > 0.0 ? f : 0.0;
}

void decimateRangeImage(const cv::Mat& src, int factor, cv::Mat* dst) {
  if (factor < 1 || src.empty() || src.type() != CV_32FC3) {
    dst->release();
    return;
  }
  if (factor == 1) {
    *dst = src;
    return;
  }
  const int rows = (src.rows + factor - 1) / factor, cols = (src.cols + factor - 1) / factor;
  if (dst->data == src.data) dst->release();  // never write into the source
  dst->create(rows, cols, CV_32FC3);
  for (int v = 0; v < rows; ++v) {
    const cv::Vec3f* in = src.ptr<cv::Vec3f>(v * factor);
    cv::Vec3f* out = dst->ptr<cv::Vec3f>(v);
    for (int u = 0; u < cols; ++u)
      out[u] = in[u * factor];
  }
}

void raisedObstaclePoints(const ObstacleDetectionResult& result, const cv::Mat& range_image,
                          const Eigen::Isometry3f& T_fixed_camera,
                          std::vector<Eigen::Vector3f>* points,
                          std::vector<std::uint32_t>* labels) {
  points->clear();
  if (labels != nullptr) labels->clear();
  if (result.mask.empty() || range_image.type() != CV_32FC3 ||
      range_image.size() != result.mask.size()) {
    return;
  }
  const bool with_labels = !result.labels.empty() && result.labels.size() == result.mask.size();
  for (int r = 0; r < result.mask.rows; ++r) {
    const std::uint8_t* m = result.mask.ptr<std::uint8_t>(r);
    const cv::Vec3f* p = range_image.ptr<cv::Vec3f>(r);
    const std::int32_t* l = with_labels ? result.labels.ptr<std::int32_t>(r) : nullptr;
    for (int c = 0; c < result.mask.cols; ++c) {
      if (m[c] != ObstacleDetectionResult::kRaised) continue;
      points->push_back(T_fixed_camera * Eigen::Vector3f(p[c][0], p[c][1], p[c][2]));
      if (labels != nullptr) {
        labels->push_back(static_cast<std::uint32_t>(l != nullptr ? std::max(0, l[c]) : 0));
      }
    }
  }
}

ObstacleDetector::ObstacleDetector(const ObstacleDetectionConfig& config) : config_(config) {
  const std::string err = config_.validate();
  if (!err.empty()) throw std::invalid_argument("ObstacleDetectionConfig: " + err);
  ht_ = static_cast<float>(config_.height_threshold);
  hmax_ = static_cast<float>(config_.max_height);
  ht2_ = ht_ * ht_;
  hmax2_ = hmax_ * hmax_;
  const double tan_t = std::tan(config_.slope_threshold_deg / kRadToDeg);
  tan2_ = static_cast<float>(tan_t * tan_t);
}

bool ObstacleDetector::compatible(const Eigen::Vector3f& a, const Eigen::Vector3f& b) const {
  // Definition 1 (003, Sec. 2): H_T < |dz| < H_max and |dz| / |b - a| > sin(theta_T), written
  // without roots as dz^2 > tan^2(theta_T) (dx^2 + dy^2). NaN fails every comparison.
  const float dx = b.x() - a.x(), dy = b.y() - a.y(), dz = b.z() - a.z();
  const float dz2 = dz * dz;
  return dz2 > ht2_ && dz2 < hmax2_ && dz2 > tan2_ * (dx * dx + dy * dy);
}

bool ObstacleDetector::detect(const cv::Mat& range_image, double focal_length,
                              const Eigen::Isometry3f& T_fixed_camera,
                              ObstacleDetectionResult* result, double baseline) {
  return run(range_image, focal_length, T_fixed_camera, false, baseline, result);
}

bool ObstacleDetector::detectColumnwise(const cv::Mat& range_image, double focal_length,
                                        const Eigen::Isometry3f& T_fixed_camera,
                                        ObstacleDetectionResult* result, double baseline) {
  return run(range_image, focal_length, T_fixed_camera, true, baseline, result);
}

bool ObstacleDetector::run(const cv::Mat& range_image, double focal_length,
                           const Eigen::Isometry3f& T_fixed_camera, bool columnwise,
                           double baseline, ObstacleDetectionResult* result) {
  if (result == nullptr) return false;
  result->obstacles.clear();
  result->num_accepted = 0;
  result->valid_points = result->pairs_tested = result->compatible_pairs = 0;
  result->error.clear();

  auto fail = [&](const char* why) {
    result->mask.release();
    result->labels.release();
    result->error = why;
    return false;
  };
  if (range_image.empty()) return fail("empty range image");
  if (range_image.type() != CV_32FC3) return fail("range image must be CV_32FC3");
  if (!std::isfinite(focal_length) || focal_length <= 0.0) {
    return fail("focal length must be finite and > 0");
  }
  const Eigen::Matrix3f R = T_fixed_camera.linear();
  if (!R.allFinite() || !T_fixed_camera.translation().allFinite() ||
      !(R.transpose() * R).isApprox(Eigen::Matrix3f::Identity(), 1e-3f) || R.determinant() < 0.0f) {
    return fail("T_fixed_camera must be a finite rigid transform");
  }
  if (!std::isfinite(baseline) || baseline < 0.0) return fail("baseline must be finite and >= 0");
  // The noise margin's scale k sigma_d / (f b) (001 Sec. 4.1), 0 when off or b is unknown.
  noise_scale_ = config_.noise_sigmas > 0.0 && baseline > 0.0
                     ? static_cast<float>(config_.noise_sigmas * config_.disparity_sigma /
                                          (focal_length * baseline))
                     : 0.0f;

  result->valid_points = prepare(range_image, T_fixed_camera);
  std::fill(marks_.begin(), marks_.end(), std::uint8_t{0});
  parent_.clear();
  parent_.push_back(0);  // label 0 = none
  pairs_tested_ = compatible_pairs_ = 0;

  const float f = static_cast<float>(focal_length);
  if (columnwise) {
    if (config_.exhaustive_search) {
      searchAllPairs<true>(f);
    } else {
      searchFirstPartner<true>(f);
    }
    if (config_.segment) blobLabels();
  } else if (config_.exhaustive_search) {
    searchAllPairs<false>(f);
  } else {
    searchFirstPartner<false>(f);
    if (config_.segment) surfaceLinks();
  }
  result->pairs_tested = pairs_tested_;
  result->compatible_pairs = compatible_pairs_;
  finalize(result);
  return true;
}

std::size_t ObstacleDetector::prepare(const cv::Mat& range_image, const Eigen::Isometry3f& T) {
  rows_ = range_image.rows;
  cols_ = range_image.cols;
  const std::size_t n = static_cast<std::size_t>(rows_) * static_cast<std::size_t>(cols_);
  if (x_.size() != n) {
    x_.resize(n);
    y_.resize(n);
    z_.resize(n);
    depth_.resize(n);
    ez_.resize(n);
    eh_.resize(n);
    marks_.resize(n);
    steep_.resize(n);
    labels_.resize(n);
    // Every new label takes two unlabelled points, so n / 2 labels at most: no reallocation.
    parent_.reserve(n / 2 + 2);
    final_id_.reserve(n / 2 + 2);
  }
  tiles_r_ = (rows_ + kTile - 1) / kTile;
  tiles_c_ = (cols_ + kTile - 1) / kTile;
  Tile empty{};
  empty.xmin = empty.ymin = empty.zmin = empty.depth_min = empty.rx_min = empty.ry_min = kInf;
  empty.xmax = empty.ymax = empty.zmax = empty.depth_max = empty.rx_max = empty.ry_max = -kInf;
  empty.count = 0;
  // The margin's bounds start at +inf only when there are errors to take the minimum of.
  empty.ez_min = empty.eh_min = noise_scale_ > 0.0f ? kInf : 0.0f;
  tiles_.assign(static_cast<std::size_t>(tiles_r_) * tiles_c_, empty);

  const Eigen::Matrix3f R = T.linear();
  const Eigen::Vector3f t = T.translation();
  // Fixed-frame z axis (up) seen from the camera: row 2 of R.
  up_camera_ = R.row(2).transpose();
  const float r00 = R(0, 0), r01 = R(0, 1), r02 = R(0, 2);
  const float r10 = R(1, 0), r11 = R(1, 1), r12 = R(1, 2);
  const float r20 = R(2, 0), r21 = R(2, 1), r22 = R(2, 2);
  const float t0 = t.x(), t1 = t.y(), t2 = t.z();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  constexpr float kMax = std::numeric_limits<float>::max();

  std::size_t valid = 0;
  for (int r = 0; r < rows_; ++r) {
    const cv::Vec3f* in = range_image.ptr<cv::Vec3f>(r);
    const std::size_t base = static_cast<std::size_t>(r) * cols_;
    float* xo = &x_[base];
    float* yo = &y_[base];
    float* zo = &z_[base];
    float* dep = &depth_[base];
    Tile* tile_row = &tiles_[static_cast<std::size_t>(r / kTile) * tiles_c_];
    // One tile-wide segment at a time, its bounds kept in locals and merged once.
    for (int c0 = 0; c0 < cols_; c0 += kTile) {
      const int c1 = std::min(cols_, c0 + kTile);
      float bx0 = kInf, bx1 = -kInf, by0 = kInf, by1 = -kInf, bz0 = kInf, bz1 = -kInf;
      float d0 = kInf, d1 = -kInf, rx0 = kInf, rx1 = -kInf, ry0 = kInf, ry1 = -kInf;
      float ez0 = kInf, eh0 = kInf;
      int count = 0;
      for (int c = c0; c < c1; ++c) {
        const float X = in[c][0], Y = in[c][1], Z = in[c][2];
        const float fx = r00 * X + r01 * Y + r02 * Z + t0;
        const float fy = r10 * X + r11 * Y + r12 * Z + t1;
        const float fz = r20 * X + r21 * Y + r22 * Z + t2;
        // z in (0, max] and every coordinate finite (NaN fails the comparisons).
        if (!(Z > 0.0f && Z <= kMax && std::fabs(fx) <= kMax && std::fabs(fy) <= kMax &&
              std::fabs(fz) <= kMax && std::fabs(X) <= kMax && std::fabs(Y) <= kMax)) {
          xo[c] = yo[c] = zo[c] = dep[c] = nan;
          continue;
        }
        xo[c] = fx;
        yo[c] = fy;
        zo[c] = fz;
        dep[c] = Z;
        ++count;
        if (noise_scale_ > 0.0f) {
          // k sigma along the ray: |P| sigma_Z / Z = |P| Z sigma_d / (f b) (001 Sec. 4.1), split
          // into its part along the fixed frame's z (the ray's rise, fz - t2) and across it.
          const float e = Z * noise_scale_;
          const float up = fz - t2;
          const float across2 = std::max(0.0f, X * X + Y * Y + Z * Z - up * up);
          ez_[base + c] = std::fabs(up) * e;
          eh_[base + c] = std::sqrt(across2) * e;
          ez0 = std::min(ez0, ez_[base + c]);
          eh0 = std::min(eh0, eh_[base + c]);
        }
        const float inv_z = 1.0f / Z;
        const float rx = X * inv_z, ry = Y * inv_z;
        bx0 = std::min(bx0, fx);
        bx1 = std::max(bx1, fx);
        by0 = std::min(by0, fy);
        by1 = std::max(by1, fy);
        bz0 = std::min(bz0, fz);
        bz1 = std::max(bz1, fz);
        d0 = std::min(d0, Z);
        d1 = std::max(d1, Z);
        rx0 = std::min(rx0, rx);
        rx1 = std::max(rx1, rx);
        ry0 = std::min(ry0, ry);
        ry1 = std::max(ry1, ry);
      }
      if (count == 0) continue;
      valid += static_cast<std::size_t>(count);
      Tile& tl = tile_row[c0 / kTile];
      tl.xmin = std::min(tl.xmin, bx0);
      tl.xmax = std::max(tl.xmax, bx1);
      tl.ymin = std::min(tl.ymin, by0);
      tl.ymax = std::max(tl.ymax, by1);
      tl.zmin = std::min(tl.zmin, bz0);
      tl.zmax = std::max(tl.zmax, bz1);
      tl.depth_min = std::min(tl.depth_min, d0);
      tl.depth_max = std::max(tl.depth_max, d1);
      tl.rx_min = std::min(tl.rx_min, rx0);
      tl.rx_max = std::max(tl.rx_max, rx1);
      tl.ry_min = std::min(tl.ry_min, ry0);
      tl.ry_max = std::max(tl.ry_max, ry1);
      if (noise_scale_ > 0.0f) {
        tl.ez_min = std::min(tl.ez_min, ez0);
        tl.eh_min = std::min(tl.eh_min, eh0);
      }
      tl.count += count;
    }
  }
  blocks_r_ = (tiles_r_ + kBlock - 1) / kBlock;
  blocks_c_ = (tiles_c_ + kBlock - 1) / kBlock;
  blocks_.assign(static_cast<std::size_t>(blocks_r_) * blocks_c_, empty);
  for (int tr = 0; tr < tiles_r_; ++tr) {
    for (int tc = 0; tc < tiles_c_; ++tc) {
      const Tile& t = tiles_[static_cast<std::size_t>(tr) * tiles_c_ + tc];
      if (t.count == 0) continue;
      Tile& b = blocks_[static_cast<std::size_t>(tr / kBlock) * blocks_c_ + tc / kBlock];
      b.xmin = std::min(b.xmin, t.xmin);
      b.xmax = std::max(b.xmax, t.xmax);
      b.ymin = std::min(b.ymin, t.ymin);
      b.ymax = std::max(b.ymax, t.ymax);
      b.zmin = std::min(b.zmin, t.zmin);
      b.zmax = std::max(b.zmax, t.zmax);
      b.count += t.count;
    }
  }
  return valid;
}

int ObstacleDetector::newLabel() {
  const int l = static_cast<int>(parent_.size());
  parent_.push_back(l);
  return l;
}

int ObstacleDetector::findRoot(int l) {
  while (parent_[l] != l) {
    parent_[l] = parent_[parent_[l]];  // path halving
    l = parent_[l];
  }
  return l;
}

void ObstacleDetector::unite(int a, int b) {
  a = findRoot(a);
  b = findRoot(b);
  if (a == b) return;
  // The older label stays the root, so final ids follow the order obstacles were first seen.
  if (a < b) {
    parent_[b] = a;
  } else {
    parent_[a] = b;
  }
}

void ObstacleDetector::linkPair(int ip, int iq, float dz, float h2, bool label) {
  ++compatible_pairs_;
  const float tan2 = h2 > 0.0f ? dz * dz / h2 : kVerticalTan2;
  // OD Algorithm 2: both ends of a compatible pair are obstacle points (003 Sec. 2).
  const int upper = dz > 0.0f ? iq : ip;
  const int ends[2] = {ip, iq};
  for (int i : ends) {
    const std::uint8_t raised = i == upper ? kMarkRaised : 0;
    if (marks_[i] == 0) {
      marks_[i] = kMarkObstacle | raised;
      steep_[i] = tan2;
      labels_[i] = 0;
    } else {
      marks_[i] |= raised;
      steep_[i] = std::max(steep_[i], tan2);
    }
  }
  if (!label) return;
  // OS Algorithm 2 (003 Sec. 3): a new node of the label graph when neither end is labelled,
  // the existing label when one is, an edge of the label graph (a union) on a conflict.
  int& lp = labels_[ip];
  int& lq = labels_[iq];
  if (lp == 0 && lq == 0) {
    lp = lq = newLabel();
  } else if (lp == 0) {
    lp = lq;
  } else if (lq == 0) {
    lq = lp;
  } else if (lp != lq) {
    unite(lp, lq);
  }
}

void ObstacleDetector::computeWindows(float f, bool column_only) {
  const float h_max = hmax_;
  const float r_max = hmax_ / std::sqrt(tan2_);
  const Eigen::Vector3f& up = up_camera_;
  f_ = f;
  // Largest decrease of the camera depth inside the double cone: the window bound below divides
  // by the smallest depth a compatible point can have.
  depth_margin_ = coneExtent(0.0f, 0.0f, 1.0f, up, h_max, r_max);
  // Search window (003 Sec. 2, Fig. 4, widened as Sec. 4.1 asks): a point q = p + d of the
  // double cone lands at image offset f (d_xy - r_xy d_z) / (Z + d_z) from p, with r = P / Z the
  // ray of p. Its numerator is linear in d, so its largest value over the cone is coneExtent();
  // dividing by the smallest Z + d_z bounds the cone's projection for any camera tilt. Both
  // extents are convex in r, so a tile's extreme rays bound all its pixels. The cone is
  // symmetric, so the bound holds upwards and downwards alike.
  for (Tile& tl : tiles_) {
    if (tl.count == 0) continue;
    tl.m_up = std::max(coneExtent(0.0f, -1.0f, tl.ry_min, up, h_max, r_max),
                       coneExtent(0.0f, -1.0f, tl.ry_max, up, h_max, r_max));
    tl.m_side = column_only ? 0.0f
                            : std::max(coneExtent(1.0f, 0.0f, -tl.rx_min, up, h_max, r_max),
                                       coneExtent(1.0f, 0.0f, -tl.rx_max, up, h_max, r_max));
  }
}

int ObstacleDetector::windowPx(float m, float depth, int clip) const {
  // Window half-size in pixels for extent m at camera depth `depth` (+1 against rounding),
  // clipped to the image, which also covers points so close that the cone reaches the camera.
  const float den = depth - depth_margin_;
  if (!(den > 0.0f)) return clip;
  const float px = f_ * m / den + 1.0f;
  return px >= static_cast<float>(clip) ? clip : static_cast<int>(px);
}

int ObstacleDetector::strideFor(float depth, int reach_rows, int reach_cols) const {
  // sample_spacing metres at `depth`, widened until the double window of (2 reach_rows + 1) x
  // (2 reach_cols + 1) pixels holds at most max_candidates_per_pixel samples.
  int s = 1;
  const float spacing_f = static_cast<float>(config_.sample_spacing) * f_;
  if (spacing_f > 0.0f) s = std::max(1, static_cast<int>(spacing_f / depth));
  const int budget = config_.max_candidates_per_pixel;
  if (budget <= 0) return s;
  auto count = [&](int st) {
    return static_cast<long long>(2 * (reach_rows / st) + 1) * (2 * (reach_cols / st) + 1);
  };
  if (count(s) > budget) {
    s = std::max(s, static_cast<int>(std::sqrt(static_cast<double>(2 * reach_rows + 1) *
                                               (2 * reach_cols + 1) / budget)));
    while (count(s) > budget)
      ++s;
  }
  return s;
}

template <bool kColumnOnly>
void ObstacleDetector::searchAllPairs(float f) {
  computeWindows(f, kColumnOnly);
  const float h_max = hmax_;
  const bool label = config_.segment && !kColumnOnly;
  const float ht = ht_, ht2 = ht2_, hmax2 = hmax2_, tan2 = tan2_;
  // OD Algorithm 2: pixels from bottom to top, left to right; each tests only the part of its
  // window at or above its own row (the upper triangle U_p), so every pair is tested once.
  for (int tr = tiles_r_ - 1; tr >= 0; --tr) {
    const int r0 = tr * kTile, r1 = std::min(rows_, r0 + kTile) - 1;
    for (int tc = 0; tc < tiles_c_; ++tc) {
      const Tile& B = tiles_[static_cast<std::size_t>(tr) * tiles_c_ + tc];
      if (B.count == 0) continue;
      const int c0 = tc * kTile, c1 = std::min(cols_, c0 + kTile) - 1;
      const int up_b = windowPx(B.m_up, B.depth_min, rows_);
      const int side_b = kColumnOnly ? 0 : windowPx(B.m_side, B.depth_min, cols_);

      // Tiles that can hold a compatible partner of some point of B: their boxes must allow
      // H_T < |dz| < H_max with a horizontal gap below |dz| / tan(theta_T).
      candidates_.clear();
      const int tr_lo = std::max(0, floorDiv(r0 - up_b, kTile));
      const int tc_lo = std::max(0, floorDiv(c0 - side_b, kTile));
      const int tc_hi = std::min(tiles_c_ - 1, (c1 + side_b) / kTile);
      for (int ur = tr_lo; ur <= tr; ++ur) {
        for (int uc = tc_lo; uc <= tc_hi; ++uc) {
          const int ci = ur * tiles_c_ + uc;
          const Tile& C = tiles_[ci];
          if (C.count == 0) continue;
          const float dz_hi = std::max(C.zmax - B.zmin, B.zmax - C.zmin);
          if (dz_hi <= ht) continue;
          const float dz_lo = std::max(C.zmin - B.zmax, B.zmin - C.zmax);
          if (dz_lo >= h_max) continue;
          const float gx = std::max(0.0f, std::max(C.xmin - B.xmax, B.xmin - C.xmax));
          const float gy = std::max(0.0f, std::max(C.ymin - B.ymax, B.ymin - C.ymax));
          const float reach = std::min(dz_hi, h_max);
          if (tan2 * (gx * gx + gy * gy) >= reach * reach) continue;
          candidates_.push_back(ci);
        }
      }
      if (candidates_.empty()) continue;

      for (int r = r1; r >= r0; --r) {
        for (int c = c0; c <= c1; ++c) {
          const int ip = r * cols_ + c;
          const float zp = z_[ip];
          if (zp != zp) continue;  // missing
          // No rise under H_max clears p's own error (findPartner): p has no partner.
          if (noise_scale_ > 0.0f && !(ht + ez_[ip] * kMarginBound < h_max)) continue;
          const float xp = x_[ip], yp = y_[ip], depth = depth_[ip];
          const int up_p = windowPx(B.m_up, depth, rows_);
          const int side_p = kColumnOnly ? 0 : windowPx(B.m_side, depth, cols_);
          // The paper's U_p in full, every pixel (no sampling).
          const int row_top = r - up_p, col_lo_p = c - side_p, col_hi_p = c + side_p;

          for (int ci : candidates_) {
            const Tile& C = tiles_[ci];
            // The same box test between the point and the tile.
            const float dz_hi = std::max(C.zmax - zp, zp - C.zmin);
            if (dz_hi <= ht) continue;
            const float dz_lo = std::max(C.zmin - zp, zp - C.zmax);
            if (dz_lo >= h_max) continue;
            const float gx = std::max(0.0f, std::max(C.xmin - xp, xp - C.xmax));
            const float gy = std::max(0.0f, std::max(C.ymin - yp, yp - C.ymax));
            const float reach = std::min(dz_hi, h_max);
            if (tan2 * (gx * gx + gy * gy) >= reach * reach) continue;

            const int ctr = ci / tiles_c_, ctc = ci - ctr * tiles_c_;
            const int cr0 = ctr * kTile, cr1 = std::min(rows_, cr0 + kTile) - 1;
            const int cc0 = ctc * kTile, cc1 = std::min(cols_, cc0 + kTile) - 1;
            const int row_lo = std::max(cr0, row_top), row_hi = std::min(cr1, r);
            if (row_lo > row_hi) continue;
            const int col_lo = kColumnOnly ? c : std::max(cc0, col_lo_p);
            const int col_hi = kColumnOnly ? c : std::min(cc1, col_hi_p);
            if (col_lo > col_hi) continue;
            for (int rr = row_hi; rr >= row_lo; --rr) {
              // On p's own row only the pixels to its right (the rest were tested from there).
              const int cs = rr == r ? std::max(col_lo, c + 1) : col_lo;
              if (cs > col_hi) continue;
              pairs_tested_ += static_cast<std::size_t>(col_hi - cs + 1);
              for (int iq = rr * cols_ + cs; iq <= rr * cols_ + col_hi; ++iq) {
                const float dz = z_[iq] - zp;
                const float dz2 = dz * dz;
                if (!(dz2 > ht2 && dz2 < hmax2)) continue;  // also skips missing points
                const float dx = x_[iq] - xp, dy = y_[iq] - yp;
                const float h2 = dx * dx + dy * dy;
                if (dz2 > tan2 * h2 && clearOfNoise(ip, iq, dz, h2)) {
                  linkPair(ip, iq, dz, h2, label);
                }
              }
            }
          }
        }
      }
    }
  }
}

template <bool kBelow, bool kColumnOnly>
bool ObstacleDetector::findPartner(const std::vector<Candidate>& tiles, int* hint, int ip, int s) {
  const float xp = x_[ip], yp = y_[ip], zp = z_[ip];
  const int col_p = ip % cols_;
  // The noise margin (clearOfNoise) of any pair with p moves p's own error at least: its rise
  // loses at least p's vertical error, its run gains at least p's horizontal one. Pruning with
  // these bounds drops no pair the margin would keep (kMarginBound keeps the bound below the
  // float value clearOfNoise computes), and p beyond the range where the margin leaves no rise
  // under H_max has no partner at all: the far floor is not searched.
  const bool margin = noise_scale_ > 0.0f;
  const float ez_p = margin ? ez_[ip] : 0.0f, eh_p = margin ? eh_[ip] : 0.0f;
  const float ht = ht_ + ez_p * kMarginBound, h_max = hmax_, tan2 = tan2_;
  if (!(ht < h_max)) return false;
  const int n = static_cast<int>(tiles.size());
  const int row_step = s * cols_;
  // Can C (a tile or a header's union of tiles) hold a point H_T..H_max below (above) p, steep
  // enough from p?
  // With the margin, a pair with some point of C loses at least the error of p and of C's
  // smallest: sqrt(ez_p^2 + ez_min^2) of its rise, sqrt(eh_p^2 + eh_min^2) added to its run.
  auto feasible = [&](const Candidate& C) {
    const float sz = margin ? kMarginBound * std::sqrt(ez_p * ez_p + C.ez_min * C.ez_min) : 0.0f;
    float reach;
    if (kBelow) {
      const float drop = zp - C.zmin;
      if (drop <= ht_ + sz || zp - C.zmax >= h_max) return false;
      reach = std::min(drop, h_max) - sz;
    } else {
      const float rise = C.zmax - zp;
      if (rise <= ht_ + sz || C.zmin - zp >= h_max) return false;
      reach = std::min(rise, h_max) - sz;
    }
    const float gx = std::max(0.0f, std::max(C.xmin - xp, xp - C.xmax));
    const float gy = std::max(0.0f, std::max(C.ymin - yp, yp - C.ymax));
    if (margin) {
      const float run = std::sqrt(gx * gx + gy * gy) +
                        kMarginBound * std::sqrt(eh_p * eh_p + C.eh_min * C.eh_min);
      return tan2 * run * run < reach * reach;
    }
    return tan2 * (gx * gx + gy * gy) < reach * reach;
  };
  // The sampled pixels of a tile (a lattice of step s, fixed for the whole group).
  auto scan = [&](const Candidate& C) {
    // Column-wise: only p's own column (the 1D profile), in the tiles of that column.
    if (kColumnOnly && (col_p < C.c0 || col_p > C.c1)) return false;
    std::size_t tested = 0;
    const int col_first = kColumnOnly ? col_p : C.c0, col_last = kColumnOnly ? col_p : C.c1;
    for (int row = C.r0; row <= C.r1; row += row_step) {
      for (int iq = row + col_first; iq <= row + col_last; iq += s) {
        if (iq == ip) continue;
        ++tested;
        const float dz = z_[iq] - zp;
        if (kBelow ? !(dz < -ht && dz > -h_max) : !(dz > ht && dz < h_max)) continue;
        const float dx = x_[iq] - xp, dy = y_[iq] - yp;
        const float h2 = dx * dx + dy * dy;
        if (dz * dz > tan2 * h2 && clearOfNoise(ip, iq, dz, h2)) {
          pairs_tested_ += tested;
          linkPair(ip, iq, dz, h2, config_.segment && !kColumnOnly);
          return true;
        }
      }
    }
    pairs_tested_ += tested;
    return false;
  };
  // Neighbouring points usually find their partner in the same tile: that one is tried first.
  const int first = *hint;
  if (first < n && tiles[first].skip == 0 && feasible(tiles[first]) && scan(tiles[first])) {
    return true;
  }
  for (int m = 0; m < n; ++m) {
    const Candidate& C = tiles[m];
    if (!feasible(C)) {
      m += C.skip;
      continue;
    }
    if (C.skip > 0 || m == first) continue;
    if (scan(C)) {
      *hint = m;
      return true;
    }
  }
  return false;
}

ObstacleDetector::Tile ObstacleDetector::groupBounds(int tr, int tc) const {
  Tile g = tiles_[static_cast<std::size_t>(tr) * tiles_c_ + tc];
  g.m_up = g.count > 0 ? g.m_up : 0.0f;
  g.m_side = g.count > 0 ? g.m_side : 0.0f;
  for (int vr = tr; vr < std::min(tiles_r_, tr + kGroup); ++vr) {
    for (int vc = tc; vc < std::min(tiles_c_, tc + kGroup); ++vc) {
      const Tile& t = tiles_[static_cast<std::size_t>(vr) * tiles_c_ + vc];
      if (t.count == 0 || (vr == tr && vc == tc)) continue;
      g.xmin = std::min(g.xmin, t.xmin);
      g.xmax = std::max(g.xmax, t.xmax);
      g.ymin = std::min(g.ymin, t.ymin);
      g.ymax = std::max(g.ymax, t.ymax);
      g.zmin = std::min(g.zmin, t.zmin);
      g.zmax = std::max(g.zmax, t.zmax);
      g.depth_min = std::min(g.depth_min, t.depth_min);
      g.depth_max = std::max(g.depth_max, t.depth_max);
      g.m_up = std::max(g.m_up, t.m_up);
      g.m_side = std::max(g.m_side, t.m_side);
      g.count += t.count;
    }
  }
  return g;
}

template <bool kColumnOnly>
void ObstacleDetector::searchFirstPartner(float f) {
  computeWindows(f, kColumnOnly);
  const float ht = ht_, h_max = hmax_, tan2 = tan2_;
  // Pixels from bottom to top, left to right as OD Algorithm 2 scans, but each searches both
  // triangles of its double window (OD Algorithm 1, 003 Sec. 2) and stops at the first partner:
  // for an obstacle point that costs about 1 / alpha tests instead of all K of its window.
  // Points are processed in groups of kGroup x kGroup tiles that share one candidate list.
  const int groups_r = (tiles_r_ + kGroup - 1) / kGroup,
            groups_c = (tiles_c_ + kGroup - 1) / kGroup;
  for (int gr = groups_r - 1; gr >= 0; --gr) {
    const int tr = gr * kGroup, r0 = tr * kTile;
    const int r1 = std::min(rows_, r0 + kGroup * kTile) - 1;
    for (int gc = 0; gc < groups_c; ++gc) {
      const int tc = gc * kGroup, c0 = tc * kTile;
      const int c1 = std::min(cols_, c0 + kGroup * kTile) - 1;
      Tile B = groupBounds(tr, tc);
      if (B.count == 0) continue;
      const int reach_b = windowPx(B.m_up, B.depth_min, rows_);
      const int side_b = kColumnOnly ? 0 : windowPx(B.m_side, B.depth_min, cols_);

      // One window and one sampling lattice for the group: its nearest point's window covers
      // all its points, its farthest point's stride samples densely enough for all of them.
      const int s = strideFor(B.depth_max, reach_b, side_b);
      // Tiles that can hold a partner below (above) some point of B, nearest first (rings of
      // growing Chebyshev distance, block by block) so that the search usually stops early.
      below_tiles_.clear();
      above_tiles_.clear();
      const int tr_lo = std::max(0, floorDiv(r0 - reach_b, kTile));
      const int tr_hi = std::min(tiles_r_ - 1, (r1 + reach_b) / kTile);
      const int tc_lo = std::max(0, floorDiv(c0 - side_b, kTile));
      const int tc_hi = std::min(tiles_c_ - 1, (c1 + side_b) / kTile);
      // Same box test for a block or a tile C: can it hold a partner below / above B?
      auto classify = [&](const Tile& C, bool* below, bool* above) {
        *below = *above = false;
        if (C.count == 0) return;
        if (std::max(C.zmin - B.zmax, B.zmin - C.zmax) >= h_max) return;
        const float gx = std::max(0.0f, std::max(C.xmin - B.xmax, B.xmin - C.xmax));
        const float gy = std::max(0.0f, std::max(C.ymin - B.ymax, B.ymin - C.ymax));
        const float gap2 = tan2 * (gx * gx + gy * gy);
        const float drop = std::min(B.zmax - C.zmin, h_max);
        const float rise = std::min(C.zmax - B.zmin, h_max);
        *below = drop > ht && gap2 < drop * drop;
        *above = rise > ht && gap2 < rise * rise;
      };
      const int br = tr / kBlock, bc = tc / kBlock;
      const int br_lo = tr_lo / kBlock, br_hi = tr_hi / kBlock;
      const int bc_lo = tc_lo / kBlock, bc_hi = tc_hi / kBlock;
      // Each block that passes is followed by its tiles that pass, behind a header entry whose
      // bounds are their union, so that a point far from all of them skips them at once.
      auto open_header = [this](std::vector<Candidate>& list) {
        const float e0 = noise_scale_ > 0.0f ? kInf : 0.0f;
        list.push_back(Candidate{kInf, -kInf, kInf, -kInf, kInf, -kInf, 0, 0, 0, 0, 0, e0, e0});
        return list.size() - 1;
      };
      auto close_header = [](std::vector<Candidate>& list, std::size_t h) {
        Candidate& hd = list[h];
        hd.skip = static_cast<int>(list.size() - h - 1);
        if (hd.skip == 0) {
          list.pop_back();
          return;
        }
        for (std::size_t k = h + 1; k < list.size(); ++k) {
          hd.xmin = std::min(hd.xmin, list[k].xmin);
          hd.xmax = std::max(hd.xmax, list[k].xmax);
          hd.ymin = std::min(hd.ymin, list[k].ymin);
          hd.ymax = std::max(hd.ymax, list[k].ymax);
          hd.zmin = std::min(hd.zmin, list[k].zmin);
          hd.zmax = std::max(hd.zmax, list[k].zmax);
          hd.ez_min = std::min(hd.ez_min, list[k].ez_min);
          hd.eh_min = std::min(hd.eh_min, list[k].eh_min);
        }
      };
      auto consider_block = [&](int ur, int uc) {
        bool below, above;
        classify(blocks_[static_cast<std::size_t>(ur) * blocks_c_ + uc], &below, &above);
        if (!below && !above) return;
        const std::size_t hb = open_header(below_tiles_), ha = open_header(above_tiles_);
        for (int vr = std::max(tr_lo, ur * kBlock); vr <= std::min(tr_hi, ur * kBlock + kBlock - 1);
             ++vr) {
          for (int vc = std::max(tc_lo, uc * kBlock);
               vc <= std::min(tc_hi, uc * kBlock + kBlock - 1); ++vc) {
            const Tile& C = tiles_[vr * tiles_c_ + vc];
            bool tb, ta;
            classify(C, &tb, &ta);
            if (!tb && !ta) continue;
            // C's pixels on the lattice of step s: first and last sampled rows (as row * cols),
            // first sampled column and last column.
            const int row_a = roundUpTo(vr * kTile, s);
            const int row_b = std::min(rows_, vr * kTile + kTile) - 1;
            const int col_a = kColumnOnly ? vc * kTile : roundUpTo(vc * kTile, s);
            const int col_b = std::min(cols_, vc * kTile + kTile) - 1;
            if (row_a > row_b || col_a > col_b) continue;
            const int row_last = row_b - (row_b - row_a) % s;
            const Candidate cand{C.xmin, C.xmax,   C.ymin,        C.ymax,           C.zmin,
                                 C.zmax, 0,        row_a * cols_, row_last * cols_, col_a,
                                 col_b,  C.ez_min, C.eh_min};
            if (tb) below_tiles_.push_back(cand);
            if (ta) above_tiles_.push_back(cand);
          }
        }
        close_header(below_tiles_, hb);
        close_header(above_tiles_, ha);
      };
      const int max_d =
          std::max(std::max(br - br_lo, br_hi - br), std::max(bc - bc_lo, bc_hi - bc));
      for (int d = 0; d <= max_d; ++d) {
        for (int ur = std::max(br_lo, br - d); ur <= std::min(br_hi, br + d); ++ur) {
          if (ur == br - d || ur == br + d) {
            for (int uc = std::max(bc_lo, bc - d); uc <= std::min(bc_hi, bc + d); ++uc) {
              consider_block(ur, uc);
            }
          } else {
            if (bc - d >= bc_lo) consider_block(ur, bc - d);
            if (bc + d <= bc_hi) consider_block(ur, bc + d);
          }
        }
      }
      if (below_tiles_.empty() && above_tiles_.empty()) continue;

      int below_hint = 0, above_hint = 0;
      const bool feet = config_.search_foot_points;
      for (int r = r1; r >= r0; --r) {
        for (int c = c0; c <= c1; ++c) {
          const int ip = r * cols_ + c;
          const float depth = depth_[ip];
          if (depth != depth) continue;  // missing
          // A partner below makes p a raised obstacle point; only without one does p need a
          // partner above to be an obstacle point at all (the foot of an obstacle), and not
          // even then if another point's search has already found p as its lower end.
          if (!findPartner<true, kColumnOnly>(below_tiles_, &below_hint, ip, s) && feet &&
              marks_[ip] == 0) {
            findPartner<false, kColumnOnly>(above_tiles_, &above_hint, ip, s);
          }
        }
      }
    }
  }
}

void ObstacleDetector::surfaceLinks() {
  // The early-exit search links each point to one or two partners only; raised points that are
  // image neighbours and touch in 3D lie on one continuous surface, so they share a label. A gap
  // in depth (003 Fig. 6: objects touching in the image only) breaks the link.
  const float d0 = static_cast<float>(config_.surface_link_distance);
  if (!(d0 > 0.0f)) return;
  const float d02 = d0 * d0;
  const float per_depth = static_cast<float>(config_.surface_link_pixels) / f_;
  // Never farther than a foot point can reach (H_max / tan(theta_T)): points farther apart are
  // not joined by the exhaustive search either, unless through a chain of pairs.
  const float cap = hmax_ / std::sqrt(tan2_);
  const float cap2 = cap * cap;
  auto close = [&](int i, int j) {
    const float dx = x_[i] - x_[j], dy = y_[i] - y_[j], dz = z_[i] - z_[j];
    const float d = per_depth * std::max(depth_[i], depth_[j]);
    return dx * dx + dy * dy + dz * dz < std::min(cap2, std::max(d02, d * d));
  };
  for (int r = 0; r < rows_; ++r) {
    for (int c = 0; c < cols_; ++c) {
      const int i = r * cols_ + c;
      if (!(marks_[i] & kMarkRaised)) continue;
      if (c > 0 && (marks_[i - 1] & kMarkRaised) && labels_[i - 1] != labels_[i] &&
          close(i, i - 1)) {
        unite(labels_[i], labels_[i - 1]);
      }
      const int u = i - cols_;
      if (r > 0 && (marks_[u] & kMarkRaised) && labels_[u] != labels_[i] && close(i, u)) {
        unite(labels_[i], labels_[u]);
      }
    }
  }
}

void ObstacleDetector::blobLabels() {
  // 2D blob colouring of the mask, 8-connected, as the column-wise detector of [Bellutta00]
  // does (003 Sec. 3 and 6): touching obstacles get one label whatever their 3D separation.
  for (int r = 0; r < rows_; ++r) {
    for (int c = 0; c < cols_; ++c) {
      const int i = r * cols_ + c;
      if (marks_[i] == 0) continue;
      int l = 0;
      auto join = [&](int rr, int cc) {
        if (rr < 0 || cc < 0 || cc >= cols_) return;
        const int j = rr * cols_ + cc;
        if (marks_[j] == 0) return;
        if (l == 0) {
          l = labels_[j];
        } else if (labels_[j] != l) {
          unite(l, labels_[j]);
        }
      };
      join(r, c - 1);
      join(r - 1, c - 1);
      join(r - 1, c);
      join(r - 1, c + 1);
      labels_[i] = l != 0 ? l : newLabel();
    }
  }
}

void ObstacleDetector::finalize(ObstacleDetectionResult* result) {
  result->mask.create(rows_, cols_, CV_8UC1);
  result->labels.create(rows_, cols_, CV_32SC1);

  if (!config_.segment) {
    result->labels.setTo(0);
    for (int r = 0; r < rows_; ++r) {
      std::uint8_t* m = result->mask.ptr<std::uint8_t>(r);
      const std::uint8_t* mk = &marks_[static_cast<std::size_t>(r) * cols_];
      for (int c = 0; c < cols_; ++c) {
        m[c] = mk[c] == 0              ? ObstacleDetectionResult::kNone
               : (mk[c] & kMarkRaised) ? ObstacleDetectionResult::kRaised
                                       : ObstacleDetectionResult::kFoot;
      }
    }
    return;
  }

  // Connected components of the label graph (003 Sec. 3): one id per root, in creation order.
  const int num_labels = static_cast<int>(parent_.size());
  final_id_.assign(static_cast<std::size_t>(num_labels), 0);
  int num_obstacles = 0;
  for (int l = 1; l < num_labels; ++l) {
    if (findRoot(l) == l) final_id_[l] = ++num_obstacles;
  }
  for (int l = 1; l < num_labels; ++l)
    final_id_[l] = final_id_[findRoot(l)];

  Accumulator zero{};
  zero.min[0] = zero.min[1] = zero.min[2] = kInf;
  zero.max[0] = zero.max[1] = zero.max[2] = -kInf;
  zero.raised_min[0] = zero.raised_min[1] = kInf;
  zero.raised_max[0] = zero.raised_max[1] = -kInf;
  acc_.assign(static_cast<std::size_t>(num_obstacles), zero);

  // Sec. 5 measures, gathered in one pass over the points, which also writes labels and mask
  // (as if every obstacle were accepted; rejected ones are cleared below).
  for (int r = 0; r < rows_; ++r) {
    std::int32_t* lab = result->labels.ptr<std::int32_t>(r);
    std::uint8_t* msk = result->mask.ptr<std::uint8_t>(r);
    const std::size_t base = static_cast<std::size_t>(r) * cols_;
    for (int c = 0; c < cols_; ++c) {
      const std::size_t i = base + c;
      const std::uint8_t mk = marks_[i];
      if (mk == 0) {
        lab[c] = 0;
        msk[c] = ObstacleDetectionResult::kNone;
        continue;
      }
      msk[c] =
          (mk & kMarkRaised) ? ObstacleDetectionResult::kRaised : ObstacleDetectionResult::kFoot;
      const int id = final_id_[labels_[i]];
      lab[c] = id;
      Accumulator& a = acc_[id - 1];
      const float p[3] = {x_[i], y_[i], z_[i]};
      ++a.count;
      for (int k = 0; k < 3; ++k) {
        a.min[k] = std::min(a.min[k], p[k]);
        a.max[k] = std::max(a.max[k], p[k]);
        a.sum[k] += p[k];
      }
      a.slope_sum += slopeFromTan2(steep_[i]);
      a.max_tan2 = std::max(a.max_tan2, steep_[i]);
      if (marks_[i] & kMarkRaised) {
        ++a.raised;
        for (int k = 0; k < 2; ++k) {
          a.raised_min[k] = std::min(a.raised_min[k], p[k]);
          a.raised_max[k] = std::max(a.raised_max[k], p[k]);
        }
        a.raised_sum_z += p[2];
      }
    }
  }

  const ObstacleDetectionConfig& cfg = config_;
  result->obstacles.resize(static_cast<std::size_t>(num_obstacles));
  for (int k = 0; k < num_obstacles; ++k) {
    const Accumulator& a = acc_[k];
    ObstacleInfo& o = result->obstacles[k];
    o = ObstacleInfo();
    o.label = k + 1;
    o.pixel_count = a.count;
    o.raised_count = a.raised;
    o.bbox_min = Eigen::Vector3f(a.min[0], a.min[1], a.min[2]);
    o.bbox_max = Eigen::Vector3f(a.max[0], a.max[1], a.max[2]);
    o.centroid = Eigen::Vector3f(static_cast<float>(a.sum[0] / a.count),
                                 static_cast<float>(a.sum[1] / a.count),
                                 static_cast<float>(a.sum[2] / a.count));
    // Height above the surrounding ground (003 Sec. 5): the component holds the lower ends of
    // its pairs, i.e. the ground at its foot, so its lowest point is that ground.
    o.ground_height = a.min[2];
    o.max_height = a.max[2] - a.min[2];
    o.avg_height =
        a.raised > 0 ? static_cast<float>(a.raised_sum_z / a.raised) - o.ground_height : 0.0f;
    o.avg_slope_deg = static_cast<float>(a.slope_sum / a.count * kRadToDeg);
    o.max_slope_deg = static_cast<float>(std::atan(std::sqrt(a.max_tan2)) * kRadToDeg);  // exact
    const Eigen::Vector3f ext = o.bbox_max - o.bbox_min;
    o.bbox_perimeter = 4.0f * (ext.x() + ext.y() + ext.z());
    const float side = a.raised > 0 ? std::max(a.raised_max[0] - a.raised_min[0],
                                               a.raised_max[1] - a.raised_min[1])
                                    : 0.0f;
    o.volume = side * side * o.max_height;

    // Rule-based rejection (003 Sec. 5): any measure below its threshold rejects.
    ObstacleRejection why = ObstacleRejection::kNone;
    if (cfg.reject_false_obstacles) {
      if (o.bbox_perimeter < cfg.min_bbox_perimeter) {
        why = ObstacleRejection::kSmallPerimeter;
      } else if (o.avg_slope_deg < cfg.min_avg_slope_deg) {
        why = ObstacleRejection::kLowAverageSlope;
      } else if (o.max_slope_deg < cfg.min_max_slope_deg) {
        why = ObstacleRejection::kLowMaxSlope;
      } else if (o.avg_height < cfg.min_avg_height) {
        why = ObstacleRejection::kLowAverageHeight;
      } else if (o.max_height < cfg.min_max_height) {
        why = ObstacleRejection::kLowMaxHeight;
      } else if (o.volume < cfg.min_volume) {
        why = ObstacleRejection::kSmallVolume;
      }
    }
    o.rejection = why;
    o.rejected = why != ObstacleRejection::kNone;
    if (!o.rejected) ++result->num_accepted;
  }

  if (result->num_accepted == num_obstacles) return;
  for (int r = 0; r < rows_; ++r) {
    std::uint8_t* m = result->mask.ptr<std::uint8_t>(r);
    const std::int32_t* lab = result->labels.ptr<std::int32_t>(r);
    for (int c = 0; c < cols_; ++c) {
      if (lab[c] != 0 && result->obstacles[lab[c] - 1].rejected)
        m[c] = ObstacleDetectionResult::kNone;
    }
  }
}

}  // namespace stereo_safety_map
