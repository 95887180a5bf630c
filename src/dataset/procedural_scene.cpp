#include "stereo_safety_map/dataset/procedural_scene.h"

#include "stereo_safety_map/dataset/portable_random.h"
#include "stereo_safety_map/dataset/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace stereo_safety_map {
namespace dataset {

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();
// Items keep this far from each other's footprints [m] (so that no two ground solids overlap and
// no obstacle stands on another item's ground).
constexpr double kItemGap = 0.3;
// Sunken fillers reach this far under the surrounding floor, so that no sliver between the cut
// and the filler is left without ground [m].
constexpr double kTuck = 0.05;
// The robot never sees farther than this in the visibility test [m] (000 Sec. VII-B: objects
// beyond 4-5 m are seen poorly).
constexpr double kViewMin = 1.0;
constexpr double kViewMax = 6.0;

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Poly = std::vector<Vec2>;

// ---- numbers and their text ----

double q4(double x) {  // coordinates and heights: 0.1 mm
  const double r = std::round(x * 1e4) / 1e4;
  return r == 0.0 ? 0.0 : r;
}
double q2(double x) {
  const double r = std::round(x * 100.0) / 100.0;
  return r == 0.0 ? 0.0 : r;
}
double q3(double x) {
  const double r = std::round(x * 1000.0) / 1000.0;
  return r == 0.0 ? 0.0 : r;
}
Vec2 q4(const Vec2& v) {
  return {q4(v.x()), q4(v.y())};
}

// Shortest text of a value rounded to 4 decimals ("1.25", "0", "-0.0375").
std::string num(double x) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.4f", q4(x));
  std::string s(buf);
  while (!s.empty() && s.back() == '0')
    s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  if (s == "-0") s = "0";
  return s;
}
std::string v2(const Vec2& v) {
  return "[" + num(v.x()) + ", " + num(v.y()) + "]";
}
std::string v3(const Vec3& v) {
  return "[" + num(v.x()) + ", " + num(v.y()) + ", " + num(v.z()) + "]";
}
std::string polyText(const Poly& p) {
  std::string s = "[";
  for (std::size_t i = 0; i < p.size(); ++i)
    s += (i ? ", " : "") + v2(p[i]);
  return s + "]";
}
std::string fmt(const char* f, double a) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), f, a);
  return buf;
}

// ---- plane geometry on convex polygons (counter-clockwise) ----

Vec2 dir(double yaw) {
  return {std::cos(yaw), std::sin(yaw)};
}
Vec2 perp(const Vec2& v) {
  return {-v.y(), v.x()};
}  // 90 deg to the left
double cross(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

double signedArea(const Poly& p) {
  double a = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i)
    a += cross(p[i], p[(i + 1) % p.size()]);
  return 0.5 * a;
}

// Keeps the part with n . x <= c.
Poly clip(const Poly& p, const Vec2& n, double c) {
  Poly out;
  const std::size_t m = p.size();
  for (std::size_t i = 0; i < m; ++i) {
    const Vec2& a = p[i];
    const Vec2& b = p[(i + 1) % m];
    const double da = n.dot(a) - c, db = n.dot(b) - c;
    if (da <= 0.0) out.push_back(a);
    if ((da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0))
      out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}

// Rounds to 0.1 mm and drops repeated and (nearly) collinear corners and slivers, so that the
// polygon is strictly convex as the loader wants it. Empty when nothing is left.
Poly cleanup(const Poly& in) {
  Poly p;
  for (const Vec2& v : in) {
    const Vec2 r = q4(v);
    if (p.empty() || (r - p.back()).norm() > 1e-3) p.push_back(r);
  }
  while (p.size() > 1 && (p.front() - p.back()).norm() <= 1e-3)
    p.pop_back();
  if (p.size() >= 3 && signedArea(p) < 0.0) std::reverse(p.begin(), p.end());
  bool changed = true;
  while (changed && p.size() >= 3) {
    changed = false;
    for (std::size_t i = 0; i < p.size() && p.size() >= 3; ++i) {
      const Vec2& a = p[(i + p.size() - 1) % p.size()];
      const Vec2& b = p[i];
      const Vec2& c = p[(i + 1) % p.size()];
      const Vec2 e1 = b - a, e2 = c - b;
      if (cross(e1, e2) <= 1e-3 * e1.norm() * e2.norm()) {  // collinear or a reflex rounding
        p.erase(p.begin() + static_cast<std::ptrdiff_t>(i));
        changed = true;
        break;
      }
    }
  }
  if (p.size() < 3) return {};
  double perim = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i)
    perim += (p[(i + 1) % p.size()] - p[i]).norm();
  const double area = signedArea(p);
  if (area < 1e-4 || area / perim < 2e-3) return {};  // a sliver thinner than ~4 mm
  return p;
}

// P minus S (both convex): convex pieces of P outside S, one per edge of S (the part of P beyond
// that edge's line), so that they overlap each other instead of meeting along new lines: pieces
// at one height then leave no sliver without ground between them however their corners are
// rounded. They also reach `overlap` [m] into S (more than the 0.05 mm rounding of the corners),
// so that no sliver opens between them and what fills S. P alone when S does not meet it.
std::vector<Poly> subtract(const Poly& P, const Poly& S_in, double overlap) {
  Poly S = S_in;
  if (signedArea(S) < 0.0) std::reverse(S.begin(), S.end());
  std::vector<Poly> pieces;
  for (std::size_t i = 0; i < S.size(); ++i) {
    const Vec2& a = S[i];
    const Vec2& b = S[(i + 1) % S.size()];
    const Vec2 n = Vec2(b.y() - a.y(), a.x() - b.x()).normalized();  // outward (right side)
    const double c = n.dot(a) - overlap;
    bool all_beyond = true;
    for (const Vec2& v : P)
      all_beyond = all_beyond && n.dot(v) >= c;
    if (all_beyond) return {P};  // S does not meet P
    const Poly beyond = clip(P, -n, -c);
    if (beyond.size() >= 3 && signedArea(beyond) > 1e-6) pieces.push_back(beyond);
  }
  return pieces;
}

bool insideConvex(const Vec2& p, const Poly& P) {
  for (std::size_t i = 0; i < P.size(); ++i)
    if (cross(P[(i + 1) % P.size()] - P[i], p - P[i]) < 0.0) return false;
  return true;
}

double pointSegment(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 ab = b - a;
  const double L2 = ab.squaredNorm();
  const double t = L2 > 0.0 ? std::min(1.0, std::max(0.0, (p - a).dot(ab) / L2)) : 0.0;
  return (a + t * ab - p).norm();
}

bool segmentsCross(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const double d1 = cross(b - a, c - a), d2 = cross(b - a, d - a);
  const double d3 = cross(d - c, a - c), d4 = cross(d - c, b - c);
  return ((d1 > 0.0) != (d2 > 0.0)) && ((d3 > 0.0) != (d4 > 0.0));
}

// Distance between a segment (a point when a == b) and a convex polygon; 0 when they meet.
double segmentPolygon(const Vec2& a, const Vec2& b, const Poly& P) {
  if (insideConvex(a, P) || insideConvex(b, P)) return 0.0;
  double d = kInf;
  for (std::size_t i = 0; i < P.size(); ++i) {
    const Vec2& c = P[i];
    const Vec2& e = P[(i + 1) % P.size()];
    if (segmentsCross(a, b, c, e)) return 0.0;
    d = std::min({d, pointSegment(a, c, e), pointSegment(b, c, e), pointSegment(c, a, b)});
  }
  return d;
}

// Distance between two convex polygons; 0 when they overlap or touch.
double polyDistance(const Poly& A, const Poly& B) {
  double d = kInf;
  for (std::size_t i = 0; i < A.size(); ++i) {
    d = std::min(d, segmentPolygon(A[i], A[(i + 1) % A.size()], B));
    if (d <= 0.0) return 0.0;
  }
  if (insideConvex(B[0], A)) return 0.0;
  return d;
}

Eigen::AlignedBox2d boxOf(const Poly& p) {
  Eigen::AlignedBox2d b;
  for (const Vec2& v : p)
    b.extend(v);
  return b;
}

// Rectangle `len` along `yaw` and `wid` across, centred on c.
Poly rect(const Vec2& c, double yaw, double len, double wid) {
  const Vec2 u = dir(yaw) * (0.5 * len), w = perp(dir(yaw)) * (0.5 * wid);
  return {c - u - w, c + u - w, c + u + w, c - u + w};
}
// Rectangle starting at the mid-point `a` of one end and extending `len` along yaw.
Poly rectFrom(const Vec2& a, double yaw, double len, double wid) {
  return rect(a + dir(yaw) * (0.5 * len), yaw, len, wid);
}

// Convex hull (Andrew's monotone chain), counter-clockwise.
Poly hull(std::vector<Vec2> pts) {
  std::sort(pts.begin(), pts.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  if (pts.size() < 3) return pts;
  Poly h(2 * pts.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    while (k >= 2 && cross(h[k - 1] - h[k - 2], pts[i] - h[k - 2]) <= 0.0)
      --k;
    h[k++] = pts[i];
  }
  for (std::size_t i = pts.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(h[k - 1] - h[k - 2], pts[i] - h[k - 2]) <= 0.0)
      --k;
    h[k++] = pts[i];
  }
  h.resize(k - 1);
  return h;
}

Poly footprintAt(const FootprintConfig& fp, double x, double y, double yaw) {
  const Vec2 c(x, y), u = dir(yaw), w = perp(u);
  const double back = -fp.base_to_rear, front = fp.length - fp.base_to_rear, hw = 0.5 * fp.width;
  return {c + u * back - w * hw, c + u * front - w * hw, c + u * front + w * hw,
          c + u * back + w * hw};
}

// Poses of a trajectory at least every `step_m` of travel and `step_deg` of turning, its end pose
// included.
std::vector<RobotPose> densePoses(const TrajectoryConfig& t, double step_m, double step_deg) {
  double vmax = t.speed;
  for (const TrajectoryStep& s : t.steps)
    if (s.kind == TrajectoryStep::Kind::kGo || s.kind == TrajectoryStep::Kind::kBack)
      vmax = std::max(vmax, s.speed);
  const double dt = std::min(step_m / vmax, step_deg / t.turn_rate_deg);
  TrajectoryConfig dense = t;
  dense.rate_hz = std::min(1000.0, 1.0 / dt);
  std::vector<RobotPose> poses = sampleTrajectory(dense);
  if (!poses.empty()) poses.push_back(poseAt(t, trajectoryDuration(t)));
  return poses;
}

// ---- material text ----

struct Mat {
  std::string texture = "noise";
  double scale = 0.3, contrast = 0.1;
  Vec3 colour = Vec3(0.5, 0.5, 0.5);
  double line_width = -1.0, detail = -1.0, grain = -1.0, grain_size = -1.0, angle = 0.0;

  std::string yaml() const {
    std::string s = "{texture: " + texture;
    if (texture != "plain") s += ", scale: " + num(scale) + ", contrast: " + num(contrast);
    s += ", colour: " + v3(colour);
    if (line_width >= 0.0) s += ", line_width: " + num(line_width);
    if (detail >= 0.0) s += ", detail: " + num(detail);
    if (grain >= 0.0) s += ", grain: " + num(grain);
    if (grain_size > 0.0) s += ", grain_size: " + num(grain_size);
    if (angle != 0.0) s += ", angle_deg: " + num(angle);
    return s + "}";
  }
};

Vec3 greyish(PortableRng& rng, double lo, double hi) {
  const double g = rng.uniform(lo, hi);
  const Vec3 c(g * (1.0 + rng.uniform(-0.05, 0.08)), g, g * (1.0 + rng.uniform(-0.1, 0.03)));
  return Vec3(q3(std::min(1.0, c.x())), q3(c.y()), q3(std::min(1.0, c.z())));
}
Vec3 tinted(PortableRng& rng, const Vec3& base, double jitter) {
  Vec3 c;
  for (int i = 0; i < 3; ++i)
    c[i] = q3(std::min(1.0, std::max(0.02, base[i] * (1.0 + rng.uniform(-jitter, jitter)))));
  return c;
}

// A floor of the given kind (ranges documented at floorKinds() in the header).
Mat floorMaterial(const std::string& kind, PortableRng& rng) {
  Mat m;
  m.angle = q2(rng.uniform(0.0, 90.0));
  if (kind == "polished") {
    if (rng.chance(0.5)) {
      m.texture = "plain";
    } else {
      m.texture = "noise";
      m.scale = q3(rng.uniform(0.5, 2.0));
      m.contrast = q3(rng.uniform(0.0, 0.03));
    }
    m.grain = q3(rng.uniform(0.0, 0.005));
    m.colour = greyish(rng, 0.45, 0.8);
  } else if (kind == "matt") {
    m.scale = q3(rng.uniform(0.3, 1.0));
    m.contrast = q3(rng.uniform(0.03, 0.08));
    m.grain = q3(rng.uniform(0.005, 0.02));
    m.colour = greyish(rng, 0.35, 0.75);
  } else if (kind == "carpet") {
    static const Vec3 kCarpets[] = {{0.30, 0.33, 0.42},
                                    {0.45, 0.25, 0.22},
                                    {0.32, 0.38, 0.30},
                                    {0.55, 0.50, 0.42},
                                    {0.35, 0.35, 0.36}};
    m.scale = q3(rng.uniform(0.05, 0.2));
    m.contrast = q3(rng.uniform(0.08, 0.2));
    m.grain = q3(rng.uniform(0.06, 0.12));
    m.grain_size = q3(rng.uniform(0.004, 0.008));
    m.colour = tinted(rng, kCarpets[rng.integer(0, 4)], 0.15);
  } else if (kind == "tiles") {
    m.texture = "tiles";
    m.scale = q3(rng.uniform(0.2, 0.6));
    m.contrast = q3(rng.uniform(0.04, 0.15));
    m.line_width = q3(rng.uniform(0.015, 0.05));
    m.detail = q3(rng.uniform(0.1, 0.5));
    m.grain = q3(rng.uniform(0.0, 0.03));
    m.colour = greyish(rng, 0.5, 0.85);
  } else if (kind == "concrete") {
    m.scale = q3(rng.uniform(0.3, 1.5));
    m.contrast = q3(rng.uniform(0.06, 0.15));
    m.grain = q3(rng.uniform(0.02, 0.06));
    m.colour = greyish(rng, 0.45, 0.7);
  } else if (kind == "paving") {
    m.texture = rng.chance(0.5) ? "bricks" : "tiles";
    m.scale = q3(rng.uniform(0.1, 0.3));
    m.contrast = q3(rng.uniform(0.1, 0.3));
    m.line_width = q3(rng.uniform(0.04, 0.1));
    m.detail = q3(rng.uniform(0.2, 0.6));
    m.grain = q3(rng.uniform(0.03, 0.08));
    m.colour =
        rng.chance(0.5) ? greyish(rng, 0.4, 0.65) : tinted(rng, Vec3(0.55, 0.38, 0.30), 0.15);
  } else {  // asphalt
    m.texture = "speckle";
    m.scale = q3(rng.uniform(0.1, 0.4));
    m.contrast = q3(rng.uniform(0.2, 0.4));
    m.grain = q3(rng.uniform(0.05, 0.1));
    m.colour = greyish(rng, 0.22, 0.36);
  }
  return m;
}

// ---- the trajectory ----

struct Leg {
  Vec2 a, b;
  double yaw = 0.0;
  bool reverse = false;
};

struct Route {
  TrajectoryConfig traj;
  std::vector<RobotPose> frames;
  std::vector<Poly> swept;  // footprints every 5 cm / 3 deg
  std::vector<Eigen::AlignedBox2d> swept_box;
  Eigen::AlignedBox2d box;
  std::vector<Leg> legs;
  std::vector<int> stop_frames;  // the last frame of each drive
};

// The trajectory: optional pause, then drives (some at an angle), pauses, turns in place,
// look-arounds and short reverses until config.duration_s, padded with a final pause.
Route makeRoute(const ProceduralConfig& cfg, PortableRng& rng) {
  Route r;
  TrajectoryConfig& t = r.traj;
  t.rate_hz = cfg.rate_hz;
  t.start_x = t.start_y = t.start_yaw_deg = 0.0;
  t.base_z = 0.0;
  t.speed = q2(rng.uniform(cfg.speed_min, cfg.speed_max));
  t.turn_rate_deg = q2(rng.uniform(cfg.turn_rate_min_deg, cfg.turn_rate_max_deg));
  const double D = cfg.duration_s;
  auto duration = [&]() { return trajectoryDuration(t); };
  auto add = [&](TrajectoryStep::Kind k, double x, double y, double value, double speed) {
    TrajectoryStep s;
    s.kind = k;
    s.x = x;
    s.y = y;
    s.value = value;
    s.speed = speed;
    t.steps.push_back(s);
  };
  auto pause = [&](double s) { add(TrajectoryStep::Kind::kPause, 0, 0, q2(s), 0); };
  std::vector<double> drive_ends;
  // Pauses: stationary frames, 10-20 % of a dataset in 000 Sec. VII-A (skipped by the mapper).
  if (rng.chance(0.8)) pause(rng.uniform(0.5, 1.5));
  bool any_go = false, last_back = false;
  while (D - duration() > 0.3) {
    const double rem = D - duration();
    const RobotPose now = poseAt(t, duration());
    const Vec2 pos(now.x, now.y);
    const double turn_rate = t.turn_rate_deg;
    const double u = rng.uniform();
    if (!any_go || last_back || u < 0.45) {  // drive, sometimes at an angle (turn, then drive)
      const double v = q2(rng.uniform(cfg.speed_min, cfg.speed_max));
      const double bearing = rng.chance(0.4) ? rng.uniform(-60.0, 60.0) : 0.0;
      const double drive_time = rem - std::abs(bearing) / turn_rate;
      double dist = rng.uniform(0.6, 3.0);
      dist = std::min(dist, drive_time * v);
      if (dist < 0.2) {
        pause(rem);
        break;
      }
      const Vec2 target = q4(pos + dir(now.yaw + bearing * kDeg) * dist);
      add(TrajectoryStep::Kind::kGo, target.x(), target.y(), 0, v);
      const RobotPose end = poseAt(t, 1e9);
      Leg leg;
      leg.a = pos;
      leg.b = Vec2(end.x, end.y);
      leg.yaw = end.yaw;
      r.legs.push_back(leg);
      drive_ends.push_back(duration());
      any_go = true;
      last_back = false;
    } else if (u < 0.63) {
      pause(std::min(rng.uniform(0.5, 2.0), rem));
    } else if (u < 0.77) {
      const double a = std::min(rng.uniform(20.0, 90.0), rem * turn_rate);
      add(TrajectoryStep::Kind::kTurnBy, 0, 0, q2(rng.sign() * a), 0);
    } else if (u < 0.86) {  // look around: turn and come back
      const double a = std::min(rng.uniform(20.0, 45.0), 0.5 * rem * turn_rate);
      const double s = rng.sign();
      add(TrajectoryStep::Kind::kTurnBy, 0, 0, q2(s * a), 0);
      add(TrajectoryStep::Kind::kTurnBy, 0, 0, q2(-s * a), 0);
    } else {  // reverse a little, slowly
      const double v =
          q2(rng.uniform(cfg.speed_min, std::min(cfg.speed_max, cfg.reverse_speed_max)));
      const double dist = std::min(rng.uniform(0.3, 1.0), rem * v);
      if (dist < 0.1) {
        pause(rem);
        break;
      }
      const Vec2 target = q4(pos - dir(now.yaw) * dist);
      add(TrajectoryStep::Kind::kBack, target.x(), target.y(), 0, v);
      const RobotPose end = poseAt(t, 1e9);
      Leg leg;
      leg.a = pos;
      leg.b = Vec2(end.x, end.y);
      leg.yaw = end.yaw;
      leg.reverse = true;
      r.legs.push_back(leg);
      drive_ends.push_back(duration());
      last_back = true;
    }
  }
  // Pad to the duration with a pause (the last one lengthened when the route ends with one).
  const double rem = D - duration();
  if (rem > 0.0) {
    if (!t.steps.empty() && t.steps.back().kind == TrajectoryStep::Kind::kPause) {
      t.steps.back().value = std::ceil((t.steps.back().value + rem) * 1e4) / 1e4;
    } else {
      add(TrajectoryStep::Kind::kPause, 0, 0, std::ceil(rem * 1e4) / 1e4, 0);
    }
  }
  r.frames = sampleTrajectory(t);
  for (double te : drive_ends)
    r.stop_frames.push_back(std::min(static_cast<int>(r.frames.size()) - 1,
                                     static_cast<int>(std::floor(te * t.rate_hz))));
  for (const RobotPose& p : densePoses(t, 0.05, 3.0)) {
    r.swept.push_back(footprintAt(cfg.footprint, p.x, p.y, p.yaw));
    r.swept_box.push_back(boxOf(r.swept.back()));
    r.box.extend(r.swept_box.back());
  }
  return r;
}

// Smallest distance between the swept footprint and a polygon.
double routeDistance(const Route& r, const Poly& p) {
  const Eigen::AlignedBox2d pb = boxOf(p);
  double best = kInf;
  for (std::size_t i = 0; i < r.swept.size(); ++i) {
    if (pb.exteriorDistance(r.swept_box[i]) >= best) continue;
    best = std::min(best, polyDistance(r.swept[i], p));
    if (best <= 0.0) return 0.0;
  }
  return best;
}

// ---- hazard items ----

struct Plan {
  HazardItem item;
  std::vector<std::string> entries;  // scene-file primitives (flow maps)
  std::vector<Poly> cuts;            // removed from the base floor
  std::vector<Poly> keepout;         // everything not start-level ground
  std::vector<Vec3> look;            // points whose visibility makes the item seen
  bool edge = false;                 // a straight edge across the whole area
  double depth = 0.0;                // deepest level below the start level [m]
};

struct Look {
  bool indoor = false;
  std::string floor_kind;
};

class Builder {
 public:
  Builder(const ProceduralConfig& cfg, PortableRng& rng, const Route& route, const Poly& area)
      : cfg_(cfg), rng_(rng), route_(route), area_(area) {}

  // Tries to place one item of `kind` with index `index`; false when this draw does not fit.
  bool build(const std::string& kind, int index, const std::vector<Plan>& placed, Plan* out);

 private:
  struct Anchor {
    Vec2 p;
    double yaw = 0.0;  // direction from the robot towards the item, or of the leg passed
    bool beside = false;
    double side = 1.0;  // beside: +1 left of the leg, -1 right
  };
  struct Edge {
    Vec2 n;  // unit normal towards the far side
    double c = 0.0;
    Vec2 foot;  // the point of the edge nearest the trajectory
  };

  Anchor ahead(double rmin, double rmax, double max_bearing_deg);
  bool beside(double lateral, Anchor* a);
  Edge edge(double gap, double p_ahead = 0.6);
  double stepHeight();
  double slope();
  double passClearance() { return rng_.uniform(cfg_.pass_clearance_min, cfg_.pass_clearance_max); }
  Poly region(const Edge& e, double offset) const {
    return cleanup(clip(area_, -e.n, -(e.c + offset)));
  }
  void edgeLook(const Edge& e, double z, Plan* p) const;
  void rectLook(const Poly& r, double z, Plan* p) const;
  std::string name(const Plan& p, const std::string& part) const {
    return part.empty() ? p.item.group : p.item.group + "_" + part;
  }

  bool curb(const std::string& kind, Plan* p);
  bool curbCut(bool down, Plan* p);
  bool step(bool up, Plan* p);
  bool ramp(bool up, Plan* p);
  bool deepEdge(const std::string& kind, Plan* p);
  bool pit(const std::string& kind, Plan* p);
  bool stairs(Plan* p);
  bool obstacle(const std::string& kind, Plan* p);
  bool wall(bool doorway, Plan* p);

  const ProceduralConfig& cfg_;
  PortableRng& rng_;
  const Route& route_;
  Poly area_;
};

Builder::Anchor Builder::ahead(double rmin, double rmax, double max_bearing_deg) {
  int f;
  if (!route_.stop_frames.empty() && rng_.chance(0.5)) {
    f = route_.stop_frames[rng_.integer(0, static_cast<int>(route_.stop_frames.size()) - 1)];
  } else {
    f = rng_.integer(0, static_cast<int>(route_.frames.size()) - 1);
  }
  const RobotPose& pose = route_.frames[f];
  Anchor a;
  a.yaw = pose.yaw + rng_.uniform(-max_bearing_deg, max_bearing_deg) * kDeg;
  a.p = Vec2(pose.x, pose.y) + dir(pose.yaw) * 0.25 + dir(a.yaw) * rng_.uniform(rmin, rmax);
  return a;
}

bool Builder::beside(double lateral, Anchor* a) {
  std::vector<const Leg*> legs;
  for (const Leg& l : route_.legs)
    if (!l.reverse && (l.b - l.a).norm() > 0.5) legs.push_back(&l);
  if (legs.empty()) return false;
  const Leg& l = *legs[rng_.integer(0, static_cast<int>(legs.size()) - 1)];
  // Far enough along the drive that the camera (0.25 m ahead of base_link) has it within 25 deg
  // of its axis while approaching; at most 1 m past the drive's end.
  const double off = 0.5 * cfg_.footprint.width + lateral;
  const double len = (l.b - l.a).norm();
  const double s_min = off / std::tan(25.0 * kDeg) - 0.25;
  if (s_min > len + 1.0) return false;
  a->yaw = l.yaw;
  a->side = rng_.sign();
  a->p = l.a + dir(l.yaw) * rng_.uniform(std::max(0.0, s_min), len + 1.0) +
         perp(dir(l.yaw)) * (a->side * off);
  a->beside = true;
  return true;
}

Builder::Edge Builder::edge(double gap, double p_ahead) {
  Edge e;
  if (route_.legs.empty() || rng_.chance(p_ahead)) {  // ahead of the robot at some frame
    const Anchor a = ahead(2.0, 3.0, 35.0);
    e.n = dir(a.yaw);
  } else {  // along a drive, on its left or right
    const Leg& l = route_.legs[rng_.integer(0, static_cast<int>(route_.legs.size()) - 1)];
    e.n = perp(dir(l.yaw)) * rng_.sign();
  }
  // Beyond the whole swept footprint by `gap`.
  double best = -kInf;
  Vec2 arg = Vec2::Zero();
  for (const Poly& fp : route_.swept) {
    for (const Vec2& v : fp) {
      if (e.n.dot(v) > best) {
        best = e.n.dot(v);
        arg = v;
      }
    }
  }
  e.c = best + gap;
  e.foot = arg + e.n * (e.c - e.n.dot(arg));
  return e;
}

double Builder::stepHeight() {
  // Curbs and steps on both sides of h_T = 5 cm (000 Alg. 2 step 17).
  if (rng_.chance(cfg_.step_near_h_t_weight)) return q4(rng_.uniform(0.03, 0.07));
  return q4(rng_.uniform(cfg_.step_min, cfg_.step_max));
}

double Builder::slope() {
  // Many ramps within 2 deg of theta_T = 3 deg and theta_max = 10 deg (000 Alg. 2 steps 2, 28).
  const double u = rng_.uniform();
  if (u < cfg_.slope_near_theta_t_weight) return rng_.uniform(1.0, 5.0);
  if (u < cfg_.slope_near_theta_t_weight + cfg_.slope_near_theta_max_weight)
    return rng_.uniform(8.0, 12.0);
  return rng_.uniform(cfg_.slope_min_deg, cfg_.slope_max_deg);
}

HazardClass slopeClass(double slope_deg) {
  return slope_deg > GroundTruthConfig().theta_max_deg ? HazardClass::kSteepRamp
                                                       : HazardClass::kGentleRamp;
}

void Builder::edgeLook(const Edge& e, double z, Plan* p) const {
  // Points along the edge inside the area, every 0.5 m, a little above the surface.
  const Vec2 t = perp(e.n);
  for (double s = -15.0; s <= 15.0; s += 0.5) {
    const Vec2 q = e.foot + t * s;
    if (insideConvex(q, area_)) p->look.emplace_back(q.x(), q.y(), z + 0.02);
  }
}

void Builder::rectLook(const Poly& r, double z, Plan* p) const {
  Vec2 c = Vec2::Zero();
  for (const Vec2& v : r)
    c += v;
  c /= static_cast<double>(r.size());
  p->look.emplace_back(c.x(), c.y(), z + 0.02);
  for (std::size_t i = 0; i < r.size(); ++i) {
    const Vec2 a = r[i], b = r[(i + 1) % r.size()];
    for (const Vec2& q : {a, Vec2(0.5 * (a + b))})
      p->look.emplace_back(q.x(), q.y(), z + 0.02);
  }
}

// curb_down / curb_up: a straight edge across the area, the far side `h` lower or higher.
bool Builder::curb(const std::string& kind, Plan* p) {
  const bool down = kind == "curb_down";
  const double h = stepHeight();
  const Edge e = edge(passClearance());
  const Poly far = region(e, 0.0);
  if (far.empty()) return false;
  p->edge = true;
  p->keepout.push_back(far);
  HazardItem& it = p->item;
  it.group_kind = "curb";
  it.size = h;
  it.position = e.foot;
  if (down) {
    const Poly street = region(e, -kTuck);
    p->cuts.push_back(far);
    p->entries.push_back("{type: floor, name: " + name(*p, "street") + ", polygon: " +
                         polyText(street) + ", z: " + num(-h) + ", material: lower}");
    it.cls = HazardClass::kDropOff;
    it.parts.push_back({name(*p, "street"), HazardClass::kDropOff});
    it.description = "curb " + num(h * 100) + " cm down to a street";
    p->depth = h;
    edgeLook(e, 0.0, p);
  } else {
    p->entries.push_back("{type: platform, name: " + name(*p, "upper") + ", polygon: " +
                         polyText(far) + ", z: " + num(h) + ", thickness: " + num(h + 0.05) +
                         ", material: raised, side_material: curb}");
    it.cls = HazardClass::kStepUp;
    it.parts.push_back({name(*p, "upper"), HazardClass::kStepUp});
    it.description = "curb " + num(h * 100) + " cm up to a sidewalk";
    edgeLook(e, h, p);
  }
  return true;
}

// A curb with a ramp cut into it perpendicular to the edge and a sloped triangular flare on each
// side (a kerb ramp). down: the robot is on the sidewalk, the cut leads down to the street; up:
// the robot is on the street level, the cut leads up to the sidewalk.
bool Builder::curbCut(bool down, Plan* p) {
  double h = q4(rng_.uniform(0.08, cfg_.step_max));
  double s = slope();
  double L = h / std::tan(s * kDeg);
  if (L > 3.0) {
    L = 3.0;
    h = q4(std::max(0.03, L * std::tan(s * kDeg)));
  }
  L = q4(std::max(0.4, L));
  s = std::atan(h / L) / kDeg;
  const double W = q4(rng_.uniform(0.9, 1.5));
  const double F = q4(std::min(1.5, std::max(0.25, h / std::tan(rng_.uniform(5.0, 15.0) * kDeg))));
  const double flare = std::atan(h * std::sqrt(1.0 / (F * F) + 1.0 / (L * L))) / kDeg;
  // Mostly ahead: the cut is what the camera should see, not only the curb beside the path.
  const Edge e = edge(passClearance() + (down ? L : 0.0), 0.85);
  const Vec2 t = perp(e.n);
  const Vec2 o = e.foot + t * rng_.uniform(-1.0, 1.0);
  // Local (s along the edge, d across it, positive towards the far side) to world.
  auto P = [&](double sl, double d) { return q4(Vec2(o + t * sl + e.n * d)); };
  auto P3 = [&](double sl, double d, double z) {
    const Vec2 q = P(sl, d);
    return Vec3(q.x(), q.y(), z);
  };
  const double hw = 0.5 * W;
  const Poly far = region(e, 0.0);
  if (far.empty()) return false;
  HazardItem& it = p->item;
  it.group_kind = "curb";
  it.size = s;
  it.cls = slopeClass(s);
  it.position = P(0.0, 0.0);
  p->edge = true;
  std::vector<Vec3> ramp, fl, fr;
  Poly trap;
  if (down) {
    ramp = {P3(-hw, -L, 0), P3(hw, -L, 0), P3(hw, 0, -h), P3(-hw, 0, -h)};
    fl = {P3(-hw, -L, 0), P3(-hw, 0, -h), P3(-hw - F, 0, 0)};
    fr = {P3(hw, -L, 0), P3(hw + F, 0, 0), P3(hw, 0, -h)};
    trap = {P(-hw, -L), P(hw, -L), P(hw + F, 0), P(-hw - F, 0)};
    const Poly street = region(e, -kTuck);
    p->cuts = {far, trap};
    p->keepout = {far, trap};
    p->entries.push_back("{type: floor, name: " + name(*p, "street") + ", polygon: " +
                         polyText(street) + ", z: " + num(-h) + ", material: lower}");
    it.parts.push_back({name(*p, "street"), HazardClass::kDropOff});
    p->depth = h;
    edgeLook(e, 0.0, p);
  } else {
    ramp = {P3(-hw, 0, 0), P3(hw, 0, 0), P3(hw, L, h), P3(-hw, L, h)};
    fl = {P3(-hw, L, h), P3(-hw, 0, 0), P3(-hw - F, 0, h)};
    fr = {P3(hw, L, h), P3(hw + F, 0, h), P3(hw, 0, 0)};
    trap = {P(-hw - F, 0), P(hw + F, 0), P(hw, L), P(-hw, L)};
    p->keepout = {far};
    int k = 0;
    for (const Poly& piece : subtract(far, trap, 5e-4)) {
      const Poly c = cleanup(piece);
      if (c.empty()) continue;
      const std::string nm = name(*p, "upper" + std::to_string(++k));
      p->entries.push_back("{type: platform, name: " + nm + ", polygon: " + polyText(c) +
                           ", z: " + num(h) + ", thickness: " + num(h + 0.05) +
                           ", material: raised, side_material: curb}");
      it.parts.push_back({nm, HazardClass::kStepUp});
    }
    edgeLook(e, h, p);
  }
  auto slab = [&](const std::string& part, const std::vector<Vec3>& top) {
    std::string s = "{type: slab, name: " + name(*p, part) + ", top: [";
    for (std::size_t i = 0; i < top.size(); ++i)
      s += (i ? ", " : "") + v3(top[i]);
    return s + "], material: ramp, side_material: curb}";
  };
  p->entries.push_back(slab("ramp", ramp));
  p->entries.push_back(slab("flare_l", fl));
  p->entries.push_back(slab("flare_r", fr));
  it.parts.push_back({name(*p, "ramp"), slopeClass(s)});
  it.parts.push_back({name(*p, "flare_l"), slopeClass(flare)});
  it.parts.push_back({name(*p, "flare_r"), slopeClass(flare)});
  for (const auto& v : ramp)
    p->look.emplace_back(v.x(), v.y(), v.z() + 0.02);
  it.description = std::string("curb cut ") + (down ? "down " : "up ") + num(h * 100) +
                   " cm: ramp " + fmt("%.1f", s) + " deg " + num(W) + " m wide, flares " +
                   fmt("%.1f", flare) + " deg";
  return true;
}

// step_up / step_down: a rectangular platform or sunken area h higher or lower.
bool Builder::step(bool up, Plan* p) {
  const double h = stepHeight();
  const double len = q4(rng_.uniform(1.0, 3.0)), wid = q4(rng_.uniform(1.0, 3.0));
  Anchor a;
  if (rng_.chance(0.4)) {
    if (!beside(passClearance() + 0.5 * wid, &a)) return false;
  } else {
    a = ahead(2.0, 4.5, 25.0);
    a.p += dir(a.yaw) * (0.5 * len);
  }
  const double yaw = q2((a.yaw / kDeg) + rng_.uniform(-20.0, 20.0)) * kDeg;
  const Poly r = cleanup(rect(q4(a.p), yaw, len, wid));
  if (r.empty()) return false;
  HazardItem& it = p->item;
  it.group_kind = "step";
  it.size = h;
  it.position = q4(a.p);
  p->keepout.push_back(r);
  if (up) {
    p->entries.push_back("{type: platform, name: " + name(*p, "top") + ", polygon: " + polyText(r) +
                         ", z: " + num(h) + ", thickness: " + num(h + 0.05) +
                         ", material: raised, side_material: curb}");
    it.cls = HazardClass::kStepUp;
    it.parts.push_back({name(*p, "top"), HazardClass::kStepUp});
    it.description =
        "step " + num(h * 100) + " cm up onto a " + num(len) + " x " + num(wid) + " m platform";
    rectLook(r, h, p);
  } else {
    p->cuts.push_back(r);
    p->entries.push_back("{type: floor, name: " + name(*p, "floor") + ", polygon: " +
                         polyText(cleanup(rect(q4(a.p), yaw, len + 2 * kTuck, wid + 2 * kTuck))) +
                         ", z: " + num(-h) + ", material: lower}");
    it.cls = HazardClass::kDropOff;
    it.parts.push_back({name(*p, "floor"), HazardClass::kDropOff});
    it.description = "step " + num(h * 100) + " cm down into a " + num(len) + " x " + num(wid) +
                     " m sunken area";
    p->depth = h;
    rectLook(r, 0.0, p);
  }
  return true;
}

// ramp_up: a ramp from the floor up to a landing; ramp_down: from the floor down to a lower area.
bool Builder::ramp(bool up, Plan* p) {
  const double s0 = slope();
  double L = rng_.uniform(1.0, 2.5);
  double h = L * std::tan(s0 * kDeg);
  if (h > 0.5) L = 0.5 / std::tan(s0 * kDeg);
  L = q4(L);
  h = q4(L * std::tan(s0 * kDeg));
  const double s = std::atan(h / L) / kDeg;
  const double W = q4(rng_.uniform(1.0, 2.0));
  const double land = q4(rng_.uniform(0.8, 1.5)), land_w = q4(W + rng_.uniform(0.0, 0.6));
  Anchor a;
  double yaw;
  if (rng_.chance(0.5)) {  // beside a drive, running along it
    if (!beside(passClearance() + 0.5 * std::max(W, land_w), &a)) return false;
    yaw = a.yaw;
  } else {  // ahead, the low (or top) end towards the robot
    a = ahead(1.5, 3.0, 25.0);
    yaw = a.yaw + rng_.uniform(-25.0, 25.0) * kDeg;
  }
  yaw = q2(yaw / kDeg) * kDeg;
  const Vec2 from = q4(a.p), u = dir(yaw);
  const Vec2 to = q4(from + u * L);
  const Poly ramp_r = cleanup(rectFrom(from, yaw, L, W));
  if (ramp_r.empty()) return false;
  HazardItem& it = p->item;
  it.group_kind = "ramp";
  it.size = s;
  it.cls = slopeClass(s);
  it.position = from;
  const std::string slope_txt = fmt("%.1f", s);
  if (up) {
    // The landing overlaps the ramp's top end by 1 cm (no gap, a step of < 3 mm).
    const Poly land_r = cleanup(rectFrom(q4(to - u * 0.01), yaw, land + 0.01, land_w));
    if (land_r.empty()) return false;
    p->keepout = {ramp_r, land_r};
    p->entries.push_back("{type: ramp, name: " + name(*p, "ramp") + ", from: " + v2(from) +
                         ", to: " + v2(to) + ", width: " + num(W) + ", z_from: 0, z_to: " + num(h) +
                         ", material: ramp, side_material: curb}");
    p->entries.push_back("{type: platform, name: " + name(*p, "landing") + ", polygon: " +
                         polyText(land_r) + ", z: " + num(h) + ", thickness: " + num(h + 0.05) +
                         ", material: raised, side_material: curb}");
    it.parts.push_back({name(*p, "ramp"), slopeClass(s)});
    it.parts.push_back({name(*p, "landing"), HazardClass::kStepUp});
    it.description = "ramp " + slope_txt + " deg up " + num(h) + " m to a landing";
    rectLook(ramp_r, 0.5 * h, p);
  } else {
    // The ramp starts 5 mm under the floor's rim and is 1 cm wider than its cut (no slivers).
    const Vec2 from_t = q4(from - u * 0.005);
    const double z_from = q4(0.005 * std::tan(s * kDeg));
    const Poly low_r = cleanup(rectFrom(to, yaw, land, land_w));
    const Poly low_fill =
        cleanup(rectFrom(q4(to - u * kTuck), yaw, land + 2 * kTuck, land_w + 2 * kTuck));
    if (low_r.empty() || low_fill.empty()) return false;
    p->cuts = {ramp_r, low_r};
    p->keepout = {ramp_r, low_r};
    p->entries.push_back("{type: ramp, name: " + name(*p, "ramp") + ", from: " + v2(from_t) +
                         ", to: " + v2(to) + ", width: " + num(W + 0.01) +
                         ", z_from: " + num(z_from) + ", z_to: " + num(-h) +
                         ", material: ramp, side_material: curb}");
    p->entries.push_back("{type: floor, name: " + name(*p, "lower") + ", polygon: " +
                         polyText(low_fill) + ", z: " + num(-h) + ", material: lower}");
    it.parts.push_back({name(*p, "ramp"), slopeClass(s)});
    it.parts.push_back({name(*p, "lower"), HazardClass::kDropOff});
    it.description = "ramp " + slope_txt + " deg down " + num(h) + " m to a lower area";
    p->depth = h;
    rectLook(ramp_r, -0.5 * h, p);
  }
  return true;
}

// platform_edge (0.3-1 m) and loading_dock (1-1.4 m): a deep drop along a straight edge.
bool Builder::deepEdge(const std::string& kind, Plan* p) {
  const bool dock = kind == "loading_dock";
  const double h = q4(dock ? rng_.uniform(1.0, 1.4) : rng_.uniform(0.3, 1.0));
  const Edge e = edge(passClearance());
  const Poly far = region(e, 0.0), low = region(e, -kTuck);
  if (far.empty() || low.empty()) return false;
  p->edge = true;
  p->cuts.push_back(far);
  p->keepout.push_back(far);
  p->entries.push_back("{type: floor, name: " + name(*p, "lower") + ", polygon: " + polyText(low) +
                       ", z: " + num(-h) + ", material: yard}");
  HazardItem& it = p->item;
  it.group_kind = "drop";
  it.cls = HazardClass::kDropOff;
  it.size = h;
  it.position = e.foot;
  it.parts.push_back({name(*p, "lower"), HazardClass::kDropOff});
  it.description = std::string(dock ? "loading dock edge " : "platform edge ") + num(h) + " m high";
  p->depth = h;
  edgeLook(e, 0.0, p);
  return true;
}

// pit (0.2-1 m deep) and light_well (1-2.5 m deep, a wall on its far side, sometimes a railing
// on its near side): a rectangular hole in the floor.
bool Builder::pit(const std::string& kind, Plan* p) {
  const bool well = kind == "light_well";
  const double h = q4(well ? rng_.uniform(1.0, 2.5) : rng_.uniform(0.2, 1.0));
  const double len = q4(well ? rng_.uniform(0.8, 1.5) : rng_.uniform(0.6, 2.0));
  const double wid = q4(well ? rng_.uniform(1.5, 3.0) : rng_.uniform(0.6, 2.0));
  Anchor a;
  if (rng_.chance(0.4)) {
    if (!beside(passClearance() + 0.5 * len, &a)) return false;
  } else {
    a = ahead(2.0, 4.5, 25.0);
    a.p += dir(a.yaw) * (0.5 * len);
  }
  // The rectangle's `len` axis points away from the robot (wall on the far long side).
  // Beside a drive: the long side along it, the wall on the side away from it.
  double yaw = a.beside ? a.yaw + a.side * M_PI / 2.0 : a.yaw;
  yaw = q2(yaw / kDeg + rng_.uniform(-10.0, 10.0)) * kDeg;
  const Vec2 c = q4(a.p), u = dir(yaw), w = perp(u);
  const Poly hole = cleanup(rect(c, yaw, len, wid));
  const Poly fill = cleanup(rect(c, yaw, len + 2 * kTuck, wid + 2 * kTuck));
  if (hole.empty() || fill.empty()) return false;
  HazardItem& it = p->item;
  it.group_kind = "drop";
  it.cls = HazardClass::kDropOff;
  it.size = h;
  it.position = c;
  p->cuts.push_back(hole);
  p->keepout.push_back(hole);
  p->entries.push_back("{type: floor, name: " + name(*p, "floor") + ", polygon: " + polyText(fill) +
                       ", z: " + num(-h) + ", material: pit}");
  it.parts.push_back({name(*p, "floor"), HazardClass::kDropOff});
  p->depth = h;
  rectLook(hole, 0.0, p);
  it.description =
      (well ? "light well " : "pit ") + num(len) + " x " + num(wid) + " m, " + num(h) + " m deep";
  if (well) {
    // The building's wall on the far long side, from the well's floor up.
    const double th = 0.2, wh = q4(rng_.uniform(2.5, 4.0));
    const Vec2 wa = q4(c + u * (0.5 * len + 0.5 * th) - w * (0.5 * wid + 0.3));
    const Vec2 wb = q4(c + u * (0.5 * len + 0.5 * th) + w * (0.5 * wid + 0.3));
    p->entries.push_back("{type: wall, name: " + name(*p, "wall") + ", from: " + v2(wa) +
                         ", to: " + v2(wb) + ", height: " + num(wh + h) +
                         ", thickness: " + num(th) + ", z: " + num(-h) + ", material: wall}");
    p->keepout.push_back(cleanup(rect(q4(0.5 * (wa + wb)), yaw, th, wid + 0.6)));
    if (rng_.chance(0.5)) {
      const Vec2 ra = q4(c - u * (0.5 * len + 0.06) - w * (0.5 * wid));
      const Vec2 rb = q4(c - u * (0.5 * len + 0.06) + w * (0.5 * wid));
      p->entries.push_back("{type: railing, name: " + name(*p, "railing") + ", from: " + v2(ra) +
                           ", to: " + v2(rb) +
                           ", height: 1.0, post_spacing: 1.0, material: metal}");
      p->keepout.push_back(cleanup(rect(q4(0.5 * (ra + rb)), yaw, 0.08, wid + 0.08)));
      it.description += ", railing";
    }
  }
  return true;
}

// stairs_down: 3-6 steps of 15-18 cm down a stairwell, a landing at the foot.
bool Builder::stairs(Plan* p) {
  const int count = rng_.integer(3, 6);
  const double rise = q4(rng_.uniform(0.15, 0.18)), run = q4(rng_.uniform(0.27, 0.32));
  const double W = q4(rng_.uniform(1.0, 1.8)), landing = q4(rng_.uniform(1.0, 1.5));
  const double len = count * run + landing;
  Anchor a = ahead(2.0, 4.0, 25.0);
  const double yaw = q2(a.yaw / kDeg + rng_.uniform(-30.0, 30.0)) * kDeg;
  const Vec2 rim = q4(a.p), u = dir(yaw);
  const Poly well = cleanup(rectFrom(rim, yaw, len - 0.01, W));
  if (well.empty()) return false;
  const double depth = q4(count * rise);
  // Steps from 5 mm under the rim, 1 cm wider than the opening (no slivers).
  const Vec2 from = q4(rim - u * 0.005);
  p->cuts.push_back(well);
  p->keepout.push_back(well);
  p->entries.push_back("{type: stairs, name: " + name(*p, "") + ", from: " + v2(from) +
                       ", direction_deg: " + num(yaw / kDeg) + ", width: " + num(W + 0.01) +
                       ", count: " + std::to_string(count) + ", rise: " + num(-rise) +
                       ", run: " + num(run) + ", landing: " + num(landing) +
                       ", material: stair, side_material: curb}");
  HazardItem& it = p->item;
  it.group_kind = "drop";
  it.cls = HazardClass::kDropOff;
  it.size = depth;
  it.position = rim;
  it.parts.push_back({name(*p, ""), HazardClass::kDropOff});
  it.description = "stairs down: " + std::to_string(count) + " steps of " + num(rise * 100) +
                   " cm, " + num(W) + " m wide";
  p->depth = depth;
  rectLook(well, 0.0, p);
  return true;
}

// Obstacles on the start level: poles, bollards, tables, shelves, thin legs, low obstacles.
bool Builder::obstacle(const std::string& kind, Plan* p) {
  HazardItem& it = p->item;
  // Footprint half-extent across a drive, for passes at a chosen lateral clearance.
  double half = 0.0, half_len = 0.0;
  double pole_r = 0.0, height = 0.0, sq = 0.0;
  bool square = false;
  double tl = 0.0, tw = 0.0, top_th = 0.0, leg_r = 0.0, inset = 0.0;
  double wall_len = 0.0, wall_h = 0.0, shelf_d = 0.0, shelf_th = 0.0, shelf_len = 0.0;
  int legs = 0;
  double leg_sp = 0.0;
  Vec3 low_size = Vec3::Zero();
  if (kind == "pole") {
    pole_r = q4(0.5 * rng_.uniform(0.05, 0.15));
    height = q4(rng_.uniform(0.8, 1.5));
    half = half_len = pole_r;
    it.group_kind = "pole";
    it.cls = HazardClass::kObstacle;
    it.size = 2 * pole_r;
  } else if (kind == "bollard") {
    square = rng_.chance(0.4);
    height = q4(rng_.uniform(0.3, 1.2));
    if (square) {
      sq = q4(rng_.uniform(0.08, 0.3));
      half = half_len = 0.5 * sq * std::sqrt(2.0);
      it.size = sq;
    } else {
      pole_r = q4(0.5 * rng_.uniform(0.1, 0.3));
      half = half_len = pole_r;
      it.size = 2 * pole_r;
    }
    it.group_kind = "pole";
    it.cls = HazardClass::kObstacle;
  } else if (kind == "table") {
    tl = q4(rng_.uniform(0.6, 1.6));
    tw = q4(rng_.uniform(0.5, 1.0));
    height = q4(rng_.uniform(0.5, 1.2));
    top_th = q4(rng_.uniform(0.02, 0.05));
    leg_r = q4(0.5 * rng_.uniform(0.02, 0.05));
    inset = q4(rng_.uniform(0.02, 0.1));
    half = 0.5 * tw;
    half_len = 0.5 * tl;
    it.group_kind = "overhang";
    it.cls = HazardClass::kOverhang;
    it.size = height;
  } else if (kind == "shelf") {
    wall_len = q4(rng_.uniform(1.5, 3.0));
    wall_h = q4(rng_.uniform(1.8, 2.5));
    shelf_d = q4(rng_.uniform(0.25, 0.5));
    shelf_th = q4(rng_.uniform(0.02, 0.04));
    shelf_len = q4(wall_len - rng_.uniform(0.0, 0.6));
    height = q4(rng_.uniform(0.5, 1.2));
    half = 0.5 * (shelf_d + 0.12);
    half_len = 0.5 * wall_len;
    it.group_kind = "overhang";
    it.cls = HazardClass::kOverhang;
    it.size = height;
  } else if (kind == "legs") {
    const double u = rng_.uniform();
    legs = u < 0.2 ? 1 : (u < 0.5 ? 2 : 4);
    leg_r = q4(0.5 * rng_.uniform(0.02, 0.05));
    height = q4(rng_.uniform(0.4, 1.0));
    leg_sp = q4(legs == 2 ? rng_.uniform(0.4, 1.0) : rng_.uniform(0.35, 0.6));
    half = legs == 4 ? 0.5 * leg_sp + leg_r : leg_r;
    half_len = legs == 1 ? leg_r : 0.5 * leg_sp + leg_r;
    it.group_kind = "legs";
    it.cls = HazardClass::kObstacle;
    it.size = 2 * leg_r;
  } else {  // kerb_stone, box, bag: 5-15 cm high
    const double h = q4(rng_.uniform(0.05, 0.15));
    if (kind == "kerb_stone") {
      low_size = Vec3(q4(rng_.uniform(0.4, 1.0)), q4(rng_.uniform(0.1, 0.2)), h);
    } else if (kind == "box") {
      low_size = Vec3(q4(rng_.uniform(0.2, 0.6)), q4(rng_.uniform(0.2, 0.6)), h);
    } else {
      low_size = Vec3(q4(rng_.uniform(0.3, 0.6)), q4(rng_.uniform(0.25, 0.45)), h);
    }
    half = 0.5 * low_size.y();
    half_len = 0.5 * low_size.x();
    height = h;
    it.group_kind = "low";
    it.cls = HazardClass::kObstacle;
    it.size = h;
  }
  // Placement: beside a drive at a chosen lateral clearance (the item's long axis along it), or
  // ahead of the robot at some frame.
  Anchor a;
  double yaw;
  if (rng_.chance(0.6) && beside(passClearance() + half, &a)) {
    yaw = a.yaw;
  } else {
    a = ahead(1.5, 4.5, 25.0);
    yaw = a.yaw + M_PI / 2.0 + rng_.uniform(-30.0, 30.0) * kDeg;  // across the view
  }
  yaw = q2(yaw / kDeg) * kDeg;
  const Vec2 c = q4(a.p), u = dir(yaw), w = perp(u);
  const std::string yaw_txt = num(yaw / kDeg);
  it.position = c;
  if (kind == "pole" || (kind == "bollard" && !square)) {
    p->entries.push_back("{type: pole, name: " + name(*p, "") + ", at: " + v2(c) +
                         ", radius: " + num(pole_r) + ", height: " + num(height) +
                         ", material: " + (kind == "pole" ? "metal" : "paint") + "}");
    Poly circle;
    for (int k = 0; k < 12; ++k)
      circle.push_back(c + dir(k * M_PI / 6.0) * (pole_r / std::cos(M_PI / 12.0)));
    p->keepout.push_back(circle);
    it.description = kind + " " + num(2 * pole_r * 100) + " cm wide, " + num(height) + " m high";
  } else if (kind == "bollard") {
    p->entries.push_back(
        "{type: box, name: " + name(*p, "") + ", base: " + v3(Vec3(c.x(), c.y(), 0)) +
        ", size: " + v3(Vec3(sq, sq, height)) + ", yaw_deg: " + yaw_txt + ", material: paint}");
    p->keepout.push_back(rect(c, yaw, sq, sq));
    it.description = "square bollard " + num(sq * 100) + " cm wide, " + num(height) + " m high";
  } else if (kind == "table") {
    p->entries.push_back("{type: table, name: " + name(*p, "") + ", center: " + v2(c) +
                         ", size: " + v2(Vec2(tl, tw)) + ", height: " + num(height) +
                         ", top_thickness: " + num(top_th) + ", leg_radius: " + num(leg_r) +
                         ", leg_inset: " + num(inset) + ", yaw_deg: " + yaw_txt +
                         ", material: wood}");
    p->keepout.push_back(rect(c, yaw, tl, tw));
    it.description = "table " + num(tl) + " x " + num(tw) + " m, top at " + num(height) +
                     " m, legs " + num(2 * leg_r * 100) + " cm";
  } else if (kind == "shelf") {
    // The wall on the far side of the footprint from the robot, the board on its near face.
    // Footprint across: the board (shelf_d) on the robot's side, the wall (0.12 m) behind it.
    Vec2 away = a.beside ? Vec2(w * a.side) : Vec2(w.dot(dir(a.yaw)) >= 0.0 ? w : Vec2(-w));
    const Vec2 wc = q4(c + away * (0.5 * shelf_d));
    const Vec2 bc = q4(c - away * 0.06);
    const Vec2 wa = q4(wc - u * (0.5 * wall_len)), wb = q4(wc + u * (0.5 * wall_len));
    p->entries.push_back("{type: wall, name: " + name(*p, "wall") + ", from: " + v2(wa) +
                         ", to: " + v2(wb) + ", height: " + num(wall_h) +
                         ", thickness: 0.12, material: wall}");
    p->entries.push_back("{type: box, name: " + name(*p, "board") +
                         ", center: " + v3(Vec3(bc.x(), bc.y(), height - 0.5 * shelf_th)) +
                         ", size: " + v3(Vec3(shelf_len, shelf_d, shelf_th)) +
                         ", yaw_deg: " + yaw_txt + ", material: wood}");
    p->keepout.push_back(rect(c, yaw, wall_len, shelf_d + 0.12));
    it.description = "shelf " + num(shelf_d) + " m deep at " + num(height) + " m on a wall";
  } else if (kind == "legs") {
    std::vector<Vec2> at;
    if (legs == 1) at = {c};
    if (legs == 2) at = {c - u * (0.5 * leg_sp), c + u * (0.5 * leg_sp)};
    if (legs == 4)
      for (int k = 0; k < 4; ++k)
        at.push_back(c + u * ((k & 1 ? 0.5 : -0.5) * leg_sp) + w * ((k & 2 ? 0.5 : -0.5) * leg_sp));
    for (std::size_t k = 0; k < at.size(); ++k)
      p->entries.push_back("{type: pole, name: " + name(*p, "leg" + std::to_string(k + 1)) +
                           ", at: " + v2(q4(at[k])) + ", radius: " + num(leg_r) +
                           ", height: " + num(height) + ", material: metal}");
    p->keepout.push_back(rect(c, yaw, 2 * half_len, 2 * half));
    it.description = std::to_string(legs) + " thin leg" + (legs > 1 ? "s " : " ") +
                     num(2 * leg_r * 100) + " cm, " + num(height) + " m high";
  } else {
    if (kind == "bag") {
      const Vec2 top(q4(low_size.x() * 0.6), q4(low_size.y() * 0.6));
      p->entries.push_back("{type: mound, name: " + name(*p, "") + ", center: " + v2(c) +
                           ", base_size: " + v2(low_size.head<2>()) + ", top_size: " + v2(top) +
                           ", height: " + num(low_size.z()) + ", yaw_deg: " + yaw_txt +
                           ", material: fabric}");
    } else {
      p->entries.push_back("{type: box, name: " + name(*p, "") +
                           ", base: " + v3(Vec3(c.x(), c.y(), 0)) + ", size: " + v3(low_size) +
                           ", yaw_deg: " + yaw_txt +
                           ", material: " + (kind == "box" ? "cardboard" : "stone") + "}");
    }
    p->keepout.push_back(rect(c, yaw, low_size.x(), low_size.y()));
    it.description = kind + " " + num(low_size.z() * 100) + " cm high";
  }
  for (const Poly& k : p->keepout)
    for (const Vec2& v : k)
      p->look.emplace_back(v.x(), v.y(), std::min(0.5 * height, 0.5));
  p->look.emplace_back(c.x(), c.y(), height);
  return true;
}

// wall (2-5 m, 1-2.5 m high) or doorway (a wall with a 0.8-1.2 m gap), across the view ahead or
// along a drive.
bool Builder::wall(bool doorway, Plan* p) {
  const double len = q4(doorway ? rng_.uniform(3.0, 6.0) : rng_.uniform(2.0, 5.0));
  const double h = q4(doorway ? rng_.uniform(2.0, 2.5) : rng_.uniform(1.0, 2.5));
  const double th = q4(rng_.uniform(0.1, 0.2));
  const double gap = q4(rng_.uniform(0.8, 1.2));
  Anchor a;
  double yaw;
  if (!doorway && rng_.chance(0.4) && beside(passClearance() + 0.5 * th, &a)) {
    yaw = a.yaw;
  } else {
    a = ahead(2.0, 4.5, 20.0);
    yaw = a.yaw + M_PI / 2.0 + rng_.uniform(-20.0, 20.0) * kDeg;
  }
  yaw = q2(yaw / kDeg) * kDeg;
  const Vec2 c = q4(a.p), u = dir(yaw);
  HazardItem& it = p->item;
  it.group_kind = "wall";
  it.cls = HazardClass::kObstacle;
  it.position = c;
  if (!doorway) {
    const Vec2 wa = q4(c - u * (0.5 * len)), wb = q4(c + u * (0.5 * len));
    p->entries.push_back("{type: wall, name: " + name(*p, "") + ", from: " + v2(wa) +
                         ", to: " + v2(wb) + ", height: " + num(h) + ", thickness: " + num(th) +
                         ", material: wall}");
    p->keepout.push_back(rect(c, yaw, len, th));
    it.size = h;
    it.description = "wall " + num(len) + " m long, " + num(h) + " m high";
    for (double s = -0.5; s <= 0.5; s += 0.125)
      p->look.emplace_back(c.x() + u.x() * s * len, c.y() + u.y() * s * len, 0.5);
    return true;
  }
  // The gap near the middle, so that it is in view.
  const double off = rng_.uniform(-0.5, 0.5);
  const Vec2 g = q4(c + u * off);
  const Vec2 a0 = q4(c - u * (0.5 * len)), a1 = q4(g - u * (0.5 * gap));
  const Vec2 b0 = q4(g + u * (0.5 * gap)), b1 = q4(c + u * (0.5 * len));
  const double door_h = 2.0;
  for (const auto& seg : {std::make_pair(a0, a1), std::make_pair(b0, b1)}) {
    const bool first = seg.first == a0;
    p->entries.push_back("{type: wall, name: " + name(*p, first ? "left" : "right") +
                         ", from: " + v2(seg.first) + ", to: " + v2(seg.second) +
                         ", height: " + num(h) + ", thickness: " + num(th) + ", material: wall}");
    const double L = (seg.second - seg.first).norm();
    p->keepout.push_back(rect(0.5 * (seg.first + seg.second), yaw, L, th));
    for (double s = 0.0; s <= 1.0; s += 0.25) {
      const Vec2 q = seg.first + (seg.second - seg.first) * s;
      p->look.emplace_back(q.x(), q.y(), 0.5);
    }
  }
  if (h > door_h + 0.05) {  // the lintel above the gap: above robot height, driven under
    p->entries.push_back("{type: box, name: " + name(*p, "lintel") +
                         ", center: " + v3(Vec3(g.x(), g.y(), 0.5 * (door_h + h))) +
                         ", size: " + v3(Vec3(gap + 0.02, th, h - door_h)) +
                         ", yaw_deg: " + num(yaw / kDeg) + ", material: wall}");
  }
  p->look.emplace_back(g.x(), g.y(), 0.02);  // the floor in the gap
  it.size = gap;
  it.description = "doorway " + num(gap) + " m wide in a " + num(len) + " m wall";
  return true;
}

bool Builder::build(const std::string& kind, int index, const std::vector<Plan>& placed,
                    Plan* out) {
  Plan p;
  p.item.kind = kind;
  p.item.group = "h" + std::to_string(index) + "_" + kind;
  bool ok = false;
  if (kind == "curb_down" || kind == "curb_up")
    ok = curb(kind, &p);
  else if (kind == "curb_cut_down" || kind == "curb_cut_up")
    ok = curbCut(kind == "curb_cut_down", &p);
  else if (kind == "step_up" || kind == "step_down")
    ok = step(kind == "step_up", &p);
  else if (kind == "ramp_up" || kind == "ramp_down")
    ok = ramp(kind == "ramp_up", &p);
  else if (kind == "platform_edge" || kind == "loading_dock")
    ok = deepEdge(kind, &p);
  else if (kind == "pit" || kind == "light_well")
    ok = pit(kind, &p);
  else if (kind == "stairs_down")
    ok = stairs(&p);
  else if (kind == "wall" || kind == "doorway")
    ok = wall(kind == "doorway", &p);
  else
    ok = obstacle(kind, &p);
  if (!ok || p.keepout.empty()) return false;
  for (Poly& k : p.keepout) {
    if (signedArea(k) < 0.0) std::reverse(k.begin(), k.end());
    if (k.size() < 3) return false;
  }
  // Inside the area (edges reach its border by construction), clear of the trajectory and of the
  // other items.
  if (!p.edge) {
    const Eigen::AlignedBox2d b = boxOf(area_);
    const Poly inner = {b.min() + Vec2(0.3, 0.3), Vec2(b.max().x() - 0.3, b.min().y() + 0.3),
                        b.max() - Vec2(0.3, 0.3), Vec2(b.min().x() + 0.3, b.max().y() - 0.3)};
    for (const Poly& k : p.keepout)
      for (const Vec2& v : k)
        if (!insideConvex(v, inner)) return false;
  }
  double clearance = kInf;
  for (const Poly& k : p.keepout)
    clearance = std::min(clearance, routeDistance(route_, k));
  if (clearance < cfg_.min_clearance) return false;
  for (const Plan& q : placed)
    for (const Poly& k : p.keepout)
      for (const Poly& l : q.keepout)
        if (polyDistance(k, l) < kItemGap) return false;
  p.item.clearance = clearance;
  *out = std::move(p);
  return true;
}

// ---- visibility ----

// Per item: frames whose left camera sees one of its look points (in the image, kViewMin to
// kViewMax away, not hidden behind another item or scenery); and frames that see any item.
void visibility(const SceneFile& f, const std::vector<Plan>& plans, std::vector<int>* per_item,
                int* frames_any, int* frames) {
  const StereoHeadConfig& head = f.camera;
  const Eigen::Isometry3d T_base_opt = head.baseToLeftOptical();
  const double fx = head.fx(), cx = head.cx(), cy = head.cy();
  const double mx = 0.02 * head.width, my = 0.02 * head.height;
  const std::vector<RobotPose> poses = sampleTrajectory(f.trajectory);
  per_item->assign(plans.size(), 0);
  *frames_any = 0;
  *frames = static_cast<int>(poses.size());
  for (const RobotPose& pose : poses) {
    const Eigen::Isometry3d T =
        basePose(pose.x, pose.y, f.trajectory.base_z, pose.yaw) * T_base_opt;
    const Eigen::Matrix3d Rt = T.linear().transpose();
    const Vec3 o = T.translation();
    bool any = false;
    for (std::size_t i = 0; i < plans.size(); ++i) {
      bool seen = false;
      for (const Vec3& P : plans[i].look) {
        const Vec3 pc = Rt * (P - o);
        const double dist = (P - o).norm();
        if (pc.z() < 0.3 || dist < kViewMin || dist > kViewMax) continue;
        const double u = fx * pc.x() / pc.z() + cx, v = fx * pc.y() / pc.z() + cy;
        if (u < mx || u > head.width - 1 - mx || v < my || v > head.height - 1 - my) continue;
        Ray ray;
        ray.origin = o;
        ray.dir = P - o;
        Hit hit;
        if (f.scene.intersect(ray, 1e-6, 0.98, &hit)) {
          const std::string& g = f.scene.primitives[hit.primitive].group;
          if (g.compare(0, plans[i].item.group.size(), plans[i].item.group) != 0) continue;
        }
        seen = true;
        break;
      }
      if (seen) {
        ++(*per_item)[i];
        any = true;
      }
    }
    if (any) ++*frames_any;
  }
}

const std::vector<std::string> kIndoorFloors = {"polished", "matt", "carpet", "tiles", "concrete"};
const std::vector<std::string> kOutdoorFloors = {"concrete", "paving", "asphalt", "tiles"};

// One whole scene from the generator's current state; empty error on success.
std::string attempt(std::uint64_t seed, const ProceduralConfig& cfg, PortableRng& rng,
                    ProceduralScene* out) {
  ProceduralScene sc;
  sc.seed = seed;
  // Look: indoor or outdoor, floor kind, stereo head, light.
  sc.indoor = rng.chance(cfg.indoor_probability);
  const std::vector<std::string>& kinds = sc.indoor ? kIndoorFloors : kOutdoorFloors;
  sc.floor_kind = kinds[rng.integer(0, static_cast<int>(kinds.size()) - 1)];
  const double mount_z = q3(rng.uniform(cfg.mount_z_min, cfg.mount_z_max));
  const double pitch = q2(rng.uniform(cfg.pitch_min_deg, cfg.pitch_max_deg));

  const Route route = makeRoute(cfg, rng);
  if (route.frames.empty()) return "empty trajectory";
  // The area: the swept footprint plus a margin, at least area_min_size wide, on a 0.1 m grid.
  Eigen::AlignedBox2d box = route.box;
  box.min() -= Vec2::Constant(cfg.area_margin);
  box.max() += Vec2::Constant(cfg.area_margin);
  for (int i = 0; i < 2; ++i) {
    const double grow = 0.5 * std::max(0.0, cfg.area_min_size - box.sizes()[i]);
    box.min()[i] = std::floor((box.min()[i] - grow) * 10.0) / 10.0;
    box.max()[i] = std::ceil((box.max()[i] + grow) * 10.0) / 10.0;
  }
  const Poly area = {box.min(), Vec2(box.max().x(), box.min().y()), box.max(),
                     Vec2(box.min().x(), box.max().y())};

  // Hazard items: a kind drawn by weight, a few placements tried, another kind after that.
  std::vector<std::pair<std::string, double>> weights(cfg.kind_weights.begin(),
                                                      cfg.kind_weights.end());
  double total = 0.0;
  for (const auto& kw : weights)
    total += kw.second;
  auto drawKind = [&]() {
    double u = rng.uniform() * total;
    for (const auto& kw : weights) {
      if (u < kw.second) return kw.first;
      u -= kw.second;
    }
    return weights.back().first;
  };
  const int n_items = rng.integer(cfg.min_items, cfg.max_items);
  Builder builder(cfg, rng, route, area);
  std::vector<Plan> plans;
  int edges = 0;
  for (int i = 0; i < n_items; ++i) {
    std::string kind;
    for (int tries = 0; tries < 40; ++tries) {
      if (tries % 8 == 0) kind = drawKind();
      Plan p;
      if (!builder.build(kind, static_cast<int>(plans.size()) + 1, plans, &p)) continue;
      if (p.edge && edges >= 2) continue;
      edges += p.edge ? 1 : 0;
      plans.push_back(std::move(p));
      break;
    }
  }
  if (static_cast<int>(plans.size()) < cfg.min_items) return "could not place enough hazards";

  // Materials.
  const Mat floor = floorMaterial(sc.floor_kind, rng);
  Mat curb;
  curb.scale = 0.2;
  curb.contrast = q3(rng.uniform(0.06, 0.15));
  curb.colour = greyish(rng, 0.5, 0.7);
  const Mat lower =
      floorMaterial(sc.indoor ? kinds[rng.integer(0, static_cast<int>(kinds.size()) - 1)]
                              : (rng.chance(0.6) ? "asphalt" : "concrete"),
                    rng);
  const Mat raised =
      floorMaterial(sc.indoor ? sc.floor_kind : (rng.chance(0.5) ? "paving" : "concrete"), rng);
  Mat ramp = floorMaterial(rng.chance(0.5) ? sc.floor_kind : "concrete", rng);
  Mat yard = floorMaterial(rng.chance(0.5) ? "asphalt" : "concrete", rng);
  Mat pit = floorMaterial("concrete", rng);
  pit.colour = greyish(rng, 0.3, 0.5);
  Mat stair = floorMaterial(rng.chance(0.5) ? "concrete" : "tiles", rng);
  Mat wall;
  if (sc.indoor) {
    wall.texture = rng.chance(0.5) ? "plain" : "noise";
    wall.scale = q3(rng.uniform(0.3, 1.0));
    wall.contrast = q3(rng.uniform(0.02, 0.08));
    wall.colour = greyish(rng, 0.6, 0.9);
  } else {
    wall.texture = rng.chance(0.5) ? "bricks" : "noise";
    wall.scale = q3(rng.uniform(0.2, 0.4));
    wall.contrast = q3(rng.uniform(0.1, 0.25));
    wall.line_width = wall.texture == "bricks" ? 0.05 : -1.0;
    wall.colour =
        rng.chance(0.5) ? tinted(rng, Vec3(0.62, 0.45, 0.36), 0.1) : greyish(rng, 0.5, 0.8);
  }
  Mat metal;
  metal.texture = "plain";
  metal.colour = greyish(rng, 0.15, 0.45);
  Mat paint;
  static const Vec3 kPaints[] = {
      {0.75, 0.6, 0.1}, {0.6, 0.15, 0.12}, {0.2, 0.25, 0.3}, {0.85, 0.85, 0.82}};
  paint.contrast = 0.05;
  paint.scale = 0.1;
  paint.colour = tinted(rng, kPaints[rng.integer(0, 3)], 0.1);
  Mat wood;
  wood.texture = "stripes";
  wood.scale = q3(rng.uniform(0.04, 0.1));
  wood.contrast = q3(rng.uniform(0.1, 0.25));
  wood.colour = tinted(rng, Vec3(0.5, 0.36, 0.22), 0.2);
  Mat fabric;
  fabric.scale = 0.05;
  fabric.contrast = 0.15;
  fabric.colour = tinted(rng, Vec3(0.3, 0.3, 0.35), 0.4);
  Mat cardboard;
  cardboard.scale = 0.1;
  cardboard.contrast = 0.08;
  cardboard.colour = tinted(rng, Vec3(0.6, 0.45, 0.3), 0.1);
  Mat stone;
  stone.scale = 0.1;
  stone.contrast = 0.15;
  stone.colour = greyish(rng, 0.5, 0.75);

  // Light.
  Vec3 light;
  double ambient, diffuse;
  Vec3 horizon, zenith;
  if (sc.indoor) {
    light = Vec3(q3(rng.uniform(-0.3, 0.3)), q3(rng.uniform(-0.3, 0.3)), -1.0);
    ambient = q3(rng.uniform(0.45, 0.6));
    diffuse = q3(rng.uniform(0.3, 0.5));
    const double g = q3(rng.uniform(0.45, 0.65));
    horizon = Vec3(g, g, g);
    zenith = Vec3(q3(g + 0.05), q3(g + 0.05), q3(g + 0.05));
  } else {
    const double el = rng.uniform(25.0, 70.0) * kDeg, az = rng.uniform(0.0, 360.0) * kDeg;
    light =
        Vec3(q3(-std::cos(el) * std::cos(az)), q3(-std::cos(el) * std::sin(az)), q3(-std::sin(el)));
    ambient = q3(rng.uniform(0.35, 0.5));
    diffuse = q3(rng.uniform(0.55, 0.75));
    horizon = tinted(rng, Vec3(0.82, 0.86, 0.92), 0.05);
    zenith = tinted(rng, Vec3(0.5, 0.62, 0.85), 0.1);
  }

  // Base floor: the area minus the sunken items' cuts, in convex pieces.
  double depth = 0.0;
  for (const Plan& p : plans)
    depth = std::max(depth, p.depth);
  std::vector<Poly> pieces = {area};
  for (const Plan& p : plans) {
    for (const Poly& cut : p.cuts) {
      Poly c = cut;
      if (signedArea(c) < 0.0) std::reverse(c.begin(), c.end());
      std::vector<Poly> next;
      for (const Poly& piece : pieces)
        for (const Poly& q : subtract(piece, c, 5e-4))
          next.push_back(q);
      pieces.swap(next);
    }
  }

  std::ostringstream y;
  const std::uint64_t file_seed = seed % 999999937ull + 1;
  y << "# Procedural scene (include/stereo_safety_map/dataset/procedural_scene.h), seed " << seed
    << ".\n# Hazards:\n";
  for (const Plan& p : plans)
    y << "#   " << p.item.group << ": " << p.item.description << " (" << toString(p.item.cls)
      << ")\n";
  std::string desc =
      std::string(sc.indoor ? "indoor" : "outdoor") + ", " + sc.floor_kind + " floor; ";
  for (std::size_t i = 0; i < plans.size(); ++i)
    desc += (i ? ", " : "") + plans[i].item.kind;
  y << "name: procedural_" << seed << "\n";
  y << "description: \"procedural seed " << seed << ": " << desc << "\"\n";
  y << "look: " << (sc.indoor ? "indoor" : "outdoor") << "\n";
  y << "seed: " << file_seed << "\n";
  y << "lighting: {direction: " << v3(light) << ", ambient: " << num(ambient)
    << ", diffuse: " << num(diffuse) << "}\n";
  y << "sky: {horizon: " << v3(horizon) << ", zenith: " << v3(zenith) << "}\n";
  y << "camera: {mount: [0.25, 0.06, " << num(mount_z) << "], pitch_deg: " << num(pitch) << "}\n";
  y << "materials:\n";
  y << "  floor: " << floor.yaml() << "\n";
  y << "  curb: " << curb.yaml() << "\n";
  y << "  lower: " << lower.yaml() << "\n";
  y << "  raised: " << raised.yaml() << "\n";
  y << "  ramp: " << ramp.yaml() << "\n";
  y << "  yard: " << yard.yaml() << "\n";
  y << "  pit: " << pit.yaml() << "\n";
  y << "  stair: " << stair.yaml() << "\n";
  y << "  wall: " << wall.yaml() << "\n";
  y << "  metal: " << metal.yaml() << "\n";
  y << "  paint: " << paint.yaml() << "\n";
  y << "  wood: " << wood.yaml() << "\n";
  y << "  fabric: " << fabric.yaml() << "\n";
  y << "  cardboard: " << cardboard.yaml() << "\n";
  y << "  stone: " << stone.yaml() << "\n";
  y << "primitives:\n";
  y << "  # The start level (z = 0), cut around the sunken areas.\n";
  int k = 0;
  for (const Poly& piece : pieces) {
    const Poly c = cleanup(piece);
    if (c.empty()) continue;
    y << "  - {type: floor, name: floor_" << ++k << ", polygon: " << polyText(c)
      << ", z: 0, thickness: " << num(depth + 0.3) << ", material: floor, side_material: curb}\n";
  }
  for (const Plan& p : plans) {
    y << "  # " << p.item.group << ": " << p.item.description << "\n";
    for (const std::string& e : p.entries)
      y << "  - " << e << "\n";
  }
  // Scenery: room walls indoors, a facade or two outdoors, just outside the area and down to the
  // deepest level.
  const double wall_z = -(depth + 0.3);
  const double room_h = q2(sc.indoor ? rng.uniform(2.5, 3.2) : rng.uniform(4.0, 8.0));
  const double p_side = sc.indoor ? 0.75 : 0.25;
  const Vec2 lo = box.min(), hi = box.max();
  const Vec2 corners[4][2] = {{Vec2(lo.x(), lo.y() - 0.1), Vec2(hi.x(), lo.y() - 0.1)},
                              {Vec2(hi.x() + 0.1, lo.y()), Vec2(hi.x() + 0.1, hi.y())},
                              {Vec2(hi.x(), hi.y() + 0.1), Vec2(lo.x(), hi.y() + 0.1)},
                              {Vec2(lo.x() - 0.1, hi.y()), Vec2(lo.x() - 0.1, lo.y())}};
  bool scenery = false;
  for (int side = 0; side < 4; ++side) {
    if (!rng.chance(p_side)) continue;
    if (!scenery) y << "  # Scenery.\n";
    scenery = true;
    y << "  - {type: wall, name: " << (sc.indoor ? "room_wall_" : "facade_") << side + 1
      << ", from: " << v2(corners[side][0]) << ", to: " << v2(corners[side][1])
      << ", height: " << num(room_h - wall_z) << ", thickness: 0.2, z: " << num(wall_z)
      << ", material: wall}\n";
  }
  const TrajectoryConfig& t = route.traj;
  y << "trajectory:\n";
  y << "  rate_hz: " << num(t.rate_hz) << "\n  start: [0, 0, 0]\n  base_z: 0\n";
  y << "  speed: " << num(t.speed) << "\n  turn_rate_deg: " << num(t.turn_rate_deg) << "\n";
  y << "  steps:\n";
  for (const TrajectoryStep& s : t.steps) {
    switch (s.kind) {
      case TrajectoryStep::Kind::kPause:
        y << "    - {pause: " << num(s.value) << "}\n";
        break;
      case TrajectoryStep::Kind::kGo:
        y << "    - {go: " << v2(Vec2(s.x, s.y)) << ", speed: " << num(s.speed) << "}\n";
        break;
      case TrajectoryStep::Kind::kBack:
        y << "    - {back: " << v2(Vec2(s.x, s.y)) << ", speed: " << num(s.speed) << "}\n";
        break;
      case TrajectoryStep::Kind::kTurnBy:
        y << "    - {turn_by: " << num(s.value) << "}\n";
        break;
      case TrajectoryStep::Kind::kTurnTo:
        y << "    - {turn_to: " << num(s.value) << "}\n";
        break;
    }
  }
  sc.yaml = y.str();
  std::string e = loadSceneFromString(sc.yaml, "", &sc.file);
  if (!e.empty()) return "generated YAML does not load: " + e;
  e = checkTrajectoryClear(sc.file, cfg.footprint);
  if (!e.empty()) return "trajectory not clear: " + e;
  std::vector<int> seen;
  int frames_any = 0, frames = 0;
  visibility(sc.file, plans, &seen, &frames_any, &frames);
  sc.view_fraction = frames > 0 ? static_cast<double>(frames_any) / frames : 0.0;
  if (sc.view_fraction < cfg.min_view_fraction)
    return "hazards seen in only " + fmt("%.0f", 100.0 * sc.view_fraction) + " % of the frames";
  for (std::size_t i = 0; i < plans.size(); ++i) {
    if (seen[i] < cfg.min_item_frames)
      return plans[i].item.group + " seen in only " + std::to_string(seen[i]) + " frames";
    plans[i].item.frames_seen = seen[i];
    sc.hazards.push_back(plans[i].item);
  }
  *out = std::move(sc);
  return "";
}

}  // namespace

// ---- public ----

const char* toString(HazardClass c) {
  switch (c) {
    case HazardClass::kNone:
      return "none";
    case HazardClass::kDropOff:
      return "drop_off";
    case HazardClass::kStepUp:
      return "step_up";
    case HazardClass::kSteepRamp:
      return "steep_ramp";
    case HazardClass::kGentleRamp:
      return "gentle_ramp";
    case HazardClass::kObstacle:
      return "obstacle";
    case HazardClass::kOverhang:
      return "overhang";
  }
  return "none";
}

bool parseHazardClass(const std::string& s, HazardClass* c) {
  for (int i = 0; i < kHazardClassCount; ++i) {
    if (s == toString(static_cast<HazardClass>(i))) {
      *c = static_cast<HazardClass>(i);
      return true;
    }
  }
  return false;
}

std::string FootprintConfig::validate() const {
  if (!(width > 0.0 && width <= 3.0)) return "footprint.width must be in (0, 3] [m]";
  if (!(length > 0.0 && length <= 3.0)) return "footprint.length must be in (0, 3] [m]";
  if (!(base_to_rear >= 0.0 && base_to_rear <= length))
    return "footprint.base_to_rear must be in [0, length] [m]";
  if (!(robot_height > 0.0 && robot_height <= 5.0))
    return "footprint.robot_height must be in (0, 5] [m]";
  if (!(clearance >= 0.0 && clearance < robot_height))
    return "footprint.clearance must be in [0, robot_height) [m]";
  if (!(ground_tolerance > 0.0 && ground_tolerance < GroundTruthConfig().h_t))
    return "footprint.ground_tolerance must be in (0, h_T = 0.05) [m]";
  return "";
}

std::map<std::string, double> ProceduralConfig::defaultKindWeights() {
  return {
      // Weights of the draws; kinds that often do not fit (ramps with landings, curb cuts, light
      // wells) are drawn more often so that they still appear in a good share of the scenes.
      {"curb_down", 1.0},     {"curb_up", 0.6},      {"curb_cut_down", 0.8}, {"curb_cut_up", 0.7},
      {"step_up", 0.7},       {"step_down", 0.7},    {"ramp_up", 1.6},       {"ramp_down", 1.6},
      {"platform_edge", 0.5}, {"loading_dock", 0.3}, {"pit", 0.4},           {"light_well", 0.5},
      {"stairs_down", 0.4},   {"pole", 0.5},         {"bollard", 0.5},       {"table", 0.5},
      {"shelf", 0.4},         {"legs", 0.4},         {"kerb_stone", 0.3},    {"box", 0.3},
      {"bag", 0.3},           {"wall", 0.4},         {"doorway", 0.4}};
}

std::vector<std::string> hazardKinds() {
  std::vector<std::string> k;
  for (const auto& kv : ProceduralConfig::defaultKindWeights())
    k.push_back(kv.first);
  return k;
}

const std::vector<std::string>& floorKinds() {
  static const std::vector<std::string> kKinds = {"polished", "matt",   "carpet", "tiles",
                                                  "concrete", "paving", "asphalt"};
  return kKinds;
}

std::string ProceduralConfig::validate() const {
  auto range = [](double lo, double hi, double min, double max) {
    return std::isfinite(lo) && std::isfinite(hi) && lo >= min && lo <= hi && hi <= max;
  };
  if (!(duration_s >= 2.0 && duration_s <= 600.0))
    return "procedural.duration_s must be in [2, 600] [s]";
  if (!(rate_hz > 0.0 && rate_hz <= 100.0)) return "procedural.rate_hz must be in (0, 100] [Hz]";
  if (!(min_items >= 1 && min_items <= max_items && max_items <= 8))
    return "procedural.min_items, max_items: 1 <= min <= max <= 8";
  if (!range(speed_min, speed_max, 0.05, 2.0))
    return "procedural.speed_min, speed_max: 0.05 <= min <= max <= 2 [m/s]";
  if (!(reverse_speed_max >= speed_min && reverse_speed_max <= 2.0))
    return "procedural.reverse_speed_max must be in [speed_min, 2] [m/s]";
  if (!range(turn_rate_min_deg, turn_rate_max_deg, 5.0, 180.0))
    return "procedural.turn_rate_min_deg, turn_rate_max_deg: 5 <= min <= max <= 180 [deg/s]";
  if (!range(pass_clearance_min, pass_clearance_max, 0.05, 5.0))
    return "procedural.pass_clearance_min, pass_clearance_max: 0.05 <= min <= max <= 5 [m]";
  if (!(min_clearance > 0.0 && min_clearance <= pass_clearance_min))
    return "procedural.min_clearance must be in (0, pass_clearance_min] [m]";
  if (!range(mount_z_min, mount_z_max, 0.2, 3.0))
    return "procedural.mount_z_min, mount_z_max: 0.2 <= min <= max <= 3 [m]";
  if (!range(pitch_min_deg, pitch_max_deg, 0.0, 60.0))
    return "procedural.pitch_min_deg, pitch_max_deg: 0 <= min <= max <= 60 [deg]";
  if (!(indoor_probability >= 0.0 && indoor_probability <= 1.0))
    return "procedural.indoor_probability must be in [0, 1]";
  if (!range(step_min, step_max, 0.01, 0.5))
    return "procedural.step_min, step_max: 0.01 <= min <= max <= 0.5 [m]";
  if (!(step_near_h_t_weight >= 0.0 && step_near_h_t_weight <= 1.0))
    return "procedural.step_near_h_t_weight must be in [0, 1]";
  if (!(slope_near_theta_t_weight >= 0.0 && slope_near_theta_max_weight >= 0.0 &&
        slope_near_theta_t_weight + slope_near_theta_max_weight <= 1.0))
    return "procedural.slope_near_theta_t_weight, slope_near_theta_max_weight: >= 0, sum <= 1";
  if (!range(slope_min_deg, slope_max_deg, 0.5, 30.0))
    return "procedural.slope_min_deg, slope_max_deg: 0.5 <= min <= max <= 30 [deg]";
  double total = 0.0;
  const std::map<std::string, double> known = defaultKindWeights();
  for (const auto& kv : kind_weights) {
    if (!known.count(kv.first)) return "procedural.kind_weights: unknown kind '" + kv.first + "'";
    if (!(kv.second >= 0.0 && std::isfinite(kv.second)))
      return "procedural.kind_weights: weights must be finite and >= 0";
    total += kv.second;
  }
  if (!(total > 0.0)) return "procedural.kind_weights: some kind needs a weight > 0";
  if (!(min_view_fraction >= 0.0 && min_view_fraction <= 1.0))
    return "procedural.min_view_fraction must be in [0, 1]";
  if (min_item_frames < 0) return "procedural.min_item_frames must be >= 0";
  if (!(area_margin >= 2.0 && area_margin <= 50.0))
    return "procedural.area_margin must be in [2, 50] [m]";
  if (!(area_min_size >= 0.0 && area_min_size <= 100.0))
    return "procedural.area_min_size must be in [0, 100] [m]";
  if (max_attempts < 1 || max_attempts > 10000)
    return "procedural.max_attempts must be in [1, 10000]";
  const std::string e = footprint.validate();
  if (!e.empty()) return "procedural." + e;
  return "";
}

std::string generateProceduralScene(std::uint64_t seed, const ProceduralConfig& config,
                                    ProceduralScene* out) {
  const std::string e = config.validate();
  if (!e.empty()) return e;
  PortableRng rng(seed);
  std::string last;
  for (int a = 1; a <= config.max_attempts; ++a) {
    ProceduralScene sc;
    last = attempt(seed, config, rng, &sc);
    if (last.empty()) {
      sc.attempts = a;
      *out = std::move(sc);
      return "";
    }
  }
  return "seed " + std::to_string(seed) + ": no valid scene in " +
         std::to_string(config.max_attempts) + " attempts (last: " + last + ")";
}

std::string checkTrajectoryClear(const SceneFile& file, const FootprintConfig& fp) {
  std::string e = fp.validate();
  if (!e.empty()) return e;
  const TrajectoryConfig& tc = file.trajectory;
  e = tc.validate();
  if (!e.empty()) return e;
  const Scene& scene = file.scene;
  const double z0 = tc.base_z;
  const double band_lo = z0 + fp.clearance, band_hi = z0 + fp.robot_height;
  // The part of every non-ground solid between clearance and robot height, seen from above: a
  // convex polygon, or a capsule (segment + radius) for cylinders.
  struct Shape {
    int prim = -1;
    bool capsule = false;
    Poly poly;
    Vec2 a, b;
    double r = 0.0;
    Eigen::AlignedBox2d box;
  };
  std::vector<Shape> shapes;
  std::vector<int> grounds;
  for (std::size_t i = 0; i < scene.primitives.size(); ++i) {
    const Primitive& p = scene.primitives[i];
    if (p.ground) {
      grounds.push_back(static_cast<int>(i));
      continue;
    }
    if (p.bounds.isEmpty() || p.bounds.max().z() <= band_lo || p.bounds.min().z() >= band_hi)
      continue;
    Shape s;
    s.prim = static_cast<int>(i);
    if (p.shape == Primitive::Shape::kConvex) {
      std::vector<HalfSpace> planes = p.planes;
      planes.push_back({Vec3::UnitZ(), band_hi});
      planes.push_back({-Vec3::UnitZ(), -band_lo});
      const Primitive clipped = makeConvex(planes);
      if (clipped.vertices.size() < 4) continue;
      std::vector<Vec2> pts;
      for (const Vec3& v : clipped.vertices)
        pts.push_back(v.head<2>());
      s.poly = hull(pts);
      if (s.poly.size() < 3) continue;
      s.box = boxOf(s.poly);
    } else {
      // Conservative: the axis where it is within a radius of the band, as a capsule.
      double s0 = 0.0, s1 = p.length;
      const double az = p.axis.z();
      if (std::abs(az) < 1e-12) {
        if (p.p0.z() < band_lo - p.radius || p.p0.z() > band_hi + p.radius) continue;
      } else {
        double t0 = (band_lo - p.radius - p.p0.z()) / az, t1 = (band_hi + p.radius - p.p0.z()) / az;
        if (t0 > t1) std::swap(t0, t1);
        s0 = std::max(s0, t0);
        s1 = std::min(s1, t1);
        if (s0 > s1) continue;
      }
      s.capsule = true;
      s.a = (p.p0 + p.axis * s0).head<2>();
      s.b = (p.p0 + p.axis * s1).head<2>();
      s.r = p.radius;
      s.box.extend(s.a);
      s.box.extend(s.b);
      s.box.min() -= Vec2::Constant(s.r);
      s.box.max() += Vec2::Constant(s.r);
    }
    shapes.push_back(s);
  }
  const std::vector<RobotPose> poses = densePoses(tc, 0.02, 1.0);
  const int nx = static_cast<int>(std::ceil(fp.length / 0.04 - 1e-9)) + 1;
  const int ny = static_cast<int>(std::ceil(fp.width / 0.04 - 1e-9)) + 1;
  auto where = [](const RobotPose& p) {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "t = %.2f s, pose (%.3f, %.3f, %.1f deg): ", p.t, p.x, p.y,
                  p.yaw / kDeg);
    return std::string(buf);
  };
  std::vector<int> cand;
  for (const RobotPose& pose : poses) {
    const Poly rectp = footprintAt(fp, pose.x, pose.y, pose.yaw);
    const Eigen::AlignedBox2d rb = boxOf(rectp);
    for (const Shape& s : shapes) {
      if (!rb.intersects(s.box)) continue;
      const bool hit = s.capsule ? segmentPolygon(s.a, s.b, rectp) < s.r - 1e-9
                                 : polyDistance(rectp, s.poly) <= 0.0;
      if (hit) {
        const Primitive& p = scene.primitives[s.prim];
        return where(pose) + "the footprint overlaps '" + p.name + "' (" + p.type + ")";
      }
    }
    cand.clear();
    for (int g : grounds) {
      const Eigen::AlignedBox3d& b = scene.primitives[g].bounds;
      if (b.min().x() <= rb.max().x() && b.max().x() >= rb.min().x() &&
          b.min().y() <= rb.max().y() && b.max().y() >= rb.min().y())
        cand.push_back(g);
    }
    const Vec2 c(pose.x, pose.y), u = dir(pose.yaw), w = perp(u);
    for (int i = 0; i < nx; ++i) {
      const double lx = -fp.base_to_rear + fp.length * i / (nx - 1);
      for (int j = 0; j < ny; ++j) {
        const double ly = -0.5 * fp.width + fp.width * j / (ny - 1);
        const Vec2 q = c + u * lx + w * ly;
        double best = -kInf;
        int arg = -1;
        for (int g : cand) {
          double z;
          if (scene.primitives[g].topHeightAt(q.x(), q.y(), &z, 1e-9) && z > best) {
            best = z;
            arg = g;
          }
        }
        if (arg < 0) {
          return where(pose) + "no ground under the footprint at (" + fmt("%.3f", q.x()) + ", " +
                 fmt("%.3f", q.y()) + ")";
        }
        if (std::abs(best - z0) > fp.ground_tolerance) {
          const Primitive& p = scene.primitives[arg];
          return where(pose) + "the footprint is over '" + p.name + "' (" + p.type +
                 ") at z = " + fmt("%.3f", best) + " m, not the start level " + fmt("%.3f", z0) +
                 " m (a curb, step, drop or ramp)";
        }
      }
    }
  }
  return "";
}

std::vector<HazardClass> hazardClassMap(const ProceduralScene& scene, const GroundTruthMap& gt,
                                        const GroundTruthConfig& config) {
  const std::size_t n = static_cast<std::size_t>(std::max(0, gt.width)) * std::max(0, gt.height);
  std::vector<HazardClass> out(n, HazardClass::kNone);
  if (gt.ground.size() != n || gt.obstacle.size() != n || gt.ground_height.size() != n) return out;
  const Scene& s = scene.file.scene;
  std::map<std::string, HazardClass> part_class;
  for (const HazardItem& it : scene.hazards)
    for (const HazardPart& part : it.parts)
      part_class[part.entry] = part.cls;
  std::vector<HazardClass> prim_class(s.primitives.size(), HazardClass::kNone);
  for (std::size_t i = 0; i < s.primitives.size(); ++i) {
    const auto f = part_class.find(s.primitives[i].group);
    if (f != part_class.end()) prim_class[i] = f->second;
  }
  for (std::size_t k = 0; k < n; ++k)
    if (gt.ground[k] >= 0 && static_cast<std::size_t>(gt.ground[k]) < prim_class.size())
      out[k] = prim_class[gt.ground[k]];
  // Obstacle cells: the GT's test again (000 Sec. V-A), noting whether the solid reaches down to
  // ground + clearance (standing) or only hangs above the cell (overhang).
  const double res = gt.resolution;
  double start_z = 0.0;
  if (gt.inside(gt.start_u, gt.start_v)) {
    const int sk = gt.index(gt.start_u, gt.start_v);
    if (gt.ground[sk] >= 0) start_z = gt.ground_height[sk];
  }
  std::vector<std::uint8_t> standing(n, 0), over(n, 0);
  const int S = config.samples_per_cell;
  for (const Primitive& p : s.primitives) {
    if (p.ground || p.bounds.isEmpty()) continue;
    const int u0 =
        std::max(gt.min_u, static_cast<int>(std::floor((p.bounds.min().x() - 0.5 * res) / res)));
    const int u1 = std::min(gt.min_u + gt.width - 1,
                            static_cast<int>(std::ceil((p.bounds.max().x() + 0.5 * res) / res)));
    const int v0 =
        std::max(gt.min_v, static_cast<int>(std::floor((p.bounds.min().y() - 0.5 * res) / res)));
    const int v1 = std::min(gt.min_v + gt.height - 1,
                            static_cast<int>(std::ceil((p.bounds.max().y() + 0.5 * res) / res)));
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        const int k = gt.index(u, v);
        if (!gt.obstacle[k] || standing[k]) continue;
        const bool has_ground = gt.ground[k] >= 0;
        const double z_top = (has_ground ? gt.ground_height[k] : start_z) + config.robot_height;
        const double len = has_ground ? config.robot_height - config.clearance : 1e6;
        Ray ray;
        ray.dir = Vec3(0.0, 0.0, -1.0);
        for (int i = 0; i < S * S && !standing[k]; ++i) {
          const double ox = ((i % S + 0.5) / S - 0.5) * res, oy = ((i / S + 0.5) / S - 0.5) * res;
          ray.origin = Vec3(u * res + ox, v * res + oy, z_top);
          double tin, tout;
          int face;
          if (!p.interval(ray, &tin, &tout, &face) || tin > len || tout < 0.0) continue;
          if (!has_ground || tout >= len) {  // no ground: anything in the column stands there
            standing[k] = 1;
          } else {
            over[k] = 1;
          }
        }
      }
    }
  }
  for (std::size_t k = 0; k < n; ++k)
    if (gt.obstacle[k])
      out[k] = standing[k] ? HazardClass::kObstacle
                           : (over[k] ? HazardClass::kOverhang : HazardClass::kObstacle);
  return out;
}

std::string proceduralSummary(const ProceduralScene& sc) {
  std::ostringstream s;
  const std::size_t frames = sampleTrajectory(sc.file.trajectory).size();
  s << "seed " << sc.seed << ": " << (sc.indoor ? "indoor" : "outdoor") << ", " << sc.floor_kind
    << " floor, camera " << num(sc.file.camera.mount_z) << " m / " << num(sc.file.camera.pitch_deg)
    << " deg, " << frames << " frames, hazards seen in " << fmt("%.0f", 100.0 * sc.view_fraction)
    << " %; ";
  for (std::size_t i = 0; i < sc.hazards.size(); ++i) {
    const HazardItem& h = sc.hazards[i];
    s << (i ? ", " : "") << h.kind << " " << num(h.size) << " (" << toString(h.cls) << ")";
  }
  return s.str();
}

}  // namespace dataset
}  // namespace stereo_safety_map
