// Procedural scenes (procedural_internal.h): numbers and their text, convex-polygon geometry.
#include "procedural_internal.h"

#include <algorithm>
#include <cstdio>

namespace stereo_safety_map {
namespace dataset {
namespace procedural {

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

}  // namespace procedural
}  // namespace dataset
}  // namespace stereo_safety_map
