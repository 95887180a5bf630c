#include "stereo_safety_map/core/safety_mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

constexpr double kDegToRad = 0.017453292519943295;

std::string prefixed(const char* name, const std::string& err) {
  return err.empty() ? err : std::string(name) + "." + err;
}

}  // namespace

const char* toString(FrameStatus s) {
  switch (s) {
    case FrameStatus::kIntegrated:
      return "integrated";
    case FrameStatus::kStationary:
      return "skipped: camera stationary since the last integrated frame";
    case FrameStatus::kEmptyInput:
      return "skipped: no points";
    case FrameStatus::kInvalidPose:
      return "skipped: sensor pose is not a finite rigid transform";
    case FrameStatus::kInvalidRobotPosition:
      return "skipped: robot base position is not finite";
    case FrameStatus::kCameraOutsideGrid:
      return "skipped: camera outside the voxel grid";
  }
  return "invalid status";
}

std::string SafetyMapperConfig::validate() const {
  std::string err;
  if (!(err = prefixed("grid", grid.validate())).empty()) return err;
  if (!(err = prefixed("height_map", height_map.validate())).empty()) return err;
  if (!(err = prefixed("segmentation", segmentation.validate())).empty()) return err;
  if (!(err = prefixed("plane_fit", plane_fit.validate())).empty()) return err;
  if (!(err = prefixed("labelling", labelling.validate())).empty()) return err;
  if (!std::isfinite(stationary_translation) || stationary_translation < 0.0 ||
      stationary_translation > 100.0) {
    return "stationary_translation must be in [0, 100] m";
  }
  if (!std::isfinite(stationary_rotation_deg) || stationary_rotation_deg < 0.0 ||
      stationary_rotation_deg > 180.0) {
    return "stationary_rotation_deg must be in [0, 180] deg";
  }
  const double max_look_ahead =
      0.5 * std::min(grid.size_x, grid.size_y) - segmentation.planning_radius;
  if (!std::isfinite(grid_look_ahead) || grid_look_ahead < 0.0 ||
      grid_look_ahead > max_look_ahead + 1e-9) {
    return "grid_look_ahead must be in [0, min(size_x, size_y) / 2 - planning_radius] = [0, " +
           std::to_string(std::max(0.0, max_look_ahead)) + "] m";
  }
  return "";
}

namespace {

const SafetyMapperConfig& checked(const SafetyMapperConfig& c) {
  const std::string err = c.validate();
  if (!err.empty()) throw std::invalid_argument("SafetyMapperConfig: " + err);
  return c;
}

bool isRigid(const Eigen::Isometry3f& T) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3f R = T.linear();
  return (R.transpose() * R - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff() < 1e-3f &&
         R.determinant() > 0.0f;
}

}  // namespace

SafetyMapper::SafetyMapper(const SafetyMapperConfig& config)
    : config_(checked(config)),
      grid_(config_.grid),
      height_map_(config_.height_map),
      segmentation_(config_.segmentation),
      plane_fitter_(config_.plane_fit),
      labelling_(config_.labelling) {}

void SafetyMapper::reset() {
  grid_.clear();
  map_ = SafetyMap();
  segments_ = GroundSegments();
  planes_.clear();
  timings_ = StageTimings();
  has_last_pose_ = false;
  grid_placed_ = false;
  frames_integrated_ = 0;
}

bool SafetyMapper::isStationary(const Eigen::Isometry3f& T_fixed_sensor) const {
  if (!config_.skip_stationary_frames || !has_last_pose_) return false;
  const Eigen::Isometry3f delta = last_pose_.inverse() * T_fixed_sensor;
  const double dt = delta.translation().norm();
  const double da = Eigen::AngleAxisf(delta.linear()).angle();
  return dt < config_.stationary_translation && da < config_.stationary_rotation_deg * kDegToRad;
}

bool SafetyMapper::integrateFrame(const std::vector<Eigen::Vector3f>& points_sensor,
                                  const Eigen::Isometry3f& T_fixed_sensor,
                                  const Eigen::Vector3f& robot_base_position, FrameResult* out) {
  FrameResult local;
  FrameResult& r = out != nullptr ? *out : local;
  r = FrameResult();
  auto skip = [&r](FrameStatus s) {
    r.status = s;
    return false;
  };
  if (!isRigid(T_fixed_sensor)) return skip(FrameStatus::kInvalidPose);
  if (!robot_base_position.allFinite()) return skip(FrameStatus::kInvalidRobotPosition);
  if (points_sensor.empty()) return skip(FrameStatus::kEmptyInput);

  // 000 Sec. IV: discard frames taken while the camera has not moved.
  if (isStationary(T_fixed_sensor)) return skip(FrameStatus::kStationary);

  const Clock::time_point t0 = Clock::now();
  // Recentre on the robot before checking the camera: it must lie inside the window that the
  // rays are traced in. A camera outside it means a pose far from the robot (bad extrinsics or
  // localisation), which would paint free space across the map.
  if (!grid_placed_ || config_.scroll_with_robot) {
    // SafetyMapperConfig::grid_look_ahead: along the optical axis projected on the ground.
    Eigen::Vector3f centre = robot_base_position;
    const Eigen::Vector3f axis = T_fixed_sensor.linear().col(2);
    const float horizontal = std::hypot(axis.x(), axis.y());
    if (config_.grid_look_ahead > 0.0 && horizontal > 1e-3f) {
      const float a = static_cast<float>(config_.grid_look_ahead) / horizontal;
      centre.x() += a * axis.x();
      centre.y() += a * axis.y();
    }
    r.voxels_scrolled = grid_.recenter(centre);
    grid_placed_ = true;
  }
  if (!grid_.contains(grid_.indexOf(T_fixed_sensor.translation()))) {
    return skip(FrameStatus::kCameraOutsideGrid);
  }
  r.integration = grid_.integrate(points_sensor, T_fixed_sensor);
  const double integrate_ms = msSince(t0);
  last_pose_ = T_fixed_sensor;
  has_last_pose_ = true;
  ++frames_integrated_;

  computeSafetyMap(robot_base_position);
  timings_.integrate_ms = integrate_ms;
  timings_.total_ms = msSince(t0);
  r.timings = timings_;
  r.status = FrameStatus::kIntegrated;
  return true;
}

const SafetyMap& SafetyMapper::computeSafetyMap(const Eigen::Vector3f& robot_base_position) {
  const Clock::time_point t0 = Clock::now();
  timings_ = StageTimings();
  const double l = grid_.config().voxel_size;
  const bool finite = robot_base_position.allFinite();

  Clock::time_point t = Clock::now();
  height_map_.build(grid_, finite ? robot_base_position.z() : 0.0f);
  timings_.height_map_ms = msSince(t);

  t = Clock::now();
  if (finite) {
    segmentation_.segment(height_map_, grid_.indexOf(robot_base_position), l, &segments_);
  } else {
    segmentation_.segment(height_map_, VoxelIndex(), -1.0, &segments_);  // everything empty
  }
  timings_.segmentation_ms = msSince(t);

  t = Clock::now();
  plane_fitter_.fitAll(grid_, segments_, &planes_);
  timings_.plane_fit_ms = msSince(t);

  t = Clock::now();
  labelling_.label(height_map_, segments_, planes_, finite ? l : -1.0, &map_);
  if (!finite) {
    map_.robot_u = 0;
    map_.robot_v = 0;
  }
  timings_.labelling_ms = msSince(t);
  timings_.total_ms = msSince(t0);
  return map_;
}

}  // namespace stereo_safety_map
