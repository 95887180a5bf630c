#include "stereo_safety_map/ros/occupancy_grid_2d_params.h"

#include "stereo_safety_map/ros/nodelet_params.h"
#include "stereo_safety_map/ros/param_reader.h"
#include "stereo_safety_map/ros/param_yaml.h"
#include "stereo_safety_map/ros/stereo_input_fields.h"

#include <cmath>
#include <sstream>

namespace stereo_safety_map {

namespace {

// The core keys applied and validated; the nodelet's own keys (frames, queues) are accepted and
// ignored, any other key is an error.
std::string applyYaml(const YAML::Node& root, const std::string& where, OccupancyGrid2DConfig* c) {
  std::vector<std::string> unknown;
  std::string e = applyYamlFields(root, occupancyGrid2DFields(), c, where, &unknown);
  if (!e.empty()) return e;
  for (const std::string& key : unknown) {
    if (occupancyGrid2DRosFields().find(key) == nullptr)
      return where + ": unknown parameter " + key;
  }
  e = c->validate();
  return e.empty() ? "" : where + ": " + e;
}

}  // namespace

std::string OccupancyGrid2DRosConfig::validate() const {
  return firstError({frameError("fixed_frame", fixed_frame, "a tf frame (e.g. odom)"),
                     frameError("base_frame", base_frame, "a tf frame (e.g. base_footprint)"),
                     queueSizeError(queue_size), maxRateError(max_rate), tfTimeoutError(tf_timeout),
                     timeJumpResetError(time_jump_reset)});
}

const ParamFieldList<OccupancyGrid2DRosConfig>& occupancyGrid2DRosFields() {
  using R = OccupancyGrid2DRosConfig;
  static const ParamFieldList<R> list = [] {
    ParamFieldList<R> l;
    l.section("Nodelet");
    addFixedFrameField(l, "frame the grid is built and published in (not in 002).");
    addBaseFrameField(l,
                      "robot frame, origin on the floor: the band's floor and the window's centre "
                      "(not in 002).");
    addSyncFields(l);
    addMaxRateField(l).doc(
        "most frames processed per second, 0 = every frame (002 Sec. 1 ran at 5 Hz).");
    addTfTimeoutField(l);
    addTimeJumpResetField(
        l, "stamps going back by more than this clear the grid; less: the frame is dropped.");
    l.add("scroll_with_robot", &R::scroll_with_robot)
        .doc("keep the window centred on the robot (not in 002: a building-sized map).");
    l.addExternal("diagnostic_period", 1.0).unit("s").doc("diagnostic_updater's period.");
    l.setValidator([](const R& c) { return c.validate(); });
    return l;
  }();
  return list;
}

std::string fromRosParam(const ros::NodeHandle& pnh, OccupancyGrid2DConfig* c) {
  return readParams(pnh, occupancyGrid2DFields(), c);
}

std::string fromRosParam(const ros::NodeHandle& pnh, OccupancyGrid2DRosConfig* c) {
  return readParams(pnh, occupancyGrid2DRosFields(), c);
}

std::vector<std::string> occupancyGrid2DParameterNames() {
  return nodeletParameterNames("occupancy_grid_2d");
}

std::string loadOccupancyGrid2DParamsFile(const std::string& path, OccupancyGrid2DConfig* c) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const std::exception& e) {
    return "cannot read " + path + ": " + e.what();
  }
  return applyYaml(root, path, c);
}

std::string setOccupancyGrid2DParam(const std::string& assignment, OccupancyGrid2DConfig* c) {
  YAML::Node root;
  const std::string e = parseAssignment(assignment, &root);
  return e.empty() ? applyYaml(root, "--set", c) : e;
}

}  // namespace stereo_safety_map
