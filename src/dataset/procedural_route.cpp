// Procedural scenes (procedural_internal.h): the wheelchair trajectory, and the check that it
// never drives into anything or off the start level (checkTrajectoryClear).
#include "procedural_internal.h"

#include <algorithm>

namespace stereo_safety_map {
namespace dataset {
namespace procedural {

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

}  // namespace procedural

using namespace procedural;  // NOLINT: the generator's internals

// ---- public: the trajectory check ----

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

}  // namespace dataset
}  // namespace stereo_safety_map
