// The obstacle-detection ROS class: a range image in (an organised PointCloud2, or a
// stereo_msgs/DisparityImage with its left CameraInfo), gravity from tf, the core's 3D obstacle
// detection and segmentation (core/obstacle_detection.h, paper 003: Def. 1, OD / OS Algorithm 2,
// Sec. 5 rules; or the column-wise baseline) and its results out: a colourised label image, the
// labelled obstacle points as a PointCloud2 in the fixed frame (the safety-map nodelet's obstacle
// cue, core/obstacle_cue.h) and the obstacles' boxes as markers. Wrapped by
// src/nodelets/obstacle_detection_nodelet.cpp (stereo_safety_map/ObstacleDetectionNodelet).
//
// Inputs are subscribed lazily, only while an output has a subscriber. The data input passes a
// tf2_ros::MessageFilter (the camera -> fixed_frame transform must exist at its stamp); the
// disparity is synchronised with the left CameraInfo (exact or approximate). Both are the shared
// ros/stereo_input.h (without its message checks).
//
// Threading model (as the other nodelets): callbacks on the nodelet manager's threads only put
// the frame into a one-slot queue; one worker thread owned by this class converts, detects and
// publishes. A frame arriving while another waits replaces it and is counted as dropped. The
// detector and its buffers belong to the worker; counters live under stats_mutex_.
#pragma once

#include "stereo_safety_map/core/obstacle_detection.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/ros/nodelet_shell.h"
#include "stereo_safety_map/ros/obstacle_params.h"
#include "stereo_safety_map/ros/stereo_input.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace stereo_safety_map {

/// Organised PointCloud2 (height > 1, FLOAT32 x / y / z) -> CV_32FC3 range image (reused),
/// NaN where a point is not finite. Empty string on success, otherwise why it is refused.
std::string organisedCloudToMat(const sensor_msgs::PointCloud2& msg, cv::Mat* xyz,
                                std::size_t* non_finite = nullptr);

class ObstacleDetectionRos : public FrameNodeletShell<StereoFrame> {
 public:
  /// Reads and validates the parameters in `pnh`. With an invalid configuration the object logs
  /// the error (naming the parameter and its range), publishes it as an ERROR diagnostic and
  /// advertises / subscribes to nothing: see ok() / configError().
  ObstacleDetectionRos(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~ObstacleDetectionRos();

 private:
  using Frame = StereoFrame;

  void setUpInputs();
  void connectCb();
  void enqueue(std::unique_ptr<Frame> frame);
  void processFrame(const Frame& frame);

  void publishLabelImage(const std_msgs::Header& header);
  void publishObstacles(const std_msgs::Header& header, const Eigen::Isometry3f& T_fixed_camera);
  void publishMarkers(const std_msgs::Header& header);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);

  ObstacleDetectionRosConfig ros_config_;
  ObstacleDetectionConfig detector_config_;

  // Inputs (subscribed lazily, under connect_mutex_).
  std::mutex connect_mutex_;
  bool subscribed_ = false;
  std::unique_ptr<StereoInput> input_;  ///< (stereo_input.h)

  // Outputs.
  ros::Publisher label_image_pub_;
  ros::Publisher obstacles_pub_;
  ros::Publisher markers_pub_;

  // Worker-only: the core and buffers reused from frame to frame.
  std::unique_ptr<ObstacleDetector> detector_;
  ObstacleDetectionResult result_;
  StereoCameraModel camera_;
  cv::Mat disparity_;
  cv::Mat xyz_;
  cv::Mat xyz_detect_;  // what the detector gets: xyz_ itself, or every ~decimation-th pixel
  std::vector<Eigen::Vector3f> raised_points_;  // the obstacle cue of the last frame
  std::vector<std::uint32_t> raised_labels_;
  cv::Mat colour_;

  // Counters and diagnostics (guarded by stats_mutex_, with the shell's counts_).
  double detection_ms_last_ = 0.0;
  double focal_length_last_ = 0.0;
  std::size_t valid_points_last_ = 0;
  std::size_t obstacle_points_last_ = 0;
  int accepted_last_ = 0;
  int rejected_last_ = 0;
};

}  // namespace stereo_safety_map
