// SafetyMapRos's inputs (safety_map_ros.h, "Threading model"): the subscribers' checks of each
// message, the tf2 MessageFilter, the stamp matcher (exact_stamp_matcher.h) or approximate sync,
// the tf wait measurement, and enqueue(), which puts a checked frame into the worker's one-slot
// queue (frame_slot.h). What the worker does with a frame is in safety_map_ros.cpp.
#include "stereo_safety_map/ros/safety_map_ros.h"

#include "stereo_safety_map/ros/conversions.h"

#include <boost/bind/bind.hpp>

#include <sstream>

namespace stereo_safety_map {

namespace {

// Frames between their check and the worker are at most queue_size in the tf filter and
// queue_size in the matcher; more entries are leftovers (e.g. a repeated stamp).
constexpr std::size_t kMaxArrivals = 256;

}  // namespace

void SafetyMapRos::setUpInputs() {
  const int q = ros_config_.queue_size;
  tf_buffer_ = std::make_shared<tf2_ros::Buffer>(ros::Duration(kTfCacheTime));
  tf_listener_ = std::make_shared<tf2_ros::TransformListener>(*tf_buffer_, nh_);
  auto failure = [this](const auto& msg, tf2_ros::filter_failure_reasons::FilterFailureReason r) {
    tfFailure(msg->header, r);
  };
  if (ros_config_.input == "cloud") {
    cloud_filter_ =
        std::make_unique<CloudFilter>(cloud_in_, *tf_buffer_, ros_config_.fixed_frame, q, nh_);
    cloud_filter_->registerCallback(
        boost::bind(&SafetyMapRos::cloudCb, this, boost::placeholders::_1));
    cloud_filter_->registerFailureCallback(
        [failure](const sensor_msgs::PointCloud2ConstPtr& m,
                  tf2_ros::filter_failure_reasons::FilterFailureReason r) { failure(m, r); });
    cloud_sub_ = nh_.subscribe("points", q, &SafetyMapRos::cloudIn, this);
    return;
  }
  disparity_filter_ = std::make_unique<DisparityFilter>(disparity_in_, *tf_buffer_,
                                                        ros_config_.fixed_frame, q, nh_);
  disparity_filter_->registerFailureCallback(
      [failure](const stereo_msgs::DisparityImageConstPtr& m,
                tf2_ros::filter_failure_reasons::FilterFailureReason r) { failure(m, r); });
  if (ros_config_.approximate_sync) {
    approximate_sync_ = std::make_unique<message_filters::Synchronizer<ApproximatePolicy>>(
        ApproximatePolicy(q), *disparity_filter_, left_info_in_, right_info_in_);
    approximate_sync_->registerCallback(
        boost::bind(&SafetyMapRos::disparityCb, this, boost::placeholders::_1,
                    boost::placeholders::_2, boost::placeholders::_3));
  } else {
    exact_matcher_ = std::make_unique<FrameMatcher>(
        FrameMatcher::Limits::forNodelet(q),
        [this](const stereo_msgs::DisparityImageConstPtr& d,
               const sensor_msgs::CameraInfoConstPtr& l,
               const sensor_msgs::CameraInfoConstPtr& r) { disparityCb(d, l, r); },
        [this](const ros::Time& stamp, const std::string& why) {
          tfWaitMs(stamp);  // forget its arrival
          reject("no camera info", unmatchedDisparityMessage(stamp, why));
        });
    exact_matcher_->connectInput<0>(*disparity_filter_);
    exact_matcher_->connectInput<1>(left_info_in_);
    exact_matcher_->connectInput<2>(right_info_in_);
  }
  // Subscribed last: the chain behind them is complete.
  left_info_sub_ = nh_.subscribe("stereo/left/camera_info", q, &SafetyMapRos::leftInfoIn, this);
  right_info_sub_ = nh_.subscribe("stereo/right/camera_info", q, &SafetyMapRos::rightInfoIn, this);
  disparity_sub_ = nh_.subscribe("stereo/disparity", q, &SafetyMapRos::disparityIn, this);
}

void SafetyMapRos::disparityIn(const stereo_msgs::DisparityImageConstPtr& msg) {
  countArrival();
  DisparityImageStats stats;
  const std::string err = checkDisparityImage(*msg, &stats);
  if (!err.empty()) {
    reject("bad disparity image", "dropped a disparity frame: " + err);
    return;
  }
  if (stats.non_finite + stats.out_of_range >= stats.pixels) {
    std::ostringstream os;
    os << "dropped a disparity frame without a valid pixel (" << stats.non_finite
       << " NaN / inf and " << stats.out_of_range << " outside [min_disparity, max_disparity]"
       << " of " << stats.pixels << "): camera covered, black or failing?";
    reject(stats.non_finite > 0 ? "non-finite input" : "no valid data", os.str());
    return;
  }
  noteArrival(msg->header.stamp);
  disparity_in_.add(msg);
}

void SafetyMapRos::leftInfoIn(const sensor_msgs::CameraInfoConstPtr& msg) {
  const std::string err = checkCameraInfo(*msg, "left");
  if (!err.empty()) {
    reject("bad camera model", "dropped a CameraInfo: " + err);
    return;
  }
  left_info_in_.add(msg);
}

void SafetyMapRos::rightInfoIn(const sensor_msgs::CameraInfoConstPtr& msg) {
  std::string err = checkCameraInfo(*msg, "right");
  if (err.empty() && !(msg->P[3] < 0.0)) {
    err = "right CameraInfo has zero baseline (P[3] = Tx = -fx B = " + std::to_string(msg->P[3]) +
          ", must be < 0)";
  }
  if (!err.empty()) {
    reject("bad camera model", "dropped a CameraInfo: " + err);
    return;
  }
  right_info_in_.add(msg);
}

void SafetyMapRos::cloudIn(const sensor_msgs::PointCloud2ConstPtr& msg) {
  countArrival();
  CloudStats stats;
  const std::string err = checkPointCloud2(*msg, &stats);
  if (!err.empty()) {
    reject("bad point cloud", "dropped a cloud: " + err);
    return;
  }
  if (stats.non_finite >= stats.points) {
    std::ostringstream os;
    os << "dropped a cloud without a finite point (" << stats.non_finite << " NaN / inf of "
       << stats.points << ")";
    reject("non-finite input", os.str());
    return;
  }
  noteArrival(msg->header.stamp);
  cloud_in_.add(msg);
}

void SafetyMapRos::countArrival() {
  std::lock_guard<std::mutex> lock(stats_mutex_);
  counts_.countReceived();
  last_arrival_ = ros::WallTime::now();
}

void SafetyMapRos::noteArrival(const ros::Time& stamp) {
  std::lock_guard<std::mutex> lock(arrival_mutex_);
  // A repeated stamp (a bag played again, whose frame of that stamp was lost in the last loop's
  // approximate sync) takes the new arrival: an old one would make its frame look stale.
  arrivals_[stamp] = Clock::now();
  while (arrivals_.size() > kMaxArrivals)
    arrivals_.erase(arrivals_.begin());
}

double SafetyMapRos::tfWaitMs(const ros::Time& stamp) {
  std::lock_guard<std::mutex> lock(arrival_mutex_);
  const auto it = arrivals_.find(stamp);
  if (it == arrivals_.end()) return 0.0;
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - it->second).count();
  arrivals_.erase(it);
  return ms;
}

void SafetyMapRos::tfFailure(const std_msgs::Header& header,
                             tf2_ros::filter_failure_reasons::FilterFailureReason reason) {
  tfWaitMs(header.stamp);  // forget its arrival
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++counts_.tf_failures;
  }
  reject("missing tf", tfFilterFailureMessage("frame", header, ros_config_.fixed_frame, reason));
}

void SafetyMapRos::disparityCb(const stereo_msgs::DisparityImageConstPtr& disparity,
                               const sensor_msgs::CameraInfoConstPtr& left,
                               const sensor_msgs::CameraInfoConstPtr& right) {
  // The frame as a whole, before it can take a valid frame's place in the slot.
  StereoCameraModel camera;
  std::string err = cameraModelFromCameraInfo(*left, *right, &camera);
  if (err.empty()) err = cameraModelForDisparity(*disparity, *left, &camera);
  if (!err.empty()) {
    tfWaitMs(disparity->header.stamp);  // forget its arrival
    reject("bad camera model", "dropped a disparity frame: " + err);
    return;
  }
  auto frame = std::make_unique<Frame>();
  frame->header = disparity->header;
  frame->disparity = disparity;
  frame->left_info = left;
  frame->right_info = right;
  frame->tf_wait_ms = tfWaitMs(disparity->header.stamp);
  ROS_DEBUG_STREAM_NAMED("frames", name_ << ": synced disparity frame " << disparity->header.stamp
                                         << ", tf wait " << frame->tf_wait_ms << " ms");
  enqueue(std::move(frame));
}

void SafetyMapRos::cloudCb(const sensor_msgs::PointCloud2ConstPtr& cloud) {
  auto frame = std::make_unique<Frame>();
  frame->header = cloud->header;
  frame->cloud = cloud;
  frame->tf_wait_ms = tfWaitMs(cloud->header.stamp);
  enqueue(std::move(frame));
}

void SafetyMapRos::enqueue(std::unique_ptr<Frame> frame) {
  const ros::Time enqueued_stamp = frame->header.stamp;
  // A transform that came long after its frame: tf stalled, and the pose of a frame in the gap
  // would be interpolated between samples seconds apart, not measured. Refused here, before the
  // slot, so that it never replaces a waiting frame and is always named, in whatever order the
  // frames of the gap and those after it come out of the tf filter.
  if (frame->tf_wait_ms > 1000.0 * ros_config_.max_tf_wait) {
    std::ostringstream os;
    os << "dropped a frame at t = " << enqueued_stamp << ": its transform came "
       << frame->tf_wait_ms / 1000.0
       << " s after it (more than max_tf_wait = " << ros_config_.max_tf_wait
       << " s): tf stalled, the pose would be interpolated across the gap";
    reject("stale tf", os.str());
    return;
  }
  std::string out_of_order;
  // Under the slot's lock: newest_stamp_ changes with the slot.
  const auto put = slot_.putIf(std::move(frame), [&](Frame& incoming, const Frame* waiting) {
    const ros::Time stamp = incoming.header.stamp;
    if (!newest_stamp_.isZero() && stamp <= newest_stamp_) {
      // Time went back. A restart (a bag played again) moves the clock back as well: the map is
      // reset once. A frame from the past while the clock runs on is stale: dropped, the map
      // kept, whatever its age (one stale message must not wipe the map).
      const double back = (newest_stamp_ - stamp).toSec();
      const ros::Time now = ros::Time::now();
      const ros::Duration jump(ros_config_.time_jump_reset);
      const bool clock_back = now.isZero() || now + jump < newest_stamp_;
      if (back > ros_config_.time_jump_reset && clock_back) {
        incoming.reset_map = true;
      } else {
        std::ostringstream os;
        os << "dropped a frame out of order: stamp " << stamp << " is " << back
           << " s older than the newest frame ("
           << (back > ros_config_.time_jump_reset
                   ? "the clock did not go back with it: a stale message"
                   : "less than time_jump_reset = " + std::to_string(ros_config_.time_jump_reset) +
                         " s")
           << "; the map is kept)";
        out_of_order = os.str();
        return false;
      }
    }
    newest_stamp_ = stamp;
    // A waiting restart is not lost with the frame that carries it.
    if (waiting && waiting->reset_map) incoming.reset_map = true;
    return true;
  });
  if (put == FrameSlot<Frame>::Put::kStopped) return;
  if (put == FrameSlot<Frame>::Put::kRefused) {
    reject("out of order", out_of_order);
    return;
  }
  const bool dropped = put == FrameSlot<Frame>::Put::kReplaced;
  ROS_DEBUG_STREAM_NAMED("frames", name_ << ": enqueued frame " << enqueued_stamp
                                         << (dropped ? " (replaced a waiting frame)" : ""));
  if (dropped) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    counts_.countDropped();
  }
}

}  // namespace stereo_safety_map
