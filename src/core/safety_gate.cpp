// Velocity safety gate on the local safety map. See safety_gate.h.
#include "stereo_safety_map/core/safety_gate.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr int kMaxSteps = 100000;         // a sweep longer than this is refused (stop)
constexpr int kMaxWindowCells = 4000000;  // 2000 x 2000 cells
constexpr double kMaxCoordinate = 1e6;    // [m]: a pose farther out is refused (cell indices)
/// A cell the footprint already covers stops the chair when its centre comes this much closer.
constexpr double kApproachEpsilon = 1e-4;  // [m]
/// theta_T of 000 Alg. 2 step 28: planes flatter than this are level.
constexpr double kLevelSlopeDeg = 3.0;

bool finite(const Eigen::Vector2d& p) {
  return std::isfinite(p.x()) && std::isfinite(p.y());
}

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

bool pointInPolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool inside = false;
  const std::size_t n = poly.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y())) {
      const double x = b.x() + (p.y() - b.y()) * (a.x() - b.x()) / (a.y() - b.y());
      if (p.x() < x) inside = !inside;
    }
  }
  return inside;
}

double segmentDistance(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                       const Eigen::Vector2d& p) {
  const Eigen::Vector2d ab = b - a;
  const double l2 = ab.squaredNorm();
  double t = l2 > 0.0 ? (p - a).dot(ab) / l2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return (a + t * ab - p).norm();
}

// Liang-Barsky: does the segment a-b meet the box [lo, hi]?
bool segmentTouchesBox(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                       const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  double t0 = 0.0, t1 = 1.0;
  const Eigen::Vector2d d = b - a;
  for (int k = 0; k < 2; ++k) {
    if (std::abs(d[k]) < 1e-15) {
      if (a[k] < lo[k] || a[k] > hi[k]) return false;
      continue;
    }
    double ta = (lo[k] - a[k]) / d[k];
    double tb = (hi[k] - a[k]) / d[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

// Proper intersection of two segments (shared end points and collinear overlaps count).
bool segmentsIntersect(const Eigen::Vector2d& p1, const Eigen::Vector2d& p2,
                       const Eigen::Vector2d& q1, const Eigen::Vector2d& q2) {
  const double d1 = cross(q2 - q1, p1 - q1);
  const double d2 = cross(q2 - q1, p2 - q1);
  const double d3 = cross(p2 - p1, q1 - p1);
  const double d4 = cross(p2 - p1, q2 - p1);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
    return true;
  auto on = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p,
               double d) {
    return std::abs(d) < 1e-12 && p.x() >= std::min(a.x(), b.x()) - 1e-12 &&
           p.x() <= std::max(a.x(), b.x()) + 1e-12 && p.y() >= std::min(a.y(), b.y()) - 1e-12 &&
           p.y() <= std::max(a.y(), b.y()) + 1e-12;
  };
  return on(q1, q2, p1, d1) || on(q1, q2, p2, d2) || on(p1, p2, q1, d3) || on(p1, p2, q2, d4);
}

// Andrew's monotone chain; `pts` is sorted in place. Counter-clockwise, no repeated first point.
void convexHull(std::vector<Eigen::Vector2d>* pts, std::vector<Eigen::Vector2d>* hull) {
  hull->clear();
  std::vector<Eigen::Vector2d>& p = *pts;
  std::sort(p.begin(), p.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  if (p.size() < 3) {
    *hull = p;
    return;
  }
  hull->resize(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross((*hull)[k - 1] - (*hull)[k - 2], p[i] - (*hull)[k - 2]) <= 0)
      --k;
    (*hull)[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross((*hull)[k - 1] - (*hull)[k - 2], p[i - 1] - (*hull)[k - 2]) <= 0)
      --k;
    (*hull)[k++] = p[i - 1];
  }
  hull->resize(k - 1);
}

GateReason reasonOf(int hazard) {
  switch (hazard) {
    case 4:
      return GateReason::kNonGround;
    case 3:
      return GateReason::kDropOff;
    case 2:
      return GateReason::kTooSteep;
    default:
      return GateReason::kUnknown;
  }
}

std::string describe(const GateCell& c) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  if (!c.inside_map) {
    os << "cell outside the map";
  } else if (c.drop_off && c.label != SafetyLabel::kNonGround) {
    os << "potential drop-off edge";
  } else if (c.label == SafetyLabel::kLevel && std::isfinite(c.slope_deg) && c.slope_deg > 0.0) {
    os << "foot of a " << std::setprecision(1) << c.slope_deg << " deg slope";
  } else if (c.label == SafetyLabel::kInclined) {
    if (std::isfinite(c.slope_deg)) {
      os << "Inclined cell of " << std::setprecision(1) << c.slope_deg << " deg";
    } else {
      os << "Inclined cell without a plane (slope unknown)";
    }
  } else {
    os << toString(c.label) << " cell";
  }
  os << std::setprecision(2) << " at (" << c.x << ", " << c.y << ")";
  return os.str();
}

}  // namespace

const char* toString(GateState s) {
  switch (s) {
    case GateState::kAllowed:
      return "allowed";
    case GateState::kSlowed:
      return "slowed";
    case GateState::kStopped:
      return "stopped";
  }
  return "?";
}

const char* toString(GateReason r) {
  switch (r) {
    case GateReason::kClear:
      return "clear";
    case GateReason::kZeroCommand:
      return "zero command";
    case GateReason::kNonGround:
      return "non-ground";
    case GateReason::kDropOff:
      return "drop-off edge";
    case GateReason::kTooSteep:
      return "too steep";
    case GateReason::kUnknown:
      return "unknown";
    case GateReason::kReverseLimit:
      return "reverse limit";
    case GateReason::kNoMap:
      return "no map";
    case GateReason::kStaleMap:
      return "stale map";
    case GateReason::kWrongFrame:
      return "wrong frame";
    case GateReason::kNoTf:
      return "no tf";
    case GateReason::kInvalidCommand:
      return "invalid command";
    case GateReason::kInvalidPose:
      return "invalid pose";
    case GateReason::kCommandTimeout:
      return "command timeout";
    case GateReason::kInvalidMap:
      return "invalid map";
  }
  return "?";
}

std::string SafetyGateConfig::validate() const {
  std::ostringstream os;
  auto out = [](double x, double lo, double hi) { return !std::isfinite(x) || x < lo || x > hi; };
  if (footprint.size() < 3 || footprint.size() > 64) {
    os << "footprint has " << footprint.size() << " vertices, must have 3 to 64";
    return os.str();
  }
  double area = 0.0;
  for (std::size_t i = 0; i < footprint.size(); ++i) {
    const Eigen::Vector2d& a = footprint[i];
    if (!finite(a) || std::abs(a.x()) > 100.0 || std::abs(a.y()) > 100.0) {
      os << "footprint vertex " << i << " (" << a.x() << ", " << a.y()
         << ") must be finite and within 100 m";
      return os.str();
    }
    area += cross(a, footprint[(i + 1) % footprint.size()]);
  }
  const std::size_t n = footprint.size();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      if (j == i + 1 || (i == 0 && j == n - 1)) continue;  // neighbouring edges share a vertex
      if (segmentsIntersect(footprint[i], footprint[(i + 1) % n], footprint[j],
                            footprint[(j + 1) % n])) {
        os << "footprint edges " << i << " and " << j << " cross: the polygon must be simple";
        return os.str();
      }
    }
  }
  if (std::abs(area) / 2.0 < 1e-4) return "footprint has no area (at least 1 cm^2)";
  if (out(footprint_padding, 0.0, 1.0)) {
    os << "footprint_padding = " << footprint_padding << ", must be in [0, 1] m";
  } else if (out(deceleration, 0.0, 20.0) || deceleration <= 0.0) {
    os << "deceleration = " << deceleration << ", must be in (0, 20] m/s^2";
  } else if (out(angular_deceleration, 0.0, 50.0) || angular_deceleration <= 0.0) {
    os << "angular_deceleration = " << angular_deceleration << ", must be in (0, 50] rad/s^2";
  } else if (out(reaction_time, 0.0, 5.0)) {
    os << "reaction_time = " << reaction_time << ", must be in [0, 5] s";
  } else if (out(margin, 0.0, 5.0)) {
    os << "margin = " << margin << ", must be in [0, 5] m";
  } else if (out(margin_angle_deg, 0.0, 180.0)) {
    os << "margin_angle_deg = " << margin_angle_deg << ", must be in [0, 180] deg";
  } else if (out(ramp_foot_height, 0.0, 1.0)) {
    os << "ramp_foot_height = " << ramp_foot_height << ", must be in [0, 1] m";
  } else if (out(safe_memory, 0.0, 60.0)) {
    os << "safe_memory = " << safe_memory << ", must be in [0, 60] s";
  } else if (max_hole_cells < 0 || max_hole_cells > 100) {
    os << "max_hole_cells = " << max_hole_cells << ", must be in [0, 100]";
  } else if (out(max_incline_deg, 0.0, 90.0) || max_incline_deg <= 0.0 || max_incline_deg >= 90.0) {
    os << "max_incline_deg = " << max_incline_deg << ", must be in (0, 90) deg";
  } else if (out(reverse_speed_limit, 0.0, 10.0)) {
    os << "reverse_speed_limit = " << reverse_speed_limit << ", must be in [0, 10] m/s";
  } else if (out(min_speed, 0.0, 10.0)) {
    os << "min_speed = " << min_speed << ", must be in [0, 10] m/s";
  } else if (out(min_angular_speed, 0.0, 10.0)) {
    os << "min_angular_speed = " << min_angular_speed << ", must be in [0, 10] rad/s";
  } else if (out(max_map_age, 0.0, 3600.0) || max_map_age <= 0.0) {
    os << "max_map_age = " << max_map_age << ", must be in (0, 3600] s";
  } else if (out(step_fraction, 0.0, 1.0) || step_fraction <= 0.0) {
    os << "step_fraction = " << step_fraction << ", must be in (0, 1]";
  } else if (out(max_step_angle_deg, 0.0, 45.0) || max_step_angle_deg <= 0.0) {
    os << "max_step_angle_deg = " << max_step_angle_deg << ", must be in (0, 45] deg";
  }
  return os.str();
}

double signedDistanceToPolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  double d = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    d = std::min(d, segmentDistance(poly[j], poly[i], p));
  }
  return pointInPolygon(poly, p) ? -d : d;
}

bool squareTouchesPolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& c,
                          double h) {
  if (poly.empty()) return false;
  if (pointInPolygon(poly, c)) return true;  // the square's centre inside (or all of it)
  const Eigen::Vector2d lo = c - Eigen::Vector2d(h, h);
  const Eigen::Vector2d hi = c + Eigen::Vector2d(h, h);
  // Otherwise an edge crosses it or the polygon lies inside it (then its edges do too).
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    if (segmentTouchesBox(poly[j], poly[i], lo, hi)) return true;
  }
  return false;
}

SafetyGate::SafetyGate(const SafetyGateConfig& config) : config_(config) {
  const std::string err = config_.validate();
  if (!err.empty()) throw std::invalid_argument("SafetyGateConfig: " + err);
  for (const Eigen::Vector2d& p : config_.footprint)
    r_max_ = std::max(r_max_, p.norm());
}

void SafetyGate::place(const Pose2D& pose, std::vector<Eigen::Vector2d>* poly) const {
  const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
  poly->resize(config_.footprint.size());
  for (std::size_t i = 0; i < config_.footprint.size(); ++i) {
    const Eigen::Vector2d& p = config_.footprint[i];
    (*poly)[i] = Eigen::Vector2d(pose.x + c * p.x() - s * p.y(), pose.y + s * p.x() + c * p.y());
  }
}

void SafetyGate::footprintAt(const Pose2D& pose, std::vector<Eigen::Vector2d>* out) const {
  place(pose, out);
}

Pose2D SafetyGate::poseAt(const Pose2D& start, double v, double omega, double lambda) const {
  Pose2D p = start;
  const double dth = omega * lambda;
  if (std::abs(dth) < 1e-9) {
    p.x += v * lambda * std::cos(start.yaw);
    p.y += v * lambda * std::sin(start.yaw);
  } else {
    const double r = v / omega;  // turning radius of the origin (0: rotation in place)
    p.x += r * (std::sin(start.yaw + dth) - std::sin(start.yaw));
    p.y -= r * (std::cos(start.yaw + dth) - std::cos(start.yaw));
  }
  p.yaw = start.yaw + dth;
  return p;
}

SafetyGate::Hazard SafetyGate::classify(const SafetyMap& map, int u, int v, GateCell* cell) {
  Hazard h = classifyCell(map, u, v, cell);
  if (h == Hazard::kUnknown && cell->inside_map && cell->label == SafetyLabel::kUnknown &&
      (remembered(u, v, cell) || smallEnclosedHole(map, u, v))) {
    h = Hazard::kNone;
  }
  if (h == Hazard::kNone) {
    const int du = u - win_u0_, dv = v - win_v0_;
    if (du >= 0 && dv >= 0 && du < win_w_ && dv < win_h_) {
      const float slope = foot_slope_[static_cast<std::size_t>(dv) * win_w_ + du];
      if (slope > 0.0f) {
        cell->slope_deg = slope;
        return Hazard::kTooSteep;
      }
    }
  }
  return h;
}

void SafetyGate::markRampFeet(const SafetyMap& map, int u0, int v0, int w, int h) {
  win_u0_ = u0;
  win_v0_ = v0;
  win_w_ = w;
  win_h_ = h;
  foot_slope_.assign(static_cast<std::size_t>(w) * h, 0.0f);
  if (config_.ramp_foot_height <= 0.0 || map.segment.size() != map.labels.size()) return;
  const double res = map.resolution;
  for (const SegmentInfo& s : map.segments) {
    const GroundPlane& p = s.plane;
    // Sloped ground the chair may not enter: Non-ground segments whose plane is inclined (too
    // steep, Alg. 2 step 2, or an unreachable slope; Alg. 1's height bands cut a ramp into
    // segments whose planes come out flatter than the ramp) and Inclined ones above the gate's
    // limit. The planes of small Unknown segments are noise (Alg. 2 step 3).
    const bool steep_ground = s.label == SafetyLabel::kNonGround && p.slope_deg > kLevelSlopeDeg;
    const bool too_steep =
        s.label == SafetyLabel::kInclined && p.slope_deg > config_.max_incline_deg;
    if (!p.valid || !std::isfinite(p.slope_deg) || !(steep_ground || too_steep) ||
        s.cells.empty()) {
      continue;
    }
    const double g = std::hypot(p.a, p.b);
    if (!std::isfinite(p.a) || !std::isfinite(p.b) || !(g > 1e-9)) continue;
    const Eigen::Vector2d dir(p.a / g, p.b / g);  // along the slope
    // A slope the chair may not drive is at least max_incline_deg steep.
    const double reach =
        std::min(1.0, config_.ramp_foot_height /
                          std::tan(std::max(p.slope_deg, config_.max_incline_deg) * kDegToRad));
    const int steps = static_cast<int>(std::ceil(reach / (0.5 * res)));
    for (const int k : s.cells) {
      if (k < 0 || k >= static_cast<int>(map.labels.size())) continue;
      const int cu = map.min_u + k % map.width, cv = map.min_v + k / map.width;
      // Cells far from the window cannot reach it.
      if (cu < u0 - steps || cv < v0 - steps || cu >= u0 + w + steps || cv >= v0 + h + steps) {
        continue;
      }
      for (int i = -steps; i <= steps; ++i) {
        const double d = i * 0.5 * res;
        const int fu = static_cast<int>(std::lround(cu + d * dir.x() / res)) - u0;
        const int fv = static_cast<int>(std::lround(cv + d * dir.y() / res)) - v0;
        if (fu < 0 || fv < 0 || fu >= w || fv >= h) continue;
        float& f = foot_slope_[static_cast<std::size_t>(fv) * w + fu];
        f = std::max(f, static_cast<float>(p.slope_deg));
      }
    }
  }
}

bool SafetyGate::remembered(int u, int v, GateCell* cell) const {
  if (config_.safe_memory <= 0.0 || mem_stamp_ < 0.0) return false;
  const int du = u - mem_min_u_, dv = v - mem_min_v_;
  if (du < 0 || dv < 0 || du >= mem_width_ || dv >= mem_height_) return false;
  const MemoryCell& m = memory_[static_cast<std::size_t>(dv) * mem_width_ + du];
  if (m.stamp < 0.0 || mem_stamp_ - m.stamp > config_.safe_memory) return false;
  if (cell != nullptr) cell->slope_deg = m.slope_deg;
  return true;
}

void SafetyGate::clearMemory() {
  memory_.clear();
  mem_width_ = mem_height_ = 0;
  mem_stamp_ = -1.0;
}

int SafetyGate::rememberedCells() const {
  int n = 0;
  for (int v = 0; v < mem_height_; ++v) {
    for (int u = 0; u < mem_width_; ++u) {
      const MemoryCell& m = memory_[static_cast<std::size_t>(v) * mem_width_ + u];
      n += m.stamp >= 0.0 && mem_stamp_ - m.stamp <= config_.safe_memory;
    }
  }
  return n;
}

void SafetyGate::observe(const SafetyMap& map, double stamp) {
  const std::size_t n = static_cast<std::size_t>(std::max(map.width, 0)) *
                        static_cast<std::size_t>(std::max(map.height, 0));
  if (config_.safe_memory <= 0.0 || map.width <= 0 || map.height <= 0 || map.labels.size() != n) {
    return;
  }
  if (!std::isfinite(stamp) || stamp < mem_stamp_ || map.resolution != mem_resolution_) {
    clearMemory();  // time went back (a bag restarted), or another grid
  }
  if (!std::isfinite(stamp)) return;
  // Carry the remembered cells over to the new window (the map scrolls with the robot).
  memory_scratch_.assign(n, MemoryCell());
  for (int v = 0; v < map.height; ++v) {
    const int ov = map.min_v + v - mem_min_v_;
    if (ov < 0 || ov >= mem_height_) continue;
    for (int u = 0; u < map.width; ++u) {
      const int ou = map.min_u + u - mem_min_u_;
      if (ou < 0 || ou >= mem_width_) continue;
      memory_scratch_[static_cast<std::size_t>(v) * map.width + u] =
          memory_[static_cast<std::size_t>(ov) * mem_width_ + ou];
    }
  }
  memory_.swap(memory_scratch_);
  mem_min_u_ = map.min_u;
  mem_min_v_ = map.min_v;
  mem_width_ = map.width;
  mem_height_ = map.height;
  mem_resolution_ = map.resolution;
  mem_stamp_ = stamp;
  GateCell cell;
  for (int v = 0; v < map.height; ++v) {
    for (int u = 0; u < map.width; ++u) {
      MemoryCell& m = memory_[static_cast<std::size_t>(v) * map.width + u];
      const Hazard h = classifyCell(map, map.min_u + u, map.min_v + v, &cell);
      if (h == Hazard::kNone) {
        m.stamp = stamp;
        m.label = cell.label;
        m.slope_deg = std::isfinite(cell.slope_deg) ? static_cast<float>(cell.slope_deg) : 0.0f;
      } else if (h != Hazard::kUnknown || cell.label == SafetyLabel::kUnexamined) {
        m.stamp = -1.0;  // a hazard now: forget that it was safe
      }
    }
  }
}

bool SafetyGate::smallEnclosedHole(const SafetyMap& map, int u, int v) {
  const int max_cells = config_.max_hole_cells;
  if (max_cells <= 0) return false;
  hole_.clear();
  hole_.emplace_back(u, v);
  GateCell scratch;
  // Breadth-first over 8-connected Unknown cells: every other neighbour must be ground the gate
  // accepts (a hazard, Unexamined or the map's edge leaves the hole open).
  for (std::size_t k = 0; k < hole_.size(); ++k) {
    const int cu = hole_[k].first, cv = hole_[k].second;
    for (int dv = -1; dv <= 1; ++dv) {
      for (int du = -1; du <= 1; ++du) {
        const std::pair<int, int> n(cu + du, cv + dv);
        if (std::find(hole_.begin(), hole_.end(), n) != hole_.end()) continue;
        const Hazard h = classifyCell(map, n.first, n.second, &scratch);
        if (h == Hazard::kNone) continue;
        if (h != Hazard::kUnknown || !scratch.inside_map ||
            scratch.label != SafetyLabel::kUnknown || static_cast<int>(hole_.size()) >= max_cells) {
          return false;
        }
        hole_.push_back(n);
      }
    }
  }
  return true;
}

SafetyGate::Hazard SafetyGate::classifyCell(const SafetyMap& map, int u, int v,
                                            GateCell* cell) const {
  cell->u = u;
  cell->v = v;
  cell->x = u * map.resolution;
  cell->y = v * map.resolution;
  cell->inside_map = map.inside(u, v);
  cell->drop_off = false;
  cell->slope_deg = std::numeric_limits<double>::quiet_NaN();
  if (!cell->inside_map) {
    cell->label = SafetyLabel::kUnknown;
    return Hazard::kUnknown;
  }
  const int idx = map.index(u, v);
  cell->label = map.labels[idx];
  cell->drop_off = map.drop_off.size() == map.labels.size() && map.drop_off[idx] != 0;
  const int seg = map.segment.size() == map.labels.size() ? map.segment[idx] : -1;
  if (seg >= 0 && seg < static_cast<int>(map.segments.size()) && map.segments[seg].plane.valid) {
    cell->slope_deg = map.segments[seg].plane.slope_deg;
  }
  switch (cell->label) {
    case SafetyLabel::kNonGround:
      return Hazard::kNonGround;
    case SafetyLabel::kLevel:
      return cell->drop_off ? Hazard::kDropOff : Hazard::kNone;
    case SafetyLabel::kInclined:
      if (cell->drop_off) return Hazard::kDropOff;
      // Alg. 2 step 28: Inclined = slope above theta_T; without a plane its slope is unknown.
      if (!std::isfinite(cell->slope_deg)) return Hazard::kUnknown;
      return cell->slope_deg > config_.max_incline_deg ? Hazard::kTooSteep : Hazard::kNone;
    default:  // Unknown, Unexamined
      return Hazard::kUnknown;
  }
}

void SafetyGate::stop(GateReason reason, const std::string& text, double v, double omega,
                      GateDecision* out) {
  out->state = GateState::kStopped;
  out->reason = reason;
  out->text = text;
  out->commanded_v = v;
  out->commanded_omega = omega;
  out->v = 0.0;
  out->omega = 0.0;
  out->scale = 0.0;
  out->cell = GateCell();
  out->hazard = false;
  out->free_distance = 0.0;
  out->free_angle = 0.0;
  out->stop_distance = 0.0;
  out->stop_angle = 0.0;
  out->footprint.clear();
  out->stop_footprint.clear();
  out->stop_zone.clear();
  out->zone_cells.clear();
  out->cells_checked = 0;
  out->steps = 0;
}

void SafetyGate::evaluate(const SafetyMap& map, const Pose2D& pose, double v, double omega,
                          double map_age, GateDecision* out) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  if (!std::isfinite(v) || !std::isfinite(omega)) {
    stop(GateReason::kInvalidCommand, "stopped: the command is not finite", v, omega, out);
    return;
  }
  if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.yaw) ||
      std::abs(pose.x) > kMaxCoordinate || std::abs(pose.y) > kMaxCoordinate) {
    stop(GateReason::kInvalidPose, "stopped: the footprint pose is not finite (or absurd)", v,
         omega, out);
    return;
  }
  const std::size_t n_cells = static_cast<std::size_t>(std::max(map.width, 0)) *
                              static_cast<std::size_t>(std::max(map.height, 0));
  if (map.width <= 0 || map.height <= 0 || map.labels.size() != n_cells ||
      !(map.resolution >= 1e-3 && map.resolution <= 100.0)) {
    stop(GateReason::kNoMap, "stopped: no safety map", v, omega, out);
    place(pose, &out->footprint);
    return;
  }
  if (!std::isfinite(map_age) || map_age > config_.max_map_age || map_age < -config_.max_map_age) {
    os << "stopped: the safety map is " << map_age << " s old (max_map_age " << config_.max_map_age
       << " s)";
    stop(GateReason::kStaleMap, os.str(), v, omega, out);
    place(pose, &out->footprint);
    return;
  }
  stop(GateReason::kZeroCommand, "zero command", v, omega, out);  // resets the fields
  place(pose, &out->footprint);
  if (v == 0.0 && omega == 0.0) {
    out->state = GateState::kAllowed;
    return;
  }

  // Reversing: the camera looks ahead, so only remembered cells, and at most the reverse limit.
  double k_max = 1.0;
  if (v < 0.0) {
    if (config_.reverse_speed_limit <= 0.0) {
      out->reason = GateReason::kReverseLimit;
      out->text = "stopped: reversing is disabled (reverse_speed_limit 0)";
      return;
    }
    k_max = std::min(1.0, config_.reverse_speed_limit / -v);
  }

  const double av = std::abs(v), aw = std::abs(omega);
  const double res = map.resolution;
  const double t_r = config_.reaction_time;
  const double t_b = std::max(av / config_.deceleration, aw / config_.angular_deceleration);
  const double inf = std::numeric_limits<double>::infinity();
  double lambda_m = std::min(av > 0.0 ? config_.margin / av : inf,
                             aw > 0.0 ? config_.margin_angle_deg * kDegToRad / aw : inf);
  if (!std::isfinite(lambda_m)) lambda_m = 0.0;
  const double lambda_stop = k_max * t_r + 0.5 * k_max * k_max * t_b + lambda_m;
  const double point_speed = av + aw * r_max_;  // farthest footprint point, at full command
  double dl = config_.step_fraction * res / point_speed;
  if (aw > 0.0) dl = std::min(dl, config_.max_step_angle_deg * kDegToRad / aw);
  const double steps_d = std::ceil(lambda_stop / dl);
  if (!(steps_d <= kMaxSteps)) {
    out->reason = GateReason::kUnknown;
    out->text = "stopped: the stop zone is too long to check";
    return;
  }
  const int n_steps = std::max(1, static_cast<int>(steps_d));
  // Half a step of the farthest point: the sampled footprints then cover the continuous sweep.
  const double pad = config_.footprint_padding + 0.5 * point_speed * dl;
  const double half = 0.5 * res + pad;
  out->stop_distance = lambda_stop * av;
  out->stop_angle = lambda_stop * aw;

  // The window holding every cell the sweep can touch.
  const double reach = r_max_ + pad + res + lambda_stop * av;
  if (!(reach / res < 1e6)) {  // also NaN: the cell indices below must fit an int
    out->reason = GateReason::kUnknown;
    out->text = "stopped: the stop zone is too large to check";
    return;
  }
  const int u0 = static_cast<int>(std::floor((pose.x - reach) / res));
  const int v0 = static_cast<int>(std::floor((pose.y - reach) / res));
  const int w = static_cast<int>(std::ceil((pose.x + reach) / res)) - u0 + 1;
  const int h = static_cast<int>(std::ceil((pose.y + reach) / res)) - v0 + 1;
  if (w <= 0 || h <= 0 || static_cast<double>(w) * h > kMaxWindowCells) {
    out->reason = GateReason::kUnknown;
    out->text = "stopped: the stop zone is too large to check";
    return;
  }
  cells_.assign(static_cast<std::size_t>(w) * h, LocalCell());
  markRampFeet(map, u0, v0, w, h);
  hull_pts_.clear();

  auto touchRange = [&](const std::vector<Eigen::Vector2d>& poly, int* ua, int* ub, int* va,
                        int* vb) {
    double xmin = inf, xmax = -inf, ymin = inf, ymax = -inf;
    for (const Eigen::Vector2d& p : poly) {
      xmin = std::min(xmin, p.x());
      xmax = std::max(xmax, p.x());
      ymin = std::min(ymin, p.y());
      ymax = std::max(ymax, p.y());
    }
    *ua = std::max(u0, static_cast<int>(std::floor((xmin - half) / res + 0.5)));
    *ub = std::min(u0 + w - 1, static_cast<int>(std::ceil((xmax + half) / res - 0.5)));
    *va = std::max(v0, static_cast<int>(std::floor((ymin - half) / res + 0.5)));
    *vb = std::min(v0 + h - 1, static_cast<int>(std::ceil((ymax + half) / res - 0.5)));
  };

  // The footprint where the chair stands: its cells are not entered, they are under it. The
  // hazards among them stop the chair when it comes closer to them; unseen cells whose centre
  // lies under the footprint are ground it stands on (the camera cannot see there).
  GateCell cell;
  poly0_ = out->footprint;
  hull_pts_.insert(hull_pts_.end(), poly0_.begin(), poly0_.end());
  int ua, ub, va, vb;
  touchRange(poly0_, &ua, &ub, &va, &vb);
  for (int cv = va; cv <= vb; ++cv) {
    for (int cu = ua; cu <= ub; ++cu) {
      const Eigen::Vector2d c(cu * res, cv * res);
      if (!squareTouchesPolygon(poly0_, c, half)) continue;
      LocalCell& lc = cells_[static_cast<std::size_t>(cv - v0) * w + (cu - u0)];
      lc.first_step = 0;
      const Hazard hz = classify(map, cu, cv, &cell);
      if (hz == Hazard::kNone) continue;
      const double d0 = signedDistanceToPolygon(poly0_, c);
      if (hz == Hazard::kUnknown && d0 <= 0.0) continue;  // unseen ground the chair stands on
      lc.initial_hazard = true;
      lc.d0 = d0;
    }
  }

  // The sweep: the first step whose footprint enters a hazard.
  int hazard_step = -1;
  int worst = 0;
  GateCell worst_cell;
  double lambda_prev = 0.0, lambda_free = lambda_stop;
  int steps = 0;
  for (int i = 1; i <= n_steps; ++i) {
    const double lambda = std::min(i * dl, lambda_stop);
    place(poseAt(pose, v, omega, lambda), &poly_);
    hull_pts_.insert(hull_pts_.end(), poly_.begin(), poly_.end());
    ++steps;
    touchRange(poly_, &ua, &ub, &va, &vb);
    for (int cv = va; cv <= vb; ++cv) {
      for (int cu = ua; cu <= ub; ++cu) {
        const Eigen::Vector2d c(cu * res, cv * res);
        LocalCell& lc = cells_[static_cast<std::size_t>(cv - v0) * w + (cu - u0)];
        if (lc.first_step >= 0 && !lc.initial_hazard) continue;  // judged before, or safe
        if (!squareTouchesPolygon(poly_, c, half)) continue;
        int hz = 0;
        if (lc.first_step < 0) {
          lc.first_step = i;
          out->zone_cells.push_back(c);
          ++out->cells_checked;
          hz = static_cast<int>(classify(map, cu, cv, &cell));
        } else if (signedDistanceToPolygon(poly_, c) < lc.d0 - kApproachEpsilon) {
          // Under the chair at the start: a hazard only when the footprint comes closer to it.
          hz = static_cast<int>(classify(map, cu, cv, &cell));
        }
        if (hz > worst) {
          worst = hz;
          worst_cell = cell;
          worst_cell.valid = true;
        }
      }
    }
    if (worst > 0) {
      hazard_step = i;
      lambda_free = lambda_prev;
      break;
    }
    lambda_prev = lambda;
  }
  out->steps = steps;
  convexHull(&hull_pts_, &out->stop_zone);

  // The largest speed scale whose stop (plus margin) ends before the hazard.
  double k = k_max;
  if (hazard_step >= 0) {
    out->hazard = true;
    out->cell = worst_cell;
    out->reason = reasonOf(worst);
    const double avail = lambda_free - lambda_m;
    if (avail <= 0.0) {
      k = 0.0;
    } else {
      k = (-t_r + std::sqrt(t_r * t_r + 2.0 * t_b * avail)) / t_b;  // t_b > 0: command non-zero
      k = std::clamp(k, 0.0, k_max);
    }
    if (!config_.slow_down) k = 0.0;
  } else {
    out->reason = k_max < 1.0 ? GateReason::kReverseLimit : GateReason::kClear;
  }
  if (k > 0.0 && k < 1.0 && k * av < config_.min_speed && k * aw < config_.min_angular_speed) {
    k = 0.0;  // slower than a creep: stop
  }
  out->free_distance = lambda_free * av;
  out->free_angle = lambda_free * aw;
  out->scale = k;
  out->v = k * v;
  out->omega = k * omega;
  if (k <= 0.0) {
    out->state = GateState::kStopped;
    out->v = 0.0;
    out->omega = 0.0;
  } else if (k < 1.0) {
    out->state = GateState::kSlowed;
  } else {
    out->state = GateState::kAllowed;
  }
  const double rest = k * t_r + 0.5 * k * k * t_b;
  place(poseAt(pose, v, omega, rest), &out->stop_footprint);

  os.str("");
  os << toString(out->state);
  if (out->state == GateState::kSlowed) {
    os << " to " << out->v << " m/s, " << out->omega << " rad/s";
  }
  if (out->hazard) {
    os << ": " << describe(out->cell) << ", ";
    // A path that is mostly a turn (or a speed too small to matter) is told in degrees.
    if (av > 0.0 && (aw == 0.0 || out->free_distance >= 0.01)) {
      os << out->free_distance << " m along the path";
    } else {
      os << std::setprecision(1) << out->free_angle / kDegToRad << " deg of turn";
    }
  } else if (out->reason == GateReason::kReverseLimit) {
    os << ": reversing is limited to " << config_.reverse_speed_limit << " m/s";
  } else {
    os << ": stop zone clear (" << out->stop_distance << " m, " << std::setprecision(1)
       << out->stop_angle / kDegToRad << " deg)";
  }
  out->text = os.str();
}

}  // namespace stereo_safety_map
