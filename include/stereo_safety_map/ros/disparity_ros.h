// The disparity ROS class: rectified left / right images + CameraInfo in, through the core's
// disparity stage (core/disparity_pipeline.h: OpenCV StereoBM / StereoSGBM and the post-filters
// of papers 002 Sec. 2.2, 4.2 and 000 Sec. III), stereo_msgs/DisparityImage out. Wrapped by
// src/nodelets/disparity_nodelet.cpp (stereo_safety_map/DisparityNodelet); a drop-in for
// stereo_image_proc/disparity (same topic names and message conventions).
//
// Inputs follow stereo_image_proc's disparity nodelet: two image_transport::SubscriberFilter
// (transport hints from the private node handle) and two CameraInfo subscribers, exact or
// approximate sync (~approximate_sync, ~queue_size), subscribed lazily in connectCb() under
// connect_mutex_ only while one of the outputs has a subscriber.
//
// Threading model. Sync callbacks run on the nodelet manager's thread pool and only put the four
// message pointers into a one-slot queue. One worker thread owned by this class takes them and
// runs the checks, the pipeline and the publishing; the pipeline and its buffers are used by that
// thread only. A frame arriving while another waits replaces it and is counted as dropped (the
// newest frame wins; latency stays one frame when the input is faster than the processing).
// dynamic_reconfigure hands a new pipeline configuration over through pending_mutex_; the worker
// applies it before its next frame, so a reconfiguration never waits for a frame. Counters live
// under stats_mutex_. Publishers are thread-safe in roscpp.
#pragma once

#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/stereo_input_check.h"
#include "stereo_safety_map/ros/disparity_params.h"
#include "stereo_safety_map/ros/nodelet_shell.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <stereo_safety_map/DisparityConfig.h>

#include <opencv2/core.hpp>

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace stereo_safety_map {

/// One synchronised input frame of the disparity nodelet, waiting for its worker.
struct StereoImageFrame {
  sensor_msgs::ImageConstPtr left_image;
  sensor_msgs::CameraInfoConstPtr left_info;
  sensor_msgs::ImageConstPtr right_image;
  sensor_msgs::CameraInfoConstPtr right_info;
};

class DisparityRos : public FrameNodeletShell<StereoImageFrame> {
 public:
  /// Reads and validates the parameters in `pnh`. With an invalid configuration the object logs
  /// the error (naming the parameter and its range), publishes it as an ERROR diagnostic and
  /// advertises / subscribes to nothing: see ok() / configError().
  DisparityRos(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~DisparityRos();

 private:
  using Image = sensor_msgs::Image;
  using CameraInfo = sensor_msgs::CameraInfo;
  using ExactPolicy =
      message_filters::sync_policies::ExactTime<Image, CameraInfo, Image, CameraInfo>;
  using ApproximatePolicy =
      message_filters::sync_policies::ApproximateTime<Image, CameraInfo, Image, CameraInfo>;

  using Frame = StereoImageFrame;

  void connectCb();
  void imageCb(const sensor_msgs::ImageConstPtr& left_image,
               const sensor_msgs::CameraInfoConstPtr& left_info,
               const sensor_msgs::ImageConstPtr& right_image,
               const sensor_msgs::CameraInfoConstPtr& right_info);
  void processFrame(const Frame& frame);
  void publishDisparity(const std_msgs::Header& header);
  void publishCloud(const std_msgs::Header& header);

  void reconfigureCb(DisparityConfig& config, uint32_t level);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);

  DisparityRosConfig ros_config_;
  DisparityPipelineConfig pipeline_config_;  ///< accepted configuration (reconfigure thread)

  // Inputs (subscribed lazily, under connect_mutex_).
  std::mutex connect_mutex_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::SubscriberFilter left_image_sub_;
  image_transport::SubscriberFilter right_image_sub_;
  message_filters::Subscriber<CameraInfo> left_info_sub_;
  message_filters::Subscriber<CameraInfo> right_info_sub_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy>> exact_sync_;
  std::unique_ptr<message_filters::Synchronizer<ApproximatePolicy>> approximate_sync_;
  bool subscribed_ = false;

  // Outputs.
  ros::Publisher disparity_pub_;
  ros::Publisher cloud_pub_;
  image_transport::Publisher debug_pub_;
  ReconfigureServer<DisparityConfig> reconfigure_;  ///< (nodelet_shell.h)

  // A configuration accepted by dynamic_reconfigure, waiting for the worker.
  std::mutex pending_mutex_;
  std::unique_ptr<DisparityPipelineConfig> pending_config_;

  // Worker-only: the core and buffers reused from frame to frame.
  DisparityPipeline pipeline_;
  StereoInputCheck input_check_;  ///< black / covered / frozen cameras
  StereoCameraModel camera_;
  cv::Mat left_buffer_, right_buffer_;
  cv::Mat disparity_;
  cv::Mat xyz_;

  // Counters and diagnostics (guarded by stats_mutex_, with the shell's counts_).
  DisparityStats last_stats_;
  std::string matcher_in_use_;
};

}  // namespace stereo_safety_map
