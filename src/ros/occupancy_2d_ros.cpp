#include "stereo_safety_map/ros/occupancy_2d_ros.h"

#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/ros/occupancy_2d_conversions.h"
#include "stereo_safety_map/ros/param_reader.h"

#include <tf2_eigen/tf2_eigen.h>

#include <boost/bind/bind.hpp>

#include <algorithm>
#include <sstream>

namespace stereo_safety_map {

namespace {}  // namespace

Occupancy2DRos::Occupancy2DRos(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), name_(pnh.getNamespace()), problems_(name_) {
  diagnostics_ = std::make_unique<NodeletDiagnostics>(
      nh_, pnh_, name_, "stereo camera", "occupancy grid 2d",
      [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { diagnose(stat); },
      NodeletDiagnostics::Clock::kRos);
  counts_.window_start = ros::WallTime::now();

  std::string err = fromRosParam(pnh_, &ros_config_);
  if (err.empty()) err = fromRosParam(pnh_, &grid_config_);
  if (!err.empty()) {
    config_error_ = err;
    ROS_ERROR_STREAM(name_ << ": refusing to start with an invalid configuration: " << err);
    diagnostics_->refuse(config_error_);
    return;
  }
  for (const std::string& p : unknownParameters(pnh_, occupancy2DParameterNames())) {
    ROS_WARN_STREAM(name_ << ": ignoring unknown parameter ~" << p << " (a typo?)");
  }
  grid_ = std::make_unique<OccupancyGrid2D>(grid_config_);  // validated above: does not throw

  grid_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("occupancy_2d", 1, true);
  reset_srv_ = pnh_.advertiseService("reset", &Occupancy2DRos::resetSrv, this);
  worker_ = std::thread([this] {
    slot_.work([this](const Frame& frame) { processFrame(frame); },
               [this] { return ros_config_.max_rate; },
               [this](const std::string& what) {
                 reject("exception", "frame skipped after an exception: " + what);
               });
  });
  setUpInputs();
  ROS_INFO_STREAM(name_ << ": 2D occupancy grid (002) in '" << ros_config_.fixed_frame
                        << "', height band " << grid_config_.floor_clearance << " .. "
                        << grid_config_.robot_height << " m above '" << ros_config_.base_frame
                        << "', K = " << grid_config_.k);
}

Occupancy2DRos::~Occupancy2DRos() {
  // Inputs first, so that no callback enqueues while the worker stops: the subscriptions end
  // (each waits for its callback in progress), then the filters, which disconnect from the
  // subscribers, then the subscribers.
  for (auto* sub : {static_cast<message_filters::SubscriberBase*>(disparity_sub_.get()),
                    static_cast<message_filters::SubscriberBase*>(left_info_sub_.get()),
                    static_cast<message_filters::SubscriberBase*>(right_info_sub_.get())}) {
    if (sub) sub->unsubscribe();  // none when the parameters were refused
  }
  approximate_sync_.reset();
  disparity_filter_.reset();
  exact_matcher_.reset();
  disparity_sub_.reset();
  left_info_sub_.reset();
  right_info_sub_.reset();
  slot_.stop();
  if (worker_.joinable()) worker_.join();
  diagnostics_->stop();
}

void Occupancy2DRos::setUpInputs() {
  const int q = ros_config_.queue_size;
  tf_buffer_ = std::make_shared<tf2_ros::Buffer>(ros::Duration(kTfCacheTime));
  tf_listener_ = std::make_shared<tf2_ros::TransformListener>(*tf_buffer_, nh_);
  disparity_sub_ = std::make_unique<message_filters::Subscriber<stereo_msgs::DisparityImage>>(
      nh_, "stereo/disparity", q);
  left_info_sub_ = std::make_unique<message_filters::Subscriber<sensor_msgs::CameraInfo>>(
      nh_, "stereo/left/camera_info", q);
  right_info_sub_ = std::make_unique<message_filters::Subscriber<sensor_msgs::CameraInfo>>(
      nh_, "stereo/right/camera_info", q);
  disparity_sub_->registerCallback([this](const stereo_msgs::DisparityImageConstPtr&) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    counts_.countReceived();
  });
  disparity_filter_ = std::make_unique<DisparityFilter>(*disparity_sub_, *tf_buffer_,
                                                        ros_config_.fixed_frame, q, nh_);
  disparity_filter_->registerFailureCallback(
      [this](const stereo_msgs::DisparityImageConstPtr& m,
             tf2_ros::filter_failure_reasons::FilterFailureReason r) { tfFailure(m->header, r); });
  if (ros_config_.approximate_sync) {
    approximate_sync_ = std::make_unique<message_filters::Synchronizer<ApproximatePolicy>>(
        ApproximatePolicy(q), *disparity_filter_, *left_info_sub_, *right_info_sub_);
    approximate_sync_->registerCallback(
        boost::bind(&Occupancy2DRos::disparityCb, this, boost::placeholders::_1,
                    boost::placeholders::_2, boost::placeholders::_3));
  } else {
    exact_matcher_ = std::make_unique<FrameMatcher>(  // exact_stamp_matcher.h: why not ExactTime
        FrameMatcher::Limits::forNodelet(q),
        [this](const stereo_msgs::DisparityImageConstPtr& d,
               const sensor_msgs::CameraInfoConstPtr& l,
               const sensor_msgs::CameraInfoConstPtr& r) { disparityCb(d, l, r); },
        [this](const ros::Time& stamp, const std::string& why) {
          reject("no camera info", unmatchedDisparityMessage(stamp, why));
        });
    exact_matcher_->connectInput<0>(*disparity_filter_);
    exact_matcher_->connectInput<1>(*left_info_sub_);
    exact_matcher_->connectInput<2>(*right_info_sub_);
  }
}

void Occupancy2DRos::tfFailure(const std_msgs::Header& header,
                               tf2_ros::filter_failure_reasons::FilterFailureReason reason) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++counts_.tf_failures;
  }
  reject("missing tf", tfFilterFailureMessage("frame", header, ros_config_.fixed_frame, reason));
}

void Occupancy2DRos::disparityCb(const stereo_msgs::DisparityImageConstPtr& disparity,
                                 const sensor_msgs::CameraInfoConstPtr& left,
                                 const sensor_msgs::CameraInfoConstPtr& right) {
  auto frame = std::make_unique<Frame>();
  frame->disparity = disparity;
  frame->left_info = left;
  frame->right_info = right;
  const bool dropped = slot_.put(std::move(frame)) == FrameSlot<Frame>::Put::kReplaced;
  if (dropped) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    counts_.countDropped();
  }
}

void Occupancy2DRos::reject(const std::string& reason, const std::string& detail) {
  if (reason != "missing tf") {  // tf drops are counted in counts_.tf_failures
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++counts_.rejected;
  }
  problems_.report(reason, detail);
}

void Occupancy2DRos::processFrame(const Frame& frame) {
  const Clock::time_point t0 = Clock::now();
  const std_msgs::Header& in = frame.disparity->header;
  const ros::Time stamp = in.stamp;

  // Time going backwards: a bag restarted (reset once, with one warning) or a late frame.
  bool reset_for_time = false;
  if (!last_stamp_.isZero() && stamp < last_stamp_) {
    const double back = (last_stamp_ - stamp).toSec();
    if (back > ros_config_.time_jump_reset) {
      ROS_WARN_STREAM(name_ << ": time went back by " << back << " s (stamp " << stamp << " after "
                            << last_stamp_ << "; a bag restarted?): resetting the grid");
      reset_for_time = true;
    } else {
      std::ostringstream os;
      os << "dropped a frame out of order: stamp " << stamp << " is " << back
         << " s older than the last frame (less than time_jump_reset = "
         << ros_config_.time_jump_reset << " s, so the grid is kept)";
      reject("out of order", os.str());
      return;
    }
  }

  // Camera pose (the tf2 MessageFilter waited for it) and the robot's base: its z is the floor
  // the height band is measured from (002 Sec. 3.3), its xy the window's centre.
  Eigen::Isometry3f T_fixed_camera;
  Eigen::Vector3f base;
  try {
    T_fixed_camera = tf2::transformToEigen(
                         tf_buffer_->lookupTransform(ros_config_.fixed_frame, in.frame_id, stamp))
                         .cast<float>();
    const geometry_msgs::TransformStamped b =
        tf_buffer_->lookupTransform(ros_config_.fixed_frame, ros_config_.base_frame, stamp,
                                    ros::Duration(ros_config_.tf_timeout));
    base = Eigen::Vector3f(static_cast<float>(b.transform.translation.x),
                           static_cast<float>(b.transform.translation.y),
                           static_cast<float>(b.transform.translation.z));
  } catch (const tf2::TransformException& e) {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++counts_.tf_failures;
    }
    reject("missing tf", "dropped a frame at t = " + std::to_string(stamp.toSec()) +
                             ": tf lookup failed: " + e.what());
    return;
  }

  std::string err = cameraModelFromCameraInfo(*frame.left_info, *frame.right_info, &camera_);
  if (err.empty()) err = cameraModelForDisparity(*frame.disparity, *frame.left_info, &camera_);
  if (!err.empty()) {
    reject("bad camera model", "dropped a disparity frame: " + err);
    return;
  }
  DisparityImageStats stats;
  err = disparityImageToMat(*frame.disparity, &disparity_, &stats);
  if (!err.empty()) {
    reject("bad disparity image", "dropped a disparity frame: " + err);
    return;
  }
  if (stats.non_finite + stats.out_of_range >= stats.pixels ||
      cv::countNonZero(disparity_ > 0.0f) == 0) {
    std::ostringstream os;
    os << "dropped a disparity frame without a valid pixel (" << stats.non_finite
       << " NaN / inf and " << stats.out_of_range << " outside [min_disparity, max_disparity]"
       << " of " << stats.pixels << ")";
    reject(stats.non_finite > 0 ? "non-finite input" : "no valid data", os.str());
    return;
  }
  if (stats.non_finite > 0) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    counts_.non_finite += stats.non_finite;
  }

  Grid2DUpdateStats result;
  {
    std::lock_guard<std::mutex> lock(core_mutex_);
    if (reset_for_time) {
      grid_->clear();
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      ++map_resets_;
      problems_.note("time went backwards: grid reset");
    }
    last_stamp_ = stamp;
    if (ros_config_.scroll_with_robot) grid_->recenter(base.head<2>());
    // 002 Sec. 3.3 reduction, Sec. 3.2 / 3.4 update, Sec. 4.3 accuracy preservation.
    result = grid_->update(disparity_, camera_, T_fixed_camera, base.z());
    if (result.ok()) {
      auto msg = boost::make_shared<nav_msgs::OccupancyGrid>();
      std_msgs::Header header;
      header.stamp = stamp;
      header.frame_id = ros_config_.fixed_frame;
      toOccupancyGrid(*grid_, header, msg.get(), &image_);
      grid_pub_.publish(msg);
    }
  }
  if (!result.ok()) {
    reject("refused by the core", std::string("dropped a frame: ") + toString(result.status));
    return;
  }
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  counts_.countProcessed(ms);
  last_update_ = result;
}

bool Occupancy2DRos::resetSrv(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  if (!grid_) return false;
  std::lock_guard<std::mutex> lock(core_mutex_);
  grid_->clear();
  {
    std::lock_guard<std::mutex> stats_lock(stats_mutex_);
    ++map_resets_;
  }
  ROS_INFO_STREAM(name_ << ": grid reset on request");
  return true;
}

void Occupancy2DRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  const ros::WallTime now = ros::WallTime::now();
  const double window = counts_.window(now);
  stat.add("fixed frame", ros_config_.fixed_frame);
  counts_.addTo(stat, window, "frames dropped (processing slower than input)", true);
  stat.add("grid resets", map_resets_);
  stat.add("columns with a reading, last frame", last_update_.columns_with_reading);
  stat.add("columns explained by better evidence, last frame", last_update_.columns_explained);
  stat.add("cells raised (+K), last frame", last_update_.cells_raised);
  stat.add("cells lowered (-K), last frame", last_update_.cells_lowered);
  stat.addf("processing time, last [ms]", "%.1f", counts_.processing_ms_last);
  stat.addf("processing time, mean [ms]", "%.1f", counts_.meanProcessingMs());
  problems_.addTo(stat);
  counts_.summarize(stat, problems_, now, window, "processing is slower than the input or max_rate",
                    "waiting for input", "grid up to date");
  counts_.nextWindow(now, window);
}

}  // namespace stereo_safety_map
