#include "stereo_safety_map/core/stereo_frame_processor.h"

#include <chrono>
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
  std::string err = disparity.validate();
  if (!err.empty()) return "disparity." + err;
  err = mapper.validate();
  if (!err.empty()) return "mapper." + err;
  err = landmark_filter.forMapper(mapper).validate();
  if (!err.empty()) return "landmark_filter." + err;
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
      mapper_(config_.mapper),
      landmarks_(config_.landmark_filter.forMapper(config_.mapper)) {}

bool StereoFrameProcessor::processImages(const cv::Mat& left, const cv::Mat& right,
                                         const StereoCameraModel& camera,
                                         const Eigen::Isometry3f& T_fixed_sensor,
                                         const Eigen::Vector3f& robot_base_position,
                                         StereoFrameResult* result, std::string* error,
                                         double stamp) {
  StereoFrameResult local;
  StereoFrameResult& r = result != nullptr ? *result : local;
  r = StereoFrameResult();
  const Clock::time_point t0 = Clock::now();
  const std::string cam_err = camera.validate();
  if (!cam_err.empty()) {
    setError(error, "bad camera model: " + cam_err);
    return false;
  }
  if (left.cols != camera.width || left.rows != camera.height) {
    std::ostringstream os;
    os << "image is " << left.cols << " x " << left.rows << ", camera model says " << camera.width
       << " x " << camera.height;
    setError(error, os.str());
    return false;
  }
  std::string err;
  if (!pipeline_.compute(left, right, &disparity_, &r.disparity, &err)) {
    setError(error, "disparity: " + err);
    return false;
  }
  r.timings.disparity_ms = msSince(t0);
  const bool ok =
      integrate(disparity_, camera, T_fixed_sensor, robot_base_position, stamp, &r, error);
  r.timings.total_ms = msSince(t0);
  return ok;
}

bool StereoFrameProcessor::processDisparity(const cv::Mat& disparity,
                                            const StereoCameraModel& camera,
                                            const Eigen::Isometry3f& T_fixed_sensor,
                                            const Eigen::Vector3f& robot_base_position,
                                            StereoFrameResult* result, std::string* error,
                                            double stamp) {
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
  disparity_.release();
  const bool ok =
      integrate(disparity, camera, T_fixed_sensor, robot_base_position, stamp, &r, error);
  r.timings.total_ms = msSince(t0);
  return ok;
}

bool StereoFrameProcessor::integrate(const cv::Mat& disparity, const StereoCameraModel& camera,
                                     const Eigen::Isometry3f& T_fixed_sensor,
                                     const Eigen::Vector3f& robot_base_position, double stamp,
                                     StereoFrameResult* r, std::string* error) {
  const Clock::time_point t0 = Clock::now();
  // Same reprojection range as the safety-map nodelet: the grid's [min_range, max_range].
  reprojectDisparity(disparity, camera, config_.mapper.grid.min_range,
                     config_.mapper.grid.max_range, config_.disparity_step, &points_);
  r->points_reprojected = points_.size();
  r->timings.reproject_ms = msSince(t0);
  // 001 Sec. 4.2 in front of the grid, on the frames the grid integrates (the filter needs
  // motion: a stationary camera repeats its mismatches).
  if (config_.landmark_filter.enabled && !points_.empty() &&
      !mapper_.isStationary(T_fixed_sensor)) {
    std::string err;
    const LandmarkStreamStatus st = landmarks_.apply(camera, T_fixed_sensor, stamp, &points_, &err);
    if (st == LandmarkStreamStatus::kRejected) {
      setError(error, err);
      return false;
    }
    if (st == LandmarkStreamStatus::kStationary) {  // not moved since the filter's last frame
      r->mapper.status = FrameStatus::kStationary;
      setError(error, toString(FrameStatus::kStationary));
      return false;
    }
    r->landmark_filter_ran = true;
    r->landmarks = landmarks_.stats();
    r->timings.landmark_ms = landmarks_.lastMs();
    r->timings.landmark_cpu_ms = landmarks_.lastCpuMs();
  }
  r->points = points_.size();
  const bool ok = mapper_.integrateFrame(points_, T_fixed_sensor, robot_base_position, &r->mapper);
  r->timings.mapper = r->mapper.timings;
  if (!ok) setError(error, toString(r->mapper.status));
  return ok;
}

}  // namespace stereo_safety_map
