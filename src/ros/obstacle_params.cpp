#include "stereo_safety_map/ros/obstacle_params.h"

#include <xmlrpcpp/XmlRpcValue.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace stereo_safety_map {

namespace {

// One list of the core's parameters, shared by the parameter server and the YAML readers:
// f(name, pointer) for every field of ObstacleDetectionConfig (003 Def. 1, Sec. 2-5).
template <typename F>
void forEachCoreParam(ObstacleDetectionConfig* c, F&& f) {
  f("height_threshold", &c->height_threshold);
  f("max_height", &c->max_height);
  f("slope_threshold_deg", &c->slope_threshold_deg);
  f("exhaustive_search", &c->exhaustive_search);
  f("search_foot_points", &c->search_foot_points);
  f("sample_spacing", &c->sample_spacing);
  f("max_candidates_per_pixel", &c->max_candidates_per_pixel);
  f("surface_link_distance", &c->surface_link_distance);
  f("surface_link_pixels", &c->surface_link_pixels);
  f("segment", &c->segment);
  f("reject_false_obstacles", &c->reject_false_obstacles);
  f("min_avg_slope_deg", &c->min_avg_slope_deg);
  f("min_max_slope_deg", &c->min_max_slope_deg);
  f("min_avg_height", &c->min_avg_height);
  f("min_max_height", &c->min_max_height);
  f("min_bbox_perimeter", &c->min_bbox_perimeter);
  f("min_volume", &c->min_volume);
}

template <typename F>
void forEachRosParam(ObstacleDetectionRosConfig* c, F&& f) {
  f("input", &c->input);
  f("fixed_frame", &c->fixed_frame);
  f("method", &c->method);
  f("queue_size", &c->queue_size);
  f("approximate_sync", &c->approximate_sync);
  f("min_depth", &c->min_depth);
  f("max_depth", &c->max_depth);
  f("focal_length", &c->focal_length);
}

template <typename F>
void forEachCueParam(ObstacleCueRosConfig* c, F&& f) {
  f("obstacle_cue", &c->enabled);
  f("obstacle_cue_lifetime", &c->cue.lifetime);
  f("obstacle_cue_min_points", &c->cue.min_points_per_cell);
}

// Typed reads from the parameter server, remembering the first error; absent names are kept.
class RosReader {
 public:
  explicit RosReader(const ros::NodeHandle& pnh) : pnh_(pnh) {}
  void operator()(const char* name, double* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
      *value = static_cast<double>(v);
    } else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
      *value = static_cast<int>(v);
    } else {
      fail(name, v, "a number");
    }
  }
  void operator()(const char* name, int* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
      *value = static_cast<int>(v);
    } else {
      fail(name, v, "an integer");
    }
  }
  void operator()(const char* name, bool* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeBoolean) {
      *value = static_cast<bool>(v);
    } else {
      fail(name, v, "true or false");
    }
  }
  void operator()(const char* name, std::string* value) {
    XmlRpc::XmlRpcValue v;
    if (!fetch(name, &v)) return;
    if (v.getType() == XmlRpc::XmlRpcValue::TypeString) {
      *value = static_cast<std::string>(v);
    } else {
      fail(name, v, "a string");
    }
  }
  std::string result(const std::string& range_error) const {
    if (!error_.empty()) return error_;
    if (range_error.empty()) return "";
    return "invalid parameter in " + pnh_.getNamespace() + ": " + range_error;
  }

 private:
  bool fetch(const char* name, XmlRpc::XmlRpcValue* v) {
    if (!error_.empty() || !pnh_.hasParam(name)) return false;
    return pnh_.getParam(name, *v);
  }
  void fail(const char* name, XmlRpc::XmlRpcValue& v, const char* expected) {
    std::ostringstream os;
    os << "invalid parameter " << pnh_.resolveName(name) << ": must be " << expected << ", got ";
    v.write(os);
    error_ = os.str();
  }
  const ros::NodeHandle& pnh_;
  std::string error_;
};

// The same from a YAML map.
class YamlReader {
 public:
  YamlReader(const YAML::Node& root, const std::string& path) : root_(root), path_(path) {}
  template <typename T>
  void operator()(const char* name, T* value) {
    if (!error_.empty()) return;
    const YAML::Node n = root_[name];
    if (!n.IsDefined() || n.IsNull()) return;
    try {
      if (!n.IsScalar()) throw YAML::Exception(YAML::Mark(), "not a scalar");
      if constexpr (std::is_same<T, int>::value) {
        // as<int>() would accept "1e3" or truncate nothing; require an integer literal.
        const std::string s = n.Scalar();
        std::size_t used = 0;
        const long v = std::stol(s, &used);
        if (used != s.size()) throw std::invalid_argument(s);
        *value = static_cast<int>(v);
      } else {
        *value = n.as<T>();
      }
    } catch (const std::exception&) {
      error_ =
          path_ + ": invalid value for " + name + ": '" + (n.IsScalar() ? n.Scalar() : "?") + "'";
    }
  }
  std::string result(const std::string& range_error) const {
    if (!error_.empty()) return error_;
    if (range_error.empty()) return "";
    return path_ + ": " + range_error;
  }

 private:
  YAML::Node root_;
  std::string path_;
  std::string error_;
};

std::string loadYaml(const std::string& path, YAML::Node* root) {
  try {
    *root = YAML::LoadFile(path);
  } catch (const std::exception& e) {
    return "cannot read " + path + ": " + e.what();
  }
  if (!root->IsMap()) return path + " is not a YAML map of parameters";
  return "";
}

// The cue's ranges under the parameter names (the core's validate() names its fields).
std::string cueRangeError(const ObstacleCueRosConfig& c) {
  std::ostringstream os;
  const ObstacleCueConfig& q = c.cue;
  if (!std::isfinite(q.lifetime) || q.lifetime < 0.0 || q.lifetime > 60.0) {
    os << "obstacle_cue_lifetime = " << q.lifetime << ", must be in [0, 60] s";
  } else if (q.min_points_per_cell < 1 || q.min_points_per_cell > 1000000) {
    os << "obstacle_cue_min_points = " << q.min_points_per_cell << ", must be in [1, 1000000]";
  } else {
    os << q.validate();
  }
  return os.str();
}

}  // namespace

std::string ObstacleDetectionRosConfig::validate() const {
  std::ostringstream os;
  if (input != "disparity" && input != "cloud") {
    os << "input = '" << input << "', must be 'disparity' or 'cloud'";
  } else if (fixed_frame.empty()) {
    os << "fixed_frame is empty, must name a tf frame whose z axis points up (e.g. odom)";
  } else if (method != "3d" && method != "columnwise") {
    os << "method = '" << method << "', must be '3d' or 'columnwise'";
  } else if (queue_size < 1 || queue_size > 1000) {
    os << "queue_size = " << queue_size << ", must be in [1, 1000]";
  } else if (!std::isfinite(min_depth) || min_depth < 0.0) {
    os << "min_depth = " << min_depth << ", must be >= 0 m";
  } else if (!std::isfinite(max_depth) || max_depth <= min_depth || max_depth > 1000.0) {
    os << "max_depth = " << max_depth << ", must be in (min_depth, 1000] m";
  } else if (!std::isfinite(focal_length) || focal_length < 0.0) {
    os << "focal_length = " << focal_length << ", must be >= 0 px (0 = from the cloud)";
  }
  return os.str();
}

std::string fromRosParam(const ros::NodeHandle& pnh, ObstacleDetectionConfig* c) {
  RosReader r(pnh);
  forEachCoreParam(c, r);
  return r.result(c->validate());
}

std::string fromRosParam(const ros::NodeHandle& pnh, ObstacleDetectionRosConfig* c) {
  RosReader r(pnh);
  forEachRosParam(c, r);
  return r.result(c->validate());
}

std::string fromRosParam(const ros::NodeHandle& pnh, ObstacleCueRosConfig* c) {
  RosReader r(pnh);
  forEachCueParam(c, r);
  return r.result(cueRangeError(*c));
}

std::vector<std::string> obstacleDetectionParameterNames() {
  std::vector<std::string> names;
  auto add = [&names](const char* name, auto*) { names.emplace_back(name); };
  ObstacleDetectionConfig core;
  ObstacleDetectionRosConfig ros;
  forEachCoreParam(&core, add);
  forEachRosParam(&ros, add);
  names.emplace_back("diagnostic_period");  // diagnostic_updater's own
  return names;
}

std::vector<std::string> obstacleCueParameterNames() {
  std::vector<std::string> names;
  auto add = [&names](const char* name, auto*) { names.emplace_back(name); };
  ObstacleCueRosConfig c;
  forEachCueParam(&c, add);
  return names;
}

std::string loadObstacleDetectionParams(const std::string& path, ObstacleDetectionConfig* config,
                                        ObstacleDetectionRosConfig* ros_config) {
  YAML::Node root;
  std::string err = loadYaml(path, &root);
  if (!err.empty()) return err;
  YamlReader r(root, path);
  forEachCoreParam(config, r);
  err = r.result(config->validate());
  if (!err.empty() || ros_config == nullptr) return err;
  YamlReader rr(root, path);
  forEachRosParam(ros_config, rr);
  return rr.result(ros_config->validate());
}

std::string loadObstacleCueParams(const std::string& path, ObstacleCueRosConfig* config) {
  YAML::Node root;
  const std::string err = loadYaml(path, &root);
  if (!err.empty()) return err;
  YamlReader r(root, path);
  forEachCueParam(config, r);
  return r.result(cueRangeError(*config));
}

}  // namespace stereo_safety_map
