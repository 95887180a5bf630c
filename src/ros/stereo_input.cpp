#include "stereo_safety_map/ros/stereo_input.h"

#include <tf2_eigen/tf2_eigen.h>

#include <boost/bind/bind.hpp>

#include <sstream>
#include <utility>

namespace stereo_safety_map {

namespace {

// Frames between their check and the owner are at most queue_size in the tf filter and
// queue_size in the matcher; more entries are leftovers (e.g. a repeated stamp).
constexpr std::size_t kMaxArrivals = 256;

}  // namespace

StereoInput::StereoInput(ros::NodeHandle nh, const Options& options, FrameBooks books,
                         FrameCallback on_frame)
    : nh_(nh), options_(options), books_(books), on_frame_(std::move(on_frame)) {
  const int q = options_.queue_size;
  tf_buffer_ = std::make_shared<tf2_ros::Buffer>(ros::Duration(kTfCacheTime));
  tf_listener_ = std::make_shared<tf2_ros::TransformListener>(*tf_buffer_, nh_);
  if (options_.cloud) {
    cloud_filter_ =
        std::make_unique<CloudFilter>(cloud_in_, *tf_buffer_, options_.fixed_frame, q, nh_);
    cloud_filter_->registerCallback(
        boost::bind(&StereoInput::cloudCb, this, boost::placeholders::_1));
    cloud_filter_->registerFailureCallback(
        [this](const sensor_msgs::PointCloud2ConstPtr& m,
               tf2_ros::filter_failure_reasons::FilterFailureReason r) {
          tfFailure(m->header, r);
        });
  } else {
    connectDisparity();
  }
  if (!options_.lazy) subscribe();
}

void StereoInput::connectDisparity() {
  const int q = options_.queue_size;
  disparity_filter_ =
      std::make_unique<DisparityFilter>(disparity_in_, *tf_buffer_, options_.fixed_frame, q, nh_);
  disparity_filter_->registerFailureCallback(
      [this](const stereo_msgs::DisparityImageConstPtr& m,
             tf2_ros::filter_failure_reasons::FilterFailureReason r) { tfFailure(m->header, r); });
  const auto on_match = [this](const stereo_msgs::DisparityImageConstPtr& d,
                               const sensor_msgs::CameraInfoConstPtr& l,
                               const sensor_msgs::CameraInfoConstPtr& r) { matched(d, l, r); };
  const auto on_drop = [this](const ros::Time& stamp, const std::string& why) {
    unmatched(stamp, why);
  };
  if (options_.approximate_sync && options_.right_info) {
    stereo_sync_ = std::make_unique<message_filters::Synchronizer<StereoPolicy>>(
        StereoPolicy(q), *disparity_filter_, left_info_in_, right_info_in_);
    stereo_sync_->registerCallback(boost::bind(&StereoInput::matched, this, boost::placeholders::_1,
                                               boost::placeholders::_2, boost::placeholders::_3));
  } else if (options_.approximate_sync) {
    left_sync_ = std::make_unique<message_filters::Synchronizer<LeftPolicy>>(
        LeftPolicy(q), *disparity_filter_, left_info_in_);
    left_sync_->registerCallback(boost::bind(&StereoInput::matched, this, boost::placeholders::_1,
                                             boost::placeholders::_2, nullptr));
  } else if (options_.right_info) {
    stereo_matcher_ =
        std::make_unique<StereoMatcher>(StereoMatcher::Limits::forNodelet(q), on_match, on_drop);
    stereo_matcher_->connectInput<0>(*disparity_filter_);
    stereo_matcher_->connectInput<1>(left_info_in_);
    stereo_matcher_->connectInput<2>(right_info_in_);
  } else {
    left_matcher_ = std::make_unique<LeftMatcher>(
        LeftMatcher::Limits::forNodelet(q),
        [on_match](const stereo_msgs::DisparityImageConstPtr& d,
                   const sensor_msgs::CameraInfoConstPtr& l) { on_match(d, l, nullptr); },
        on_drop);
    left_matcher_->connectInput<0>(*disparity_filter_);
    left_matcher_->connectInput<1>(left_info_in_);
  }
}

void StereoInput::subscribe() {
  std::lock_guard<std::mutex> lock(subscribe_mutex_);
  const int q = options_.queue_size;
  if (options_.cloud) {
    if (cloud_filter_ && !cloud_sub_)
      cloud_sub_ = nh_.subscribe("points", q, &StereoInput::cloudIn, this);
    return;
  }
  if (!disparity_filter_ || disparity_sub_) return;  // shut down, or subscribed
  // The disparity last: the chain behind it is complete.
  left_info_sub_ = nh_.subscribe("stereo/left/camera_info", q, &StereoInput::leftInfoIn, this);
  if (options_.right_info) {
    right_info_sub_ = nh_.subscribe("stereo/right/camera_info", q, &StereoInput::rightInfoIn, this);
  }
  disparity_sub_ = nh_.subscribe("stereo/disparity", q, &StereoInput::disparityIn, this);
}

void StereoInput::unsubscribe() {
  std::lock_guard<std::mutex> lock(subscribe_mutex_);
  for (ros::Subscriber* sub : {&disparity_sub_, &left_info_sub_, &right_info_sub_, &cloud_sub_}) {
    sub->shutdown();
    *sub = ros::Subscriber();
  }
}

void StereoInput::shutdown() {
  unsubscribe();
  std::lock_guard<std::mutex> lock(subscribe_mutex_);  // subscribe() finds no filter after this
  stereo_sync_.reset();
  left_sync_.reset();
  disparity_filter_.reset();
  cloud_filter_.reset();
  stereo_matcher_.reset();
  left_matcher_.reset();
}

void StereoInput::disparityIn(const stereo_msgs::DisparityImageConstPtr& msg) {
  books_.countReceived();
  if (options_.check_messages) {
    DisparityImageStats stats;
    const std::string err = checkDisparityImage(*msg, &stats);
    if (!err.empty()) {
      books_.reject("bad disparity image", "dropped a disparity frame: " + err);
      return;
    }
    if (noValidPixel(stats)) {
      rejectWithoutValidPixel(stats, ": camera covered, black or failing?");
      return;
    }
  }
  noteArrival(msg->header.stamp);
  disparity_in_.add(msg);
}

void StereoInput::leftInfoIn(const sensor_msgs::CameraInfoConstPtr& msg) {
  const std::string err = options_.check_messages ? checkCameraInfo(*msg, "left") : "";
  if (!err.empty()) {
    books_.reject("bad camera model", "dropped a CameraInfo: " + err);
    return;
  }
  left_info_in_.add(msg);
}

void StereoInput::rightInfoIn(const sensor_msgs::CameraInfoConstPtr& msg) {
  std::string err = options_.check_messages ? checkCameraInfo(*msg, "right") : "";
  if (options_.check_messages && err.empty() && !(msg->P[3] < 0.0)) {
    err = "right CameraInfo has zero baseline (P[3] = Tx = -fx B = " + std::to_string(msg->P[3]) +
          ", must be < 0)";
  }
  if (!err.empty()) {
    books_.reject("bad camera model", "dropped a CameraInfo: " + err);
    return;
  }
  right_info_in_.add(msg);
}

void StereoInput::cloudIn(const sensor_msgs::PointCloud2ConstPtr& msg) {
  books_.countReceived();
  if (options_.check_messages) {
    CloudStats stats;
    const std::string err = checkPointCloud2(*msg, &stats);
    if (!err.empty()) {
      books_.reject("bad point cloud", "dropped a cloud: " + err);
      return;
    }
    if (stats.non_finite >= stats.points) {
      std::ostringstream os;
      os << "dropped a cloud without a finite point (" << stats.non_finite << " NaN / inf of "
         << stats.points << ")";
      books_.reject("non-finite input", os.str());
      return;
    }
  }
  noteArrival(msg->header.stamp);
  cloud_in_.add(msg);
}

void StereoInput::matched(const stereo_msgs::DisparityImageConstPtr& disparity,
                          const sensor_msgs::CameraInfoConstPtr& left,
                          const sensor_msgs::CameraInfoConstPtr& right) {
  if (options_.check_messages) {
    // The frame as a whole, before it can take a valid frame's place in the owner's slot.
    StereoCameraModel camera;
    std::string err = right ? cameraModelFromCameraInfo(*left, *right, &camera) : "";
    if (err.empty()) err = cameraModelForDisparity(*disparity, *left, &camera);
    if (!err.empty()) {
      tfWaitMs(disparity->header.stamp);  // forget its arrival
      books_.reject("bad camera model", "dropped a disparity frame: " + err);
      return;
    }
  }
  StereoFrame frame;
  frame.header = disparity->header;
  frame.disparity = disparity;
  frame.left_info = left;
  frame.right_info = right;
  frame.tf_wait_ms = tfWaitMs(disparity->header.stamp);
  on_frame_(std::move(frame));
}

void StereoInput::cloudCb(const sensor_msgs::PointCloud2ConstPtr& cloud) {
  StereoFrame frame;
  frame.header = cloud->header;
  frame.cloud = cloud;
  frame.tf_wait_ms = tfWaitMs(cloud->header.stamp);
  on_frame_(std::move(frame));
}

void StereoInput::unmatched(const ros::Time& stamp, const std::string& why) {
  tfWaitMs(stamp);  // forget its arrival
  books_.reject("no camera info", unmatchedDisparityMessage(stamp, why));
}

void StereoInput::tfFailure(const std_msgs::Header& header,
                            tf2_ros::filter_failure_reasons::FilterFailureReason reason) {
  tfWaitMs(header.stamp);  // forget its arrival
  books_.reject("missing tf", tfFilterFailureMessage("frame", header, options_.fixed_frame, reason,
                                                     options_.tf_hint));
}

void StereoInput::noteArrival(const ros::Time& stamp) {
  std::lock_guard<std::mutex> lock(arrival_mutex_);
  // A repeated stamp (a bag played again, whose frame of that stamp was lost in the last loop's
  // approximate sync) takes the new arrival: an old one would make its frame look stale.
  arrivals_[stamp] = Clock::now();
  while (arrivals_.size() > kMaxArrivals)
    arrivals_.erase(arrivals_.begin());
}

double StereoInput::tfWaitMs(const ros::Time& stamp) {
  std::lock_guard<std::mutex> lock(arrival_mutex_);
  const auto it = arrivals_.find(stamp);
  if (it == arrivals_.end()) return 0.0;
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - it->second).count();
  arrivals_.erase(it);
  return ms;
}

bool StereoInput::lookUp(const std_msgs::Header& header, const std::string& sensor_frame,
                         const std::string& base_frame, double tf_timeout, FramePose* pose) {
  const ros::Time& stamp = header.stamp;
  const ros::Duration timeout(tf_timeout);
  const std::string& fixed = options_.fixed_frame;
  try {
    if (!sensor_frame.empty() && sensor_frame != header.frame_id) {
      pose->T_fixed_sensor =
          tf2::transformToEigen(tf_buffer_->lookupTransform(fixed, sensor_frame, stamp, timeout))
              .cast<float>();
      pose->T_sensor_data =
          tf2::transformToEigen(
              tf_buffer_->lookupTransform(sensor_frame, header.frame_id, stamp, timeout))
              .cast<float>();
    } else {
      pose->T_fixed_sensor =
          tf2::transformToEigen(tf_buffer_->lookupTransform(fixed, header.frame_id, stamp))
              .cast<float>();
      pose->T_sensor_data.setIdentity();
    }
    if (!base_frame.empty()) {
      const geometry_msgs::TransformStamped base =
          tf_buffer_->lookupTransform(fixed, base_frame, stamp, timeout);
      Eigen::Vector3d base_position;
      tf2::fromMsg(base.transform.translation, base_position);
      pose->base = base_position.cast<float>();
    }
  } catch (const tf2::TransformException& e) {
    books_.reject("missing tf", "dropped a frame at t = " + std::to_string(stamp.toSec()) +
                                    ": tf lookup failed: " + e.what());
    return false;
  }
  return true;
}

bool StereoInput::toCore(const StereoFrame& frame, StereoCameraModel* camera, cv::Mat* disparity,
                         DisparityImageStats* stats) {
  std::string err = frame.right_info
                        ? cameraModelFromCameraInfo(*frame.left_info, *frame.right_info, camera)
                        : "";
  if (err.empty()) err = cameraModelForDisparity(*frame.disparity, *frame.left_info, camera);
  if (!err.empty()) {
    books_.reject("bad camera model", "dropped a disparity frame: " + err);
    return false;
  }
  err = disparityImageToMat(*frame.disparity, disparity, stats);
  if (!err.empty()) {
    books_.reject("bad disparity image", "dropped a disparity frame: " + err);
    return false;
  }
  return true;
}

void StereoInput::rejectWithoutValidPixel(const DisparityImageStats& stats,
                                          const std::string& hint) {
  std::ostringstream os;
  os << "dropped a disparity frame without a valid pixel (" << stats.non_finite << " NaN / inf and "
     << stats.out_of_range << " outside [min_disparity, max_disparity]"
     << " of " << stats.pixels << ")" << hint;
  books_.reject(stats.non_finite > 0 ? "non-finite input" : "no valid data", os.str());
}

}  // namespace stereo_safety_map
