#include "stereo_safety_map/ros/occupancy_2d_params.h"

#include "stereo_safety_map/ros/param_reader.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <sstream>

namespace stereo_safety_map {

namespace {

const char* const kRosKeys[] = {"fixed_frame",      "base_frame",       "queue_size",
                                "approximate_sync", "max_rate",         "tf_timeout",
                                "time_jump_reset",  "scroll_with_robot"};

// Core keys -> setters from YAML (the file and --set); the rosparam reads below use the same
// names.
using Setter = std::function<void(const YAML::Node&, OccupancyGrid2DConfig*)>;
const std::map<std::string, Setter>& coreSetters() {
  static const std::map<std::string, Setter> table = {
      {"resolution",
       [](const YAML::Node& n, OccupancyGrid2DConfig* c) { c->resolution = n.as<double>(); }},
      {"size_x", [](const YAML::Node& n, OccupancyGrid2DConfig* c) { c->size_x = n.as<double>(); }},
      {"size_y", [](const YAML::Node& n, OccupancyGrid2DConfig* c) { c->size_y = n.as<double>(); }},
      {"k", [](const YAML::Node& n, OccupancyGrid2DConfig* c) { c->k = n.as<int>(); }},
      {"free_threshold",
       [](const YAML::Node& n, OccupancyGrid2DConfig* c) { c->free_threshold = n.as<int>(); }},
      {"occupied_threshold",
       [](const YAML::Node& n, OccupancyGrid2DConfig* c) { c->occupied_threshold = n.as<int>(); }},
      {"floor_clearance",
       [](const YAML::Node& n, OccupancyGrid2DConfig* c) { c->floor_clearance = n.as<double>(); }},
      {"robot_height",
       [](const YAML::Node& n, OccupancyGrid2DConfig* c) { c->robot_height = n.as<double>(); }},
      {"disparity_half_width",
       [](const YAML::Node& n, OccupancyGrid2DConfig* c) {
         c->disparity_half_width = n.as<double>();
       }},
      {"accuracy_preservation",
       [](const YAML::Node& n, OccupancyGrid2DConfig* c) {
         c->accuracy_preservation = n.as<bool>();
       }},
  };
  return table;
}

std::string applyYaml(const YAML::Node& root, const std::string& where, OccupancyGrid2DConfig* c) {
  if (!root.IsMap()) return where + ": not a map of parameters";
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    const auto it = coreSetters().find(key);
    if (it == coreSetters().end()) {
      if (std::find(std::begin(kRosKeys), std::end(kRosKeys), key) != std::end(kRosKeys) ||
          key == "diagnostic_period") {
        continue;  // the nodelet's own settings
      }
      return where + ": unknown parameter " + key;
    }
    try {
      it->second(kv.second, c);
    } catch (const std::exception& e) {
      return where + ": bad value for " + key + ": " + e.what();
    }
  }
  const std::string e = c->validate();
  return e.empty() ? "" : where + ": " + e;
}

}  // namespace

std::string Occupancy2DRosConfig::validate() const {
  std::ostringstream os;
  if (fixed_frame.empty()) {
    os << "fixed_frame is empty, must name a tf frame (e.g. odom)";
  } else if (base_frame.empty()) {
    os << "base_frame is empty, must name a tf frame (e.g. base_link)";
  } else if (queue_size < 1 || queue_size > 1000) {
    os << "queue_size = " << queue_size << ", must be in [1, 1000]";
  } else if (!std::isfinite(max_rate) || max_rate < 0.0 || max_rate > 1000.0) {
    os << "max_rate = " << max_rate << ", must be in [0, 1000] Hz (0 = every frame)";
  } else if (!std::isfinite(tf_timeout) || tf_timeout < 0.0 || tf_timeout > 10.0) {
    os << "tf_timeout = " << tf_timeout << ", must be in [0, 10] s";
  } else if (!std::isfinite(time_jump_reset) || time_jump_reset < 0.0 || time_jump_reset > 3600.0) {
    os << "time_jump_reset = " << time_jump_reset << ", must be in [0, 3600] s";
  }
  return os.str();
}

std::string fromRosParam(const ros::NodeHandle& pnh, OccupancyGrid2DConfig* c) {
  ParamReader r(pnh);
  r.read("resolution", &c->resolution);
  r.read("size_x", &c->size_x);
  r.read("size_y", &c->size_y);
  r.read("k", &c->k);
  r.read("free_threshold", &c->free_threshold);
  r.read("occupied_threshold", &c->occupied_threshold);
  r.read("floor_clearance", &c->floor_clearance);
  r.read("robot_height", &c->robot_height);
  r.read("disparity_half_width", &c->disparity_half_width);
  r.read("accuracy_preservation", &c->accuracy_preservation);
  return r.result(c->validate());
}

std::string fromRosParam(const ros::NodeHandle& pnh, Occupancy2DRosConfig* c) {
  ParamReader r(pnh);
  r.read("fixed_frame", &c->fixed_frame);
  r.read("base_frame", &c->base_frame);
  r.read("queue_size", &c->queue_size);
  r.read("approximate_sync", &c->approximate_sync);
  r.read("max_rate", &c->max_rate);
  r.read("tf_timeout", &c->tf_timeout);
  r.read("time_jump_reset", &c->time_jump_reset);
  r.read("scroll_with_robot", &c->scroll_with_robot);
  return r.result(c->validate());
}

std::vector<std::string> occupancy2DParameterNames() {
  std::vector<std::string> names;
  for (const auto& kv : coreSetters())
    names.push_back(kv.first);
  names.insert(names.end(), std::begin(kRosKeys), std::end(kRosKeys));
  names.push_back("diagnostic_period");  // diagnostic_updater's own
  return names;
}

std::string loadOccupancy2DParamsFile(const std::string& path, OccupancyGrid2DConfig* c) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const std::exception& e) {
    return "cannot read " + path + ": " + e.what();
  }
  return applyYaml(root, path, c);
}

std::string setOccupancy2DParam(const std::string& assignment, OccupancyGrid2DConfig* c) {
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) return "--set needs key=value, got " + assignment;
  YAML::Node root;
  try {
    root[assignment.substr(0, eq)] = YAML::Load(assignment.substr(eq + 1));
  } catch (const std::exception& e) {
    return "--set " + assignment + ": " + e.what();
  }
  return applyYaml(root, "--set", c);
}

}  // namespace stereo_safety_map
