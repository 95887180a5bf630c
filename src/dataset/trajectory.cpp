#include "stereo_safety_map/dataset/trajectory.h"

#include <algorithm>
#include <cmath>

namespace stereo_safety_map {
namespace dataset {

namespace {

constexpr double kDeg = M_PI / 180.0;

double wrapAngle(double a) {
  while (a > M_PI)
    a -= 2.0 * M_PI;
  while (a < -M_PI)
    a += 2.0 * M_PI;
  return a;
}

struct Segment {
  double t0 = 0.0, t1 = 0.0;
  double x0 = 0.0, y0 = 0.0, yaw0 = 0.0;
  double x1 = 0.0, y1 = 0.0, yaw1 = 0.0;
  bool reverse = false;  // driving backwards (kBack): negative forward speed
};

std::vector<Segment> buildSegments(const TrajectoryConfig& c) {
  std::vector<Segment> segs;
  double t = 0.0, x = c.start_x, y = c.start_y, yaw = c.start_yaw_deg * kDeg;
  const double turn_rate = c.turn_rate_deg * kDeg;
  auto push = [&](double duration, double nx, double ny, double nyaw, bool reverse = false) {
    if (!(duration > 0.0)) return;
    Segment s;
    s.reverse = reverse;
    s.t0 = t;
    s.t1 = t + duration;
    s.x0 = x;
    s.y0 = y;
    s.yaw0 = yaw;
    s.x1 = nx;
    s.y1 = ny;
    s.yaw1 = nyaw;
    segs.push_back(s);
    t = s.t1;
    x = nx;
    y = ny;
    yaw = nyaw;
  };
  auto turn = [&](double dyaw) { push(std::abs(dyaw) / turn_rate, x, y, yaw + dyaw); };
  for (const TrajectoryStep& st : c.steps) {
    switch (st.kind) {
      case TrajectoryStep::Kind::kPause:
        push(st.value, x, y, yaw);
        break;
      case TrajectoryStep::Kind::kTurnTo:
        turn(wrapAngle(st.value * kDeg - yaw));
        break;
      case TrajectoryStep::Kind::kTurnBy:
        turn(st.value * kDeg);
        break;
      case TrajectoryStep::Kind::kGo: {
        const double dx = st.x - x, dy = st.y - y;
        const double dist = std::hypot(dx, dy);
        if (dist < 1e-9) break;
        // Wheelchair-like motion: face the target in place, then drive straight.
        const double dyaw = wrapAngle(std::atan2(dy, dx) - yaw);
        if (std::abs(dyaw) > 1e-9) turn(dyaw);
        const double v = st.speed > 0.0 ? st.speed : c.speed;
        push(dist / v, st.x, st.y, yaw);
        break;
      }
      case TrajectoryStep::Kind::kBack: {
        const double dx = st.x - x, dy = st.y - y;
        const double dist = std::hypot(dx, dy);
        if (dist < 1e-9) break;
        // Reversing: turn (if needed) so that the rear faces the target, then back up straight.
        const double dyaw = wrapAngle(std::atan2(dy, dx) + M_PI - yaw);
        if (std::abs(dyaw) > 1e-9) turn(dyaw);
        const double v = st.speed > 0.0 ? st.speed : c.speed;
        push(dist / v, st.x, st.y, yaw, true);
        break;
      }
    }
  }
  return segs;
}

}  // namespace

std::string TrajectoryConfig::validate() const {
  if (!(std::isfinite(rate_hz) && rate_hz > 0.0 && rate_hz <= 1000.0))
    return "trajectory.rate_hz must be in (0, 1000] [Hz]";
  if (!std::isfinite(start_x) || !std::isfinite(start_y) || !std::isfinite(start_yaw_deg) ||
      !std::isfinite(base_z))
    return "trajectory.start must be finite";
  if (!(std::isfinite(speed) && speed > 0.0 && speed <= 5.0))
    return "trajectory.speed must be in (0, 5] [m/s]";
  if (!(std::isfinite(turn_rate_deg) && turn_rate_deg > 0.0 && turn_rate_deg <= 360.0))
    return "trajectory.turn_rate_deg must be in (0, 360] [deg/s]";
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const TrajectoryStep& s = steps[i];
    const std::string who = "trajectory.steps[" + std::to_string(i) + "]: ";
    if (!std::isfinite(s.x) || !std::isfinite(s.y) || !std::isfinite(s.value) ||
        !std::isfinite(s.speed))
      return who + "values must be finite";
    if (s.kind == TrajectoryStep::Kind::kPause && !(s.value >= 0.0 && s.value <= 3600.0))
      return who + "pause must be in [0, 3600] [s]";
    if ((s.kind == TrajectoryStep::Kind::kGo || s.kind == TrajectoryStep::Kind::kBack) &&
        !(s.speed >= 0.0 && s.speed <= 5.0))
      return who + "speed must be in [0, 5] [m/s] (0 = default)";
  }
  if (trajectoryDuration(*this) > 3600.0) return "trajectory longer than one hour";
  return "";
}

double trajectoryDuration(const TrajectoryConfig& config) {
  const std::vector<Segment> segs = buildSegments(config);
  return segs.empty() ? 0.0 : segs.back().t1;
}

namespace {

RobotPose evaluate(const std::vector<Segment>& segs, const TrajectoryConfig& c, double t) {
  RobotPose p;
  p.t = t;
  p.z = c.base_z;
  if (segs.empty()) {
    p.x = c.start_x;
    p.y = c.start_y;
    p.yaw = wrapAngle(c.start_yaw_deg * kDeg);
    return p;
  }
  const double tc = std::min(std::max(t, 0.0), segs.back().t1);
  auto it = std::upper_bound(segs.begin(), segs.end(), tc,
                             [](double tv, const Segment& s) { return tv < s.t1; });
  if (it == segs.end()) --it;
  const Segment& s = *it;
  const double dur = s.t1 - s.t0;
  const double a = dur > 0.0 ? std::min(std::max((tc - s.t0) / dur, 0.0), 1.0) : 1.0;
  p.x = s.x0 + a * (s.x1 - s.x0);
  p.y = s.y0 + a * (s.y1 - s.y0);
  p.yaw = wrapAngle(s.yaw0 + a * (s.yaw1 - s.yaw0));
  if (t >= 0.0 && t <= segs.back().t1 && dur > 0.0) {
    p.v = std::hypot(s.x1 - s.x0, s.y1 - s.y0) / dur * (s.reverse ? -1.0 : 1.0);
    p.omega = (s.yaw1 - s.yaw0) / dur;
  }
  return p;
}

}  // namespace

RobotPose poseAt(const TrajectoryConfig& config, double t) {
  return evaluate(buildSegments(config), config, t);
}

std::vector<RobotPose> sampleTrajectory(const TrajectoryConfig& config) {
  std::vector<RobotPose> poses;
  if (!config.validate().empty()) return poses;
  const std::vector<Segment> segs = buildSegments(config);
  const double duration = segs.empty() ? 0.0 : segs.back().t1;
  const std::size_t n = static_cast<std::size_t>(std::floor(duration * config.rate_hz + 1e-9)) + 1;
  poses.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    RobotPose p = evaluate(segs, config, static_cast<double>(i) / config.rate_hz);
    if (!poses.empty()) {
      const RobotPose& q = poses.back();
      p.stationary = std::abs(p.x - q.x) < 1e-12 && std::abs(p.y - q.y) < 1e-12 &&
                     std::abs(wrapAngle(p.yaw - q.yaw)) < 1e-12;
    }
    poses.push_back(p);
  }
  return poses;
}

std::vector<std::size_t> subsampleFrames(std::size_t total, std::size_t count) {
  std::vector<std::size_t> idx;
  if (total == 0 || count == 0) return idx;
  if (count >= total) {
    for (std::size_t i = 0; i < total; ++i)
      idx.push_back(i);
    return idx;
  }
  if (count == 1) return {0};
  for (std::size_t i = 0; i < count; ++i)
    idx.push_back(static_cast<std::size_t>(std::llround(
        static_cast<double>(i) * static_cast<double>(total - 1) / static_cast<double>(count - 1))));
  return idx;
}

}  // namespace dataset
}  // namespace stereo_safety_map
