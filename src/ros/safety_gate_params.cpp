#include "stereo_safety_map/ros/safety_gate_params.h"

#include "stereo_safety_map/ros/param_reader.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <cmath>
#include <cstdlib>
#include <sstream>

namespace stereo_safety_map {

namespace {

bool number(const XmlRpc::XmlRpcValue& v, double* out) {
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    *out = static_cast<double>(const_cast<XmlRpc::XmlRpcValue&>(v));
    return true;
  }
  if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
    *out = static_cast<int>(const_cast<XmlRpc::XmlRpcValue&>(v));
    return true;
  }
  return false;
}

// "[[0.75, 0.35], [-0.45, 0.35], ...]": the numbers in order, pairs taken as vertices.
bool parseFootprintString(const std::string& s, std::vector<Eigen::Vector2d>* out) {
  std::vector<double> values;
  int depth = 0, pairs = 0, in_pair = 0;
  for (std::size_t i = 0; i < s.size();) {
    const char c = s[i];
    if (c == '[') {
      ++depth;
      if (depth == 2) in_pair = 0;
      if (depth > 2) return false;
      ++i;
    } else if (c == ']') {
      if (depth == 2) {
        if (in_pair != 2) return false;
        ++pairs;
      }
      --depth;
      if (depth < 0) return false;
      ++i;
    } else if (c == ',' || c == ' ' || c == '\t' || c == '\n') {
      ++i;
    } else {
      if (depth != 2) return false;
      char* end = nullptr;
      const double x = std::strtod(s.c_str() + i, &end);
      if (end == s.c_str() + i) return false;
      values.push_back(x);
      ++in_pair;
      i = static_cast<std::size_t>(end - s.c_str());
    }
  }
  if (depth != 0 || values.size() != 2u * pairs) return false;
  out->clear();
  for (std::size_t k = 0; k + 1 < values.size(); k += 2)
    out->emplace_back(values[k], values[k + 1]);
  return true;
}

// The footprint parameter, list or string; "" when absent or valid.
std::string readFootprint(const ros::NodeHandle& pnh, std::vector<Eigen::Vector2d>* out) {
  if (!pnh.hasParam("footprint")) return "";
  XmlRpc::XmlRpcValue v;
  pnh.getParam("footprint", v);
  const std::string err = "invalid parameter " + pnh.resolveName("footprint") +
                          ": must be a list of [x, y] pairs, e.g. [[0.75, 0.35], [-0.45, 0.35], "
                          "[-0.45, -0.35], [0.75, -0.35]]";
  if (v.getType() == XmlRpc::XmlRpcValue::TypeString) {
    return parseFootprintString(static_cast<std::string>(v), out) ? "" : err;
  }
  if (v.getType() != XmlRpc::XmlRpcValue::TypeArray) return err;
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < v.size(); ++i) {
    XmlRpc::XmlRpcValue& p = v[i];
    double x = 0.0, y = 0.0;
    if (p.getType() != XmlRpc::XmlRpcValue::TypeArray || p.size() != 2 || !number(p[0], &x) ||
        !number(p[1], &y)) {
      return err;
    }
    pts.emplace_back(x, y);
  }
  *out = pts;
  return "";
}

}  // namespace

std::string SafetyGateRosConfig::validate() const {
  if (fixed_frame.empty()) return "fixed_frame must not be empty";
  if (footprint_frame.empty()) return "footprint_frame must not be empty";
  if (!std::isfinite(cmd_timeout) || cmd_timeout <= 0.0 || cmd_timeout > 60.0) {
    return rangeError("cmd_timeout", cmd_timeout, "(0, 60] s");
  }
  if (!std::isfinite(tf_timeout) || tf_timeout < 0.0 || tf_timeout > 1.0) {
    return rangeError("tf_timeout", tf_timeout, "[0, 1] s");
  }
  if (!std::isfinite(max_tf_age) || max_tf_age <= 0.0 || max_tf_age > 60.0) {
    return rangeError("max_tf_age", max_tf_age, "(0, 60] s");
  }
  if (queue_size < 1 || queue_size > 100) return rangeError("queue_size", queue_size, "[1, 100]");
  return "";
}

std::string fromRosParam(const ros::NodeHandle& pnh, SafetyGateRosConfig* rc, SafetyGateConfig* g) {
  ParamReader r(pnh);
  r.read("fixed_frame", &rc->fixed_frame);
  r.read("footprint_frame", &rc->footprint_frame);
  r.read("cmd_timeout", &rc->cmd_timeout);
  r.read("tf_timeout", &rc->tf_timeout);
  r.read("max_tf_age", &rc->max_tf_age);
  r.read("queue_size", &rc->queue_size);
  r.read("footprint_padding", &g->footprint_padding);
  r.read("deceleration", &g->deceleration);
  r.read("angular_deceleration", &g->angular_deceleration);
  r.read("reaction_time", &g->reaction_time);
  r.read("margin", &g->margin);
  r.read("margin_angle_deg", &g->margin_angle_deg);
  r.read("max_hole_cells", &g->max_hole_cells);
  r.read("safe_memory", &g->safe_memory);
  r.read("max_incline_deg", &g->max_incline_deg);
  r.read("ramp_foot_height", &g->ramp_foot_height);
  r.read("reverse_speed_limit", &g->reverse_speed_limit);
  r.read("slow_down", &g->slow_down);
  r.read("min_speed", &g->min_speed);
  r.read("min_angular_speed", &g->min_angular_speed);
  r.read("max_map_age", &g->max_map_age);
  r.read("step_fraction", &g->step_fraction);
  r.read("max_step_angle_deg", &g->max_step_angle_deg);
  if (!r.error().empty()) return r.error();
  const std::string fp = readFootprint(pnh, &g->footprint);
  if (!fp.empty()) return fp;
  std::string err = rc->validate();
  if (err.empty()) err = g->validate();
  return r.result(err);
}

std::vector<std::string> safetyGateParameterNames() {
  return {"fixed_frame",       "footprint_frame",      "cmd_timeout",   "tf_timeout",
          "max_tf_age",        "queue_size",           "footprint",     "footprint_padding",
          "deceleration",      "angular_deceleration", "reaction_time", "margin",
          "margin_angle_deg",  "max_hole_cells",       "safe_memory",   "max_incline_deg",
          "ramp_foot_height",  "reverse_speed_limit",  "slow_down",     "min_speed",
          "min_angular_speed", "max_map_age",          "step_fraction", "max_step_angle_deg",
          "diagnostic_period"};
}

}  // namespace stereo_safety_map
