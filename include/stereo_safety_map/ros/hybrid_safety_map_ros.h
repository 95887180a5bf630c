// The hybrid safety-map ROS class: fuses a planar laser (sensor_msgs/LaserScan) with the stereo
// safety map of paper 000 (stereo_safety_map/SafetyMap from the safety-map nodelet) into the
// local safety map of paper 001 (Murarka, Modayil & Kuipers 2006, Sec. 2 and 5): Obstacle,
// Hazard, Caution, Unknown, Safe. Wrapped by src/nodelets/hybrid_safety_map_nodelet.cpp
// (stereo_safety_map/HybridSafetyMapNodelet).
//
// Scans go through a tf2_ros::MessageFilter (laser frame -> fixed frame) and are ray cast into
// the core's LaserGrid (001 Sec. 3), which scrolls with the laser. Each stereo map that arrives
// is combined with the laser grid as it stands (core/hybrid_safety_map.h) and published at the
// stereo map's stamp. While no stereo map newer than ~vision_timeout exists, scans publish the
// laser's part alone (vision Unknown) at most ~laser_only_rate times a second, so that a stalled
// camera leaves obstacles in the laser plane on the map instead of a stale picture.
//
// Threading: the work per message is small (ray casting one scan, combining two 100 x 100 grids:
// well under a millisecond), so callbacks do it themselves under one mutex rather than through a
// worker thread; the tf wait is in the MessageFilter, never in a callback.
#pragma once

#include "stereo_safety_map/core/hybrid_safety_map.h"
#include "stereo_safety_map/core/laser_grid.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/ros/hybrid_safety_map_params.h"
#include "stereo_safety_map/ros/msgs.h"
#include "stereo_safety_map/ros/nodelet_shell.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <message_filters/subscriber.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_srvs/Empty.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace stereo_safety_map {

class HybridSafetyMapRos : public NodeletShell {
 public:
  /// Reads and validates the parameters in `pnh`. With an invalid configuration the object logs
  /// the error, reports it as an ERROR diagnostic and subscribes to nothing (see ok()).
  HybridSafetyMapRos(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~HybridSafetyMapRos();

 private:
  using ScanFilter = tf2_ros::MessageFilter<sensor_msgs::LaserScan>;

  void scanCb(const sensor_msgs::LaserScanConstPtr& scan);
  void scanTfFailure(const sensor_msgs::LaserScanConstPtr& scan,
                     tf2_ros::filter_failure_reasons::FilterFailureReason reason);
  void visionCb(const SafetyMapMsg::ConstPtr& msg);
  /// Combines the current stereo map (when `use_vision`) with the laser grid and publishes
  /// (core_mutex_ held).
  void publish(const ros::Time& stamp, bool use_vision);
  /// Counts a refused message under `reason` and logs `detail`, throttled per reason.
  void reject(const std::string& reason, const std::string& detail);
  void clearAll();
  bool resetSrv(std_srvs::Empty::Request& req, std_srvs::Empty::Response& res);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);

  HybridSafetyMapRosConfig ros_config_;
  LaserGridConfig laser_config_;
  HybridSafetyMapConfig hybrid_config_;

  std::shared_ptr<tf2_ros::Buffer> tf_buffer_;
  std::shared_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<message_filters::Subscriber<sensor_msgs::LaserScan>> scan_sub_;
  std::unique_ptr<ScanFilter> scan_filter_;
  ros::Subscriber vision_sub_;

  ros::Publisher map_pub_;
  ros::Publisher labels_pub_;
  ros::Publisher laser_pub_;
  ros::ServiceServer reset_srv_;

  // The core and its inputs (guarded by core_mutex_).
  std::mutex core_mutex_;
  std::unique_ptr<LaserGrid> laser_;
  std::unique_ptr<HybridSafetyMapBuilder> builder_;
  SafetyMap vision_;  ///< the last stereo map (width 0: none)
  ros::Time vision_stamp_;
  SafetyMap no_vision_;  ///< empty: the laser alone
  HybridSafetyMap hybrid_;
  ros::Time last_scan_stamp_;
  ros::Time last_laser_only_publish_;

  // Counters and diagnostics (guarded by stats_mutex_).
  std::mutex stats_mutex_;
  std::uint64_t scans_received_ = 0;
  std::uint64_t scans_integrated_ = 0;
  std::uint64_t scans_rejected_ = 0;
  std::uint64_t tf_failures_ = 0;
  std::uint64_t maps_received_ = 0;
  std::uint64_t maps_rejected_ = 0;
  std::uint64_t maps_published_ = 0;
  std::uint64_t laser_only_published_ = 0;
  bool last_publish_laser_only_ = false;
  std::uint64_t invalid_ranges_ = 0;  ///< NaN / -inf / below range_min: skipped
  std::uint64_t no_return_ranges_ = 0;
  std::uint64_t resets_ = 0;
  double build_ms_last_ = 0.0;
  std::uint64_t label_counts_[5] = {0, 0, 0, 0, 0};  ///< classes of the last published map
};

}  // namespace stereo_safety_map
