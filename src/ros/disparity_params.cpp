#include "stereo_safety_map/ros/disparity_params.h"

#include "stereo_safety_map/ros/nodelet_params.h"
#include "stereo_safety_map/ros/param_reader.h"
#include "stereo_safety_map/ros/stereo_input_fields.h"

#include <sstream>

namespace stereo_safety_map {

std::string fromRosParam(const ros::NodeHandle& pnh, DisparityPipelineConfig* c) {
  return readParams(pnh, disparityPipelineFields(), c);
}

std::string DisparityRosConfig::validate() const {
  const std::string queue_error = queueSizeError(queue_size);
  if (!queue_error.empty()) return queue_error;
  std::ostringstream os;
  if (!(cloud_max_depth > 0.0 && cloud_max_depth <= 1000.0)) {
    os << "cloud_max_depth = " << cloud_max_depth << " must be in (0, 1000]";
  } else if (!(min_image_contrast >= 0.0 && min_image_contrast <= 128.0)) {
    os << "min_image_contrast = " << min_image_contrast << " must be in [0, 128]";
  } else if (frame_queue < 1 || frame_queue > 10) {
    os << "frame_queue = " << frame_queue << " must be in [1, 10]";
  }
  return os.str();
}

const ParamFieldList<DisparityRosConfig>& disparityRosFields() {
  using R = DisparityRosConfig;
  static const ParamFieldList<R> list = [] {
    ParamFieldList<R> l;
    l.section("Nodelet");
    addSyncFields(l, "subscriber and sync queue.",
                  "approximate instead of exact image / CameraInfo sync (cameras without "
                  "hardware sync).");
    l.add("cloud_max_depth", &R::cloud_max_depth)
        .openClosed(0, 1000)
        .unit("m")
        .doc("`points2` beyond this are NaN.");
    l.add("min_image_contrast", &R::min_image_contrast)
        .closed(0, 128)
        .unit("grey levels")
        .doc(
            "a left or right image whose grey levels have a smaller standard deviation is "
            "refused (camera covered, black or saturated), 0 = off (ours).");
    l.add("reject_frozen_images", &R::reject_frozen_images)
        .doc(
            "refuse a pair in which an image repeats the previous one byte for byte (a frozen "
            "camera or driver); false for noiseless simulators.");
    l.add("frame_queue", &R::frame_queue)
        .closed(1, 10)
        .unit("pairs")
        .doc(
            "stereo pairs that may wait for the matcher: 1 = the newest only (a pair arriving "
            "while one waits replaces it); 2 absorbs one pair that took longer than the camera "
            "period (the manager's other nodelets had the cores) instead of dropping it, at one "
            "frame of latency then (ours).");
    l.addExternal("diagnostic_period", 1.0).unit("s").doc("diagnostic_updater's period.");
    l.setValidator([](const R& c) { return c.validate(); });
    return l;
  }();
  return list;
}

std::string fromRosParam(const ros::NodeHandle& pnh, DisparityRosConfig* c) {
  return readParams(pnh, disparityRosFields(), c);
}

std::vector<std::string> disparityParameterNames() {
  return nodeletParameterNames("disparity");
}

}  // namespace stereo_safety_map
