// The stereo input of the frame-processing nodelets (safety map, 2D occupancy grid, obstacle
// detection): one copy of the subscribers, the tf2 MessageFilter, the stamp matching, the checks
// and the tf lookups, instead of one per nodelet.
//
// Disparity input: stereo/disparity, stereo/left/camera_info and (Options::right_info)
// stereo/right/camera_info. The DisparityImage passes a tf2_ros::MessageFilter (its frame must be
// transformable into fixed_frame at its stamp), then the exact matcher (exact_stamp_matcher.h:
// why not message_filters' ExactTime is there) or, with approximate_sync, message_filters'
// ApproximateTime with the CameraInfo. Cloud input (Options::cloud): a PointCloud2 on `points`
// through its own tf filter. A frame that passes is handed to the owner's callback (in the
// callback's thread: the owner puts it into its slot, frame_slot.h).
//
// With Options::check_messages each subscriber callback first checks its message on its own
// (structure, values: conversions.h check*(), no copy); a malformed message is counted and
// dropped there, so that it never reaches the tf2 MessageFilter or the sync, where it could push
// a valid message out. The matched frame is then checked as a whole (camera models, sizes)
// before it can take a valid frame's place in the owner's slot.
//
// Refusals are counted and reported through the owner's books (frame_counters.h: FrameBooks):
// "missing tf" (the tf filter, a failed lookup), "no camera info" (the matcher dropped a frame),
// "bad disparity image", "bad camera model", "bad point cloud", "non-finite input", "no valid
// data". Every frame's arrival is counted as received.
//
// Thread-safe: the callbacks run on the nodelet manager's threads; the lookups and toCore() on
// the owner's worker. The owner calls shutdown() before it stops its worker (no callback runs
// after it returns); the tf buffer lives until this object is destroyed, after the worker.
#pragma once

#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/ros/exact_stamp_matcher.h"
#include "stereo_safety_map/ros/frame_counters.h"

#include <message_filters/pass_through.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/synchronizer.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/PointCloud2.h>
#include <stereo_msgs/DisparityImage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace stereo_safety_map {

/// One input frame, matched and checked.
struct StereoFrame {
  std_msgs::Header header;  ///< the disparity's (or the cloud's)
  stereo_msgs::DisparityImageConstPtr disparity;
  sensor_msgs::CameraInfoConstPtr left_info;
  sensor_msgs::CameraInfoConstPtr right_info;  ///< null without Options::right_info
  sensor_msgs::PointCloud2ConstPtr cloud;      ///< with Options::cloud, instead of the three above
  double tf_wait_ms = 0.0;                     ///< from arrival to the transform being available
};

/// A frame's transforms at its stamp (StereoInput::lookUp).
struct FramePose {
  Eigen::Isometry3f T_fixed_sensor = Eigen::Isometry3f::Identity();  ///< the sensor's pose
  /// The data's frame in the sensor's: identity but for a cloud already in another frame.
  Eigen::Isometry3f T_sensor_data = Eigen::Isometry3f::Identity();
  Eigen::Vector3f base = Eigen::Vector3f::Zero();  ///< the robot base's origin in the fixed frame
};

class StereoInput {
 public:
  struct Options {
    std::string fixed_frame;
    int queue_size = 5;
    bool approximate_sync = false;
    bool cloud = false;           ///< a PointCloud2 on `points` instead of the disparity input
    bool right_info = true;       ///< the right CameraInfo as well (a frame of three parts)
    bool check_messages = false;  ///< each message checked in its callback, the frame when matched
    bool lazy = false;            ///< subscribed by subscribe() only (else at construction)
    std::string tf_hint = "Is the tf tree complete?";  ///< ends the tf filter's message

    /// fixed_frame, queue_size and approximate_sync from a nodelet's settings of those names.
    template <class RosConfig>
    static Options of(const RosConfig& c) {
      Options o;
      o.fixed_frame = c.fixed_frame;
      o.queue_size = c.queue_size;
      o.approximate_sync = c.approximate_sync;
      return o;
    }
  };
  using FrameCallback = std::function<void(StereoFrame&&)>;

  StereoInput(ros::NodeHandle nh, const Options& options, FrameBooks books, FrameCallback on_frame);
  ~StereoInput() { shutdown(); }

  StereoInput(const StereoInput&) = delete;
  StereoInput& operator=(const StereoInput&) = delete;

  /// Subscribes the inputs (again); unsubscribe() ends them (Options::lazy: the owner decides).
  void subscribe();
  void unsubscribe();
  /// Unsubscribes and disconnects the filters, each waiting for a callback in progress: no frame
  /// is handed on after it returns. The tf buffer stays (for the owner's worker).
  void shutdown();

  tf2_ros::Buffer& tfBuffer() { return *tf_buffer_; }

  /// The frame's transforms at its stamp: the pose of `sensor_frame` (empty or the data's frame:
  /// the data's frame, which the tf filter waited for; else waiting up to `tf_timeout`, and the
  /// data's frame in it) and, unless `base_frame` is empty, the base's origin (waiting up to
  /// `tf_timeout`). On failure counts and reports "missing tf" and returns false.
  bool lookUp(const std_msgs::Header& header, const std::string& sensor_frame,
              const std::string& base_frame, double tf_timeout, FramePose* pose);

  /// A disparity frame for the core (reused buffers): its camera model (both CameraInfo when the
  /// frame has the right one; the disparity's own f and T) and its disparities (invalid pixels
  /// 0). Refuses ("bad camera model", "bad disparity image") and returns false otherwise.
  bool toCore(const StereoFrame& frame, StereoCameraModel* camera, cv::Mat* disparity,
              DisparityImageStats* stats);

  /// Whether no pixel of the disparity image is valid (all NaN / inf or out of range).
  static bool noValidPixel(const DisparityImageStats& stats) {
    return stats.non_finite + stats.out_of_range >= stats.pixels;
  }
  /// Refuses a disparity frame without a valid pixel ("non-finite input" or "no valid data"),
  /// `hint` ending the message.
  void rejectWithoutValidPixel(const DisparityImageStats& stats, const std::string& hint = "");

 private:
  using DisparityFilter = tf2_ros::MessageFilter<stereo_msgs::DisparityImage>;
  using CloudFilter = tf2_ros::MessageFilter<sensor_msgs::PointCloud2>;
  using StereoMatcher = ExactStampMatcher<stereo_msgs::DisparityImage, sensor_msgs::CameraInfo,
                                          sensor_msgs::CameraInfo>;
  using LeftMatcher = ExactStampMatcher<stereo_msgs::DisparityImage, sensor_msgs::CameraInfo>;
  using StereoPolicy = message_filters::sync_policies::ApproximateTime<
      stereo_msgs::DisparityImage, sensor_msgs::CameraInfo, sensor_msgs::CameraInfo>;
  using LeftPolicy = message_filters::sync_policies::ApproximateTime<stereo_msgs::DisparityImage,
                                                                     sensor_msgs::CameraInfo>;
  using Clock = std::chrono::steady_clock;

  void connectDisparity();
  // Subscriber callbacks: check one message (Options::check_messages), hand it on or drop it.
  void disparityIn(const stereo_msgs::DisparityImageConstPtr& msg);
  void leftInfoIn(const sensor_msgs::CameraInfoConstPtr& msg);
  void rightInfoIn(const sensor_msgs::CameraInfoConstPtr& msg);
  void cloudIn(const sensor_msgs::PointCloud2ConstPtr& msg);
  void matched(const stereo_msgs::DisparityImageConstPtr& disparity,
               const sensor_msgs::CameraInfoConstPtr& left,
               const sensor_msgs::CameraInfoConstPtr& right);
  void cloudCb(const sensor_msgs::PointCloud2ConstPtr& cloud);
  void unmatched(const ros::Time& stamp, const std::string& why);
  void tfFailure(const std_msgs::Header& header,
                 tf2_ros::filter_failure_reasons::FilterFailureReason reason);
  /// A checked message enters the tf filter: its arrival time, for tfWaitMs().
  void noteArrival(const ros::Time& stamp);
  /// How long the frame stamped `stamp` waited since noteArrival() (0 if unknown); forgets it.
  double tfWaitMs(const ros::Time& stamp);

  ros::NodeHandle nh_;
  const Options options_;
  const FrameBooks books_;
  const FrameCallback on_frame_;

  std::shared_ptr<tf2_ros::Buffer> tf_buffer_;
  std::shared_ptr<tf2_ros::TransformListener> tf_listener_;
  std::mutex subscribe_mutex_;  ///< the subscribers
  ros::Subscriber disparity_sub_;
  ros::Subscriber left_info_sub_;
  ros::Subscriber right_info_sub_;
  ros::Subscriber cloud_sub_;
  // Messages enter the filters through these.
  message_filters::PassThrough<stereo_msgs::DisparityImage> disparity_in_;
  message_filters::PassThrough<sensor_msgs::CameraInfo> left_info_in_;
  message_filters::PassThrough<sensor_msgs::CameraInfo> right_info_in_;
  message_filters::PassThrough<sensor_msgs::PointCloud2> cloud_in_;
  std::unique_ptr<DisparityFilter> disparity_filter_;
  std::unique_ptr<CloudFilter> cloud_filter_;
  std::unique_ptr<StereoMatcher> stereo_matcher_;  ///< approximate_sync false, right_info
  std::unique_ptr<LeftMatcher> left_matcher_;      ///< approximate_sync false, no right_info
  std::unique_ptr<message_filters::Synchronizer<StereoPolicy>> stereo_sync_;
  std::unique_ptr<message_filters::Synchronizer<LeftPolicy>> left_sync_;

  // Arrival times of the frames between their check and the owner (tf filter, matcher), by
  // stamp, to measure how long each waited for tf (guarded by arrival_mutex_).
  std::mutex arrival_mutex_;
  std::map<ros::Time, Clock::time_point> arrivals_;
};

}  // namespace stereo_safety_map
