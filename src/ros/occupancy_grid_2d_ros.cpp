#include "stereo_safety_map/ros/occupancy_grid_2d_ros.h"

#include "stereo_safety_map/ros/conversions.h"
#include "stereo_safety_map/ros/occupancy_grid_2d_conversions.h"
#include "stereo_safety_map/ros/param_reader.h"

#include <algorithm>
#include <sstream>

namespace stereo_safety_map {

namespace {}  // namespace

OccupancyGrid2DRos::OccupancyGrid2DRos(ros::NodeHandle nh, ros::NodeHandle pnh)
    : FrameNodeletShell(nh, pnh) {
  startDiagnostics(
      "stereo camera", "occupancy grid 2d",
      [this](diagnostic_updater::DiagnosticStatusWrapper& stat) { diagnose(stat); },
      NodeletDiagnostics::Clock::kRos);

  std::string err = fromRosParam(pnh_, &ros_config_);
  if (err.empty()) err = fromRosParam(pnh_, &grid_config_);
  if (!acceptParams(err, occupancyGrid2DParameterNames())) return;
  grid_ = std::make_unique<OccupancyGrid2D>(grid_config_);  // validated above: does not throw

  grid_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("occupancy_2d", 1, true);
  reset_srv_ = pnh_.advertiseService("reset", &OccupancyGrid2DRos::resetSrv, this);
  startWorker([this](const Frame& frame) { processFrame(frame); },
              [this] { return ros_config_.max_rate; });
  setUpInputs();
  ROS_INFO_STREAM(name_ << ": 2D occupancy grid (002) in '" << ros_config_.fixed_frame
                        << "', height band " << grid_config_.floor_clearance << " .. "
                        << grid_config_.robot_height << " m above '" << ros_config_.base_frame
                        << "', K = " << grid_config_.k);
}

OccupancyGrid2DRos::~OccupancyGrid2DRos() {
  // Inputs first, so that no callback enqueues while the worker stops: the subscriptions end
  // (each waits for its callback in progress), then the filters (stereo_input.h: shutdown()).
  if (input_) input_->shutdown();  // none when the parameters were refused
  stopWorker();
  diagnostics_->stop();
}

void OccupancyGrid2DRos::setUpInputs() {
  auto options = StereoInput::Options::of(ros_config_);
  input_ = std::make_unique<StereoInput>(nh_, options, books_, [this](StereoFrame&& in) {
    putFrame(std::make_unique<Frame>(std::move(in)));
  });
}

void OccupancyGrid2DRos::processFrame(const Frame& frame) {
  const Clock::time_point t0 = Clock::now();
  const ros::Time stamp = frame.header.stamp;

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
      books_.reject("out of order", os.str());
      return;
    }
  }

  // Camera pose (the tf2 MessageFilter waited for it) and the robot's base: its z is the floor
  // the height band is measured from (002 Sec. 3.3), its xy the window's centre.
  FramePose pose;
  if (!input_->lookUp(frame.header, "", ros_config_.base_frame, ros_config_.tf_timeout, &pose)) {
    return;
  }
  const Eigen::Isometry3f& T_fixed_camera = pose.T_fixed_sensor;
  const Eigen::Vector3f& base = pose.base;

  DisparityImageStats stats;
  if (!input_->toCore(frame, &camera_, &disparity_, &stats)) return;
  if (StereoInput::noValidPixel(stats) || cv::countNonZero(disparity_ > 0.0f) == 0) {
    input_->rejectWithoutValidPixel(stats);
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
    books_.reject("refused by the core",
                  std::string("dropped a frame: ") + toString(result.status));
    return;
  }
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  counts_.countProcessed(ms);
  last_update_ = result;
}

bool OccupancyGrid2DRos::resetSrv(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
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

void OccupancyGrid2DRos::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
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
