#include "stereo_safety_map/ros/safety_map_ros.h"

#include "stereo_safety_map/core/map_costs.h"
#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/ros/hybrid_conversions.h"
#include "stereo_safety_map/ros/param_reader.h"
#include "stereo_safety_map/ros/reconfigure_fields.h"
#include "stereo_safety_map/ros/safety_map_export.h"

#include <nav_msgs/OccupancyGrid.h>
#include <tf2_eigen/tf2_eigen.h>
#include <visualization_msgs/MarkerArray.h>

#include <boost/bind/bind.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

namespace stereo_safety_map {

namespace {

constexpr double kAgePeriod = 0.25;  // [s] between two agings / staleness checks of the map

}  // namespace

SafetyMapRos::SafetyMapRos(ros::NodeHandle nh, ros::NodeHandle pnh) : FrameNodeletShell(nh, pnh) {
  // A wall timer: it reports while a bag is paused (nodelet_diagnostics.h).
  startDiagnostics(
      "stereo camera", "safety map",
      [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { diagnose(stat); },
      NodeletDiagnostics::Clock::kWall);
  started_ = counts_.window_start;

  std::string err = fromRosParam(pnh_, &ros_config_);
  if (err.empty()) err = fromRosParam(pnh_, &mapper_config_);
  if (err.empty()) err = fromRosParam(pnh_, &landmark_config_);
  if (err.empty()) {
    // The filter sees the points the grid would use (001 Sec. 4.2 in front of 000 Sec. IV).
    landmark_config_ = landmark_config_.forMapper(mapper_config_);
    const std::string why = landmark_config_.validate();
    if (!why.empty()) err = "invalid parameter in " + pnh_.getNamespace() + ": landmark_" + why;
  }
  if (err.empty()) err = fromRosParam(pnh_, &cue_config_);
  if (!acceptParams(err, safetyMapParameterNames())) return;
  // The core's frame path (stereo_frame_processor.h), the one the offline evaluators run.
  StereoFrameProcessorConfig processor_config;
  processor_config.mapper = mapper_config_;
  processor_config.disparity_step = ros_config_.disparity_step;
  processor_config.row_gap_fill = ros_config_.row_gap_fill;
  processor_config.landmark_filter = landmark_config_;
  processor_config.obstacle_cue = cue_config_.enabled;
  processor_config.cue = cue_config_.cue;
  err = processor_config.validate();  // each part was validated as it was read
  if (!err.empty()) {
    refuse("invalid parameter in " + pnh_.getNamespace() + ": " + err);
    return;
  }
  processor_ = std::make_unique<StereoFrameProcessor>(processor_config);  // valid: no throw
  max_rate_ = ros_config_.max_rate;
  max_cell_age_ = mapper_config_.max_cell_age;

  map_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("safety_map", 1, true);
  labels_pub_ = nh_.advertise<SafetyMapMsg>("safety_map_labels", 1, true);
  markers_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("planes", 1);
  points_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("occupied_points", 1);
  timings_pub_ = nh_.advertise<StageTimingsMsg>("stage_timings", 10);
  obstacles_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("safety_obstacles", 1);
  if (landmark_config_.enabled) {
    landmarks_pub_ = nh_.advertise<sensor_msgs::PointCloud2>("landmarks", 1);
    if (ros_config_.input == "cloud") {
      ROS_WARN_STREAM(name_ << ": use_landmark_filter needs input: disparity (the filter works "
                               "in the image); clouds are not filtered");
    }
  }
  if (!ros_config_.sensor_frame.empty() && ros_config_.input != "cloud") {
    ROS_WARN_STREAM(name_ << ": sensor_frame '" << ros_config_.sensor_frame
                          << "' is used with input: cloud only; a disparity image is in its "
                             "camera's frame");
  }
  reset_srv_ = pnh_.advertiseService("reset", &SafetyMapRos::resetSrv, this);
  save_srv_ = pnh_.advertiseService("save", &SafetyMapRos::saveSrv, this);

  // The server reads the (already validated) start-up values from the parameter server and calls
  // reconfigureCb once with them.
  reconfigure_.start(
      pnh_, [this](SafetyMapConfig& config, std::uint32_t level) { reconfigureCb(config, level); });

  // A frame the queue drops hands its map reset (a restart) on to the frame after it.
  slot_.setCapacity(static_cast<std::size_t>(ros_config_.frame_queue));
  slot_.setCarry([](const Frame& dropped, Frame& successor) {
    if (dropped.reset_map) successor.reset_map = true;
  });
  startWorker([this](const Frame& frame) { processFrame(frame); },
              [this] { return max_rate_.load(); });
  age_timer_ = nh_.createWallTimer(ros::WallDuration(kAgePeriod),
                                   [this](const ros::WallTimerEvent&) { ageTimerCb(); });
  setUpInputs();
  setUpObstacleCue();
  ROS_INFO_STREAM(name_ << ": building the safety map in '" << ros_config_.fixed_frame << "' from "
                        << (ros_config_.input == "cloud" ? "point clouds" : "disparity images")
                        << ", robot frame '" << ros_config_.base_frame << "'"
                        << (ros_config_.input == "cloud" && !ros_config_.sensor_frame.empty()
                                ? ", sensor frame '" + ros_config_.sensor_frame + "'"
                                : std::string()));
}

SafetyMapRos::~SafetyMapRos() {
  // Everything that calls back into this object first, each shutdown waiting for a callback in
  // progress: timers, services, the reconfigure server (before the mutex it uses), subscribers.
  // Then the filters, then the worker. Only then are the members destroyed.
  age_timer_.stop();
  diagnostics_->stop();
  reset_srv_.shutdown();
  save_srv_.shutdown();
  reconfigure_.stop();
  if (input_) input_->shutdown();  // none when the parameters were refused
  stopWorker();
}

void SafetyMapRos::processFrame(const Frame& frame) {
  const Clock::time_point t0 = Clock::now();
  const ros::Time stamp = frame.header.stamp;

  // Time went back with the clock (enqueue() decided): a bag restarted. Reset once, one warning.
  const bool reset_for_time = frame.reset_map;
  if (reset_for_time) {
    ROS_WARN_STREAM(name_ << ": time went back by " << (last_stamp_ - stamp).toSec() << " s (stamp "
                          << stamp << " after " << last_stamp_
                          << ", the clock went back too; a bag restarted?): resetting the map");
  } else if (!last_stamp_.isZero() && stamp <= last_stamp_) {
    books_.reject("out of order", "dropped a frame out of order: stamp " +
                                      std::to_string(stamp.toSec()) +
                                      " is not newer than the last frame's");
    return;
  }

  // Transforms: the sensor's is available (the tf2 MessageFilter waited for it); the base's
  // may need a moment more.
  // A cloud already in another frame (sensor_frame set): the rays start at the sensor, so the
  // points go to the sensor's frame and the pose is the sensor's.
  const bool cloud_in_other_frame = frame.cloud && !ros_config_.sensor_frame.empty() &&
                                    ros_config_.sensor_frame != frame.header.frame_id;
  FramePose pose;
  if (!input_->lookUp(frame.header, frame.cloud ? ros_config_.sensor_frame : std::string(),
                      ros_config_.base_frame, ros_config_.tf_timeout, &pose)) {
    return;
  }
  const Eigen::Isometry3f& T_fixed_sensor = pose.T_fixed_sensor;
  const Eigen::Vector3f& robot_position = pose.base;

  // Convert the input (worker-owned buffers) and refuse what the core must not see.
  std::size_t non_finite = 0;
  std::size_t values = 0;  // pixels or points of the input
  if (frame.disparity) {
    DisparityImageStats stats;
    if (!input_->toCore(frame, &camera_, &disparity_, &stats)) return;
    non_finite = stats.non_finite;
    values = stats.pixels;
    if (frozen(frame)) return;
    if (StereoInput::noValidPixel(stats)) {
      input_->rejectWithoutValidPixel(stats);
      return;
    }
  } else if (frame.cloud) {
    CloudStats stats;
    const std::string err = pointCloud2ToPoints(*frame.cloud, &points_, &stats);
    if (!err.empty()) {
      books_.reject("bad point cloud", "dropped a cloud: " + err);
      return;
    }
    non_finite = stats.non_finite;
    values = stats.points;
    if (frozen(frame)) return;
    if (cloud_in_other_frame) {
      for (Eigen::Vector3f& p : points_)
        p = pose.T_sensor_data * p;
    }
    if (points_.empty()) {
      std::ostringstream os;
      os << "dropped a cloud without a finite point (" << stats.non_finite << " NaN / inf of "
         << stats.points << ")";
      books_.reject("non-finite input", os.str());
      return;
    }
  }
  if (non_finite > 0) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    counts_.non_finite += non_finite;
  }

  StereoFrameResult result;
  std::string core_error;
  bool integrated = false;
  {
    std::lock_guard<std::mutex> lock(core_mutex_);
    if (reset_for_time) {
      processor_->reset();
      std::lock_guard<std::mutex> stats_lock(stats_mutex_);
      ++map_resets_;
      problems_.note("time went backwards: map reset");
    }
    last_stamp_ = stamp;
    takePendingCues();
    // The core's one entry point per frame (stereo_frame_processor.h): landmark filter (001 Sec.
    // 4.2, disparity input only), mapper (000 Sec. IV-VI), obstacle cue (003).
    if (frame.disparity) {
      integrated = processor_->processDisparity(disparity_, camera_, T_fixed_sensor, robot_position,
                                                stamp.toSec(), &result, &core_error);
    } else {
      integrated = processor_->processPoints(points_, T_fixed_sensor, robot_position, stamp.toSec(),
                                             &result, &core_error);
    }
    if (result.landmark_filter_ran) {
      {
        std::lock_guard<std::mutex> stats_lock(stats_mutex_);
        landmark_kept_last_ = result.points_reprojected > 0
                                  ? static_cast<double>(result.points) / result.points_reprojected
                                  : 0.0;
        landmark_ms_last_ = result.timings.landmark_ms;
        landmarks_permanent_ = result.landmarks.permanent;
        if (result.points == 0) ++landmark_frames_empty_;
      }
      if (landmarks_pub_.getNumSubscribers() > 0) {
        processor_->landmarkFilter().permanentLandmarks(&landmark_points_);
        auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
        std_msgs::Header h;
        h.stamp = stamp;
        h.frame_id = ros_config_.fixed_frame;
        pointsToCloud(landmark_points_, h, cloud.get());
        landmarks_pub_.publish(cloud);
      }
    }
    std_msgs::Header header;
    header.stamp = stamp;
    header.frame_id = ros_config_.fixed_frame;
    const bool stationary = !integrated && result.mapper.status == FrameStatus::kStationary;
    if (integrated) {
      robot_position_ = robot_position;
      publishOutputs(header, robot_position);
    } else if (stationary) {
      // 000 Sec. IV skips the frame, but the camera saw what the map holds: the map is vouched
      // for at this stamp (and may have aged). Consumers that check its age (the safety gate)
      // keep working while the chair stands still. With live obstacle cues the processor has
      // recomputed it with them (StereoFrameResult::map_refreshed).
      publishMap(header, true);
    }
    {
      std::lock_guard<std::mutex> cue_lock(cue_mutex_);
      if (integrated || result.map_refreshed) cue_stats_ = processor_->lastCueStats();
      cues_live_ = processor_->cueCount();
    }
    std::lock_guard<std::mutex> stats_lock(stats_mutex_);
    cells_aged_ = processor_->mapper().cellsAged();
    cells_under_overhangs_ = processor_->mapper().cellsUnderOverhangs();
    cells_unseen_overhang_ = processor_->mapper().cellsUnderUnseenOverhangs();
    cells_unseen_floor_ = processor_->mapper().cellsUnseenFloor();
  }
  // The landmark filter confirmed no point yet: nothing for the grid, nothing refused.
  if (result.landmark_filter_ran && result.points == 0) return;

  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  const FrameStatus status = integrated ? FrameStatus::kIntegrated : result.mapper.status;
  if (integrated || status == FrameStatus::kStationary) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    last_used_ = ros::WallTime::now();
    if (!integrated) {
      ++frames_stationary_;
    } else {
      counts_.countProcessed(ms);
    }
    tf_wait_ms_sum_ += frame.tf_wait_ms;
    ++tf_wait_count_;
    ROS_DEBUG_STREAM_NAMED(
        "frames", name_ << ": frame " << stamp << " " << toString(status) << " in " << ms << " ms");
    return;
  }
  if (status == FrameStatus::kEmptyInput) {  // nothing within [min_range, max_range]
    std::ostringstream os;
    os << "dropped a frame without a point within [min_range, max_range] (" << non_finite
       << " NaN / inf of " << values << ")";
    books_.reject(non_finite > 0 ? "non-finite input" : "no valid data", os.str());
    return;
  }
  books_.reject("refused by the core", "frame " + core_error);
}

bool SafetyMapRos::frozen(const Frame& frame) {
  if (!ros_config_.reject_frozen_input) return false;
  const std::vector<std::uint8_t>& data =
      frame.disparity ? frame.disparity->image.data : frame.cloud->data;
  const std::uint32_t width = frame.disparity ? frame.disparity->image.width : frame.cloud->width;
  const std::uint32_t height =
      frame.disparity ? frame.disparity->image.height : frame.cloud->height;
  // A real camera's noise never repeats a frame byte for byte; a frozen driver re-sends its last
  // buffer with new stamps. Integrated with new poses, it would paint the old view where the
  // robot is now (and clear free space through whatever is really there).
  const bool same = !previous_input_stamp_.isZero() &&
                    frame.header.stamp != previous_input_stamp_ && width == previous_input_width_ &&
                    height == previous_input_height_ && data.size() == previous_input_.size() &&
                    std::memcmp(data.data(), previous_input_.data(), data.size()) == 0;
  previous_input_.assign(data.begin(), data.end());
  previous_input_stamp_ = frame.header.stamp;
  previous_input_width_ = width;
  previous_input_height_ = height;
  if (!same) return false;
  books_.reject("frozen input",
                std::string("dropped a frame whose ") + (frame.disparity ? "disparity" : "cloud") +
                    " is byte for byte the previous frame's under a new stamp: camera or "
                    "driver frozen? (a noiseless simulator: set reject_frozen_input "
                    "false)");
  return true;
}

void SafetyMapRos::ageTimerCb() {
  const ros::Time now = ros::Time::now();
  if (!processor_ || now.isZero()) return;  // sim time without a clock yet: no time passes
  std::lock_guard<std::mutex> lock(core_mutex_);
  SafetyMapper& mapper = processor_->mapper();
  if (mapper.safetyMap().width <= 0 || map_stamp_.isZero()) return;
  std_msgs::Header header;
  header.stamp = map_stamp_;  // the map's age stays visible: never `now`
  header.frame_id = ros_config_.fixed_frame;
  // No frame integrated for stale_input_timeout (ROS clock, the consumers' clock): the published
  // grid says so. A clock that went back (a bag restarted) is not staleness.
  const double silent = (now - map_vouched_at_).toSec();
  if (!map_stale_ && now >= map_vouched_at_ && silent > ros_config_.stale_input_timeout) {
    map_stale_ = true;
    ++stale_maps_;
    problems_.note("no frame integrated for stale_input_timeout: safety_map published all Unknown");
    ROS_WARN_STREAM(name_ << ": no frame integrated for " << silent << " s (stale_input_timeout "
                          << ros_config_.stale_input_timeout
                          << " s): publishing safety_map as all Unknown at the last frame's stamp "
                          << map_stamp_);
    // The grid only, unless aging changed the map: the labels keep their content and stamp (their
    // consumers, the gate and the hybrid map, check its age themselves).
    if (mapper.ageSafetyMap(now.toSec()) > 0) {
      publishMap(header, false);
    } else {
      publishGrid(header);
    }
  } else if (mapper.ageSafetyMap(now.toSec()) > 0) {
    // Frames age the map at their stamps; this ages it while they do not come.
    publishMap(header, false);
  } else {
    return;
  }
  std::lock_guard<std::mutex> stats_lock(stats_mutex_);
  cells_aged_ = mapper.cellsAged();
}

void SafetyMapRos::publishMap(const std_msgs::Header& header, bool from_frame) {
  const SafetyMapper& mapper = processor_->mapper();
  const SafetyMap& map = mapper.safetyMap();
  map_stamp_ = header.stamp;
  if (from_frame) {
    map_vouched_at_ = ros::Time::now();
    if (map_stale_) {
      ROS_INFO_STREAM(name_ << ": frames are integrated again; safety_map is live");
    }
    map_stale_ = false;
  }
  publishGrid(header);
  auto labels = boost::make_shared<SafetyMapMsg>();
  toSafetyMapMsg(map, robot_position_, header, labels.get());
  labels_pub_.publish(labels);
}

void SafetyMapRos::publishGrid(const std_msgs::Header& header) {
  const SafetyMapper& mapper = processor_->mapper();
  const SafetyMap& map = mapper.safetyMap();
  auto grid = boost::make_shared<nav_msgs::OccupancyGrid>();
  toOccupancyGrid(map, mapper.config().labelling, ros_config_.costs, header, grid.get());
  if (map_stale_) {
    // A documented equivalent of "no information": every cell Unknown (-1), the stamp the last
    // frame's. costmap_2d's static layer reads the grid without looking at its stamp.
    std::fill(grid->data.begin(), grid->data.end(), static_cast<std::int8_t>(CostTable::kUnknown));
  } else if (obstacles_pub_.getNumSubscribers() > 0) {
    // The lethal cells, for a costmap's obstacle layer (marking, and clearing by ray tracing from
    // its sensor_frame): at the robot's base height + obstacles_cloud_height.
    lethalCellPoints(map, grid->data,
                     robot_position_.z() + static_cast<float>(ros_config_.obstacles_cloud_height),
                     &obstacle_points_);
    auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
    pointsToCloud(obstacle_points_, header, cloud.get());
    obstacles_pub_.publish(cloud);
  }
  map_pub_.publish(grid);
}

void SafetyMapRos::publishOutputs(const std_msgs::Header& header,
                                  const Eigen::Vector3f& robot_position) {
  robot_position_ = robot_position;
  publishMap(header, true);

  if (markers_pub_.getNumSubscribers() > 0) {
    auto markers = boost::make_shared<visualization_msgs::MarkerArray>();
    toMarkerArray(processor_->mapper(), header, markers.get());
    markers_pub_.publish(markers);
  }
  if (points_pub_.getNumSubscribers() > 0) {
    auto cloud = boost::make_shared<sensor_msgs::PointCloud2>();
    occupiedPointsToCloud(processor_->mapper().grid(), header, cloud.get());
    points_pub_.publish(cloud);
  }
  auto timings = boost::make_shared<StageTimingsMsg>();
  toStageTimingsMsg(processor_->mapper().lastTimings(), header, timings.get());
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    timings->frames_received = counts_.received;
    timings->frames_processed = counts_.processed + 1;  // this one
    timings->frames_skipped_stationary = frames_stationary_;
    timings->frames_dropped = counts_.dropped;
    timings->frames_rejected = counts_.rejected + counts_.tf_failures;
  }
  timings_pub_.publish(timings);
}

bool SafetyMapRos::resetSrv(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  if (!processor_) return false;
  std::lock_guard<std::mutex> lock(core_mutex_);
  processor_->reset();
  map_stamp_ = ros::Time();
  map_stale_ = false;
  {
    std::lock_guard<std::mutex> stats_lock(stats_mutex_);
    ++map_resets_;
    cells_aged_ = 0;
    cells_under_overhangs_ = 0;
    cells_unseen_overhang_ = 0;
    cells_unseen_floor_ = 0;
  }
  ROS_INFO_STREAM(name_ << ": map reset on request");
  return true;
}

bool SafetyMapRos::saveSrv(SaveMap::Request& req, SaveMap::Response& res) {
  if (!processor_) {
    res.success = false;
    res.message = "not running: " + config_error_;
    return true;
  }
  const std::string requested = req.path_prefix.empty() ? ros_config_.save_prefix : req.path_prefix;
  std::string prefix;
  std::string err = prepareSavePrefix(ros_config_.save_directory, requested, &prefix);
  if (!err.empty()) {
    res.success = false;
    res.message = err;
    problems_.report("save refused", "~save: " + err);
    return true;
  }

  // The files' bytes are made from one state of the map under core_mutex_ (safety_map_export.h);
  // they are written after it is released, so that the worker does not wait for the disk.
  std::vector<SaveFile> files;
  {
    std::lock_guard<std::mutex> lock(core_mutex_);
    err = makeSaveFiles(processor_->mapper(), ros_config_.costs, ros_config_.fixed_frame, prefix,
                        &files);
  }
  if (err.empty()) {
    std::lock_guard<std::mutex> save_lock(save_mutex_);
    err = writeFilesAtomically(&files);
  }
  if (!err.empty()) {
    res.success = false;
    res.message = err;
    return true;
  }
  for (const SaveFile& f : files)
    res.files.push_back(f.path);
  res.success = true;
  res.message = "saved " + std::to_string(res.files.size()) + " files";
  ROS_INFO_STREAM(name_ << ": " << res.message << " with prefix " << prefix);
  return true;
}

void SafetyMapRos::reconfigureCb(SafetyMapConfig& config, uint32_t /*level*/) {
  if (!processor_) return;
  // The live fields of the two lists (core/config_fields.h, ros/safety_map_params.h), by name.
  SafetyMapperConfig c = mapper_config_;
  SafetyMapRosConfig r = ros_config_;
  std::string err = fromReconfigure(config, safetyMapperFields(), &c);
  if (err.empty()) err = fromReconfigure(config, safetyMapRosFields(), &r);
  if (err.empty()) err = c.validate();
  if (err.empty()) err = r.validate();
  if (!err.empty()) {
    ROS_ERROR_STREAM(name_ << ": reconfiguration refused, keeping the previous values: " << err);
    // Hand the current values back to the server (and so to rqt_reconfigure).
    toReconfigure(mapper_config_, safetyMapperFields(), &config);
    toReconfigure(ros_config_, safetyMapRosFields(), &config);
    return;
  }
  ros_config_.max_rate = r.max_rate;
  max_rate_ = r.max_rate;

  uint32_t changed = 0;
  changedFields(safetyMapperFields(), mapper_config_, c, &changed);
  const bool grid_changed = (changed & SafetyMapLevel::kGrid) != 0;
  const bool stage_changed = (changed & SafetyMapLevel::kStage) != 0;
  if (!grid_changed && !stage_changed) return;

  // In place, under the core's lock: the worker finishes its frame first, and the next frame
  // (or map) sees the whole new configuration. The stages keep no state between frames, so a
  // stage change keeps the 3D model and the observation times; the grid's sensor model cannot
  // be changed in place, so a grid change starts a new map.
  std::lock_guard<std::mutex> lock(core_mutex_);
  bool grid_reset = false;
  const std::string refused = processor_->reconfigureMapper(c, &grid_reset);
  if (!refused.empty()) {  // validated above: does not happen
    ROS_ERROR_STREAM(name_ << ": reconfiguration refused: " << refused);
    return;
  }
  mapper_config_ = c;
  max_cell_age_ = c.max_cell_age;
  if (grid_reset) {
    ROS_WARN_STREAM(name_ << ": voxel grid sensor model changed (incr_high " << c.grid.incr_high
                          << ", incr_low " << c.grid.incr_low << ", decr " << c.grid.decr
                          << ", occ_threshold " << c.grid.occ_threshold
                          << "): the map starts again");
    std::lock_guard<std::mutex> stats_lock(stats_mutex_);
    ++map_resets_;
    cells_aged_ = 0;
    cells_under_overhangs_ = 0;
    cells_unseen_overhang_ = 0;
    cells_unseen_floor_ = 0;
  } else {
    if (processor_->mapper().safetyMap().width > 0) {
      processor_->recompute(robot_position_, last_stamp_.toSec());
    }
    ROS_INFO_STREAM(name_ << ": reconfigured; the 3D model is kept");
    std::lock_guard<std::mutex> stats_lock(stats_mutex_);
    cells_aged_ = processor_->mapper().cellsAged();
  }
}

void SafetyMapRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  using diagnostic_msgs::DiagnosticStatus;
  std::lock_guard<std::mutex> lock(stats_mutex_);
  const ros::WallTime now = ros::WallTime::now();
  const double window = counts_.window(now);
  stat.add("input", ros_config_.input);
  stat.add("fixed frame", ros_config_.fixed_frame);
  counts_.addTo(stat, window, "frames dropped (processing slower than input)", true);
  stat.add("frames skipped (stationary)", frames_stationary_);
  stat.add("map resets", map_resets_);
  stat.addf("max cell age [s]", "%.1f", max_cell_age_.load());
  stat.add("cells aged to Unknown (current map)", cells_aged_);
  stat.add("floor under an overhang's front edge made Non-ground, last map (overhang_roof)",
           cells_under_overhangs_);
  stat.add("floor under a layer stereo did not see, made unsafe, last map (unseen_overhang)",
           cells_unseen_overhang_);
  stat.add("floor nothing was seen above, made Unknown, last map (unseen_floor_band)",
           cells_unseen_floor_);
  stat.add("published safety_map", map_stale_ ? "stale: all Unknown (no frame integrated for "
                                                "stale_input_timeout)"
                                              : "live");
  stat.add("times the map went stale", stale_maps_.load());
  const double since_input =
      counts_.last_received.isZero() ? -1.0 : (now - counts_.last_received).toSec();
  const double since_used = (now - (last_used_.isZero() ? started_ : last_used_)).toSec();
  stat.addf("last input [s ago]", "%.1f", since_input);
  stat.addf("last frame used [s ago]", "%.1f", last_used_.isZero() ? -1.0 : since_used);
  stat.addf("processing time, last [ms]", "%.1f", counts_.processing_ms_last);
  stat.addf("processing time, mean [ms]", "%.1f", counts_.meanProcessingMs());
  stat.addf("tf wait, mean [ms]", "%.1f",
            tf_wait_count_ > 0 ? tf_wait_ms_sum_ / tf_wait_count_ : 0.0);
  stat.add("landmark filter (001 Sec. 4.2)", landmark_config_.enabled ? "on" : "off");
  if (landmark_config_.enabled) {
    stat.addf("landmark filter: points kept, last frame [%]", "%.1f", 100.0 * landmark_kept_last_);
    stat.add("landmark filter: permanent landmarks", landmarks_permanent_);
    stat.add("landmark filter: frames without a confirmed point", landmark_frames_empty_);
    stat.addf("landmark filter: time, last [ms]", "%.1f", landmark_ms_last_);
  }
  diagnoseObstacleCue(stat);
  problems_.addTo(stat);
  const std::string last_problem = problems_.last();
  const double stale = ros_config_.stale_input_timeout;
  if (counts_.received > 0 && since_input > stale) {
    stat.summaryf(DiagnosticStatus::WARN,
                  "no input for %.1f s: the map is not updated (cells not re-observed for "
                  "max_cell_age fall back to Unknown)%s%s",
                  since_input,
                  last_problem.empty() ? "" : "; last problem: ", last_problem.c_str());
  } else if (counts_.received > 0 && since_used > stale) {
    stat.summaryf(DiagnosticStatus::WARN,
                  "input arrives but no frame was used for %.1f s: the map is not updated%s%s",
                  since_used, last_problem.empty() ? "" : "; last problem: ", last_problem.c_str());
  } else {
    counts_.summarize(stat, problems_, now, window,
                      "processing is slower than the input or max_rate", "waiting for input",
                      "map up to date");
  }
  counts_.nextWindow(now, window);
}

// ---------------------------------------------------------------------------------------------
// Obstacle cue: ObstacleDetectionNodelet's obstacle points (paper 003, one frame) mark their cells
// Non-ground in the next map, before the voxel grid has confirmed them (core/obstacle_cue.h).

void SafetyMapRos::setUpObstacleCue() {
  if (!cue_config_.enabled) return;
  obstacle_cue_sub_ = nh_.subscribe<sensor_msgs::PointCloud2>("obstacles", ros_config_.queue_size,
                                                              &SafetyMapRos::obstacleCueCb, this);
}

void SafetyMapRos::obstacleCueCb(const sensor_msgs::PointCloud2ConstPtr& cloud) {
  std::vector<Eigen::Vector3f> points;  // callbacks may run concurrently: a local buffer
  CloudStats stats;
  // An empty cloud is a frame without obstacles: a valid (empty) cue.
  if (static_cast<std::size_t>(cloud->width) * cloud->height > 0) {
    const std::string err = pointCloud2ToPoints(*cloud, &points, &stats);
    if (!err.empty()) {
      obstacleCueProblem("ignored an obstacle cue: " + err);
      return;
    }
  }
  if (cloud->header.frame_id != ros_config_.fixed_frame && !points.empty()) {
    try {
      const Eigen::Isometry3f T =
          tf2::transformToEigen(input_->tfBuffer().lookupTransform(
                                    ros_config_.fixed_frame, cloud->header.frame_id,
                                    cloud->header.stamp, ros::Duration(ros_config_.tf_timeout)))
              .cast<float>();
      for (Eigen::Vector3f& p : points)
        p = T * p;
    } catch (const tf2::TransformException& e) {
      obstacleCueProblem(std::string("ignored an obstacle cue: no tf to the fixed frame: ") +
                         e.what());
      return;
    }
  }
  const double stamp = cloud->header.stamp.toSec();
  if (!std::isfinite(stamp)) {
    obstacleCueProblem("ignored an obstacle cue with a non-finite stamp");
    return;
  }
  std::lock_guard<std::mutex> lock(cue_mutex_);
  // The processor keeps at most max_cues cues; more waiting here would be dropped there anyway.
  while (pending_cues_.size() >= static_cast<std::size_t>(cue_config_.cue.max_cues)) {
    pending_cues_.pop_front();
  }
  pending_cues_.push_back(PendingCue{stamp, std::move(points)});
  ++cues_received_;
}

void SafetyMapRos::takePendingCues() {
  std::deque<PendingCue> cues;
  {
    std::lock_guard<std::mutex> lock(cue_mutex_);
    cues.swap(pending_cues_);
  }
  for (const PendingCue& c : cues)
    processor_->addObstacleCue(c.stamp, c.points);
}

void SafetyMapRos::obstacleCueProblem(const std::string& detail) {
  {
    std::lock_guard<std::mutex> lock(cue_mutex_);
    ++cues_refused_;
  }
  problems_.report("obstacle cue", detail);
}

void SafetyMapRos::diagnoseObstacleCue(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(cue_mutex_);
  if (!cue_config_.enabled) {
    stat.add("obstacle cue", "off");
    return;
  }
  stat.add("obstacle cue", "on");
  stat.add("obstacle cues received", cues_received_);
  stat.add("obstacle cues refused", cues_refused_);
  stat.add("obstacle cues live, last map", cue_stats_.live_cues);
  stat.add("obstacle cues held", cues_live_);
  stat.add("cells marked by the obstacle cue, last map", cue_stats_.cells_marked);
  stat.add("cells made Non-ground by the cue, last map", cue_stats_.cells_changed);
}

}  // namespace stereo_safety_map
