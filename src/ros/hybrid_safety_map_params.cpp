#include "stereo_safety_map/ros/hybrid_safety_map_params.h"

#include "stereo_safety_map/ros/nodelet_params.h"
#include "stereo_safety_map/ros/param_reader.h"
#include "stereo_safety_map/ros/stereo_input_fields.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace stereo_safety_map {

namespace {

// The nodelet's settings, then the laser grid's window in cells from laser_size_x / laser_size_y
// and resolution (stored into `p`), then the laser grid's and the combination's validate().
std::string finishHybrid(HybridSafetyMapParams* p) {
  const HybridSafetyMapRosConfig* rc = &p->ros;
  LaserGridConfig* laser = &p->laser;
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
  if (err.empty()) err = p->hybrid.validate();
  return err;
}

// The nodelet's own section: its input's fields (the shared stereo_input_fields.h helpers) and
// the timing of the combination. laser_size_x / laser_size_y, also HybridSafetyMapRosConfig's, are
// listed with the laser grid's fields.
const ParamFieldList<HybridSafetyMapRosConfig>& nodeletSectionFields() {
  using R = HybridSafetyMapRosConfig;
  static const ParamFieldList<R> list = [] {
    ParamFieldList<R> l;
    l.section("Nodelet");
    addFixedFrameField(l,
                       "frame of the laser grid; must be the safety-map nodelet's (stereo maps in "
                       "another frame are refused).");
    addQueueSizeField(l, "scan subscriber and tf filter queue.");
    l.add("vision_timeout", &R::vision_timeout)
        .openClosed(0, 3600)
        .unit("s")
        .doc("a stereo map older than this, against the newest scan, is no longer combined.");
    l.add("laser_only_rate", &R::laser_only_rate)
        .closed(0, 100)
        .unit("Hz")
        .doc("rate of the laser-only map while no current stereo map exists; 0 = never.");
    addTimeJumpResetField(
        l, "scan stamps going back by more than this clear the grids; less: the scan is dropped.");
    l.addExternal("diagnostic_period", 1.0).unit("s").doc("diagnostic_updater's period.");
    return l;
  }();
  return list;
}

}  // namespace

std::string HybridSafetyMapRosConfig::validate() const {
  const std::string input_error =
      firstError({frameError("fixed_frame", fixed_frame, "a tf frame (e.g. odom)"),
                  queueSizeError(queue_size)});
  if (!input_error.empty()) return input_error;
  if (!std::isfinite(vision_timeout) || vision_timeout <= 0.0 || vision_timeout > 3600.0) {
    return rangeError("vision_timeout", vision_timeout, "(0, 3600] s");
  }
  if (!std::isfinite(laser_only_rate) || laser_only_rate < 0.0 || laser_only_rate > 100.0) {
    return rangeError("laser_only_rate", laser_only_rate, "[0, 100] Hz");
  }
  const std::string jump_error = timeJumpResetError(time_jump_reset);
  if (!jump_error.empty()) return jump_error;
  if (!std::isfinite(laser_size_x) || laser_size_x <= 0.0 || laser_size_x > 1000.0) {
    return rangeError("laser_size_x", laser_size_x, "[resolution, 1000] m");
  }
  if (!std::isfinite(laser_size_y) || laser_size_y <= 0.0 || laser_size_y > 1000.0) {
    return rangeError("laser_size_y", laser_size_y, "[resolution, 1000] m");
  }
  return "";
}

const ParamFieldList<HybridSafetyMapParams>& hybridSafetyMapParamsFields() {
  using P = HybridSafetyMapParams;
  using R = HybridSafetyMapRosConfig;
  static const ParamFieldList<P> list = [] {
    ParamFieldList<P> l;
    l.include(nodeletSectionFields(), &P::ros);
    l.include(laserGridFields(), &P::laser);
    l.section(laserGridFields().fields().front().info.section);
    l.add("laser_size_x", &P::ros, &R::laser_size_x)
        .openClosed(0, 1000)
        .rangeText("[resolution, 1000]")
        .unit("m")
        .doc(
            "laser grid extent along x, centred on the laser; larger than the 10 m stereo map "
            "so that it covers it while the laser sits off the robot's centre (ours).");
    l.add("laser_size_y", &P::ros, &R::laser_size_y)
        .openClosed(0, 1000)
        .rangeText("[resolution, 1000]")
        .unit("m")
        .doc("laser grid extent along y (ours).");
    l.include(hybridSafetyMapFields(), &P::hybrid);
    l.setValidator([](const P& p) {
      P copy = p;
      return finishHybrid(&copy);
    });
    return l;
  }();
  return list;
}

std::string fromRosParam(const ros::NodeHandle& pnh, HybridSafetyMapRosConfig* rc,
                         LaserGridConfig* laser, HybridSafetyMapConfig* hybrid) {
  HybridSafetyMapParams p{*rc, *laser, *hybrid};
  ParamReader r(pnh);
  r.readFields(hybridSafetyMapParamsFields(), &p);
  const std::string err = r.error().empty() ? finishHybrid(&p) : "";
  *rc = p.ros;
  *laser = p.laser;
  *hybrid = p.hybrid;
  return r.result(err);
}

std::vector<std::string> hybridSafetyMapParameterNames() {
  return nodeletParameterNames("hybrid_safety_map");
}

}  // namespace stereo_safety_map
