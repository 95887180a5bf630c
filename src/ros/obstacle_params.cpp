#include "stereo_safety_map/ros/obstacle_params.h"

#include "stereo_safety_map/ros/nodelet_params.h"
#include "stereo_safety_map/ros/param_reader.h"
#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/ros/stereo_input_fields.h"

#include <cmath>
#include <sstream>

namespace stereo_safety_map {

namespace {

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

// The fields of `list` from one YAML map, validated; messages start with the file's path.
template <typename Config>
std::string applyYaml(const YAML::Node& root, const std::string& path,
                      const ParamFieldList<Config>& list, Config* config) {
  const std::string err = applyYamlFields(root, list, config, path);
  if (!err.empty()) return err;
  const std::string range = list.validate(*config);
  return range.empty() ? "" : path + ": " + range;
}

}  // namespace

const ParamFieldList<ObstacleDetectionRosConfig>& obstacleDetectionRosFields() {
  using R = ObstacleDetectionRosConfig;
  static const ParamFieldList<R> list = [] {
    ParamFieldList<R> l;
    l.section("Nodelet");
    addInputField(l,
                  "input type: stereo_msgs/DisparityImage + left CameraInfo, or an organised "
                  "sensor_msgs/PointCloud2 (one point per pixel).");
    addFixedFrameField(l, "its z axis is \"up\" (003 Def. 1 heights); frame of the outputs.");
    l.add("method", &R::method)
        .oneOf({"3d", "columnwise"})
        .doc("OD / OS Algorithm 2 (003 Sec. 2-3), or the column-wise baseline (003 Sec. 1, 6).");
    addSyncFields(l);
    addMaxRateField(l).doc(
        "most frames processed per second, 0 = every frame (not in 003); newer frames replace a "
        "waiting one. 0: the default graph keeps a 30 Hz camera on two cores with the detector "
        "on every frame (issue 18); 15 or less on a smaller machine (the safety map's cue lives "
        "1 s).");
    l.add("min_depth", &R::min_depth)
        .atLeast(0)
        .unit("m")
        .doc("range image: nearer points are missing (the safety map's min_range).");
    l.add("max_depth", &R::max_depth)
        .closed(0, 1000)
        .rangeText("(min_depth, 1000]")
        .unit("m")
        .doc("range image: farther points are missing (the safety map's max_range).");
    l.add("focal_length", &R::focal_length)
        .atLeast(0)
        .unit("px")
        .doc("cloud input only: f of the organised cloud; 0 = fitted from the cloud itself.");
    l.add("decimation", &R::decimation)
        .closed(1, 8)
        .doc(
            "the detector runs on every n-th pixel of every n-th row, with f / n and the noise "
            "margin of the full image (ours; 1 = the full image, 003).");
    l.addExternal("diagnostic_period", 1.0).unit("s").doc("diagnostic_updater's period.");
    l.setValidator([](const R& c) { return c.validate(); });
    return l;
  }();
  return list;
}

const ParamFieldList<ObstacleCueRosConfig>& obstacleCueFields() {
  using C = ObstacleCueRosConfig;
  static const ParamFieldList<C> list = [] {
    ParamFieldList<C> l;
    l.section("Obstacle cue (paper 003, `core/obstacle_cue.h`; see \"Obstacle cue\" below)");
    l.add("obstacle_cue", &C::enabled)
        .doc(
            "subscribe to `obstacles` and mark their cells Non-ground in the next map (003 + 000 "
            "Sec. VII-B).");
    l.add("obstacle_cue_lifetime", &C::cue, &ObstacleCueConfig::lifetime)
        .closed(0, 60)
        .unit("s")
        .doc("a cue marks the maps within this time of its stamp (ours).");
    l.add("obstacle_cue_min_points", &C::cue, &ObstacleCueConfig::min_points_per_cell)
        .closed(1, 1000000)
        .doc("cue points a cell needs to be marked (ours).");
    l.setValidator(cueRangeError);
    return l;
  }();
  return list;
}

std::string ObstacleDetectionRosConfig::validate() const {
  const std::string input_error =
      firstError({inputError(input), frameError("fixed_frame", fixed_frame,
                                                "a tf frame whose z axis points up (e.g. odom)")});
  if (!input_error.empty()) return input_error;
  std::ostringstream os;
  if (method != "3d" && method != "columnwise") {
    os << "method = '" << method << "', must be '3d' or 'columnwise'";
  } else if (!queueSizeError(queue_size).empty()) {
    os << queueSizeError(queue_size);
  } else if (!maxRateError(max_rate).empty()) {
    os << maxRateError(max_rate);
  } else if (!std::isfinite(min_depth) || min_depth < 0.0) {
    os << "min_depth = " << min_depth << ", must be >= 0 m";
  } else if (!std::isfinite(max_depth) || max_depth <= min_depth || max_depth > 1000.0) {
    os << "max_depth = " << max_depth << ", must be in (min_depth, 1000] m";
  } else if (!std::isfinite(focal_length) || focal_length < 0.0) {
    os << "focal_length = " << focal_length << ", must be >= 0 px (0 = from the cloud)";
  } else if (decimation < 1 || decimation > 8) {
    os << "decimation = " << decimation << ", must be in [1, 8]";
  }
  return os.str();
}

std::string fromRosParam(const ros::NodeHandle& pnh, ObstacleDetectionConfig* c) {
  return readParams(pnh, obstacleDetectionFields(), c);
}

std::string fromRosParam(const ros::NodeHandle& pnh, ObstacleDetectionRosConfig* c) {
  return readParams(pnh, obstacleDetectionRosFields(), c);
}

std::string fromRosParam(const ros::NodeHandle& pnh, ObstacleCueRosConfig* c) {
  return readParams(pnh, obstacleCueFields(), c);
}

std::vector<std::string> obstacleDetectionParameterNames() {
  return nodeletParameterNames("obstacle_detection");
}

std::vector<std::string> obstacleCueParameterNames() {
  return obstacleCueFields().names();
}

std::string loadObstacleDetectionParams(const std::string& path, ObstacleDetectionConfig* config,
                                        ObstacleDetectionRosConfig* ros_config) {
  YAML::Node root;
  std::string err = loadYamlMap(path, &root);
  if (err.empty()) err = applyYaml(root, path, obstacleDetectionFields(), config);
  if (err.empty() && ros_config != nullptr) {
    err = applyYaml(root, path, obstacleDetectionRosFields(), ros_config);
  }
  return err;
}

std::string loadObstacleCueParams(const std::string& path, ObstacleCueRosConfig* config) {
  YAML::Node root;
  std::string err = loadYamlMap(path, &root);
  if (err.empty()) err = applyYaml(root, path, obstacleCueFields(), config);
  return err;
}

}  // namespace stereo_safety_map
