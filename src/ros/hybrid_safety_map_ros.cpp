#include "stereo_safety_map/ros/hybrid_safety_map_ros.h"

#include "stereo_safety_map/ros/hybrid_conversions.h"
#include "stereo_safety_map/ros/param_reader.h"

#include <nav_msgs/OccupancyGrid.h>
#include <tf2_eigen/tf2_eigen.h>
#include <boost/bind/bind.hpp>

#include <algorithm>
#include <chrono>
#include <sstream>

namespace stereo_safety_map {

HybridSafetyMapRos::HybridSafetyMapRos(ros::NodeHandle nh, ros::NodeHandle pnh)
    : NodeletShell(nh, pnh) {
  startDiagnostics(
      "laser + stereo", "hybrid safety map",
      [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { diagnose(stat); },
      NodeletDiagnostics::Clock::kRos);

  const std::string err = fromRosParam(pnh_, &ros_config_, &laser_config_, &hybrid_config_);
  if (!acceptParams(err, hybridSafetyMapParameterNames())) return;
  laser_ = std::make_unique<LaserGrid>(laser_config_);                  // validated: no throw
  builder_ = std::make_unique<HybridSafetyMapBuilder>(hybrid_config_);  // validated: no throw

  map_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("hybrid_map", 1, true);
  labels_pub_ = nh_.advertise<HybridSafetyMapMsg>("hybrid_map_labels", 1, true);
  laser_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("laser_grid", 1);
  reset_srv_ = pnh_.advertiseService("reset", &HybridSafetyMapRos::resetSrv, this);

  const int q = ros_config_.queue_size;
  tf_buffer_ = std::make_shared<tf2_ros::Buffer>(ros::Duration(30.0));
  tf_listener_ = std::make_shared<tf2_ros::TransformListener>(*tf_buffer_, nh_);
  scan_sub_ = std::make_unique<message_filters::Subscriber<sensor_msgs::LaserScan>>(nh_, "scan", q);
  scan_sub_->registerCallback([this](const sensor_msgs::LaserScanConstPtr&) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++scans_received_;
  });
  scan_filter_ =
      std::make_unique<ScanFilter>(*scan_sub_, *tf_buffer_, ros_config_.fixed_frame, q, nh_);
  scan_filter_->registerCallback(
      boost::bind(&HybridSafetyMapRos::scanCb, this, boost::placeholders::_1));
  scan_filter_->registerFailureCallback(boost::bind(
      &HybridSafetyMapRos::scanTfFailure, this, boost::placeholders::_1, boost::placeholders::_2));
  vision_sub_ = nh_.subscribe("safety_map_labels", q, &HybridSafetyMapRos::visionCb, this);
  ROS_INFO_STREAM(name_ << ": fusing '" << scan_sub_->getTopic() << "' with '"
                        << vision_sub_.getTopic() << "' in '" << ros_config_.fixed_frame << "'");
}

HybridSafetyMapRos::~HybridSafetyMapRos() {
  scan_filter_.reset();
  scan_sub_.reset();
  vision_sub_.shutdown();
  diagnostics_->stop();
}

void HybridSafetyMapRos::reject(const std::string& reason, const std::string& detail) {
  problems_.report(reason, detail);
}

void HybridSafetyMapRos::scanTfFailure(const sensor_msgs::LaserScanConstPtr& scan,
                                       tf2_ros::filter_failure_reasons::FilterFailureReason r) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++tf_failures_;
  }
  reject("missing tf", tfFilterFailureMessage("scan", scan->header, ros_config_.fixed_frame, r,
                                              "Is the laser in the tf tree?"));
}

void HybridSafetyMapRos::clearAll() {
  laser_->clear();
  vision_ = SafetyMap();
  vision_stamp_ = ros::Time();
  last_laser_only_publish_ = ros::Time();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++resets_;
}

void HybridSafetyMapRos::scanCb(const sensor_msgs::LaserScanConstPtr& scan) {
  LaserScanInfo info;
  const std::string err = laserScanInfoFromMsg(*scan, &info);
  if (!err.empty()) {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++scans_rejected_;
    }
    reject("bad scan", "dropped a scan from '" + scan->header.frame_id + "': " + err);
    return;
  }
  const ros::Time stamp = scan->header.stamp;
  Eigen::Isometry3f T_fixed_laser;
  try {
    T_fixed_laser = tf2::transformToEigen(tf_buffer_->lookupTransform(ros_config_.fixed_frame,
                                                                      scan->header.frame_id, stamp))
                        .cast<float>();
  } catch (const tf2::TransformException& e) {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++tf_failures_;
    }
    reject("missing tf", std::string("dropped a scan: tf lookup failed: ") + e.what());
    return;
  }

  std::lock_guard<std::mutex> lock(core_mutex_);
  if (!last_scan_stamp_.isZero() && stamp < last_scan_stamp_) {
    const double back = (last_scan_stamp_ - stamp).toSec();
    if (back > ros_config_.time_jump_reset) {
      ROS_WARN_STREAM(name_ << ": time went back by " << back
                            << " s (a bag restarted?): clearing the laser grid and the stereo map");
      clearAll();
    } else {
      {
        std::lock_guard<std::mutex> stats_lock(stats_mutex_);
        ++scans_rejected_;
      }
      std::ostringstream os;
      os << "dropped a scan out of order: stamp " << stamp << " is " << back
         << " s older than the last scan";
      reject("out of order", os.str());
      return;
    }
  }
  last_scan_stamp_ = stamp;
  // 001 Sec. 3: the laser grid follows the robot; the laser is on it.
  laser_->recenter(T_fixed_laser.translation().x(), T_fixed_laser.translation().y());
  const LaserIntegrationStats st = laser_->integrate(info, scan->ranges, T_fixed_laser);
  if (st.rejected) {
    {
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      ++scans_rejected_;
    }
    reject("bad scan", "dropped a scan: non-finite laser pose or scan geometry");
    return;
  }
  {
    std::lock_guard<std::mutex> stats_lock(stats_mutex_);
    ++scans_integrated_;
    invalid_ranges_ += st.invalid;
    no_return_ranges_ += st.no_return;
  }
  if (st.returns == 0 && st.no_return == 0) {
    reject("no valid range", "a scan from '" + scan->header.frame_id + "' had no usable range (" +
                                 std::to_string(st.invalid) + " NaN / below range_min)");
  }
  if (laser_pub_.getNumSubscribers() > 0) {
    auto grid = boost::make_shared<nav_msgs::OccupancyGrid>();
    std_msgs::Header h;
    h.stamp = stamp;
    h.frame_id = ros_config_.fixed_frame;
    laserGridToOccupancyGrid(*laser_, h, grid.get());
    laser_pub_.publish(grid);
  }

  // Without a current stereo map, the laser's part alone, throttled.
  const bool vision_current =
      vision_.width > 0 && std::abs((stamp - vision_stamp_).toSec()) <= ros_config_.vision_timeout;
  if (!vision_current && ros_config_.laser_only_rate > 0.0 &&
      (last_laser_only_publish_.isZero() || stamp < last_laser_only_publish_ ||
       (stamp - last_laser_only_publish_).toSec() >= 1.0 / ros_config_.laser_only_rate)) {
    last_laser_only_publish_ = stamp;
    publish(stamp, false);
  }
}

void HybridSafetyMapRos::visionCb(const SafetyMapMsg::ConstPtr& msg) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++maps_received_;
  }
  std::string err;
  if (msg->header.frame_id != ros_config_.fixed_frame) {
    err = "the map is in frame '" + msg->header.frame_id + "', the fusion works in fixed_frame '" +
          ros_config_.fixed_frame + "'";
  }
  SafetyMap map;
  if (err.empty()) err = safetyMapFromMsg(*msg, &map);
  if (!err.empty()) {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++maps_rejected_;
    }
    reject("bad safety map", "dropped a stereo safety map: " + err);
    return;
  }
  std::lock_guard<std::mutex> lock(core_mutex_);
  if (!vision_stamp_.isZero() && msg->header.stamp < vision_stamp_ &&
      (vision_stamp_ - msg->header.stamp).toSec() > ros_config_.time_jump_reset) {
    ROS_WARN_STREAM(name_ << ": stereo map stamps went back (a bag restarted?): clearing");
    clearAll();
  }
  vision_ = std::move(map);
  vision_stamp_ = msg->header.stamp;
  publish(msg->header.stamp, true);
}

void HybridSafetyMapRos::publish(const ros::Time& stamp, bool use_vision) {
  const auto t0 = std::chrono::steady_clock::now();
  const SafetyMap& vision = use_vision ? vision_ : no_vision_;
  builder_->build(HybridSource::kMerged, vision, *laser_, &hybrid_);
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = ros_config_.fixed_frame;
  auto grid = boost::make_shared<nav_msgs::OccupancyGrid>();
  toHybridOccupancyGrid(hybrid_, hybrid_config_, header, grid.get());
  auto labels = boost::make_shared<HybridSafetyMapMsg>();
  toHybridSafetyMapMsg(hybrid_, vision, use_vision,
                       use_vision ? (stamp - vision_stamp_).toSec() : 0.0, *laser_, header,
                       labels.get());
  map_pub_.publish(grid);
  labels_pub_.publish(labels);
  std::uint64_t counts[5] = {0, 0, 0, 0, 0};
  for (HybridLabel l : hybrid_.labels) {
    ++counts[std::min<int>(static_cast<int>(l), 4)];
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++maps_published_;
  if (!use_vision) ++laser_only_published_;
  last_publish_laser_only_ = !use_vision;
  std::copy(counts, counts + 5, label_counts_);
  build_ms_last_ =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

bool HybridSafetyMapRos::resetSrv(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  if (!laser_) return false;
  std::lock_guard<std::mutex> lock(core_mutex_);
  clearAll();
  last_scan_stamp_ = ros::Time();
  ROS_INFO_STREAM(name_ << ": laser grid and stereo map cleared (~reset)");
  return true;
}

void HybridSafetyMapRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  using diagnostic_msgs::DiagnosticStatus;
  std::lock_guard<std::mutex> lock(stats_mutex_);
  const ros::WallTime now = ros::WallTime::now();
  stat.add("fixed frame", ros_config_.fixed_frame);
  stat.add("scans received", scans_received_);
  stat.add("scans integrated", scans_integrated_);
  stat.add("scans rejected (bad input)", scans_rejected_);
  stat.add("scans dropped (missing tf)", tf_failures_);
  stat.add("ranges skipped (NaN, -inf, below range_min)", invalid_ranges_);
  stat.add("ranges without return (+inf, >= range_max)", no_return_ranges_);
  stat.add("stereo maps received", maps_received_);
  stat.add("stereo maps rejected", maps_rejected_);
  stat.add("hybrid maps published", maps_published_);
  stat.add("of which laser only (no current stereo map)", laser_only_published_);
  stat.add("resets", resets_);
  stat.addf("combination time, last [ms]", "%.2f", build_ms_last_);
  const char* names[5] = {"unknown", "safe", "caution", "hazard", "obstacle"};
  for (int k = 0; k < 5; ++k)
    stat.add(std::string("cells ") + names[k], label_counts_[k]);
  problems_.addTo(stat);
  if (problems_.recent(now)) {
    stat.summary(DiagnosticStatus::WARN, problems_.last());
  } else if (scans_received_ == 0 && maps_received_ == 0) {
    stat.summary(DiagnosticStatus::OK, "waiting for input");
  } else if (maps_received_ == 0 || last_publish_laser_only_) {
    stat.summary(
        DiagnosticStatus::WARN,
        "no stereo safety map newer than vision_timeout: publishing the laser's part only");
  } else if (scans_integrated_ == 0) {
    stat.summary(DiagnosticStatus::WARN, "no scan yet: stereo only");
  } else {
    stat.summary(DiagnosticStatus::OK, "map up to date");
  }
}

}  // namespace stereo_safety_map
