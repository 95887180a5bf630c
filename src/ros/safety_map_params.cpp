#include "stereo_safety_map/ros/safety_map_params.h"

#include "stereo_safety_map/ros/nodelet_params.h"
#include "stereo_safety_map/ros/param_reader.h"
#include "stereo_safety_map/ros/stereo_input_fields.h"

#include <xmlrpcpp/XmlRpcValue.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace stereo_safety_map {

std::string fromRosParam(const ros::NodeHandle& pnh, SafetyMapperConfig* c) {
  return readParams(pnh, safetyMapperFields(), c);
}

std::string SafetyMapRosConfig::validate() const {
  const std::string input_error = firstError(
      {inputError(input), frameError("fixed_frame", fixed_frame, "a tf frame (e.g. odom)"),
       frameError("base_frame", base_frame, "a tf frame (e.g. base_footprint)"),
       queueSizeError(queue_size), maxRateError(max_rate), tfTimeoutError(tf_timeout)});
  if (!input_error.empty()) return input_error;
  std::ostringstream os;
  if (disparity_step < 1 || disparity_step > 16) {
    os << "disparity_step = " << disparity_step << ", must be in [1, 16]";
  } else if (!row_gap_fill.validate().empty()) {
    os << row_gap_fill.validate();
  } else if (!timeJumpResetError(time_jump_reset).empty()) {
    os << timeJumpResetError(time_jump_reset);
  } else if (save_directory.empty() || save_directory.front() != '/') {
    os << "save_directory = '" << save_directory
       << "', must be an absolute path such as /tmp/stereo_safety_map";
  } else if (save_prefix.empty()) {
    os << "save_prefix is empty, must be a path prefix such as map (under save_directory)";
  } else if (!std::isfinite(max_tf_wait) || max_tf_wait <= 0.0 || max_tf_wait > 3600.0) {
    os << "max_tf_wait = " << max_tf_wait << ", must be in (0, 3600] s";
  } else if (frame_queue < 1 || frame_queue > 10) {
    os << "frame_queue = " << frame_queue << ", must be in [1, 10]";
  } else if (!std::isfinite(stale_input_timeout) || stale_input_timeout <= 0.0 ||
             stale_input_timeout > 3600.0) {
    os << "stale_input_timeout = " << stale_input_timeout << ", must be in (0, 3600] s";
  } else if (!std::isfinite(obstacles_cloud_height) || obstacles_cloud_height < -10.0 ||
             obstacles_cloud_height > 10.0) {
    os << "obstacles_cloud_height = " << obstacles_cloud_height << ", must be in [-10, 10] m";
  }
  const std::string s = os.str();
  return s.empty() ? costs.validate() : s;
}

const ParamFieldList<SafetyMapRosConfig>& safetyMapRosFields() {
  using R = SafetyMapRosConfig;
  static const ParamFieldList<R> list = [] {
    ParamFieldList<R> l;
    l.section("Nodelet");
    addInputField(l,
                  "input type: stereo_msgs/DisparityImage + CameraInfo, or sensor_msgs/PointCloud2 "
                  "from any depth sensor.");
    addFixedFrameField(
        l, "frame the map is built in; only needs to be locally consistent (000 Sec. III).");
    addBaseFrameField(l,
                      "robot frame, origin on the ground under the robot (000 Alg. 1 step 2); "
                      "REP 120's footprint frame.");
    l.add("sensor_frame", &R::sensor_frame)
        .rangeText("tf frame or empty")
        .doc(
            "input cloud: the sensor's frame, where its rays start (free space, stationary "
            "frames), for a cloud already transformed into another frame (the robot's, odom); "
            "empty = the cloud's own frame (ours).");
    addSyncFields(l);
    addMaxRateField(l)
        .live(SafetyMapLevel::kRos)
        .doc(
            "most frames processed per second, 0 = every frame; newer frames replace a waiting "
            "one.");
    addTfTimeoutField(l);
    l.add("disparity_step", &R::disparity_step).closed(1, 16).doc("use every n-th pixel.");
    addTimeJumpResetField(l,
                          "stamps going back by more than this, with the clock going back too (a "
                          "bag restarted), reset the map once; otherwise the frame is dropped (a "
                          "stale message never wipes the map).");
    l.add("max_tf_wait", &R::max_tf_wait)
        .openClosed(0, 3600)
        .unit("s")
        .doc(
            "a frame whose transform arrived later than this after the frame is dropped (tf "
            "stalled: its pose would be interpolated across the gap).");
    l.add("frame_queue", &R::frame_queue)
        .closed(1, 10)
        .unit("frames")
        .doc(
            "frames that may wait for the mapper: 1 = the newest only (a frame arriving while "
            "one waits replaces it); 2 absorbs one frame whose map took longer than the camera "
            "period (the manager's other nodelets had the cores) instead of dropping it, at one "
            "frame of latency then. A dropped frame's map reset passes to the next (ours).");
    l.add("reject_frozen_input", &R::reject_frozen_input)
        .doc(
            "drop a frame whose disparity / cloud is byte for byte the previous frame's under a "
            "new stamp (a frozen camera or driver); false for a noiseless simulator that repeats "
            "frames.");
    l.add("stale_input_timeout", &R::stale_input_timeout)
        .openClosed(0, 3600)
        .unit("s")
        .doc(
            "WARN in /diagnostics after this long without input or without a usable frame; after "
            "this long (ROS clock) without a frame integrated, the published `safety_map` turns "
            "all Unknown (-1), still at the last frame's stamp, and `safety_obstacles` stops.");
    l.add("save_directory", &R::save_directory)
        .rangeText("absolute path")
        .doc(
            "`~save` writes only under this directory (created when missing); a prefix that "
            "leaves it (an absolute path elsewhere, `..`, a symlink out) is refused.");
    l.add("save_prefix", &R::save_prefix)
        .rangeText("non-empty")
        .doc(
            "default prefix of `~save` (<prefix>.bt, .pgm, .yaml and _labels.png), relative to "
            "save_directory.");
    l.addExternal("diagnostic_period", 1.0).unit("s").doc("diagnostic_updater's period.");
    l.include(rowGapFillFields(), &R::row_gap_fill);  // section "Reprojection"
    l.section("Cost table of `safety_map` (core/map_costs.h; Non-ground 100, Unknown -1 fixed)");
    l.add("cost_level", &R::costs, &CostTable::level)
        .closed(0, 99)
        .doc("value of Level cells (000 Sec. I-A: safe).");
    l.add("cost_inclined_low", &R::costs, &CostTable::inclined_low)
        .closed(0, 99)
        .rangeText("[cost_level, 99]")
        .doc(
            "value of Inclined cells at theta_T, rising linearly with the slope (000 Alg. 2 step "
            "28).");
    l.add("cost_inclined_high", &R::costs, &CostTable::inclined_high)
        .closed(0, 99)
        .rangeText("[cost_inclined_low, 99]")
        .doc("value of Inclined cells at theta_max; graded Inclined stays below lethal.");
    l.add("cost_drop_off", &R::costs, &CostTable::drop_off)
        .closed(1, 100)
        .doc(
            "value of potential drop-off edges (000 Sec. VI: a drop-off is expected nearby); 100 = "
            "lethal. Below 100 a costmap needs trinary_costmap: false, or the edge reads as free.");
    l.add("obstacles_cloud_height", &R::obstacles_cloud_height)
        .closed(-10, 10)
        .unit("m")
        .doc(
            "height of the `safety_obstacles` points above the robot's base (within the obstacle "
            "layer's min / max_obstacle_height) (ours).");

    l.setValidator([](const R& c) { return c.validate(); });
    return l;
  }();
  return list;
}

std::string fromRosParam(const ros::NodeHandle& pnh, SafetyMapRosConfig* c) {
  return readParams(pnh, safetyMapRosFields(), c);
}

std::vector<std::string> safetyMapParameterNames() {
  return nodeletParameterNames("safety_map");
}

std::string fromRosParam(const ros::NodeHandle& pnh, LandmarkStreamConfig* c) {
  return readParams(pnh, landmarkStreamFields(), c);
}

std::vector<std::string> landmarkParameterNames() {
  return landmarkStreamFields().names();
}

}  // namespace stereo_safety_map
