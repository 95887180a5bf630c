// The safety-map ROS class: translates stereo data and tf into calls of the core's one entry
// point per frame (core/stereo_frame_processor.h: reprojection, landmark filter, mapper of paper
// 000 Sec. IV-VI, obstacle cue) and its results into messages; the offline evaluators call the
// same entry point. Wrapped by
// src/nodelets/safety_map_nodelet.cpp (stereo_safety_map/SafetyMapNodelet). Implemented in
// src/ros/safety_map_inputs.cpp (the callbacks up to the slot), src/ros/safety_map_ros.cpp (the
// rest) and ros/safety_map_export.h (~save's files); its inputs are the shared stereo input
// (ros/stereo_input.h, with its message checks on).
//
// Threading model. Message callbacks run on the nodelet manager's thread pool. Each subscriber
// callback first checks its message on its own (structure, values: conversions.h check*(), no
// copy); a malformed message is counted and dropped there, so that it never reaches the tf2
// MessageFilter, the sync or the queue, where it could push a valid message out. The sync
// (exact_stamp_matcher.h unless approximate_sync: it keeps a frame's parts whatever else arrives,
// where message_filters' ExactTime let a flood evict them) calls back with the frame; it checks the
// frame as a whole (camera models, sizes), then frameIn() its stamp order, and puts the frame (the
// message pointers) into a queue of `frame_queue` frames (default 2), so callbacks never wait for
// the pipeline. One worker thread owned by this class takes frames from the queue, oldest first,
// and runs conversion, the core and publishing. When a frame arrives while the queue is full, the
// oldest waiting frame is dropped and counted (with one slot the newest frame wins and the
// latency stays one frame; two absorb one slow map); a dropped frame's reset_map passes to the
// frame after it. max_rate throttles by taking the newest waiting frame. A worker (rather than
// processing in the callback) keeps the tf2 MessageFilter and the sync running on time while a
// frame is processed, and lets drops be counted in one place.
//
// Locks, and what each guards (always taken in this order, never the other way round):
//   reconfigure_mutex_  dynamic_reconfigure's server (held by it while reconfigureCb runs);
//                       mapper_config_ and ros_config_.max_rate are only touched there.
//   core_mutex_         the core (processor_) and robot_position_: the worker for a frame, the
//                       aging timer, ~reset, ~save (while it serialises the map) and
//                       reconfigureCb. Maps are published under it, so a message is never built
//                       from a map being changed.
//   save_mutex_         writing ~save's files (after core_mutex_ is released).
//   the slot's mutex    (frame_slot.h) the slot and newest_stamp_ (the stamp order, changed in
//                       putIf()'s accept), held for a swap.
//   stats_mutex_        counters and diagnostics (the tf wait is measured in stereo_input.h).
// The exact matcher has its own mutex, never held while it calls back (into frameIn).
// Worker-only state (points_, disparity_, camera_, previous_input_...) is touched by the worker
// thread alone. Constant after the constructor: ros_config_ (but max_rate), config_error_.
// Publishers are thread-safe in roscpp. The destructor stops the timers, services, reconfigure
// server and subscribers before the worker, so that no callback runs into a half-destroyed object.
#pragma once

#include "stereo_safety_map/core/landmark_filter.h"
#include "stereo_safety_map/core/obstacle_cue.h"
#include "stereo_safety_map/core/safety_mapper.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/ros/nodelet_shell.h"
#include "stereo_safety_map/ros/obstacle_params.h"
#include "stereo_safety_map/ros/safety_map_params.h"
#include "stereo_safety_map/ros/stereo_input.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Empty.h>
#include <stereo_safety_map/SafetyMapConfig.h>
#include <stereo_safety_map/SaveMap.h>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace stereo_safety_map {

/// One input frame of the safety-map nodelet, waiting for its worker.
struct SafetyMapFrame : StereoFrame {
  bool reset_map = false;  ///< time went back (the clock too): a restart, reset first
};

class SafetyMapRos : public FrameNodeletShell<SafetyMapFrame> {
 public:
  /// Reads and validates the parameters in `pnh`. With an invalid configuration the object
  /// logs the error (naming the parameter and its range), publishes it as an ERROR diagnostic
  /// and subscribes to nothing: see ok() / configError().
  SafetyMapRos(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~SafetyMapRos();

 private:
  using Clock = std::chrono::steady_clock;

  using Frame = SafetyMapFrame;

  void setUpInputs();
  /// A checked frame from the stereo input (disparity or cloud): on to enqueue().
  void frameIn(StereoFrame&& in);
  /// Puts a frame into the slot unless its transform came more than max_tf_wait after it
  /// ("stale tf"), or its stamp is not newer than the newest frame's (then it is dropped, or
  /// marks a restart when the clock went back as well: time_jump_reset). A refused frame never
  /// takes a waiting frame's place.
  void enqueue(std::unique_ptr<Frame> frame);

  void processFrame(const Frame& frame);
  void publishOutputs(const std_msgs::Header& header, const Eigen::Vector3f& robot_position);
  /// Map, labels and safety_obstacles (core_mutex_ held). `header.stamp` is the stamp of the last
  /// frame integrated (or skipped as stationary); `from_frame` when a frame vouches for the map
  /// now (it is fresh again), false when the timer republishes it (aged, or stale: then the
  /// OccupancyGrid is all Unknown and safety_obstacles is not published).
  void publishMap(const std_msgs::Header& header, bool from_frame);
  /// The OccupancyGrid (all Unknown while stale) and safety_obstacles (not while stale) alone.
  void publishGrid(const std_msgs::Header& header);
  /// True when the frame's data are byte for byte those of the previous frame (another stamp):
  /// a frozen camera or driver. Worker only.
  bool frozen(const Frame& frame);
  /// Ages the map by the clock while frames do not (max_cell_age), and republishes it; after
  /// stale_input_timeout without a frame, republishes the OccupancyGrid as all Unknown.
  void ageTimerCb();

  bool resetSrv(std_srvs::Empty::Request& req, std_srvs::Empty::Response& res);
  bool saveSrv(SaveMap::Request& req, SaveMap::Response& res);
  void reconfigureCb(SafetyMapConfig& config, uint32_t level);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);

  SafetyMapRosConfig ros_config_;
  SafetyMapperConfig mapper_config_;

  // Inputs (stereo_input.h: subscribers, checks, tf filter, sync, tf buffer).
  std::unique_ptr<StereoInput> input_;

  // Outputs.
  ros::Publisher map_pub_;
  ros::Publisher labels_pub_;
  ros::Publisher markers_pub_;
  ros::Publisher points_pub_;
  ros::Publisher timings_pub_;
  ros::Publisher landmarks_pub_;  ///< permanent landmarks (001 Sec. 4.2), with the filter on
  ros::Publisher obstacles_pub_;  ///< safety_obstacles: the lethal cells as points
  ros::ServiceServer reset_srv_;
  ros::ServiceServer save_srv_;
  ros::WallTimer age_timer_;
  ReconfigureServer<SafetyMapConfig> reconfigure_;  ///< (nodelet_shell.h)
  std::mutex save_mutex_;

  // The shell's frame queue: what decides the order of the frames put into it.
  ros::Time newest_stamp_;  ///< of the last frame put into the slot
  std::atomic<double> max_rate_{0.0};
  std::atomic<double> max_cell_age_{0.0};  ///< for diagnostics (mapper_config_ is the server's)

  // Worker-only buffers, reused from frame to frame.
  std::vector<Eigen::Vector3f> points_;
  cv::Mat disparity_;
  StereoCameraModel camera_;
  ros::Time last_stamp_;
  std::vector<std::uint8_t> previous_input_;  ///< data of the previous frame (frozen input)
  ros::Time previous_input_stamp_;
  std::uint32_t previous_input_width_ = 0, previous_input_height_ = 0;

  // The core (guarded by core_mutex_).
  std::mutex core_mutex_;
  /// The core's frame path: reprojection, 001's landmark filter (~use_landmark_filter), the
  /// mapper, the obstacle cue (~obstacle_cue). Null with an invalid configuration.
  std::unique_ptr<StereoFrameProcessor> processor_;
  LandmarkStreamConfig landmark_config_;
  std::vector<Eigen::Vector3f> landmark_points_;
  Eigen::Vector3f robot_position_ = Eigen::Vector3f::Zero();
  // What was published (guarded by core_mutex_): the map's stamp (the last frame integrated or
  // skipped as stationary), the ROS time a frame last vouched for it, whether the published
  // OccupancyGrid is the stale (all Unknown) one. Buffers reused for the costs and the cloud.
  ros::Time map_stamp_;
  ros::Time map_vouched_at_;
  std::atomic<bool> map_stale_{false};        ///< (atomic: diagnostics read it)
  std::atomic<std::uint64_t> stale_maps_{0};  ///< times the published map went stale
  std::vector<Eigen::Vector3f> obstacle_points_;

  // Counters and diagnostics (guarded by stats_mutex_, with the shell's counts_).
  std::uint64_t frames_stationary_ = 0;
  std::uint64_t map_resets_ = 0;
  std::size_t cells_aged_ = 0;     ///< safe cells of the current map turned Unknown by age
  int cells_under_overhangs_ = 0;  ///< SafetyMapper::cellsUnderOverhangs of the last map
  int cells_unseen_overhang_ = 0;  ///< SafetyMapper::cellsUnderUnseenOverhangs of the last map
  int cells_unseen_floor_ = 0;     ///< SafetyMapper::cellsUnseenFloor of the last map
  ros::WallTime last_used_;        ///< last frame integrated or skipped as stationary
  ros::WallTime started_;
  std::uint64_t landmark_frames_empty_ = 0;  ///< frames of which the filter confirmed no point
  double landmark_kept_last_ = 0.0;          ///< fraction of the last frame's points kept
  double landmark_ms_last_ = 0.0;
  std::size_t landmarks_permanent_ = 0;
  double tf_wait_ms_sum_ = 0.0;
  std::uint64_t tf_wait_count_ = 0;

  // Obstacle cue (~obstacle_cue): the labelled obstacle points of ObstacleDetectionNodelet (paper
  // 003) mark their cells Non-ground in the next map (the processor's cue stage,
  // core/obstacle_cue.h). The callback converts a cue and queues it under cue_mutex_; the worker
  // hands the queued cues to the processor (under core_mutex_) before each frame, so that a cue
  // never waits for a frame being processed. Lock order: core_mutex_ or stats_mutex_ before
  // cue_mutex_; the cue callback holds cue_mutex_ alone.
  struct PendingCue {
    double stamp = 0.0;
    std::vector<Eigen::Vector3f> points;  ///< fixed frame
  };
  void setUpObstacleCue();
  void obstacleCueCb(const sensor_msgs::PointCloud2ConstPtr& cloud);
  void obstacleCueProblem(const std::string& detail);
  /// Hands the queued cues to the processor (core_mutex_ held).
  void takePendingCues();
  void diagnoseObstacleCue(diagnostic_updater::DiagnosticStatusWrapper& stat);
  ObstacleCueRosConfig cue_config_;
  ros::Subscriber obstacle_cue_sub_;
  std::mutex cue_mutex_;
  std::deque<PendingCue> pending_cues_;  ///< (guarded by cue_mutex_)
  std::uint64_t cues_received_ = 0;      ///< (guarded by cue_mutex_)
  std::uint64_t cues_refused_ = 0;
  ObstacleCueStats cue_stats_;  ///< of the last map (guarded by cue_mutex_)
  int cues_live_ = 0;           ///< held by the processor after the last map
};

}  // namespace stereo_safety_map
