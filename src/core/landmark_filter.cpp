#include "stereo_safety_map/core/landmark_filter.h"

#include "stereo_safety_map/core/safety_mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

bool positiveFinite(double v) {
  return std::isfinite(v) && v > 0.0;
}

template <typename T>
std::string rangeMessage(const char* name, T value, const char* range) {
  std::ostringstream s;
  s << name << " = " << value << " is out of range " << range;
  return s.str();
}

// R^T C R for a symmetric C, written out: a third of the work of two general 3x3 products, and
// this runs once per landmark in view per frame.
Eigen::Matrix3d rotateCovariance(const Eigen::Matrix3d& Rt, const Eigen::Matrix3f& c) {
  const double c00 = c(0, 0), c01 = c(0, 1), c02 = c(0, 2);
  const double c11 = c(1, 1), c12 = c(1, 2), c22 = c(2, 2);
  Eigen::Matrix3d m;  // rows of Rt times C
  for (int i = 0; i < 3; ++i) {
    const double a = Rt(i, 0), b = Rt(i, 1), d = Rt(i, 2);
    m(i, 0) = a * c00 + b * c01 + d * c02;
    m(i, 1) = a * c01 + b * c11 + d * c12;
    m(i, 2) = a * c02 + b * c12 + d * c22;
  }
  Eigen::Matrix3d out;
  for (int i = 0; i < 3; ++i) {
    for (int j = i; j < 3; ++j) {
      out(i, j) = out(j, i) = m(i, 0) * Rt(j, 0) + m(i, 1) * Rt(j, 1) + m(i, 2) * Rt(j, 2);
    }
  }
  return out;
}

// floor() for the window bounds, which lie within a few hundred pixels of the image: without
// SSE4.1 std::floor is a library call, and this runs for every row of every window.
inline int floorToInt(double x) {
  const int i = static_cast<int>(x);
  return i - (x < i ? 1 : 0);
}

// CPU time of the calling thread [ms] (POSIX).
double threadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

const LandmarkFilterConfig& checked(const LandmarkFilterConfig& config) {
  const std::string why = config.validate();
  if (!why.empty()) throw std::invalid_argument("LandmarkFilterConfig: " + why);
  return config;
}

}  // namespace

std::string LandmarkFilterConfig::validate() const {
  std::string why = error_model.validate();
  if (!why.empty()) return why;
  if (!positiveFinite(gate_chi2)) return rangeMessage("gate_chi2", gate_chi2, "(0, inf)");
  if (!positiveFinite(euclidean_gate)) {
    return rangeMessage("euclidean_gate", euclidean_gate, "(0, inf) m");
  }
  if (min_matches < 1 || min_matches > 65535) {
    return rangeMessage("min_matches", min_matches, "[1, 65535]");
  }
  if (!positiveFinite(time_window)) return rangeMessage("time_window", time_window, "(0, inf) s");
  if (!positiveFinite(stale_time) && stale_time != std::numeric_limits<double>::infinity()) {
    return rangeMessage("stale_time", stale_time, "(0, inf] s");
  }
  if (max_landmarks < 1 || max_landmarks > (1 << 30)) {
    return rangeMessage("max_landmarks", max_landmarks, "[1, 2^30]");
  }
  if (!std::isfinite(max_search_radius_px) || max_search_radius_px < 1.0 ||
      max_search_radius_px > 256.0) {
    return rangeMessage("max_search_radius_px", max_search_radius_px, "[1, 256] px");
  }
  if (!positiveFinite(max_depth)) return rangeMessage("max_depth", max_depth, "(0, inf) m");
  if (!positiveFinite(min_depth) || min_depth >= max_depth) {
    return rangeMessage("min_depth", min_depth, "(0, max_depth) m");
  }
  if (!(max_landmark_distance >= max_depth)) {
    return rangeMessage("max_landmark_distance", max_landmark_distance, "[max_depth, inf] m");
  }
  if (descriptor_dim < 0 || descriptor_dim > kMaxDescriptorDim) {
    return rangeMessage("descriptor_dim", descriptor_dim, "[0, 4]");
  }
  if (!positiveFinite(descriptor_sigma)) {
    return rangeMessage("descriptor_sigma", descriptor_sigma, "(0, inf)");
  }
  return {};
}

LandmarkFilter::LandmarkFilter(const StereoCameraModel& camera, const LandmarkFilterConfig& config)
    : config_(checked(config)), error_model_(camera, config.error_model), camera_(camera) {
  if (camera.width <= 0 || camera.height <= 0) {
    throw std::invalid_argument("LandmarkFilter: camera width and height must be > 0");
  }
  inv_desc_var_ = 1.0 / (config_.descriptor_sigma * config_.descriptor_sigma);
  gate_ =
      config_.use_mahalanobis ? config_.gate_chi2 : config_.euclidean_gate * config_.euclidean_gate;
  inv_fx_ = 1.0 / camera.fx;
  inv_fy_ = 1.0 / camera.fy;
  inv_fb_ = 1.0 / (camera.fx * camera.baseline);
  const StereoErrorModelConfig& em = config_.error_model;
  sr2_ = em.sigma_row * em.sigma_row;
  sc2_ = em.sigma_col * em.sigma_col;
  sd2_ = em.sigma_disparity * em.sigma_disparity;
}

void LandmarkFilter::clear() {
  landmarks_.clear();
  free_slots_.clear();
  num_permanent_ = 0;
  num_temporary_ = 0;
  has_stamp_ = false;
}

void LandmarkFilter::removeLandmark(std::int32_t slot) {
  Landmark& l = landmarks_[slot];
  if (l.status == LandmarkStatus::kPermanent) --num_permanent_;
  if (l.status == LandmarkStatus::kTemporary) --num_temporary_;
  l.status = LandmarkStatus::kFree;
  free_slots_.push_back(slot);
}

const LandmarkFilterStats& LandmarkFilter::update(const std::vector<Eigen::Vector3f>& points,
                                                  const Eigen::Isometry3f& T_fixed_camera,
                                                  double stamp,
                                                  std::vector<std::uint8_t>* keep_mask,
                                                  const std::vector<float>* descriptors) {
  stats_ = LandmarkFilterStats();
  const std::size_t n = points.size();
  stats_.points_in = n;
  associations_.assign(n, -1);
  if (keep_mask) keep_mask->assign(n, 0);

  if (!std::isfinite(stamp) || !T_fixed_camera.matrix().allFinite()) {
    stats_.rejected = true;
    stats_.permanent = num_permanent_;
    stats_.temporary = num_temporary_;
    return stats_;
  }
  if (has_stamp_ && stamp < last_stamp_) {
    clear();
    stats_.reset = true;
  }
  has_stamp_ = true;
  last_stamp_ = stamp;
  stamp_ = stamp;

  const std::size_t dim = static_cast<std::size_t>(config_.descriptor_dim);
  bool use_descriptors = false;
  if (descriptors) {
    use_descriptors = dim > 0 && descriptors->size() == n * dim;
    stats_.descriptors_ignored = !use_descriptors;
  }

  const Eigen::Isometry3d T = T_fixed_camera.cast<double>();
  bucketPoints(points);
  associate(T, use_descriptors, descriptors);
  updateMatched(T, use_descriptors, descriptors);
  createLandmarks(T, stamp, use_descriptors, descriptors);

  // A point is confirmed when a landmark that is permanent after this update explains it.
  for (std::size_t s = 0; s < num_sorted_; ++s) {
    const std::int32_t idx = sorted_index_[s];
    if (owner_[s] >= 0) {
      associations_[idx] = owner_[s];
      ++stats_.points_matched;
    }
    if (nearest_[s] >= 0) ++stats_.points_in_gate;
    const bool keep = near_permanent_[s] || (nearest_[s] >= 0 && landmarks_[nearest_[s]].status ==
                                                                     LandmarkStatus::kPermanent);
    if (keep) {
      ++stats_.points_kept;
      if (keep_mask) (*keep_mask)[idx] = 1;
    }
  }
  stats_.permanent = num_permanent_;
  stats_.temporary = num_temporary_;
  return stats_;
}

void LandmarkFilter::bucketPoints(const std::vector<Eigen::Vector3f>& points) {
  const std::size_t n = points.size();
  const std::size_t num_buckets = static_cast<std::size_t>(camera_.width) * camera_.height;
  bucket_start_.assign(num_buckets + 1, 0);
  point_bucket_.resize(n);
  const float fx = static_cast<float>(camera_.fx), fy = static_cast<float>(camera_.fy);
  const float cx = static_cast<float>(camera_.cx), cy = static_cast<float>(camera_.cy);
  const float w = static_cast<float>(camera_.width), h = static_cast<float>(camera_.height);
  const float zmin = static_cast<float>(config_.min_depth);
  const float zmax = static_cast<float>(config_.max_depth);
  std::size_t valid = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f& p = points[i];
    point_bucket_[i] = -1;
    // Written so that NaN fails every comparison.
    if (!(p.z() >= zmin && p.z() <= zmax) || !std::isfinite(p.x()) || !std::isfinite(p.y())) {
      continue;
    }
    const float iz = 1.0f / p.z();
    const float col = fx * p.x() * iz + cx;
    const float row = fy * p.y() * iz + cy;
    if (!(col >= 0.f && col < w && row >= 0.f && row < h)) continue;
    const std::int32_t b = static_cast<std::int32_t>(row) * camera_.width + static_cast<int>(col);
    point_bucket_[i] = b;
    ++bucket_start_[b + 1];
    ++valid;
  }
  stats_.points_invalid = n - valid;
  for (std::size_t b = 0; b < num_buckets; ++b) {
    bucket_start_[b + 1] += bucket_start_[b];
  }

  // Counting sort into pixel order; bucket_start_[b] serves as bucket b's write cursor and is
  // restored afterwards.
  num_sorted_ = valid;
  // Padded so that the scan may load a whole packet past the last point.
  for (std::vector<float>* v : {&sorted_x_, &sorted_y_, &sorted_z_}) {
    v->resize(valid + kLanes);
    std::fill(v->begin() + valid, v->end(), 1.0f);
  }
  sorted_index_.resize(valid);
  for (std::size_t i = 0; i < n; ++i) {
    const std::int32_t b = point_bucket_[i];
    if (b < 0) continue;
    const Eigen::Vector3f& p = points[i];
    const std::int32_t s = bucket_start_[b]++;
    sorted_x_[s] = p.x();
    sorted_y_[s] = p.y();
    sorted_z_[s] = p.z();
    sorted_index_[s] = static_cast<std::int32_t>(i);
  }
  for (std::size_t b = num_buckets; b > 0; --b) {
    bucket_start_[b] = bucket_start_[b - 1];
  }
  bucket_start_[0] = 0;

  owner_.assign(valid, -1);
  owner_cost_.assign(valid, kInf);
  owner_det_.resize(valid);
  nearest_.assign(valid, -1);
  nearest_d2_.assign(valid, kInf);
  near_permanent_.assign(valid, 0);
  covered_.assign(valid, 0);
}

template <typename Fn>
void LandmarkFilter::scanGate(const Eigen::Vector3d& pc, const Eigen::Matrix3d& L, Fn&& fn) {
  const double fx = camera_.fx, fy = camera_.fy;
  const int width = camera_.width, height = camera_.height;
  const double max_r = config_.max_search_radius_px;
  const double iz = 1.0 / pc.z();
  const double u = pc.x() * iz, v = pc.y() * iz;
  const double col = fx * u + camera_.cx, row = fy * v + camera_.cy;
  if (col < -max_r || col > width + max_r || row < -max_r || row > height + max_r) return;
  // 2x2 covariance of the image-plane difference (point - landmark): the point's own pixel noise
  // plus the landmark's covariance pushed through the projection Jacobian
  // J_c = f_x / z (1, 0, -u), J_r = f_y / z (0, 1, -v). Its chi-square ellipse is the first-order
  // image of the 3D gate; the scan covers it row by row.
  const bool mahalanobis = config_.use_mahalanobis;
  double pcc, prr, pcr, g;
  if (mahalanobis) {
    const double a = fx * iz, b = fy * iz;
    pcc = sc2_ + std::max(0.0, a * a * (L(0, 0) - 2.0 * u * L(0, 2) + u * u * L(2, 2)));
    prr = sr2_ + std::max(0.0, b * b * (L(1, 1) - 2.0 * v * L(1, 2) + v * v * L(2, 2)));
    pcr = a * b * (L(0, 1) - v * L(0, 2) - u * L(1, 2) + u * v * L(2, 2));
    const double limit = 0.999 * std::sqrt(pcc * prr);
    pcr = std::min(limit, std::max(-limit, pcr));
    g = gate_;
  } else {
    // Image of a sphere of radius euclidean_gate at this depth, as a circle.
    const double eg = config_.euclidean_gate;
    const double w = fx * eg / std::max(pc.z() - eg, 0.05);
    pcc = prr = w * w;
    pcr = 0.0;
    g = 1.0;
  }
  const double wr = std::min(std::sqrt(g * prr), max_r);
  const int r0 = std::max(0, floorToInt(row - wr));
  const int r1 = std::min(height - 1, floorToInt(row + wr));
  const double slope = pcr / prr;
  const double conditional = pcc - pcr * slope;  // variance of the column given the row

  // Locals, not members: fn stores bytes, which may alias anything, and members would be
  // reloaded after every store.
  const std::int32_t* const bucket_start = bucket_start_.data();
  const float* const px = sorted_x_.data();
  const float* const py = sorted_y_.data();
  const float* const pz = sorted_z_.data();
  std::size_t tested = 0;
  // The buckets of pixel row r under the ellipse, as a range of the sorted points.
  const auto rowRange = [&](int r, std::int32_t* begin, std::int32_t* end) {
    // Points of pixel row r have sub-pixel rows in [r, r + 1).
    const double dlo = r - row, dhi = r + 1 - row;
    const double dmin2 = (dlo <= 0.0 && dhi >= 0.0) ? 0.0 : std::min(dlo * dlo, dhi * dhi);
    const double rest = g - dmin2 / prr;
    if (rest < 0.0) return false;
    const double hw = std::sqrt(conditional * rest);
    const double c_lo = std::max(col - max_r, col + std::min(slope * dlo, slope * dhi) - hw);
    const double c_hi = std::min(col + max_r, col + std::max(slope * dlo, slope * dhi) + hw);
    const int k0 = std::max(0, floorToInt(c_lo));
    const int k1 = std::min(width - 1, floorToInt(c_hi));
    if (k0 > k1) return false;
    // Buckets k0..k1 of one pixel row are contiguous in the sorted points.
    *begin = bucket_start[static_cast<std::size_t>(r) * width + k0];
    *end = bucket_start[static_cast<std::size_t>(r) * width + k1 + 1];
    tested += static_cast<std::size_t>(*end - *begin);
    return true;
  };
  const double pcx = pc.x(), pcy = pc.y(), pcz = pc.z();
  const double gate = gate_;

  if (!mahalanobis) {
    for (int r = r0; r <= r1; ++r) {
      std::int32_t begin, end;
      if (!rowRange(r, &begin, &end)) continue;
      for (std::int32_t s = begin; s < end; ++s) {
        const double e0 = px[s] - pcx, e1 = py[s] - pcy, e2 = pz[s] - pcz;
        const double d2 = e0 * e0 + e1 * e1 + e2 * e2;
        if (d2 <= gate) fn(s, d2, 1.0);
      }
    }
    stats_.candidates_tested += tested;
    return;
  }

  // Eq. (9): e^T (Sigma_p + Sigma_l)^-1 e, with Sigma_p of each candidate in its closed form
  // (Eq. (1)): Sigma_p = z^2 diag(ax, ay, 0) + kd z^2 p p^T; S = Sigma_p + Sigma_l is inverted
  // through its adjugate (it is symmetric positive definite). Evaluated on packets of kLanes
  // candidates without branches (Eigen maps them to SSE / NEON), in float: the cofactors lose at
  // worst ~1e-4 relative accuracy to the ray-aligned elongation, far below what the gate resolves.
  using Packet = Eigen::Array<float, kLanes, 1>;
  const auto broadcast = [](double value) { return Packet::Constant(static_cast<float>(value)); };
  const Packet l00 = broadcast(L(0, 0)), l01 = broadcast(L(0, 1)), l02 = broadcast(L(0, 2));
  const Packet l11 = broadcast(L(1, 1)), l12 = broadcast(L(1, 2)), l22 = broadcast(L(2, 2));
  const Packet ax = broadcast(sc2_ * inv_fx_ * inv_fx_), ay = broadcast(sr2_ * inv_fy_ * inv_fy_);
  const Packet kd = broadcast(sd2_ * inv_fb_ * inv_fb_);
  const Packet mx = broadcast(pcx), my = broadcast(pcy), mz = broadcast(pcz);
  const Packet gate_p = broadcast(gate);
  for (int r = r0; r <= r1; ++r) {
    std::int32_t begin, end;
    if (!rowRange(r, &begin, &end)) continue;
    for (std::int32_t s = begin; s < end; s += kLanes) {
      const Packet x = Packet::Map(px + s), y = Packet::Map(py + s), z = Packet::Map(pz + s);
      const Packet e0 = x - mx, e1 = y - my, e2 = z - mz;
      const Packet z2 = z * z;
      const Packet k = kd * z2;
      const Packet s00 = l00 + ax * z2 + k * x * x;
      const Packet s11 = l11 + ay * z2 + k * y * y;
      const Packet s22 = l22 + k * z2;
      const Packet s01 = l01 + k * x * y;
      const Packet s02 = l02 + k * x * z;
      const Packet s12 = l12 + k * y * z;
      const Packet c00 = s11 * s22 - s12 * s12;
      const Packet c01 = s02 * s12 - s01 * s22;
      const Packet c02 = s01 * s12 - s02 * s11;
      const Packet c11 = s00 * s22 - s02 * s02;
      const Packet c12 = s01 * s02 - s00 * s12;
      const Packet c22 = s00 * s11 - s01 * s01;
      const Packet det = s00 * c00 + s01 * c01 + s02 * c02;
      const Packet q = c00 * e0 * e0 + c11 * e1 * e1 + c22 * e2 * e2 +
                       2.0f * (c01 * e0 * e1 + c02 * e0 * e2 + c12 * e1 * e2);
      const auto inside = (det > 0.0f) && (q <= gate_p * det);
      if (!inside.any()) continue;
      const int lanes = std::min<std::int32_t>(kLanes, end - s);
      for (int i = 0; i < lanes; ++i) {
        if (inside[i]) fn(s + i, q[i] / det[i], det[i]);
      }
    }
  }
  stats_.candidates_tested += tested;
}

void LandmarkFilter::associate(const Eigen::Isometry3d& T, bool use_descriptors,
                               const std::vector<float>* descriptors) {
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Matrix3d Rt = R.transpose();
  const Eigen::Vector3d t = T.translation();
  const double max_dist2 = config_.max_landmark_distance * config_.max_landmark_distance;
  const double min_z = 0.5 * config_.min_depth;
  const std::size_t dim = static_cast<std::size_t>(config_.descriptor_dim);
  const bool mahalanobis = config_.use_mahalanobis;
  const double fx = camera_.fx, fy = camera_.fy, cx = camera_.cx, cy = camera_.cy;
  const double width = camera_.width, height = camera_.height;
  const double margin = config_.max_search_radius_px;

  // Pass 1: retire landmarks, and list those in view by image row so that pass 2 walks the
  // row-major point buckets nearly in order (far fewer cache misses than slot order).
  visit_row_start_.assign(static_cast<std::size_t>(camera_.height) + 1, 0);
  visit_unsorted_.clear();
  visit_row_.clear();
  const std::int32_t num_slots = static_cast<std::int32_t>(landmarks_.size());
  for (std::int32_t slot = 0; slot < num_slots; ++slot) {
    Landmark& l = landmarks_[slot];
    if (l.status == LandmarkStatus::kFree) continue;
    // Removing False Positives (001 Sec. 4.2): the window has closed without enough matches.
    if (l.status == LandmarkStatus::kTemporary && stamp_ - l.first_stamp > config_.time_window) {
      removeLandmark(slot);
      ++stats_.landmarks_expired;
      continue;
    }
    const Eigen::Vector3d rel = l.mean.cast<double>() - t;
    if (rel.squaredNorm() > max_dist2) {
      removeLandmark(slot);
      ++stats_.landmarks_dropped_far;
      continue;
    }
    const Eigen::Vector3d pc = Rt * rel;
    if (pc.z() < min_z) continue;  // behind or at the camera: not observable
    const double col = fx * pc.x() / pc.z() + cx, row = fy * pc.y() / pc.z() + cy;
    if (!(col > -margin && col < width + margin && row > -margin && row < height + margin)) {
      continue;
    }
    // Not in 001: a permanent landmark in plain view that no point has matched for stale_time
    // is gone (an object that moved away, or a surface that other landmarks now explain).
    if (l.status == LandmarkStatus::kPermanent &&
        stamp_ - l.last_match_stamp > config_.stale_time && col >= 0.0 && col < width &&
        row >= 0.0 && row < height && pc.z() >= config_.min_depth && pc.z() <= config_.max_depth) {
      removeLandmark(slot);
      ++stats_.landmarks_stale;
      continue;
    }
    const int r = std::min(std::max(static_cast<int>(row), 0), camera_.height - 1);
    // Everything pass 2 needs, computed here while the landmarks are read in memory order; pass
    // 2 then reads these records in image-row order, sequentially.
    VisitRecord v;
    v.pc = pc;
    v.L = rotateCovariance(Rt, l.covariance);
    v.slot = slot;
    v.permanent = l.status == LandmarkStatus::kPermanent ? 1 : 0;
    visit_unsorted_.push_back(v);
    visit_row_.push_back(r);
    ++visit_row_start_[r + 1];
  }
  stats_.landmarks_in_view = visit_unsorted_.size();
  for (int r = 0; r < camera_.height; ++r) {
    visit_row_start_[r + 1] += visit_row_start_[r];
  }
  visit_sorted_.resize(visit_unsorted_.size());
  for (std::size_t i = 0; i < visit_unsorted_.size(); ++i) {
    visit_sorted_[visit_row_start_[visit_row_[i]]++] = visit_unsorted_[i];
  }

  // Pass 2: association, Eq. (9)-(12). Raw pointers, see scanGate().
  float* const nearest_d2 = nearest_d2_.data();
  std::int32_t* const nearest = nearest_.data();
  std::uint8_t* const near_permanent = near_permanent_.data();
  const double inv_desc_var = inv_desc_var_;
  for (const VisitRecord& v : visit_sorted_) {
    const std::int32_t slot = v.slot;
    const Eigen::Vector3d& pc = v.pc;
    const Eigen::Matrix3d& L = v.L;
    const std::uint8_t permanent = v.permanent;
    double best_cost = std::numeric_limits<double>::infinity();
    double best_det = 1.0;
    std::int32_t best = -1;
    scanGate(pc, L, [&](std::int32_t s, double d2, double det) {
      const float fd2 = static_cast<float>(d2);
      if (fd2 < nearest_d2[s]) {
        nearest_d2[s] = fd2;
        nearest[s] = slot;
      }
      near_permanent[s] |= permanent;
      double cost = d2;
      if (use_descriptors) {
        // Eq. (11)-(12): descriptor term with Sigma_d = descriptor_sigma^2 I.
        const float* dp = descriptors->data() + static_cast<std::size_t>(sorted_index_[s]) * dim;
        double dd = 0.0;
        for (std::size_t a = 0; a < dim; ++a) {
          const double diff = static_cast<double>(dp[a]) - landmarks_[slot].descriptor[a];
          dd += diff * diff;
        }
        cost += dd * inv_desc_var;
      }
      // Eq. (12): the landmark takes the candidate of least cost.
      if (cost < best_cost) {
        best_cost = cost;
        best_det = det;
        best = s;
      }
    });
    if (best < 0) continue;
    // Two landmarks want the same point: the one more likely to have produced it keeps it, by
    // the full Gaussian negative log-likelihood d^2 + ln det(S). Eq. (12) drops ln det(S) as it
    // compares points for one landmark; between landmarks it matters, and without it a new,
    // uncertain landmark on the same ray steals observations from an established one.
    if (owner_[best] < 0) {
      owner_[best] = slot;
      owner_cost_[best] = static_cast<float>(best_cost);
      owner_det_[best] = best_det;
    } else {
      const double log_ratio = mahalanobis ? std::log(best_det / owner_det_[best]) : 0.0;
      if (best_cost + log_ratio < owner_cost_[best]) {
        owner_[best] = slot;
        owner_cost_[best] = static_cast<float>(best_cost);
        owner_det_[best] = best_det;
      }
    }
  }
}

void LandmarkFilter::updateMatched(const Eigen::Isometry3d& T, bool use_descriptors,
                                   const std::vector<float>* descriptors) {
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Matrix3d r00 = R.col(0) * R.col(0).transpose();
  const Eigen::Matrix3d r11 = R.col(1) * R.col(1).transpose();
  const std::size_t dim = static_cast<std::size_t>(config_.descriptor_dim);
  for (std::size_t s = 0; s < num_sorted_; ++s) {
    const std::int32_t slot = owner_[s];
    if (slot < 0) continue;
    const Eigen::Vector3d pc(sorted_x_[s], sorted_y_[s], sorted_z_[s]);
    const Eigen::Vector3d rp = R * pc;
    const Eigen::Vector3d x = rp + T.translation();
    const StereoCovarianceTerms c = error_model_.termsAtDepth(pc.z());
    const Eigen::Matrix3d sigma_p =
        c.lateral_x * r00 + c.lateral_y * r11 + c.ray * (rp * rp.transpose());  // Eq. (1)
    Landmark& l = landmarks_[slot];
    const Eigen::Matrix3d sigma_l = l.covariance.cast<double>();
    // Eq. (2) in its gain form, K = Sigma_l (Sigma_l + Sigma_p)^-1, which needs no inverse of
    // the (possibly ill-conditioned) individual covariances.
    const Eigen::Matrix3d K = sigma_l * (sigma_l + sigma_p).inverse();
    const Eigen::Vector3d mu = l.mean.cast<double>();
    l.mean = (mu + K * (x - mu)).cast<float>();
    Eigen::Matrix3d updated = sigma_l - K * sigma_l;
    updated = 0.5 * (updated + updated.transpose());
    l.covariance = updated.cast<float>();
    if (l.matches < 65535) ++l.matches;
    l.last_match_stamp = stamp_;
    if (l.status == LandmarkStatus::kTemporary && l.matches >= config_.min_matches) {
      l.status = LandmarkStatus::kPermanent;
      --num_temporary_;
      ++num_permanent_;
      ++stats_.landmarks_promoted;
    }
    if (use_descriptors) {
      const float* dp = descriptors->data() + static_cast<std::size_t>(sorted_index_[s]) * dim;
      std::copy(dp, dp + dim, l.descriptor);
    }
  }
}

void LandmarkFilter::createLandmarks(const Eigen::Isometry3d& T, double stamp, bool use_descriptors,
                                     const std::vector<float>* descriptors) {
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Matrix3d r00 = R.col(0) * R.col(0).transpose();
  const Eigen::Matrix3d r11 = R.col(1) * R.col(1).transpose();
  const std::size_t dim = static_cast<std::size_t>(config_.descriptor_dim);
  const std::size_t capacity = static_cast<std::size_t>(config_.max_landmarks);
  for (std::size_t s = 0; s < num_sorted_; ++s) {
    // No Matches and New Landmarks (001 Sec. 4.2): only points in no landmark's gate, counting
    // the landmarks started earlier in this frame. Without that, dense stereo starts one landmark
    // per pixel in the first frame and keeps them all; with it, landmarks are about one gate
    // apart and every point in a gate still counts for the keep mask.
    if (nearest_[s] >= 0 || covered_[s]) continue;
    std::int32_t slot;
    if (!free_slots_.empty()) {
      slot = free_slots_.back();
      free_slots_.pop_back();
    } else if (landmarks_.size() < capacity) {
      slot = static_cast<std::int32_t>(landmarks_.size());
      landmarks_.emplace_back();
    } else {
      ++stats_.landmarks_refused;
      continue;
    }
    const Eigen::Vector3d pc(sorted_x_[s], sorted_y_[s], sorted_z_[s]);
    const Eigen::Vector3d rp = R * pc;
    const StereoCovarianceTerms c = error_model_.termsAtDepth(pc.z());
    Landmark& l = landmarks_[slot];
    l.mean = (rp + T.translation()).cast<float>();
    l.covariance =
        (c.lateral_x * r00 + c.lateral_y * r11 + c.ray * (rp * rp.transpose())).cast<float>();
    l.first_stamp = stamp;
    l.last_match_stamp = stamp;
    l.matches = 0;
    l.status = LandmarkStatus::kTemporary;
    ++num_temporary_;
    ++stats_.landmarks_created;
    if (use_descriptors) {
      const float* dp = descriptors->data() + static_cast<std::size_t>(sorted_index_[s]) * dim;
      std::copy(dp, dp + dim, l.descriptor);
    }
    Eigen::Matrix3d L = c.ray * (pc * pc.transpose());
    L(0, 0) += c.lateral_x;
    L(1, 1) += c.lateral_y;
    covered_[s] = 1;
    scanGate(pc, L, [&](std::int32_t other, double, double) { covered_[other] = 1; });
  }
}

void LandmarkFilter::permanentLandmarks(std::vector<Eigen::Vector3f>* out) const {
  out->clear();
  for (const Landmark& l : landmarks_) {
    if (l.status == LandmarkStatus::kPermanent) out->push_back(l.mean);
  }
}

void applyKeepMask(const std::vector<Eigen::Vector3f>& points,
                   const std::vector<std::uint8_t>& keep_mask, std::vector<Eigen::Vector3f>* out) {
  out->clear();
  if (keep_mask.size() != points.size()) return;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (keep_mask[i]) out->push_back(points[i]);
  }
}

LandmarkStreamConfig LandmarkStreamConfig::forMapper(const SafetyMapperConfig& mapper) const {
  LandmarkStreamConfig c = *this;
  const double min_range = mapper.grid.min_range, max_range = mapper.grid.max_range;
  c.filter.min_depth = std::max(min_range, 1e-3);
  c.filter.max_depth = max_range;
  if (!(c.filter.max_landmark_distance >= max_range)) c.filter.max_landmark_distance = max_range;
  c.skip_stationary_frames = mapper.skip_stationary_frames;
  c.stationary_translation = mapper.stationary_translation;
  c.stationary_rotation_deg = mapper.stationary_rotation_deg;
  return c;
}

std::string LandmarkStreamConfig::validate() const {
  const std::string why = filter.validate();
  if (!why.empty()) return why;
  if (!std::isfinite(stationary_translation) || stationary_translation < 0.0 ||
      stationary_translation > 100.0) {
    return rangeMessage("stationary_translation", stationary_translation, "[0, 100] m");
  }
  if (!std::isfinite(stationary_rotation_deg) || stationary_rotation_deg < 0.0 ||
      stationary_rotation_deg > 180.0) {
    return rangeMessage("stationary_rotation_deg", stationary_rotation_deg, "[0, 180] deg");
  }
  return {};
}

namespace {
const LandmarkStreamConfig& checkedStream(const LandmarkStreamConfig& config) {
  const std::string why = config.validate();
  if (!why.empty()) throw std::invalid_argument("LandmarkStreamConfig: " + why);
  return config;
}
}  // namespace

LandmarkStreamFilter::LandmarkStreamFilter(const LandmarkStreamConfig& config)
    : config_(checkedStream(config)) {}

void LandmarkStreamFilter::reset() {
  if (filter_) filter_->clear();
  stats_ = LandmarkFilterStats();
  has_last_pose_ = false;
}

void LandmarkStreamFilter::permanentLandmarks(std::vector<Eigen::Vector3f>* out) const {
  if (filter_) {
    filter_->permanentLandmarks(out);
  } else {
    out->clear();
  }
}

LandmarkStreamStatus LandmarkStreamFilter::apply(const StereoCameraModel& camera,
                                                 const Eigen::Isometry3f& T_fixed_camera,
                                                 double stamp, std::vector<Eigen::Vector3f>* points,
                                                 std::string* error) {
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = threadCpuMs();
  const auto fail = [error](const std::string& why) {
    if (error != nullptr) *error = "landmark filter: " + why;
    return LandmarkStreamStatus::kRejected;
  };
  if (!std::isfinite(stamp)) return fail("the frame has no finite stamp");
  if (!T_fixed_camera.matrix().allFinite()) return fail("the camera pose is not finite");
  // 000 Sec. IV: a camera that has not moved repeats its mismatches; they must not confirm
  // each other.
  if (config_.skip_stationary_frames && has_last_pose_) {
    const Eigen::Isometry3f delta = last_pose_.inverse() * T_fixed_camera;
    const double dt = delta.translation().norm();
    const double da = Eigen::AngleAxisf(delta.linear()).angle() * 180.0 / M_PI;
    if (dt < config_.stationary_translation && da < config_.stationary_rotation_deg) {
      return LandmarkStreamStatus::kStationary;
    }
  }
  const bool same_camera = filter_ && camera.width == camera_.width &&
                           camera.height == camera_.height && camera.fx == camera_.fx &&
                           camera.fy == camera_.fy && camera.cx == camera_.cx &&
                           camera.cy == camera_.cy && camera.cx_right == camera_.cx_right &&
                           camera.baseline == camera_.baseline;
  if (!same_camera) {
    std::string why = StereoErrorModel::checkCamera(camera);
    if (why.empty() && (camera.width <= 0 || camera.height <= 0)) {
      why = "camera width and height must be > 0";
    }
    if (!why.empty()) return fail(why);
    if (filter_) ++camera_changes_;
    filter_ = std::make_unique<LandmarkFilter>(camera, config_.filter);  // checked: no throw
    camera_ = camera;
  }
  last_pose_ = T_fixed_camera;
  has_last_pose_ = true;
  stats_ = filter_->update(*points, T_fixed_camera, stamp, &keep_);
  // In place, order kept: the voxel grid sees the confirmed points as they came.
  std::size_t out = 0;
  for (std::size_t i = 0; i < points->size(); ++i) {
    if (keep_[i]) (*points)[out++] = (*points)[i];
  }
  points->resize(out);
  last_ms_ =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  last_cpu_ms_ = threadCpuMs() - c0;
  return LandmarkStreamStatus::kFiltered;
}

}  // namespace stereo_safety_map
