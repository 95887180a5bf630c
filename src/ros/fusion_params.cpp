#include "stereo_safety_map/ros/fusion_params.h"

#include "stereo_safety_map/ros/param_reader.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <cmath>
#include <limits>
#include <sstream>

namespace stereo_safety_map {

namespace {

// Reads typed parameters, remembering the first error (param_reader.h).
using Reader = ParamReader;

std::string rangeError(const char* name, double value, const char* range) {
  std::ostringstream os;
  os << name << " = " << value << " is out of range " << range;
  return os.str();
}

}  // namespace

std::string fromRosParam(const ros::NodeHandle& pnh, LandmarkStreamConfig* c) {
  Reader r(pnh);
  LandmarkFilterConfig& f = c->filter;
  r.read("use_landmark_filter", &c->enabled);
  r.read("landmark_sigma_row", &f.error_model.sigma_row);
  r.read("landmark_sigma_col", &f.error_model.sigma_col);
  r.read("landmark_sigma_disparity", &f.error_model.sigma_disparity);
  r.read("landmark_gate_chi2", &f.gate_chi2);
  r.read("landmark_use_mahalanobis", &f.use_mahalanobis);
  r.read("landmark_euclidean_gate", &f.euclidean_gate);
  r.read("landmark_min_matches", &f.min_matches);
  r.read("landmark_time_window", &f.time_window);
  r.read("landmark_stale_time", &f.stale_time);
  r.read("landmark_max_landmarks", &f.max_landmarks);
  r.read("landmark_max_search_radius_px", &f.max_search_radius_px);
  r.read("landmark_max_distance", &f.max_landmark_distance);
  // The core's messages name the struct's fields; the parameters carry the landmark_ prefix.
  std::string err = f.validate();
  const std::string far = "max_landmark_distance";
  if (err.compare(0, far.size(), far) == 0) {
    err = "landmark_max_distance" + err.substr(far.size());
  } else if (!err.empty()) {
    err = "landmark_" + err;
  }
  return r.result(err);
}

std::vector<std::string> landmarkParameterNames() {
  return {"use_landmark_filter",      "landmark_sigma_row",     "landmark_sigma_col",
          "landmark_sigma_disparity", "landmark_gate_chi2",     "landmark_use_mahalanobis",
          "landmark_euclidean_gate",  "landmark_min_matches",   "landmark_time_window",
          "landmark_stale_time",      "landmark_max_landmarks", "landmark_max_search_radius_px",
          "landmark_max_distance"};
}

std::string HybridSafetyMapRosConfig::validate() const {
  if (fixed_frame.empty()) return "fixed_frame must not be empty";
  if (queue_size < 1 || queue_size > 1000) {
    return rangeError("queue_size", queue_size, "[1, 1000]");
  }
  if (!std::isfinite(vision_timeout) || vision_timeout <= 0.0 || vision_timeout > 3600.0) {
    return rangeError("vision_timeout", vision_timeout, "(0, 3600] s");
  }
  if (!std::isfinite(laser_only_rate) || laser_only_rate < 0.0 || laser_only_rate > 100.0) {
    return rangeError("laser_only_rate", laser_only_rate, "[0, 100] Hz");
  }
  if (!std::isfinite(time_jump_reset) || time_jump_reset < 0.0 || time_jump_reset > 3600.0) {
    return rangeError("time_jump_reset", time_jump_reset, "[0, 3600] s");
  }
  if (!std::isfinite(laser_size_x) || laser_size_x <= 0.0 || laser_size_x > 1000.0) {
    return rangeError("laser_size_x", laser_size_x, "[resolution, 1000] m");
  }
  if (!std::isfinite(laser_size_y) || laser_size_y <= 0.0 || laser_size_y > 1000.0) {
    return rangeError("laser_size_y", laser_size_y, "[resolution, 1000] m");
  }
  return "";
}

std::string fromRosParam(const ros::NodeHandle& pnh, HybridSafetyMapRosConfig* rc,
                         LaserGridConfig* laser, HybridSafetyMapConfig* hybrid) {
  Reader r(pnh);
  r.read("fixed_frame", &rc->fixed_frame);
  r.read("queue_size", &rc->queue_size);
  r.read("vision_timeout", &rc->vision_timeout);
  r.read("laser_only_rate", &rc->laser_only_rate);
  r.read("time_jump_reset", &rc->time_jump_reset);
  r.read("laser_size_x", &rc->laser_size_x);
  r.read("laser_size_y", &rc->laser_size_y);
  r.read("resolution", &laser->resolution);
  r.read("log_odds_hit", &laser->log_odds_hit);
  r.read("log_odds_miss", &laser->log_odds_miss);
  r.read("log_odds_min", &laser->log_odds_min);
  r.read("log_odds_max", &laser->log_odds_max);
  r.read("occupied_threshold", &laser->occupied_threshold);
  r.read("free_threshold", &laser->free_threshold);
  r.read("clear_no_return", &laser->clear_no_return);
  r.read("detect_narrow_passages", &hybrid->detect_narrow_passages);
  r.read("min_passage_width", &hybrid->min_passage_width);
  r.read("drop_off_edges_are_caution", &hybrid->drop_off_edges_are_caution);
  r.read("laser_free_required_for_safe", &hybrid->laser_free_required_for_safe);
  r.read("laser_free_vision_unknown_is_safe", &hybrid->laser_free_vision_unknown_is_safe);
  std::string err = rc->validate();
  if (err.empty() && std::isfinite(laser->resolution) && laser->resolution > 0.0) {
    // The window in cells; at least one cell, the core checks the upper bound.
    const double w = std::round(rc->laser_size_x / laser->resolution);
    const double h = std::round(rc->laser_size_y / laser->resolution);
    if (w < 1.0) err = rangeError("laser_size_x", rc->laser_size_x, "[resolution, 1000] m");
    if (err.empty() && h < 1.0) {
      err = rangeError("laser_size_y", rc->laser_size_y, "[resolution, 1000] m");
    }
    laser->width = static_cast<int>(std::min(w, 1e6));
    laser->height = static_cast<int>(std::min(h, 1e6));
  }
  if (err.empty()) err = laser->validate();
  if (err.empty()) err = hybrid->validate();
  return r.result(err);
}

std::vector<std::string> hybridSafetyMapParameterNames() {
  return {"fixed_frame",
          "queue_size",
          "vision_timeout",
          "laser_only_rate",
          "time_jump_reset",
          "laser_size_x",
          "laser_size_y",
          "resolution",
          "log_odds_hit",
          "log_odds_miss",
          "log_odds_min",
          "log_odds_max",
          "occupied_threshold",
          "free_threshold",
          "clear_no_return",
          "detect_narrow_passages",
          "min_passage_width",
          "drop_off_edges_are_caution",
          "laser_free_required_for_safe",
          "laser_free_vision_unknown_is_safe",
          "diagnostic_period"};
}

}  // namespace stereo_safety_map
