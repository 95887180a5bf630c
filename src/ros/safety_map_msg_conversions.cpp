#include "stereo_safety_map/ros/safety_map_msg_conversions.h"

#include "stereo_safety_map/ros/hybrid_conversions.h"

#include <cmath>
#include <sstream>

namespace stereo_safety_map {

std::string fromSafetyMapMsg(const SafetyMapMsg& msg, SafetyMap* out) {
  std::string err = safetyMapFromMsg(msg, out);  // grid, labels, drop-off edges
  if (!err.empty()) return err;
  const std::size_t n = out->labels.size();
  if (!msg.segment.empty() && msg.segment.size() != n) {
    return "segment has " + std::to_string(msg.segment.size()) + " entries for " +
           std::to_string(n) + " cells";
  }
  const std::size_t nseg = msg.segments.size();
  if (nseg > n + 1) {
    return "segments has " + std::to_string(nseg) + " entries for " + std::to_string(n) + " cells";
  }
  out->segments.resize(nseg);
  for (std::size_t k = 0; k < nseg; ++k) {
    const GroundSegment& g = msg.segments[k];
    if (g.label > SafetyMapMsg::NON_GROUND) {
      return "segments[" + std::to_string(k) + "].label = " + std::to_string(g.label) +
             " is not a SafetyMap label (0..4)";
    }
    if (g.plane_valid &&
        !(std::isfinite(g.a) && std::isfinite(g.b) && std::isfinite(g.c) &&
          std::isfinite(g.slope_deg) && g.slope_deg >= 0.0 && g.slope_deg <= 90.0)) {
      std::ostringstream os;
      os << "segments[" << k << "] has a valid plane with non-finite coefficients or a slope of "
         << g.slope_deg << " deg outside [0, 90]";
      return os.str();
    }
    SegmentInfo& s = out->segments[k];
    s = SegmentInfo();
    s.id = g.id;
    s.label = static_cast<SafetyLabel>(g.label);
    s.reachable = g.reachable;
    s.indexed_height = g.indexed_height;
    s.num_interior = static_cast<int>(g.num_interior_cells);
    s.plane.valid = g.plane_valid;
    s.plane.a = g.a;
    s.plane.b = g.b;
    s.plane.c = g.c;
    s.plane.normal = Eigen::Vector3d(g.normal.x, g.normal.y, g.normal.z);
    s.plane.slope_deg = g.slope_deg;
    s.plane.residual_rms = g.residual_rms;
    s.plane.num_points = g.num_points;
    s.plane.centroid = Eigen::Vector3d(g.centroid.x, g.centroid.y, g.centroid.z);
  }
  if (msg.segment.empty()) {
    out->segment.assign(n, -1);
  } else {
    out->segment.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const int s = msg.segment[i];
      if (s < -1 || s >= static_cast<int>(nseg)) {
        return "segment[" + std::to_string(i) + "] = " + std::to_string(s) +
               " is neither -1 nor an index into segments (" + std::to_string(nseg) + ")";
      }
      out->segment[i] = s;
      if (s >= 0) out->segments[s].cells.push_back(static_cast<int>(i));
    }
  }
  const double res = out->resolution;
  const geometry_msgs::Point& r = msg.robot_position;
  if (std::isfinite(r.x) && std::isfinite(r.y) && std::abs(r.x / res) < 1e9 &&
      std::abs(r.y / res) < 1e9) {
    out->robot_u = static_cast<int>(std::lround(r.x / res));
    out->robot_v = static_cast<int>(std::lround(r.y / res));
  } else {
    out->robot_u = out->robot_v = 0;
  }
  if (out->robot_segment < -1 || out->robot_segment >= static_cast<int>(nseg)) {
    out->robot_segment = -1;
  }
  out->column_height.clear();
  return "";
}

}  // namespace stereo_safety_map
