#include "stereo_safety_map/core/stereo_frame_processor.h"

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

const StereoFrameProcessorConfig& checked(const StereoFrameProcessorConfig& c) {
  const std::string err = c.validate();
  if (!err.empty()) throw std::invalid_argument("StereoFrameProcessorConfig: " + err);
  return c;
}

void setError(std::string* error, const std::string& message) {
  if (error != nullptr) *error = message;
}

}  // namespace

std::string StereoFrameProcessorConfig::validate() const {
  std::string err = input_check.validate();
  if (!err.empty()) return "input_check." + err;
  err = disparity.validate();
  if (!err.empty()) return "disparity." + err;
  err = mapper.validate();
  if (!err.empty()) return "mapper." + err;
  err = landmark_filter.forMapper(mapper).validate();
  if (!err.empty()) return "landmark_filter." + err;
  err = cue.validate();
  if (!err.empty()) return "cue." + err;
  err = row_gap_fill.validate();
  if (!err.empty()) return err;
  if (disparity_step < 1 || disparity_step > 16) {
    std::ostringstream os;
    os << "disparity_step = " << disparity_step << " must be in [1, 16]";
    return os.str();
  }
  return "";
}

SafetyMapperConfig singleFrameMapperConfig(const SafetyMapperConfig& base, double seed_radius) {
  SafetyMapperConfig c = base;
  c.grid.occ_threshold = c.grid.incr_high;  // one hit
  c.grid.decr = 0;
  c.segmentation.seed_radius = seed_radius;
  c.skip_stationary_frames = false;
  return c;
}

StereoFrameProcessor::StereoFrameProcessor(const StereoFrameProcessorConfig& config)
    : config_(checked(config)),
      pipeline_(config_.disparity),
      input_check_(config_.input_check),
      mapper_(config_.mapper),
      landmarks_(config_.landmark_filter.forMapper(config_.mapper)) {
  if (config_.obstacle_cue) cue_ = std::make_unique<ObstacleCueFusion>(config_.cue);
}

const cv::Mat& StereoFrameProcessor::gapFilled(const cv::Mat& disparity,
                                               const StereoCameraModel& camera,
                                               StereoFrameResult* r) {
  if (!config_.row_gap_fill.enabled) return disparity;
  disparity.copyTo(filled_);  // reuses filled_'s buffer when the size is the same
  r->gap_filled = fillRowGaps(config_.row_gap_fill, camera, &filled_, &fill_above_);
  return filled_;
}

void StereoFrameProcessor::reset() {
  mapper_.reset();
  input_check_.reset();
  landmarks_.reset();
  if (cue_) cue_->clear();
  cue_marked_.clear();
  cue_stats_ = ObstacleCueStats();
}

std::string StereoFrameProcessor::reconfigureMapper(const SafetyMapperConfig& config,
                                                    bool* grid_reset) {
  bool new_grid = false;
  const std::string err = mapper_.reconfigure(config, &new_grid);
  if (grid_reset != nullptr) *grid_reset = new_grid;
  if (!err.empty()) return err;
  config_.mapper = config;
  if (new_grid) {
    landmarks_.reset();
    if (cue_) cue_->clear();
    cue_marked_.clear();
  }
  return "";
}

bool StereoFrameProcessor::addObstacleCue(double stamp,
                                          const std::vector<Eigen::Vector3f>& points_fixed) {
  return cue_ && cue_->addCue(stamp, points_fixed);
}

bool StereoFrameProcessor::processImages(const cv::Mat& left, const cv::Mat& right,
                                         const StereoCameraModel& camera,
                                         const Eigen::Isometry3f& T_fixed_sensor,
                                         const Eigen::Vector3f& robot_base_position, double stamp,
                                         StereoFrameResult* result, std::string* error) {
  StereoFrameResult local;
  StereoFrameResult& r = result != nullptr ? *result : local;
  r = StereoFrameResult();
  const Clock::time_point t0 = Clock::now();
  // disparity() is this frame's or empty, never a previous frame's.
  auto refuse = [this, error](const std::string& why) {
    disparity_.release();
    setError(error, why);
    return false;
  };
  const std::string cam_err = camera.validate();
  if (!cam_err.empty()) return refuse("bad camera model: " + cam_err);
  if (left.cols != camera.width || left.rows != camera.height) {
    std::ostringstream os;
    os << "image is " << left.cols << " x " << left.rows << ", camera model says " << camera.width
       << " x " << camera.height;
    return refuse(os.str());
  }
  std::string err;
  if (config_.check_input && left.type() == CV_8UC1 && right.type() == CV_8UC1) {
    // The disparity nodelet refuses a covered, black or frozen camera before matching.
    const StereoInputProblem problem = input_check_.check(left, right, &err);
    if (problem != StereoInputProblem::kNone) {
      return refuse(std::string(toString(problem)) + ": " + err);
    }
  }
  pipeline_.setFocalBaseline(camera.fx * camera.baseline);
  if (!pipeline_.compute(left, right, &disparity_, &r.disparity, &err)) {
    return refuse("disparity: " + err);
  }
  r.timings.disparity_ms = msSince(t0);
  const Clock::time_point t1 = Clock::now();
  // What the safety-map nodelet gets from the disparity nodelet's message: its values and its
  // camera model (f and T in float32), so that this path and the two nodelets agree bit for bit.
  const DisparityMessageGeometry g = disparityMessageGeometry(
      camera, pipeline_.config().min_disparity, pipeline_.config().num_disparities);
  // With coarse_free_space off the coarse fill's readings go into an image of their own
  // (coarseDisparity()), the full-resolution ones stay in disparity_. With it on (default) the
  // output stays merged, as the disparity nodelet publishes it, so that this path and the
  // nodelets' (disparity -> safety map) map the same points in the same order.
  const cv::Mat& mask = pipeline_.coarseMask();
  if (!config_.coarse_free_space && !mask.empty() && cv::countNonZero(mask) > 0) {
    coarse_disparity_.create(disparity_.size(), CV_32FC1);
    coarse_disparity_.setTo(0.0f);
    disparity_.copyTo(coarse_disparity_, mask);
    disparity_.setTo(0.0f, mask);
    throughDisparityMessage(g, &coarse_disparity_);
  } else {
    coarse_disparity_.release();
  }
  throughDisparityMessage(g, &disparity_);
  disparity_camera_ = messageCameraModel(g, camera);
  reproject(disparity_, coarse_disparity_, disparity_camera_, &r);
  r.timings.reproject_ms = msSince(t1);
  const bool ok =
      integrate(&disparity_camera_, T_fixed_sensor, robot_base_position, stamp, &r, error);
  r.timings.total_ms = msSince(t0);
  return ok;
}

bool StereoFrameProcessor::processDisparity(const cv::Mat& disparity,
                                            const StereoCameraModel& camera,
                                            const Eigen::Isometry3f& T_fixed_sensor,
                                            const Eigen::Vector3f& robot_base_position,
                                            double stamp, StereoFrameResult* result,
                                            std::string* error, const cv::Mat& coarse) {
  StereoFrameResult local;
  StereoFrameResult& r = result != nullptr ? *result : local;
  r = StereoFrameResult();
  const Clock::time_point t0 = Clock::now();
  const std::string cam_err = camera.validate();
  if (!cam_err.empty()) {
    setError(error, "bad camera model: " + cam_err);
    return false;
  }
  if (disparity.empty() || disparity.type() != CV_32FC1 || disparity.cols != camera.width ||
      disparity.rows != camera.height) {
    setError(error, "disparity must be CV_32FC1 of the camera model's size");
    return false;
  }
  if (!coarse.empty() && (coarse.type() != CV_32FC1 || coarse.size() != disparity.size())) {
    setError(error, "coarse disparity must be CV_32FC1 of the disparity's size");
    return false;
  }
  if (disparity.data != disparity_.data) disparity_.release();
  if (coarse.data != coarse_disparity_.data) coarse_disparity_.release();
  reproject(disparity, coarse, camera, &r);
  r.timings.reproject_ms = msSince(t0);
  const bool ok = integrate(&camera, T_fixed_sensor, robot_base_position, stamp, &r, error);
  r.timings.total_ms = msSince(t0);
  return ok;
}

bool StereoFrameProcessor::processPoints(const std::vector<Eigen::Vector3f>& points_sensor,
                                         const Eigen::Isometry3f& T_fixed_sensor,
                                         const Eigen::Vector3f& robot_base_position, double stamp,
                                         StereoFrameResult* result, std::string* error) {
  StereoFrameResult local;
  StereoFrameResult& r = result != nullptr ? *result : local;
  r = StereoFrameResult();
  const Clock::time_point t0 = Clock::now();
  disparity_.release();
  coarse_disparity_.release();
  first_no_carve_ = VoxelGrid::kAllCarve;
  points_ = points_sensor;  // reused buffer: no allocation once it has grown
  const bool ok = integrate(nullptr, T_fixed_sensor, robot_base_position, stamp, &r, error);
  r.timings.total_ms = msSince(t0);
  return ok;
}

void StereoFrameProcessor::reproject(const cv::Mat& disparity, const cv::Mat& coarse,
                                     const StereoCameraModel& camera, StereoFrameResult* r) {
  // The grid's depth range (000 Sec. IV ignores points outside it anyway).
  const double lo = mapper_.config().grid.min_range, hi = mapper_.config().grid.max_range;
  reprojectDisparity(gapFilled(disparity, camera, r), camera, lo, hi, config_.disparity_step,
                     &points_);
  first_no_carve_ = VoxelGrid::kAllCarve;
  if (coarse.empty()) return;
  // The coarse fill's points after the others: they lose every voxel the others share with
  // them (000 Sec. IV: one point per voxel and frame, the first), and carve nothing when
  // coarse_free_space is off.
  reprojectDisparity(coarse, camera, lo, hi, config_.disparity_step, &coarse_points_);
  if (!config_.coarse_free_space) first_no_carve_ = points_.size();
  points_.insert(points_.end(), coarse_points_.begin(), coarse_points_.end());
}

bool StereoFrameProcessor::integrate(const StereoCameraModel* camera,
                                     const Eigen::Isometry3f& T_fixed_sensor,
                                     const Eigen::Vector3f& robot_base_position, double stamp,
                                     StereoFrameResult* r, std::string* error) {
  r->points_reprojected = points_.size();
  // 001 Sec. 4.2 in front of the grid, on the frames the grid integrates (the filter needs
  // motion: a stationary camera repeats its mismatches).
  if (camera != nullptr && config_.landmark_filter.enabled && !points_.empty() &&
      !mapper_.isStationary(T_fixed_sensor)) {
    std::string err;
    const LandmarkStreamStatus st =
        landmarks_.apply(*camera, T_fixed_sensor, stamp, &points_, &err);
    if (st == LandmarkStreamStatus::kRejected) {
      setError(error, "landmark filter: " + err);
      return false;
    }
    if (st == LandmarkStreamStatus::kStationary) {  // not moved since the filter's last frame
      r->mapper.status = FrameStatus::kStationary;
      refreshAtRest(robot_base_position, stamp, r);
      setError(error, toString(FrameStatus::kStationary));
      return false;
    }
    r->landmark_filter_ran = true;
    r->landmarks = landmarks_.stats();
    r->timings.landmark_ms = landmarks_.lastMs();
    r->timings.landmark_cpu_ms = landmarks_.lastCpuMs();
  }
  r->points = points_.size();
  // VoxelGridConfig::neighbour_sigmas: the range error of these points (001 Sec. 4.1).
  if (camera != nullptr) mapper_.setStereoGeometry(camera->fx * camera->baseline);
  // The landmark filter removes points: the coarse ones' index is lost, all carve.
  const std::size_t no_carve = r->landmark_filter_ran ? VoxelGrid::kAllCarve : first_no_carve_;
  const bool ok = mapper_.integrateFrame(points_, T_fixed_sensor, robot_base_position, stamp,
                                         &r->mapper, no_carve);
  r->timings.mapper = r->mapper.timings;
  if (!ok) {
    if (r->mapper.status == FrameStatus::kStationary) refreshAtRest(robot_base_position, stamp, r);
    setError(error, toString(r->mapper.status));
    return false;
  }
  applyCue(robot_base_position, stamp, r);
  return true;
}

void StereoFrameProcessor::applyCue(const Eigen::Vector3f& robot_base_position, double stamp,
                                    StereoFrameResult* r) {
  // Paper 003's cue on the new map, right after 000's labelling (obstacle_cue.h). Points above
  // the robot's top are overhangs it passes under (000 Sec. V-A).
  cue_marked_.clear();
  cue_stats_ = ObstacleCueStats();
  if (!cue_ || !std::isfinite(stamp) || !robot_base_position.allFinite()) return;
  const float max_z =
      robot_base_position.z() + static_cast<float>(mapper_.config().height_map.robot_height);
  cue_stats_ = cue_->apply(stamp, max_z, &mapper_.mutableSafetyMap(), &cue_marked_);
  if (r != nullptr) {
    r->cue = cue_stats_;
    r->cue_applied = true;
  }
}

void StereoFrameProcessor::refreshAtRest(const Eigen::Vector3f& robot_base_position, double stamp,
                                         StereoFrameResult* r) {
  if (!cue_ || !std::isfinite(stamp) || !robot_base_position.allFinite()) return;
  if (mapper_.safetyMap().width <= 0) return;                     // no map yet
  if (cue_->size() == 0 && cue_stats_.cells_marked == 0) return;  // nothing would change
  // 000 Sec. IV skips the frame for the grid; the cues are single-frame evidence (003) and
  // belong to the map of this stamp. The grid is unchanged, so the map is 000's of the last
  // integrated frame for the robot where it stands, plus the cues live now.
  mapper_.computeSafetyMap(robot_base_position);
  applyCue(robot_base_position, stamp, r);
  r->map_refreshed = true;
}

const SafetyMap& StereoFrameProcessor::recompute(const Eigen::Vector3f& robot_base_position,
                                                 double stamp) {
  mapper_.computeSafetyMap(robot_base_position);
  applyCue(robot_base_position, stamp, nullptr);
  return mapper_.safetyMap();
}

}  // namespace stereo_safety_map
