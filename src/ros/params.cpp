#include "stereo_safety_map/ros/params.h"

#include "stereo_safety_map/ros/param_reader.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace stereo_safety_map {

namespace {

// Reads typed parameters, remembering the first error (param_reader.h).
using Reader = ParamReader;

}  // namespace

std::string fromRosParam(const ros::NodeHandle& pnh, VoxelGridConfig* c) {
  Reader r(pnh);
  r.read("voxel_size", &c->voxel_size);
  r.read("size_x", &c->size_x);
  r.read("size_y", &c->size_y);
  r.read("size_z", &c->size_z);
  r.read("z_below_robot", &c->z_below_robot);
  r.read("incr_high", &c->incr_high);
  r.read("incr_low", &c->incr_low);
  r.read("decr", &c->decr);
  r.read("occ_threshold", &c->occ_threshold);
  r.read("lop_min", &c->lop_min);
  r.read("lop_max", &c->lop_max);
  r.read("point_list_capacity", &c->point_list_capacity);
  r.read("max_range", &c->max_range);
  r.read("min_range", &c->min_range);
  return r.result(c->validate());
}

std::string fromRosParam(const ros::NodeHandle& pnh, HeightMapConfig* c) {
  Reader r(pnh);
  r.read("robot_height", &c->robot_height);
  return r.result(c->validate());
}

std::string fromRosParam(const ros::NodeHandle& pnh, GroundSegmentationConfig* c) {
  Reader r(pnh);
  r.read("planning_radius", &c->planning_radius);
  r.read("height_tolerance", &c->height_tolerance);
  r.read("connectivity", &c->connectivity);
  r.read("seed_radius", &c->seed_radius);
  r.read("segment_islands", &c->segment_islands);
  r.read("island_max_span", &c->island_max_span);
  return r.result(c->validate());
}

std::string fromRosParam(const ros::NodeHandle& pnh, PlaneFitConfig* c) {
  Reader r(pnh);
  r.read("min_points", &c->min_points);
  r.read("min_xy_stddev", &c->min_xy_stddev);
  r.read("plane_vertical_margin", &c->vertical_margin);
  return r.result(c->validate());
}

std::string fromRosParam(const ros::NodeHandle& pnh, SafetyLabellingConfig* c) {
  Reader r(pnh);
  r.read("max_slope_deg", &c->max_slope_deg);
  r.read("min_segment_cells", &c->min_segment_cells);
  r.read("thin_ratio", &c->thin_ratio);
  r.read("max_step_height", &c->max_step_height);
  r.read("min_passage_cells", &c->min_passage_cells);
  r.read("level_slope_deg", &c->level_slope_deg);
  r.read("max_gap_cells", &c->max_gap_cells);
  r.read("measured_step_test", &c->measured_step_test);
  r.read("mark_drop_offs", &c->mark_drop_offs);
  r.read("drop_off_radius", &c->drop_off_radius);
  r.read("drop_off_min_drop", &c->drop_off_min_drop);
  return r.result(c->validate());
}

std::string fromRosParam(const ros::NodeHandle& pnh, SafetyMapperConfig* c) {
  std::string err;
  if (!(err = fromRosParam(pnh, &c->grid)).empty()) return err;
  if (!(err = fromRosParam(pnh, &c->height_map)).empty()) return err;
  if (!(err = fromRosParam(pnh, &c->segmentation)).empty()) return err;
  if (!(err = fromRosParam(pnh, &c->plane_fit)).empty()) return err;
  if (!(err = fromRosParam(pnh, &c->labelling)).empty()) return err;
  Reader r(pnh);
  r.read("skip_stationary_frames", &c->skip_stationary_frames);
  r.read("stationary_translation", &c->stationary_translation);
  r.read("grid_look_ahead", &c->grid_look_ahead);
  r.read("stationary_rotation_deg", &c->stationary_rotation_deg);
  r.read("scroll_with_robot", &c->scroll_with_robot);
  r.read("max_cell_age", &c->max_cell_age);
  return r.result(c->validate());
}

std::string SafetyMapRosConfig::validate() const {
  std::ostringstream os;
  if (input != "disparity" && input != "cloud") {
    os << "input = '" << input << "', must be 'disparity' or 'cloud'";
  } else if (fixed_frame.empty()) {
    os << "fixed_frame is empty, must name a tf frame (e.g. odom)";
  } else if (base_frame.empty()) {
    os << "base_frame is empty, must name a tf frame (e.g. base_link)";
  } else if (queue_size < 1 || queue_size > 1000) {
    os << "queue_size = " << queue_size << ", must be in [1, 1000]";
  } else if (!std::isfinite(max_rate) || max_rate < 0.0 || max_rate > 1000.0) {
    os << "max_rate = " << max_rate << ", must be in [0, 1000] Hz (0 = every frame)";
  } else if (!std::isfinite(tf_timeout) || tf_timeout < 0.0 || tf_timeout > 10.0) {
    os << "tf_timeout = " << tf_timeout << ", must be in [0, 10] s";
  } else if (disparity_step < 1 || disparity_step > 16) {
    os << "disparity_step = " << disparity_step << ", must be in [1, 16]";
  } else if (!std::isfinite(time_jump_reset) || time_jump_reset < 0.0 || time_jump_reset > 3600.0) {
    os << "time_jump_reset = " << time_jump_reset << ", must be in [0, 3600] s";
  } else if (save_prefix.empty()) {
    os << "save_prefix is empty, must be a path prefix such as /tmp/safety_map";
  } else if (!std::isfinite(max_tf_wait) || max_tf_wait <= 0.0 || max_tf_wait > 3600.0) {
    os << "max_tf_wait = " << max_tf_wait << ", must be in (0, 3600] s";
  } else if (!std::isfinite(stale_input_timeout) || stale_input_timeout <= 0.0 ||
             stale_input_timeout > 3600.0) {
    os << "stale_input_timeout = " << stale_input_timeout << ", must be in (0, 3600] s";
  }
  return os.str();
}

std::string fromRosParam(const ros::NodeHandle& pnh, SafetyMapRosConfig* c) {
  Reader r(pnh);
  r.read("input", &c->input);
  r.read("fixed_frame", &c->fixed_frame);
  r.read("base_frame", &c->base_frame);
  r.read("queue_size", &c->queue_size);
  r.read("approximate_sync", &c->approximate_sync);
  r.read("max_rate", &c->max_rate);
  r.read("tf_timeout", &c->tf_timeout);
  r.read("disparity_step", &c->disparity_step);
  r.read("time_jump_reset", &c->time_jump_reset);
  r.read("save_prefix", &c->save_prefix);
  r.read("reject_frozen_input", &c->reject_frozen_input);
  r.read("stale_input_timeout", &c->stale_input_timeout);
  r.read("max_tf_wait", &c->max_tf_wait);
  return r.result(c->validate());
}

std::vector<std::string> safetyMapParameterNames() {
  return {
      // VoxelGridConfig
      "voxel_size", "size_x", "size_y", "size_z", "z_below_robot", "incr_high", "incr_low", "decr",
      "occ_threshold", "lop_min", "lop_max", "point_list_capacity", "max_range", "min_range",
      // HeightMapConfig
      "robot_height",
      // GroundSegmentationConfig
      "planning_radius", "height_tolerance", "connectivity", "seed_radius", "segment_islands",
      "island_max_span",
      // PlaneFitConfig
      "min_points", "min_xy_stddev", "plane_vertical_margin",
      // SafetyLabellingConfig
      "max_slope_deg", "min_segment_cells", "thin_ratio", "max_step_height", "min_passage_cells",
      "level_slope_deg", "max_gap_cells", "measured_step_test", "mark_drop_offs", "drop_off_radius",
      "drop_off_min_drop",
      // SafetyMapperConfig
      "skip_stationary_frames", "stationary_translation", "stationary_rotation_deg",
      "grid_look_ahead", "scroll_with_robot", "max_cell_age",
      // SafetyMapRosConfig
      "input", "fixed_frame", "base_frame", "queue_size", "approximate_sync", "max_rate",
      "tf_timeout", "disparity_step", "time_jump_reset", "save_prefix", "reject_frozen_input",
      "stale_input_timeout", "max_tf_wait",
      // Obstacle cue (obstacle_params.h)
      "obstacle_cue", "obstacle_cue_lifetime", "obstacle_cue_min_points",
      // diagnostic_updater's own
      "diagnostic_period"};
}

std::vector<std::string> unknownParameters(const ros::NodeHandle& pnh,
                                           const std::vector<std::string>& known) {
  std::vector<std::string> all;
  std::vector<std::string> unknown;
  if (!pnh.getParamNames(all)) return unknown;
  const std::string prefix = pnh.getNamespace() + "/";
  for (const std::string& name : all) {
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    std::string rest = name.substr(prefix.size());
    rest = rest.substr(0, rest.find('/'));  // first level only
    if (std::find(known.begin(), known.end(), rest) == known.end() &&
        std::find(unknown.begin(), unknown.end(), rest) == unknown.end()) {
      unknown.push_back(rest);
    }
  }
  return unknown;
}

}  // namespace stereo_safety_map
