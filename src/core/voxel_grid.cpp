// 3D log-odds voxel grid with per-voxel point lists (000, Sec. IV).
//
// Sensor model details the paper leaves open, as implemented here:
// - The ray is walked from the camera's voxel (which is decremented: the camera sees through
//   it) to the endpoint voxel with an exact Amanatides & Woo traversal; "fore" is the last voxel
//   before the endpoint on that walk, "aft" the first one after it. Ties at voxel edges and
//   corners step one axis at a time, so the walk is always face-connected.
// - Within a frame all decrements are applied first (each clamped at lop_min) and the
//   increments after them, so a ray that grazes a surface cannot remove evidence another ray
//   of the same frame added for it.
// - An endpoint outside the window still clears the in-window part of its ray and gives
//   incr_L to an in-window fore / aft neighbour. The one-point-per-voxel rule also holds for
//   such endpoints (small per-frame hash set).
// - Increments and decrements apply to every used point, independent of its list: a voxel
//   whose list is full still gets incr_H.
#include "stereo_safety_map/core/voxel_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

// Above this many voxels the window is surely a unit mistake (e.g. voxel_size in cm).
constexpr double kMaxVoxels = 50e6;
// Above this many point slots (voxels x point_list_capacity, 16 B each) memory would explode.
constexpr double kMaxPointSlots = 250e6;

// floor() for |s| < 2^31 without a libm call (the hot loop runs this three times per point).
inline int fastFloor(double s) {
  const int i = static_cast<int>(s);
  return i - (s < static_cast<double>(i) ? 1 : 0);
}

// Eq. (1) before the floor: s = x / l_v + 1/2. One helper for indexOf() and integrate(), so that
// both round identically (also if the compiler fuses the multiply-add).
inline double scaled(float x, double inv_voxel_size) {
  return static_cast<double>(x) * inv_voxel_size + 0.5;
}

// Eq. (1) on one axis, given s = scaled(x): u = floor(s), so voxel u spans
// [(u - 1/2) l_v, (u + 1/2) l_v) (000, Sec. IV; ties round up). NaN and huge values are clamped.
inline int toIndex(double s, int limit) {
  if (!(s > -limit)) return -limit;  // also NaN
  if (s >= limit) return limit;
  return fastFloor(s);
}

inline std::int64_t floorMod(std::int64_t a, std::int64_t n) {
  const std::int64_t r = a % n;
  return r < 0 ? r + n : r;
}

// In double, so that validate() can look at absurd sizes without overflowing an int.
inline double voxelsAlong(double size, double voxel_size) {
  return std::round(size / voxel_size);
}

template <typename T>
std::string describe(const char* name, T value, const char* range) {
  std::ostringstream os;
  os << "VoxelGridConfig." << name << " = " << value << " is invalid, must be " << range;
  return os.str();
}

}  // namespace

std::string VoxelGridConfig::validate() const {
  constexpr int kI16Max = std::numeric_limits<std::int16_t>::max();
  constexpr int kI16Min = std::numeric_limits<std::int16_t>::min();
  if (!(voxel_size > 0.0) || !std::isfinite(voxel_size))
    return describe("voxel_size", voxel_size, "finite and > 0 [m]");
  const double sizes[3] = {size_x, size_y, size_z};
  const char* names[3] = {"size_x", "size_y", "size_z"};
  for (int a = 0; a < 3; ++a) {
    if (!(sizes[a] >= voxel_size) || !std::isfinite(sizes[a]))
      return describe(names[a], sizes[a], "finite and >= voxel_size [m]");
  }
  const double voxels = voxelsAlong(size_x, voxel_size) * voxelsAlong(size_y, voxel_size) *
                        voxelsAlong(size_z, voxel_size);
  if (!(voxels <= kMaxVoxels)) {
    std::ostringstream os;
    os << "VoxelGridConfig.size_x/size_y/size_z/voxel_size give " << voxels
       << " voxels, must be <= " << kMaxVoxels;
    return os.str();
  }
  if (!(z_below_robot >= 0.0 && z_below_robot <= size_z))
    return describe("z_below_robot", z_below_robot, "in [0, size_z] [m]");
  if (incr_high < 0 || incr_high > kI16Max)
    return describe("incr_high", incr_high, "in [0, 32767]");
  if (incr_low < 0 || incr_low > kI16Max) return describe("incr_low", incr_low, "in [0, 32767]");
  if (incr_low_fore < -1 || incr_low_fore > kI16Max)
    return describe("incr_low_fore", incr_low_fore, "in [-1, 32767]");
  if (decr < 0 || decr > kI16Max) return describe("decr", decr, "in [0, 32767]");
  if (lop_min < kI16Min || lop_min >= 0) return describe("lop_min", lop_min, "in [-32768, -1]");
  if (lop_max <= 0 || lop_max > kI16Max) return describe("lop_max", lop_max, "in [1, 32767]");
  if (occ_threshold <= 0 || occ_threshold > lop_max)
    return describe("occ_threshold", occ_threshold, "in [1, lop_max]");
  if (point_list_capacity < 1 || point_list_capacity > 255)
    return describe("point_list_capacity", point_list_capacity, "in [1, 255]");
  if (voxels * point_list_capacity > kMaxPointSlots) {
    std::ostringstream os;
    os << "VoxelGridConfig.point_list_capacity = " << point_list_capacity << " with " << voxels
       << " voxels gives " << voxels * point_list_capacity
       << " point slots, must be <= " << kMaxPointSlots;
    return os.str();
  }
  if (!(min_range >= 0.0) || !std::isfinite(min_range))
    return describe("min_range", min_range, "finite and >= 0 [m]");
  if (!(max_range > min_range) || !std::isfinite(max_range))
    return describe("max_range", max_range, "finite and > min_range [m]");
  if (!(neighbour_sigmas >= 0.0 && neighbour_sigmas <= 100.0))
    return describe("neighbour_sigmas", neighbour_sigmas, "in [0, 100]");
  if (!(disparity_sigma > 0.0 && disparity_sigma <= 10.0))
    return describe("disparity_sigma", disparity_sigma, "in (0, 10] [px]");
  return {};
}

namespace {
// (1 - 1 / kHitMassWindow)^age for the hit masses' fading; 0 beyond the table (below 1e-7).
constexpr int kFadeTableSize = 1024;
const float* fadeTable() {
  static const std::vector<float> table = [] {
    std::vector<float> t(kFadeTableSize);
    const double keep = 1.0 - 1.0 / static_cast<double>(VoxelGrid::kHitMassWindow);
    for (int a = 0; a < kFadeTableSize; ++a)
      t[a] = static_cast<float>(std::pow(keep, a));
    return t;
  }();
  return table.data();
}
inline float fadeFor(std::uint32_t age) {
  return age < static_cast<std::uint32_t>(kFadeTableSize) ? fadeTable()[age] : 0.0f;
}
}  // namespace

VoxelGrid::VoxelGrid(const VoxelGridConfig& config) : config_(config) {
  const std::string err = config_.validate();
  if (!err.empty()) throw std::invalid_argument(err);
  nu_ = static_cast<int>(voxelsAlong(config_.size_x, config_.voxel_size));
  nv_ = static_cast<int>(voxelsAlong(config_.size_y, config_.voxel_size));
  nw_ = static_cast<int>(voxelsAlong(config_.size_z, config_.voxel_size));
  z_below_voxels_ = static_cast<int>(std::lround(config_.z_below_robot / config_.voxel_size));
  inv_voxel_size_ = 1.0 / config_.voxel_size;

  const std::size_t n = static_cast<std::size_t>(nu_) * nv_ * nw_;
  lop_.assign(n, 0);
  stamp_.assign(n, 0);
  point_count_.assign(n, 0);
  moments_.assign(n, VoxelMoments());
  fadeTable();  // built once, here, so that integrate() never allocates
  hit_mass_.assign(n, 0.0f);
  hit_frac_.assign(n, 0.0f);
  mass_frame_.assign(n, 0);
  frame_hits_.assign(n, 0);
  frame_frac_.assign(n, 0.0f);
  hit_voxels_.assign(n, 0);
  point_storage_.resize(n * static_cast<std::size_t>(config_.point_list_capacity));
  pending_.assign(n, 0);
  touched_.assign(n, 0);
  slot_u_.assign(nu_, 0);
  slot_v_.assign(nv_, 0);
  slot_w_.assign(nw_, 0);
  outside_seen_.assign(std::size_t{1} << kOutsideSetBits, OutsideEntry());

  // Before the first recenter() the robot is assumed at the origin.
  min_ = windowMinFor(Eigen::Vector3f::Zero());
  rebuildSlotTables();
}

VoxelIndex VoxelGrid::indexOf(const Eigen::Vector3f& p) const {
  VoxelIndex i;
  i.u = toIndex(scaled(p.x(), inv_voxel_size_), kIndexLimit);
  i.v = toIndex(scaled(p.y(), inv_voxel_size_), kIndexLimit);
  i.w = toIndex(scaled(p.z(), inv_voxel_size_), kIndexLimit);
  return i;
}

Eigen::Vector3f VoxelGrid::centerOf(const VoxelIndex& i) const {
  const double l = config_.voxel_size;
  return Eigen::Vector3f(static_cast<float>(i.u * l), static_cast<float>(i.v * l),
                         static_cast<float>(i.w * l));
}

bool VoxelGrid::contains(const VoxelIndex& i) const {
  const std::int64_t du = static_cast<std::int64_t>(i.u) - min_.u;
  const std::int64_t dv = static_cast<std::int64_t>(i.v) - min_.v;
  const std::int64_t dw = static_cast<std::int64_t>(i.w) - min_.w;
  return du >= 0 && du < nu_ && dv >= 0 && dv < nv_ && dw >= 0 && dw < nw_;
}

std::size_t VoxelGrid::linear(const VoxelIndex& i) const {
  return static_cast<std::size_t>(slot_u_[i.u - min_.u]) + slot_v_[i.v - min_.v] +
         slot_w_[i.w - min_.w];
}

void VoxelGrid::rebuildSlotTables() {
  // w innermost so that a voxel column (fixed u, v) is contiguous for the height map (000 V-A).
  const std::int64_t stride_u = static_cast<std::int64_t>(nv_) * nw_;
  for (int r = 0; r < nu_; ++r)
    slot_u_[r] = static_cast<std::uint32_t>(floorMod(std::int64_t{min_.u} + r, nu_) * stride_u);
  for (int r = 0; r < nv_; ++r)
    slot_v_[r] = static_cast<std::uint32_t>(floorMod(std::int64_t{min_.v} + r, nv_) * nw_);
  for (int r = 0; r < nw_; ++r)
    slot_w_[r] = static_cast<std::uint32_t>(floorMod(std::int64_t{min_.w} + r, nw_));
}

VoxelIndex VoxelGrid::windowMinFor(const Eigen::Vector3f& robot) const {
  const VoxelIndex r = indexOf(robot);
  // |r| <= 2^30 and n <= 5e7, so these stay far from int overflow.
  return VoxelIndex{r.u - nu_ / 2, r.v - nv_ / 2, r.w - z_below_voxels_};
}

void VoxelGrid::clearVoxel(std::size_t k) {
  lop_[k] = 0;
  point_count_[k] = 0;
  moments_[k] = VoxelMoments();
  hit_mass_[k] = 0.0f;
  hit_frac_[k] = 0.0f;
  mass_frame_[k] = 0;
  stamp_[k] = 0;
}

void VoxelGrid::clear() {
  std::fill(lop_.begin(), lop_.end(), 0);
  std::fill(point_count_.begin(), point_count_.end(), 0);
  std::fill(moments_.begin(), moments_.end(), VoxelMoments());
  std::fill(hit_mass_.begin(), hit_mass_.end(), 0.0f);
  std::fill(hit_frac_.begin(), hit_frac_.end(), 0.0f);
  std::fill(mass_frame_.begin(), mass_frame_.end(), 0);
  std::fill(stamp_.begin(), stamp_.end(), 0);
  for (OutsideEntry& e : outside_seen_)
    e.stamp = 0;
}

std::size_t VoxelGrid::recenter(const Eigen::Vector3f& robot_base_position) {
  if (!robot_base_position.allFinite()) return 0;
  const VoxelIndex nm = windowMinFor(robot_base_position);
  const std::int64_t d[3] = {std::int64_t{nm.u} - min_.u, std::int64_t{nm.v} - min_.v,
                             std::int64_t{nm.w} - min_.w};
  const std::int64_t n[3] = {nu_, nv_, nw_};
  const std::size_t total = lop_.size();

  std::size_t cleared = 0;
  if (std::abs(d[0]) >= n[0] || std::abs(d[1]) >= n[1] || std::abs(d[2]) >= n[2]) {
    clear();
    cleared = total;
  } else if (d[0] != 0 || d[1] != 0 || d[2] != 0) {
    // The voxels leaving along an axis occupy the ring-buffer slabs that the entering ones will
    // reuse, so clearing the leaving slabs is all the scrolling there is (nothing moves).
    const std::int64_t old_min[3] = {min_.u, min_.v, min_.w};
    const std::size_t su = static_cast<std::size_t>(nv_) * nw_;
    for (int axis = 0; axis < 3; ++axis) {
      const std::int64_t count = std::abs(d[axis]);
      const std::int64_t first = d[axis] > 0 ? old_min[axis] : old_min[axis] + n[axis] + d[axis];
      for (std::int64_t g = first; g < first + count; ++g) {
        const std::size_t s = static_cast<std::size_t>(floorMod(g, n[axis]));
        if (axis == 0) {
          for (std::size_t k = s * su; k < (s + 1) * su; ++k)
            clearVoxel(k);
        } else if (axis == 1) {
          for (int u = 0; u < nu_; ++u) {
            const std::size_t base = u * su + s * nw_;
            for (std::size_t k = base; k < base + nw_; ++k)
              clearVoxel(k);
          }
        } else {
          for (std::size_t col = 0; col < su * nu_; col += nw_)
            clearVoxel(col + s);
        }
      }
    }
    cleared = total - static_cast<std::size_t>((n[0] - std::abs(d[0])) * (n[1] - std::abs(d[1])) *
                                               (n[2] - std::abs(d[2])));
  }
  min_ = nm;
  rebuildSlotTables();
  return cleared;
}

std::uint32_t VoxelGrid::nextStamp() {
  if (++stamp_now_ == 0) {
    // After 2^32 frames the stamps wrap: forget them all once rather than mistake old ones.
    std::fill(stamp_.begin(), stamp_.end(), 0);
    for (OutsideEntry& e : outside_seen_)
      e.stamp = 0;
    stamp_now_ = 1;
  }
  return stamp_now_;
}

bool VoxelGrid::firstOutsideHit(std::int64_t ru, std::int64_t rv, std::int64_t rw) {
  constexpr std::int64_t kHalf = std::int64_t{1} << 20;
  // Too far away to pack: such a ray cannot reach the window unless max_range is absurd.
  if (ru < -kHalf || ru >= kHalf || rv < -kHalf || rv >= kHalf || rw < -kHalf || rw >= kHalf)
    return true;
  const std::uint64_t key = (static_cast<std::uint64_t>(ru + kHalf) << 42) |
                            (static_cast<std::uint64_t>(rv + kHalf) << 21) |
                            static_cast<std::uint64_t>(rw + kHalf);
  const std::size_t mask = outside_seen_.size() - 1;
  std::size_t h = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> (64 - kOutsideSetBits));
  for (int probe = 0; probe < kOutsideSetProbes; ++probe, h = (h + 1) & mask) {
    OutsideEntry& e = outside_seen_[h];
    if (e.stamp != stamp_now_) {
      e.key = key;
      e.stamp = stamp_now_;
      return true;
    }
    if (e.key == key) return false;
  }
  return true;  // set saturated this frame: keep the point rather than guess
}

void VoxelGrid::addIncrement(std::size_t k, int amount) {
  if (amount == 0) return;
  std::int32_t& p = pending_[k];
  if (p == 0) touched_[num_touched_++] = static_cast<std::uint32_t>(k);
  // Saturating: the final value is clamped to lop_max anyway.
  p = std::min<std::int32_t>(p + amount, 1 << 20);
}

void VoxelGrid::insertPoint(std::size_t k, const Eigen::Vector3f& p, float range) {
  // Every point joins the voxel's moments (VoxelMoments), the list or not.
  VoxelMoments& m = moments_[k];
  if (m.weight >= kMomentWindow) {
    constexpr float kFade = (kMomentWindow - 1.0f) / kMomentWindow;
    m.sx *= kFade;
    m.sy *= kFade;
    m.sz *= kFade;
    m.weight *= kFade;
  }
  m.sx += p.x();
  m.sy += p.y();
  m.sz += p.z();
  m.weight += 1.0f;
  // Lists are ordered by camera range and pruned from the far end: points seen from closer are
  // more accurate (000, Sec. IV).
  const std::size_t cap = static_cast<std::size_t>(config_.point_list_capacity);
  VoxelPoint* list = point_storage_.data() + k * cap;
  std::size_t n = point_count_[k];
  if (n == cap) {
    if (!(range < list[n - 1].range)) return;
    --n;
  }
  std::size_t pos = n;
  while (pos > 0 && list[pos - 1].range > range) {
    list[pos] = list[pos - 1];
    --pos;
  }
  list[pos].position = p;
  list[pos].range = range;
  point_count_[k] = static_cast<std::uint8_t>(n + 1);
}

// Amanatides & Woo traversal in window-local voxel coordinates (voxel r spans [r, r + 1)),
// from the camera a towards the endpoint b whose voxel is e. The segment is clipped to the
// window first, so a camera outside the grid costs nothing for the part outside. Applies the
// decrements of 000 Sec. IV immediately and queues incr_L for the fore neighbour; the endpoint
// and aft neighbour are handled by the caller.
void VoxelGrid::castRay(const double a[3], const double b[3], const int e[3], bool fore_increment,
                        IntegrationStats& stats) {
  const double n[3] = {static_cast<double>(nu_), static_cast<double>(nv_),
                       static_cast<double>(nw_)};
  const double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  int cur[3];
  if (a[0] >= 0.0 && a[0] < n[0] && a[1] >= 0.0 && a[1] < n[1] && a[2] >= 0.0 && a[2] < n[2]) {
    for (int i = 0; i < 3; ++i)
      cur[i] = static_cast<int>(a[i]);
  } else {
    double t0 = 0.0, t1 = 1.0;
    for (int i = 0; i < 3; ++i) {
      if (d[i] == 0.0) {
        if (a[i] < 0.0 || a[i] >= n[i]) return;
        continue;
      }
      double ta = (0.0 - a[i]) / d[i];
      double tb = (n[i] - a[i]) / d[i];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    }
    if (!(t0 <= t1)) return;  // the segment misses the window
    for (int i = 0; i < 3; ++i) {
      const double p = std::floor(a[i] + t0 * d[i]);
      cur[i] = static_cast<int>(std::min(std::max(p, 0.0), n[i] - 1.0));
    }
  }

  // Step counts to e per axis: the walk ends exactly in e whatever the rounding of tmax.
  constexpr double kInf = std::numeric_limits<double>::infinity();
  constexpr double kBig = 1e300;  // finite, so an axis with steps left always beats an idle one
  int step[3], rem[3];
  double tmax[3], tdelta[3];
  for (int i = 0; i < 3; ++i) {
    step[i] = e[i] > cur[i] ? 1 : (e[i] < cur[i] ? -1 : 0);
    rem[i] = step[i] * (e[i] - cur[i]);
    if (rem[i] == 0) {
      tmax[i] = kInf;
      tdelta[i] = 0.0;
    } else {
      const double boundary = cur[i] + (step[i] > 0 ? 1.0 : 0.0);
      tmax[i] = std::min(kBig, d[i] != 0.0 ? (boundary - a[i]) / d[i] : kBig);
      tdelta[i] = std::min(1e30, d[i] != 0.0 ? 1.0 / std::abs(d[i]) : 1e30);
    }
  }
  // The walk with per-axis scalars (an array indexed by the stepping axis would live in memory).
  int cu = cur[0], cv = cur[1], cw = cur[2];
  int ru = rem[0], rv = rem[1], rw = rem[2];
  double tu = tmax[0], tv = tmax[1], tw = tmax[2];
  const int nu = nu_, nv = nv_, nw = nw_;
  const std::uint32_t* const slot_u = slot_u_.data();
  const std::uint32_t* const slot_v = slot_v_.data();
  const std::uint32_t* const slot_w = slot_w_.data();
  std::size_t ku = slot_u[cu], kv = slot_v[cv], kw = slot_w[cw];
  std::int64_t total = std::int64_t{ru} + rv + rw;  // each up to 2^30 + n
  const int decr = config_.decr;
  const int lop_min = config_.lop_min;
  std::int16_t* const lop = lop_.data();
  std::size_t decremented = 0;
  while (total > 0) {
    const std::size_t k = ku + kv + kw;
    if (total == 1) {  // fore neighbour
      if (fore_increment) {
        addIncrement(k, config_.incr_low_fore < 0 ? config_.incr_low : config_.incr_low_fore);
      }
      break;
    }
    const int v = lop[k] - decr;
    lop[k] = static_cast<std::int16_t>(v < lop_min ? lop_min : v);
    ++decremented;
    --total;
    if (tu <= tv && tu <= tw) {
      cu += step[0];
      if (static_cast<unsigned>(cu) >= static_cast<unsigned>(nu)) break;  // left the window
      ku = slot_u[cu];
      tu = --ru == 0 ? kInf : tu + tdelta[0];
    } else if (tv <= tw) {
      cv += step[1];
      if (static_cast<unsigned>(cv) >= static_cast<unsigned>(nv)) break;
      kv = slot_v[cv];
      tv = --rv == 0 ? kInf : tv + tdelta[1];
    } else {
      cw += step[2];
      if (static_cast<unsigned>(cw) >= static_cast<unsigned>(nw)) break;
      kw = slot_w[cw];
      tw = --rw == 0 ? kInf : tw + tdelta[2];
    }
  }
  stats.voxels_decremented += decremented;
}

// The rare path of integrate(): a point that survived the per-voxel de-duplication (or whose
// endpoint is outside the window). Kept out of line so the per-point loop stays small.
__attribute__((noinline)) void VoxelGrid::useEndpoint(const double a[3], const Endpoint& ep,
                                                      bool carve, IntegrationStats& stats) {
  const std::int64_t* r = ep.r;
  const bool inside = ep.inside;
  const std::size_t k = ep.k;
  if (!inside) {
    if (!firstOutsideHit(r[0], r[1], r[2])) {
      ++stats.points_duplicate;
      return;
    }
    ++stats.points_outside_grid;
  }
  ++stats.points_used;
  // Endpoints of rays that can reach the window are within max_range of it, so these fit.
  if (std::abs(r[0]) >= kIndexLimit || std::abs(r[1]) >= kIndexLimit ||
      std::abs(r[2]) >= kIndexLimit)
    return;
  const int e[3] = {static_cast<int>(r[0]), static_cast<int>(r[1]), static_cast<int>(r[2])};
  const double b[3] = {ep.s[0] - min_.u, ep.s[1] - min_.v, ep.s[2] - min_.w};
  // A huge coordinate over a tiny voxel scales to inf: then there is no ray to trace nor an aft
  // neighbour to find (fuzzing found it), only the endpoint.
  const bool traceable = std::isfinite(a[0]) && std::isfinite(a[1]) && std::isfinite(a[2]) &&
                         std::isfinite(b[0]) && std::isfinite(b[1]) && std::isfinite(b[2]);
  const double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  // VoxelGridConfig::neighbour_sigmas: k sigma_Z at the point's range (001 Sec. 4.1) as a
  // fraction of the segment camera -> point (the ray parameter t runs 0 .. 1 over it).
  const bool model = neighbour_reach_ > 0.0 && traceable && ep.range > 0.0f;
  const double reach_t = model ? neighbour_reach_ * static_cast<double>(ep.range) : 0.0;
  bool fore_increment = true;
  if (model) {
    // The ray entered e at t_in = 1 - (the largest of the per-axis entry parameters below 1).
    double t_in = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < 3; ++i) {
      if (d[i] == 0.0) continue;
      t_in = std::max(t_in, ((e[i] + (d[i] > 0.0 ? 0.0 : 1.0)) - b[i]) / d[i]);
    }
    fore_increment = -t_in <= reach_t;
  }
  if (traceable && carve) castRay(a, b, e, fore_increment, stats);

  if (inside) {
    addIncrement(k, config_.incr_high);
    insertPoint(k, ep.pf, ep.range);
  }
  if (!traceable) return;
  // Aft neighbour: the voxel the ray enters when it leaves e beyond the point.
  int ax = -1;
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0.0) continue;
    const double t = ((e[i] + (d[i] > 0.0 ? 1.0 : 0.0)) - b[i]) / d[i];
    if (t < best) {
      best = t;
      ax = i;
    }
  }
  if (ax < 0) return;  // the point is at the camera: no direction, no aft neighbour
  if (model && best > reach_t) return;
  int f[3] = {e[0], e[1], e[2]};
  f[ax] += d[ax] > 0.0 ? 1 : -1;
  if (static_cast<unsigned>(f[0]) < static_cast<unsigned>(nu_) &&
      static_cast<unsigned>(f[1]) < static_cast<unsigned>(nv_) &&
      static_cast<unsigned>(f[2]) < static_cast<unsigned>(nw_)) {
    addIncrement(static_cast<std::size_t>(slot_u_[f[0]]) + slot_v_[f[1]] + slot_w_[f[2]],
                 config_.incr_low);
  }
}

IntegrationStats VoxelGrid::integrate(const std::vector<Eigen::Vector3f>& points,
                                      const Eigen::Isometry3f& T_fixed_sensor,
                                      std::size_t first_no_carve) {
  IntegrationStats stats;
  stats.points_in = points.size();
  ++frame_;
  const std::uint32_t now = nextStamp();
  num_touched_ = 0;

  const Eigen::Vector3f cam = T_fixed_sensor.translation();
  const Eigen::Matrix3f R = T_fixed_sensor.linear();
  if (!cam.allFinite() || !R.allFinite()) {
    stats.points_non_finite = points.size();
    return stats;
  }
  const double inv = inv_voxel_size_;
  const double a[3] = {cam.x() * inv + 0.5 - min_.u, cam.y() * inv + 0.5 - min_.v,
                       cam.z() * inv + 0.5 - min_.w};
  const float min_r2 = static_cast<float>(config_.min_range * config_.min_range);
  const float max_r2 = static_cast<float>(config_.max_range * config_.max_range);
  // Locals, so that the loop does not reload members after every store.
  const std::int64_t mu = min_.u, mv = min_.v, mw = min_.w;
  const std::uint64_t nu = static_cast<std::uint64_t>(nu_), nv = static_cast<std::uint64_t>(nv_),
                      nw = static_cast<std::uint64_t>(nw_);
  const std::uint32_t* const slot_u = slot_u_.data();
  const std::uint32_t* const slot_v = slot_v_.data();
  const std::uint32_t* const slot_w = slot_w_.data();
  std::uint32_t* const stamp = stamp_.data();
  std::uint16_t* const frame_hits = frame_hits_.data();
  float* const frame_frac = frame_frac_.data();
  std::uint32_t* const hit_voxels = hit_voxels_.data();
  std::size_t num_hit_voxels = 0;
  const bool track_mass = track_hit_mass_;
  std::size_t duplicates = 0;
  // |x| below this keeps |x / l_v + 1/2| well inside int (fastFloor's domain); tested on the
  // float so that NaN and inf fail it too.
  const float coord_limit = static_cast<float>(0.5 * kIndexLimit * config_.voxel_size);

  const std::size_t num_points = points.size();
  for (std::size_t pi = 0; pi < num_points; ++pi) {
    const Eigen::Vector3f& ps = points[pi];
    const float px = ps.x(), py = ps.y(), pz = ps.z();
    const float r2 = px * px + py * py + pz * pz;
    // NaN and inf fail this test too; they are told apart only on this rare path.
    if (!(r2 >= min_r2 && r2 <= max_r2)) {
      if (std::isfinite(px) && std::isfinite(py) && std::isfinite(pz))
        ++stats.points_out_of_range;
      else
        ++stats.points_non_finite;
      continue;
    }
    // T * ps, written out: the generic Eigen product was a third of the per-point cost.
    const float fx = R(0, 0) * px + R(0, 1) * py + R(0, 2) * pz + cam.x();
    const float fy = R(1, 0) * px + R(1, 1) * py + R(1, 2) * pz + cam.y();
    const float fz = R(2, 0) * px + R(2, 1) * py + R(2, 2) * pz + cam.z();
    // Same arithmetic as indexOf(), so integrate() and the accessors agree on every voxel face.
    const double sx = scaled(fx, inv), sy = scaled(fy, inv), sz = scaled(fz, inv);
    std::int64_t ru, rv, rw;
    if (std::abs(fx) < coord_limit && std::abs(fy) < coord_limit && std::abs(fz) < coord_limit) {
      ru = fastFloor(sx) - mu;
      rv = fastFloor(sy) - mv;
      rw = fastFloor(sz) - mw;
    } else if (!(std::isfinite(fx) && std::isfinite(fy) && std::isfinite(fz))) {
      ++stats.points_non_finite;  // a finite point pushed past FLT_MAX by a huge translation
      continue;
    } else {
      ru = toIndex(sx, kIndexLimit) - mu;
      rv = toIndex(sy, kIndexLimit) - mv;
      rw = toIndex(sz, kIndexLimit) - mw;
    }
    const bool inside = static_cast<std::uint64_t>(ru) < nu &&
                        static_cast<std::uint64_t>(rv) < nv && static_cast<std::uint64_t>(rw) < nw;
    std::size_t k = 0;
    // One point per voxel per frame, the first one, to weaken the correlation of neighbouring
    // stereo pixels (000, Sec. IV). Most points of a dense frame end here.
    if (inside) {
      k = static_cast<std::size_t>(slot_u[ru]) + slot_v[rv] + slot_w[rw];
      if (stamp[k] == now) {
        ++duplicates;
        // Every point counts towards hitMass(), the duplicates too.
        if (track_mass && frame_hits[k] != 0xffff) {
          ++frame_hits[k];
          frame_frac[k] += static_cast<float>(sz - std::floor(sz));
        }
        continue;
      }
      stamp[k] = now;
      if (track_mass) {
        frame_hits[k] = 1;
        frame_frac[k] = static_cast<float>(sz - std::floor(sz));
        hit_voxels[num_hit_voxels++] = static_cast<std::uint32_t>(k);
      }
    }
    // Built only here, so that nothing of the rare path is materialised for every point.
    const Endpoint ep{{sx, sy, sz}, {ru, rv, rw}, Eigen::Vector3f(fx, fy, fz), std::sqrt(r2), k,
                      inside};
    useEndpoint(a, ep, pi < first_no_carve, stats);
  }
  stats.points_duplicate += duplicates;

  // This frame's counts join hitMass(), older ones faded by the frames since.
  for (std::size_t t = 0; t < num_hit_voxels; ++t) {
    const std::size_t k = hit_voxels[t];
    const float keep = fadeFor(frame_ - mass_frame_[k]);
    hit_mass_[k] = hit_mass_[k] * keep + static_cast<float>(frame_hits[k]);
    hit_frac_[k] = hit_frac_[k] * keep + frame_frac[k];
    mass_frame_[k] = frame_;
    frame_hits[k] = 0;
    frame_frac[k] = 0.0f;
  }

  // Increments after all decrements of the frame: a ray that grazes a surface seen by another
  // ray of the same frame must not erase that evidence through the clamp at lop_max / lop_min.
  // (The paper does not specify the order; with unclamped sums it would not matter.)
  const int lop_min = config_.lop_min;
  const int lop_max = config_.lop_max;
  for (std::size_t t = 0; t < num_touched_; ++t) {
    const std::size_t k = touched_[t];
    const int v = lop_[k] + pending_[k];
    lop_[k] = static_cast<std::int16_t>(v < lop_min ? lop_min : (v > lop_max ? lop_max : v));
    pending_[k] = 0;
  }
  num_touched_ = 0;
  return stats;
}

void VoxelGrid::setStereoGeometry(double focal_times_baseline) {
  const bool known = std::isfinite(focal_times_baseline) && focal_times_baseline > 0.0;
  focal_baseline_ = known ? focal_times_baseline : 0.0;
  // k sigma_Z / Z^2 = k sigma_d / (f b) (001 Sec. 4.1).
  neighbour_reach_ = known && config_.neighbour_sigmas > 0.0
                         ? config_.neighbour_sigmas * config_.disparity_sigma / focal_times_baseline
                         : 0.0;
}

int VoxelGrid::logOdds(const VoxelIndex& i) const {
  return contains(i) ? lop_[linear(i)] : 0;
}

bool VoxelGrid::isOccupied(const VoxelIndex& i) const {
  return contains(i) && lop_[linear(i)] >= config_.occ_threshold;
}

float VoxelGrid::hitMass(const VoxelIndex& i) const {
  if (!contains(i)) return 0.0f;
  const std::size_t k = linear(i);
  const float m = hit_mass_[k];
  if (m == 0.0f) return 0.0f;
  return m * fadeFor(frame_ - mass_frame_[k]);
}

float VoxelGrid::hitMeanZ(const VoxelIndex& i) const {
  if (!contains(i)) return std::numeric_limits<float>::quiet_NaN();
  const std::size_t k = linear(i);
  if (!(hit_mass_[k] > 0.0f)) return std::numeric_limits<float>::quiet_NaN();
  // The fading scales both sums alike: their ratio needs no fading. A voxel (w) spans
  // [(w - 1/2) l_v, (w + 1/2) l_v) (Eq. (1), rounding).
  const double frac = static_cast<double>(hit_frac_[k]) / hit_mass_[k];
  return static_cast<float>((i.w - 0.5 + frac) * config_.voxel_size);
}

float VoxelGrid::massMeanZ(int u, int v, int w_from, int w_to) const {
  double mass = 0.0, sum = 0.0;
  for (int w = w_from; w <= w_to; ++w) {
    const VoxelIndex i{u, v, w};
    if (!contains(i)) continue;
    const std::size_t k = linear(i);
    const float m = hit_mass_[k];
    if (!(m > 0.0f)) continue;
    // Both sums fade alike from the voxel's last update: weigh by the faded mass.
    const double keep = fadeFor(frame_ - mass_frame_[k]);
    mass += m * keep;
    sum += ((w - 0.5) * m + hit_frac_[k]) * keep;
  }
  if (!(mass > 0.0)) return std::numeric_limits<float>::quiet_NaN();
  return static_cast<float>(sum / mass * config_.voxel_size);
}

float VoxelGrid::columnMass(int u, int v, int w_from, int w_to) const {
  double mass = 0.0;
  for (int w = w_from; w <= w_to; ++w)
    mass += hitMass(VoxelIndex{u, v, w});
  return static_cast<float>(mass);
}

VoxelPointList VoxelGrid::points(const VoxelIndex& i) const {
  VoxelPointList list;
  if (!contains(i)) return list;
  const std::size_t k = linear(i);
  list.data = point_storage_.data() + k * static_cast<std::size_t>(config_.point_list_capacity);
  list.size = point_count_[k];
  return list;
}

VoxelMoments VoxelGrid::moments(const VoxelIndex& i) const {
  return contains(i) ? moments_[linear(i)] : VoxelMoments();
}

bool VoxelGrid::columnSpan(int u, int v, int w_lo, int w_hi, const std::int16_t** column,
                           std::int64_t* lo, std::int64_t* hi) const {
  const std::int64_t ru = std::int64_t{u} - min_.u;
  const std::int64_t rv = std::int64_t{v} - min_.v;
  if (ru < 0 || ru >= nu_ || rv < 0 || rv >= nv_) return false;
  *lo = std::max<std::int64_t>(std::int64_t{w_lo} - min_.w, 0);
  *hi = std::min<std::int64_t>(std::int64_t{w_hi} - min_.w, nw_ - 1);
  // w is the innermost axis of the ring buffer: the column is contiguous, in ring order.
  *column = lop_.data() + slot_u_[ru] + slot_v_[rv];
  return *lo <= *hi;
}

bool VoxelGrid::occupiedExtent(int u, int v, int w_lo, int w_hi, int* w_top, int* w_bottom) const {
  const std::int16_t* column = nullptr;
  std::int64_t lo = 0, hi = -1;
  if (!columnSpan(u, v, w_lo, w_hi, &column, &lo, &hi)) return false;
  const std::uint32_t* const slot_w = slot_w_.data();
  const int occ = config_.occ_threshold;
  // Most columns of the window hold no occupied voxel at all: one pass over the whole column's
  // contiguous storage, in memory order (the compiler vectorises it), answers that before the
  // ring-ordered scan below. No voxel of the column occupied means none in [lo, hi] either.
  std::int16_t peak = std::numeric_limits<std::int16_t>::min();
  for (std::int64_t k = 0; k < nw_; ++k)
    peak = std::max(peak, column[k]);
  if (peak < occ) return false;
  std::int64_t top = hi;
  while (top >= lo && column[slot_w[top]] < occ)
    --top;
  if (top < lo) return false;
  std::int64_t bottom = lo;
  while (column[slot_w[bottom]] < occ)  // stops at top at the latest
    ++bottom;
  *w_top = static_cast<int>(top + min_.w);
  *w_bottom = static_cast<int>(bottom + min_.w);
  return true;
}

bool VoxelGrid::hiddenBelowObserved(int u, int v, int w_lo, int w_hi, int free_lop) const {
  const std::int16_t* column = nullptr;
  std::int64_t lo = 0, hi = -1;
  if (!columnSpan(u, v, w_lo, w_hi, &column, &lo, &hi)) return false;
  const int occ = config_.occ_threshold;
  const int free_max = -std::max(free_lop, 1);
  bool seen_above = false;
  for (std::int64_t w = hi; w >= lo; --w) {
    const int lop = column[slot_w_[w]];
    if (lop >= occ || lop <= free_max)
      seen_above = true;
    else if (seen_above)
      return true;
  }
  return false;
}

bool VoxelGrid::seenFreeWithin(int u, int v, int w_lo, int w_hi, int free_lop) const {
  const std::int16_t* column = nullptr;
  std::int64_t lo = 0, hi = -1;
  if (!columnSpan(u, v, w_lo, w_hi, &column, &lo, &hi)) return false;
  const int free_max = -std::max(free_lop, 1);
  for (std::int64_t w = lo; w <= hi; ++w)
    if (column[slot_w_[w]] <= free_max) return true;
  return false;
}

void VoxelGrid::setLogOdds(const VoxelIndex& i, int lop) {
  if (!contains(i)) return;
  lop_[linear(i)] =
      static_cast<std::int16_t>(std::min(std::max(lop, config_.lop_min), config_.lop_max));
}

}  // namespace stereo_safety_map
