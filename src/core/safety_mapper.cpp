#include "stereo_safety_map/core/safety_mapper.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

constexpr double kDegToRad = 0.017453292519943295;
// SafetyMapperConfig::relevel: a reference cell's measured surface must lie this close to the
// robot's level ground [m] (1.5 cm: the measured heights' noise on a level floor).
constexpr double kRelevelCellTolerance = 0.015;

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
  if (!(err = prefixed("relevel", relevel.validate())).empty()) return err;
  if (!(err = overhang_roof.validate()).empty()) return err;
  if (!std::isfinite(stationary_translation) || stationary_translation < 0.0 ||
      stationary_translation > 100.0) {
    return "stationary_translation must be in [0, 100] m";
  }
  if (!std::isfinite(stationary_rotation_deg) || stationary_rotation_deg < 0.0 ||
      stationary_rotation_deg > 180.0) {
    return "stationary_rotation_deg must be in [0, 180] deg";
  }
  if (stationary_warmup_frames < 0 || stationary_warmup_frames > 100000) {
    return "stationary_warmup_frames must be in [0, 100000]";
  }
  // A window smaller than 2 R_max allows no look-ahead (but stays valid centred on the robot).
  const double max_look_ahead =
      std::max(0.0, 0.5 * std::min(grid.size_x, grid.size_y) - segmentation.planning_radius);
  if (!std::isfinite(grid_look_ahead) || grid_look_ahead < 0.0 ||
      grid_look_ahead > max_look_ahead + 1e-9) {
    return "grid_look_ahead must be in [0, min(size_x, size_y) / 2 - planning_radius] = [0, " +
           std::to_string(max_look_ahead) + "] m";
  }
  if (!std::isfinite(obstacle_memory_max_range) || obstacle_memory_max_range < 0.0 ||
      obstacle_memory_max_range > 1000.0) {
    return "obstacle_memory_max_range must be in [0, 1000] m (0 = any range)";
  }
  if (!std::isfinite(unseen_overhang_min_height) || unseen_overhang_min_height < 0.0 ||
      unseen_overhang_min_height > 5.0) {
    return "unseen_overhang_min_height must be in [0, 5] m (0 = off)";
  }
  if (unseen_floor_band < 0 || unseen_floor_band > 10) {
    return "unseen_floor_band must be in [0, 10] voxels (0 = off)";
  }
  if (!std::isfinite(unseen_floor_min_range) || unseen_floor_min_range < 0.0 ||
      unseen_floor_min_range > 100.0) {
    return "unseen_floor_min_range must be in [0, 100] m";
  }
  if (unseen_overhang_min_width < 1 || unseen_overhang_min_width > 9) {
    return "unseen_overhang_min_width must be in [1, 9] cells";
  }
  if (unseen_overhang_free_lop < 1 || unseen_overhang_free_lop > -grid.lop_min) {
    return "unseen_overhang_free_lop must be in [1, -grid.lop_min] = [1, " +
           std::to_string(-grid.lop_min) + "]";
  }
  if (obstacle_memory_clear_margin < 1 ||
      obstacle_memory_clear_margin > grid.occ_threshold - grid.lop_min) {
    return "obstacle_memory_clear_margin must be in [1, grid.occ_threshold - grid.lop_min] = [1, " +
           std::to_string(grid.occ_threshold - grid.lop_min) + "]";
  }
  if (!std::isfinite(max_cell_age) || max_cell_age < 0.0 || max_cell_age > 86400.0) {
    return "max_cell_age must be in [0, 86400] s (0 = off)";
  }
  return "";
}

bool risesAboveLocalGround(const SafetyMap& m, const HeightMap& hm, int c, float fallback_ground_z,
                           double min_rise, int radius) {
  // A column whose top voxel stands only because the ground's noise (stereo at range, an
  // unreported pitch) reached into the next voxel is not an obstacle: its surface is within
  // h_T of the ground around it.
  const float top = hm.surfaceHeightAtIndex(c);
  if (!std::isfinite(top)) return true;
  const int u = c % m.width, v = c / m.width;
  float ground = std::numeric_limits<float>::infinity();
  for (int vn = std::max(0, v - radius); vn <= std::min(m.height - 1, v + radius); ++vn) {
    for (int un = std::max(0, u - radius); un <= std::min(m.width - 1, u + radius); ++un) {
      const int cn = vn * m.width + un;
      if (!isSafe(m.labels[cn])) continue;
      const float z = hm.surfaceHeightAtIndex(cn);
      if (std::isfinite(z)) ground = std::min(ground, z);
    }
  }
  if (!std::isfinite(ground)) ground = fallback_ground_z;
  return top - ground > min_rise;
}

SafetyMapperConfig paperFaithful(const SafetyMapperConfig& config) {
  SafetyMapperConfig c = config;
  c.segmentation.segment_islands = false;      // 000 Alg. 1 grows from the robot's island only
  c.segmentation.footprint_radius = 0.0;       // 000 seeds on observed ground only
  c.segmentation.seed_on_support = false;      // 000 seeds at the base's height
  c.segmentation.split_steps = false;          // 000 Alg. 1: a segment is one indexed height
  c.height_map.observation_means = false;      // 000 Sec. IV: the voxels' point lists
  c.height_map.near_view_ratio = 0.0;          // 000 Sec. V-A: the highest occupied voxel
  c.height_map.tail_share = 0.0;               // 000 Sec. V-A: the highest occupied voxel
  c.height_map.mass_heights = false;           // 000 Sec. IV-V: the top voxel's list
  c.height_map.mass_bands = false;             // 000 Sec. V-A: the highest occupied voxel
  c.height_map.sparse_edge_share = 0.0;        // 000 Sec. V-A: every column with a height
  c.plane_fit.mass_heights = false;            // 000 Sec. V-B: the voxels' point lists
  c.labelling.small_obstacles = false;         // 000 Alg. 2 steps 3-4: small or thin is Unknown
  c.labelling.floor_fragments = false;         // 000 Alg. 2 steps 3-4: small or thin is Unknown
  c.labelling.robot_fragment_passage = false;  // 000 Alg. 2 step 21: num_T on both sides
  c.labelling.footprint_bridge = 0.0;
  c.labelling.bridge_tilt_deg = 0.0;
  c.labelling.isolated_ground_unknown = false;  // 000 Alg. 2 step 27: unreached is Non-ground
  c.obstacle_memory = false;                    // 000 recomputes the map from the grid
  c.unseen_overhang_min_height = 0.0;           // 000 labels the floor alone
  c.unseen_floor_band = 0;                      // the same
  c.relevel.enabled = false;                    // 000 takes the pose from odometry
  c.overhang_roof.enabled = false;              // 000: the top voxel alone (Sec. V-A)
  c.labelling.max_gap_cells = 0;                // 000 Sec. VI: neighbours touch
  c.labelling.measured_step_test = false;       // 000 Alg. 2 steps 15-17: planes only
  c.labelling.step_height_margin = 0.0;         // 000 Alg. 2 step 17: h_T alone
  c.labelling.slope_margin_deg = 0.0;           // 000 Alg. 2 step 2: theta_max alone
  c.labelling.drop_off_margin = false;          // 000 Sec. VI: annotation only
  c.labelling.drop_off_sink = 0.0;              // 000 Sec. VI: annotation only
  c.labelling.obstacle_face_margin = false;     // 000 Sec. VI: no margin
  c.plane_fit.vertical_margin = 0;              // 000 Sec. V-B: the segment's own points
  c.plane_fit.observation_means = false;        // 000 Sec. V-B: the voxels' point lists
  c.max_cell_age = 0.0;                         // 000 keeps every voxel while in the window
  c.stationary_warmup_frames = 0;               // 000 Sec. IV: every stationary frame skipped
  c.grid.neighbour_sigmas = 0.0;                // 000 Sec. IV: both neighbours always get incr_L
  c.grid.incr_low_fore = -1;                    // 000 Sec. IV: the same incr_L on both sides
  // The look-ahead must stay within the window; 0 centres it on the robot (000 Sec. IV).
  c.grid_look_ahead = 0.0;
  return c;
}

namespace {

// Whether segment k holds a cell of the robot's footprint (GroundSegments::footprint).
bool holdsFootprint(const GroundSegments& s, int k) {
  if (s.footprint.empty()) return false;
  for (const int* c = s.cellsBegin(k); c != s.cellsEnd(k); ++c)
    if (s.footprint[*c]) return true;
  return false;
}

const SafetyMapperConfig& checked(const SafetyMapperConfig& c) {
  const std::string err = c.validate();
  if (!err.empty()) throw std::invalid_argument("SafetyMapperConfig: " + err);
  return c;
}

bool sameGrid(const VoxelGridConfig& a, const VoxelGridConfig& b) {
  return a.voxel_size == b.voxel_size && a.size_x == b.size_x && a.size_y == b.size_y &&
         a.size_z == b.size_z && a.z_below_robot == b.z_below_robot && a.incr_high == b.incr_high &&
         a.incr_low == b.incr_low && a.decr == b.decr && a.occ_threshold == b.occ_threshold &&
         a.lop_min == b.lop_min && a.lop_max == b.lop_max &&
         a.point_list_capacity == b.point_list_capacity && a.max_range == b.max_range &&
         a.min_range == b.min_range && a.neighbour_sigmas == b.neighbour_sigmas &&
         a.incr_low_fore == b.incr_low_fore && a.disparity_sigma == b.disparity_sigma;
}

constexpr double kNoTime = std::numeric_limits<double>::quiet_NaN();

bool isRigid(const Eigen::Isometry3f& T) {
  if (!T.matrix().allFinite()) return false;
  const Eigen::Matrix3f R = T.linear();
  return (R.transpose() * R - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff() < 1e-3f &&
         R.determinant() > 0.0f;
}

// Whether a switch reads VoxelGrid::hitMass() and the means behind it.
bool readsHitMass(const SafetyMapperConfig& c) {
  return c.height_map.tail_share > 0.0 || c.height_map.mass_heights || c.plane_fit.mass_heights ||
         c.height_map.sparse_edge_share > 0.0;
}

}  // namespace

SafetyMapper::SafetyMapper(const SafetyMapperConfig& config)
    : config_(checked(config)),
      grid_(config_.grid),
      height_map_(config_.height_map),
      segmentation_(config_.segmentation),
      plane_fitter_(config_.plane_fit),
      labelling_(config_.labelling),
      latest_time_(kNoTime) {
  observation_age_.resize(grid_.sizeU(), grid_.sizeV());
  grid_.setHitMassTracking(readsHitMass(config_));
}

std::string SafetyMapper::reconfigure(const SafetyMapperConfig& config, bool* grid_reset) {
  if (grid_reset != nullptr) *grid_reset = false;
  const std::string err = config.validate();
  if (!err.empty()) return err;
  const bool new_grid = !sameGrid(config.grid, config_.grid);
  // Constructed before anything is assigned: validated above, they do not throw.
  HeightMap height_map(config.height_map);
  GroundSegmentation segmentation(config.segmentation);
  PlaneFitter plane_fitter(config.plane_fit);
  SafetyLabelling labelling(config.labelling);
  if (new_grid) grid_ = VoxelGrid(config.grid);
  height_map_ = std::move(height_map);
  segmentation_ = std::move(segmentation);
  plane_fitter_ = std::move(plane_fitter);
  labelling_ = std::move(labelling);
  config_ = config;
  // Switched on later, the masses start from this frame on.
  grid_.setHitMassTracking(readsHitMass(config_));
  if (new_grid) {
    observation_age_.resize(grid_.sizeU(), grid_.sizeV());
    reset();
    if (grid_reset != nullptr) *grid_reset = true;
  }
  return "";
}

Eigen::Isometry3f SafetyMapper::relevelPose(const std::vector<Eigen::Vector3f>& points_sensor,
                                            const Eigen::Isometry3f& T_fixed_sensor,
                                            const Eigen::Vector3f& robot_base_position,
                                            FrameLevellingResult* result) {
  const FrameLevellingConfig& lc = config_.relevel;
  const double l = grid_.config().voxel_size;
  const float base_z = robot_base_position.z();
  const SafetyMap& m = map_;
  const GroundSegments& segs = segments_;
  const int rs = m.robot_segment;
  GroundReference reference;
  if (lc.near_radius > 0.0) {
    // FrameLevellingConfig::near_radius: the base's level plane around the robot.
    const float r2 = static_cast<float>(lc.near_radius * lc.near_radius);
    const float bx = robot_base_position.x(), by = robot_base_position.y();
    reference = [=](float x, float y) {
      const float dx = x - bx, dy = y - by;
      return dx * dx + dy * dy <= r2 ? base_z : std::numeric_limits<float>::quiet_NaN();
    };
  } else if (rs >= 0 && rs < static_cast<int>(m.segments.size()) && m.segments[rs].plane.valid &&
             static_cast<int>(segs.footprint.size()) == m.width * m.height) {
    // The robot's ground in the odometry frame is the level plane through its base (a planar
    // robot, 000 Sec. I-A; odometry knows no pitch or roll): the reference is that plane over the
    // observed cells of the robot's segment whose measured surface lies on it. Not the segment's
    // fitted plane: its band also holds the first decimetres of a ramp or of a smear into a
    // drop, which would tilt the plane and, through it, every later frame.
    reference = [&](float x, float y) {
      const int u = static_cast<int>(std::lround(x / l)), v = static_cast<int>(std::lround(y / l));
      if (!m.inside(u, v)) return std::numeric_limits<float>::quiet_NaN();
      const int c = m.index(u, v);
      if (m.segment[c] != rs || segs.footprint[c]) return std::numeric_limits<float>::quiet_NaN();
      if (!(std::abs(height_map_.surfaceHeightAtIndex(c) - base_z) < kRelevelCellTolerance)) {
        return std::numeric_limits<float>::quiet_NaN();
      }
      return base_z;
    };
  } else if (lc.filter_frames == 0) {
    return T_fixed_sensor;
  }
  Eigen::Isometry3f T_frame = T_fixed_sensor;
  if (reference) {
    levelFrame(points_sensor, T_fixed_sensor, reference, lc, &T_frame, result, &levelling_scratch_);
  }
  if (lc.filter_frames == 0) return T_frame;

  // FrameLevellingConfig::filter_frames: the estimate in the camera heading's frame (x forward,
  // y left), the median of the last N applied instead of this frame's own.
  const Eigen::Matrix3f& R = T_fixed_sensor.linear();
  const double heading = std::atan2(static_cast<double>(R(1, 2)), static_cast<double>(R(0, 2)));
  const double ch = std::cos(heading), sh = std::sin(heading);
  if (result->applied) {
    const double a = result->roll_deg * kDegToRad, b = result->pitch_deg * kDegToRad;
    // (a, b) are rotations about the fixed x and y axes; about the heading's axes:
    levelling_history_.emplace_back(ch * a + sh * b, -sh * a + ch * b, result->dz);
    if (static_cast<int>(levelling_history_.size()) > lc.filter_frames) {
      levelling_history_.erase(levelling_history_.begin());
    }
  }
  if (levelling_history_.empty()) return T_fixed_sensor;
  Eigen::Vector3d med;
  for (int k = 0; k < 3; ++k) {
    levelling_sorted_.clear();
    for (const Eigen::Vector3d& h : levelling_history_)
      levelling_sorted_.push_back(h[k]);
    const std::size_t mid = levelling_sorted_.size() / 2;
    std::nth_element(levelling_sorted_.begin(), levelling_sorted_.begin() + mid,
                     levelling_sorted_.end());
    med[k] = levelling_sorted_[mid];
  }
  const double a = ch * med.x() - sh * med.y(), b = sh * med.x() + ch * med.y();
  result->applied = true;
  result->roll_deg = a / kDegToRad;
  result->pitch_deg = b / kDegToRad;
  result->dz = med.z();
  return levelledPose(T_fixed_sensor, a, b, med.z());
}

void SafetyMapper::reset() {
  grid_.clear();
  obstacle_memory_.clear();
  roof_memory_.clear();
  face_memory_.clear();
  cells_remembered_ = 0;
  observation_age_.clear();
  latest_time_ = kNoTime;
  cells_aged_ = 0;
  map_ = SafetyMap();
  segments_ = GroundSegments();
  planes_.clear();
  levelling_history_.clear();
  timings_ = StageTimings();
  has_last_pose_ = false;
  last_camera_ = Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  grid_placed_ = false;
  frames_integrated_ = 0;
}

bool SafetyMapper::isStationary(const Eigen::Isometry3f& T_fixed_sensor) const {
  if (!config_.skip_stationary_frames || !has_last_pose_) return false;
  // SafetyMapperConfig::stationary_warmup_frames: a grid started at rest fills first.
  if (frames_integrated_ < static_cast<std::uint32_t>(config_.stationary_warmup_frames))
    return false;
  const Eigen::Isometry3f delta = last_pose_.inverse() * T_fixed_sensor;
  const double dt = delta.translation().norm();
  const double da = Eigen::AngleAxisf(delta.linear()).angle();
  return dt < config_.stationary_translation && da < config_.stationary_rotation_deg * kDegToRad;
}

bool SafetyMapper::integrateFrame(const std::vector<Eigen::Vector3f>& points_sensor,
                                  const Eigen::Isometry3f& T_fixed_sensor,
                                  const Eigen::Vector3f& robot_base_position, FrameResult* out) {
  return integrate(points_sensor, T_fixed_sensor, robot_base_position, kNoTime, out);
}

bool SafetyMapper::integrateFrame(const std::vector<Eigen::Vector3f>& points_sensor,
                                  const Eigen::Isometry3f& T_fixed_sensor,
                                  const Eigen::Vector3f& robot_base_position, double stamp,
                                  FrameResult* out, std::size_t first_no_carve) {
  // A non-finite stamp is no stamp.
  return integrate(points_sensor, T_fixed_sensor, robot_base_position,
                   std::isfinite(stamp) ? stamp : kNoTime, out, first_no_carve);
}

void SafetyMapper::observe(const std::vector<Eigen::Vector3f>& points_sensor,
                           const Eigen::Isometry3f& T_fixed_sensor,
                           const Eigen::Vector3f& robot_base_position, double stamp) {
  if (!(config_.max_cell_age > 0.0) || !std::isfinite(stamp)) return;
  const float lo = static_cast<float>(config_.grid.min_range);
  const float hi = static_cast<float>(config_.grid.max_range);
  for (const Eigen::Vector3f& p : points_sensor) {
    if (!p.allFinite()) continue;
    const float range = p.norm();            // the camera is the sensor frame's origin
    if (range < lo || range > hi) continue;  // the grid ignores these points as well
    const VoxelIndex i = grid_.indexOf(T_fixed_sensor * p);
    if (grid_.contains(i)) observation_age_.observe(i.u, i.v, stamp);
  }
  // The robot stands on its footprint (GroundSegmentationConfig::footprint_radius): vouched for
  // by the robot itself at every frame.
  const double r = config_.segmentation.footprint_radius;
  if (r > 0.0 && robot_base_position.allFinite()) {
    const double l = config_.grid.voxel_size;
    const VoxelIndex c = grid_.indexOf(robot_base_position);
    const int rc = static_cast<int>(std::floor(r / l + 1e-6));
    const double r2 = (r / l) * (r / l) + 1e-6;
    for (int dv = -rc; dv <= rc; ++dv) {
      for (int du = -rc; du <= rc; ++du) {
        if (du * du + dv * dv > r2) continue;
        const VoxelIndex i{c.u + du, c.v + dv, c.w};
        if (grid_.contains(i)) observation_age_.observe(i.u, i.v, stamp);
      }
    }
  }
}

std::size_t SafetyMapper::ageSafetyMap(double now) {
  if (!std::isfinite(now)) return 0;
  if (!std::isfinite(latest_time_) || now > latest_time_) latest_time_ = now;
  if (!(config_.max_cell_age > 0.0)) return 0;
  const std::size_t n = observation_age_.apply(latest_time_, config_.max_cell_age, &map_);
  cells_aged_ += n;
  return n;
}

bool SafetyMapper::integrate(const std::vector<Eigen::Vector3f>& points_sensor,
                             const Eigen::Isometry3f& T_fixed_sensor,
                             const Eigen::Vector3f& robot_base_position, double stamp,
                             FrameResult* out, std::size_t first_no_carve) {
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

  // 000 Sec. IV: discard frames taken while the camera has not moved. The camera still sees
  // what it saw: the columns its points fall into count as observed (observation_age.h).
  if (isStationary(T_fixed_sensor)) {
    observe(points_sensor, T_fixed_sensor, robot_base_position, stamp);
    if (std::isfinite(stamp)) r.cells_aged = ageSafetyMap(stamp);
    return skip(FrameStatus::kStationary);
  }

  const Clock::time_point t0 = Clock::now();
  // SafetyMapperConfig::relevel: the pose corrected on the ground the robot stands on.
  const Eigen::Isometry3f T_frame =
      config_.relevel.enabled
          ? relevelPose(points_sensor, T_fixed_sensor, robot_base_position, &r.levelling)
          : T_fixed_sensor;
  // Recentre on the robot before checking the camera: it must lie inside the window that the
  // rays are traced in. A camera outside it means a pose far from the robot (bad extrinsics or
  // localisation), which would paint free space across the map.
  if (!grid_placed_ || config_.scroll_with_robot) {
    // SafetyMapperConfig::grid_look_ahead: along the optical axis projected on the ground.
    Eigen::Vector3f centre = robot_base_position;
    const Eigen::Vector3f axis = T_frame.linear().col(2);
    const float horizontal = std::hypot(axis.x(), axis.y());
    if (config_.grid_look_ahead > 0.0 && horizontal > 1e-3f) {
      const float a = static_cast<float>(config_.grid_look_ahead) / horizontal;
      centre.x() += a * axis.x();
      centre.y() += a * axis.y();
    }
    r.voxels_scrolled = grid_.recenter(centre);
    grid_placed_ = true;
  }
  if (!grid_.contains(grid_.indexOf(T_frame.translation()))) {
    return skip(FrameStatus::kCameraOutsideGrid);
  }
  r.integration = grid_.integrate(points_sensor, T_frame, first_no_carve);
  // SafetyMapperConfig::overhang_roof looks from the last camera that saw something: a frame
  // whose points all failed leaves the map as it was.
  if (r.integration.points_used > 0) last_camera_ = T_frame.translation();
  observe(points_sensor, T_frame, robot_base_position, stamp);
  if (std::isfinite(stamp) && !(stamp <= latest_time_)) latest_time_ = stamp;
  const double integrate_ms = msSince(t0);
  last_pose_ = T_fixed_sensor;
  has_last_pose_ = true;
  ++frames_integrated_;

  computeSafetyMap(robot_base_position);
  timings_.integrate_ms = integrate_ms;
  timings_.total_ms = msSince(t0);
  r.timings = timings_;
  r.cells_aged = cells_aged_;
  r.status = FrameStatus::kIntegrated;
  return true;
}

namespace {
// The memories' key of a cell (global (u, v)).
std::int64_t memoryKey(int u, int v) {
  return static_cast<std::int64_t>(
      (static_cast<std::uint64_t>(static_cast<std::uint32_t>(u)) << 32) |
      static_cast<std::uint32_t>(v));
}
}  // namespace

bool SafetyMapper::rememberedObstacle(int u, int v, int* lo, int* hi) const {
  const auto it = obstacle_memory_.find(memoryKey(u, v));
  if (it == obstacle_memory_.end()) return false;
  if (lo) *lo = it->second.lo;
  if (hi) *hi = it->second.hi;
  return true;
}

void SafetyMapper::applyObstacleMemory(std::int32_t robot_w, float robot_z) {
  SafetyMap& m = map_;
  const double max_range2 = config_.obstacle_memory_max_range * config_.obstacle_memory_max_range;
  const int clear_lop = grid_.config().occ_threshold - config_.obstacle_memory_clear_margin;
  // Cells that hold an obstacle now: non-traversable columns and small obstacles' tops.
  for (int v = m.min_v; v < m.min_v + m.height; ++v) {
    for (int u = m.min_u; u < m.min_u + m.width; ++u) {
      const int c = m.index(u, v);
      if (m.labels[c] != SafetyLabel::kNonGround) continue;
      const int k = m.segment[c];
      if (k >= 0 && !(k < static_cast<int>(m.segments.size()) && m.segments[k].obstacle)) {
        continue;  // too steep or unreachable ground: its label follows reachability
      }
      // The obstacle is what rises above the robot's base in the column (a column on lower
      // ground is Non-ground for its reachability); the ground voxel under it is not part of it.
      const std::int32_t hi = height_map_.atIndex(c);
      if (hi == HeightMap::kNoHeight || hi <= robot_w) continue;
      // Only what was judged from near enough (SafetyMapperConfig::obstacle_memory_max_range).
      if (max_range2 > 0.0) {
        const double du = u - m.robot_u, dv = v - m.robot_v;
        if ((du * du + dv * dv) * m.resolution * m.resolution > max_range2) continue;
      }
      // Ground noise that reached the voxel above the ground is no obstacle to remember.
      if (!risesAboveLocalGround(m, height_map_, c, robot_z, config_.labelling.max_step_height))
        continue;
      const std::int32_t low = height_map_.lowestAtIndex(c);
      const std::int32_t lo = hi > low ? std::max(low + 1, robot_w + 1) : hi;
      ObstacleMark& mark =
          obstacle_memory_.emplace(memoryKey(u, v), ObstacleMark{lo, hi}).first->second;
      mark.lo = std::min(mark.lo, lo);
      mark.hi = std::max(mark.hi, hi);
    }
  }
  // A memory's cells: forgotten once out of the window or when holds(u, v, mark) says the
  // evidence is gone; otherwise Non-ground whatever the labelling says.
  auto apply = [&](auto& memory, auto&& holds) {
    memory_drop_.clear();
    for (const auto& [k, mark] : memory) {
      const int u = static_cast<int>(k >> 32);
      const int v = static_cast<int>(static_cast<std::int32_t>(k & 0xffffffff));
      if (!m.inside(u, v) || !holds(u, v, mark)) {
        memory_drop_.push_back(k);
        continue;
      }
      const int c = m.index(u, v);
      if (m.labels[c] == SafetyLabel::kNonGround || m.labels[c] == SafetyLabel::kUnexamined) {
        continue;
      }
      m.labels[c] = SafetyLabel::kNonGround;
      m.drop_off[c] = 0;
      ++cells_remembered_;
    }
    for (const std::int64_t k : memory_drop_)
      memory.erase(k);
  };
  // Obstacle columns: free space observed there is every voxel of the band at or below
  // occ_threshold - obstacle_memory_clear_margin.
  apply(obstacle_memory_, [&](int u, int v, const ObstacleMark& mark) {
    for (std::int32_t w = mark.lo; w <= mark.hi; ++w)
      if (grid_.logOdds(VoxelIndex{u, v, w}) > clear_lop) return true;
    return false;
  });

  // SafetyLabellingConfig::obstacle_face_margin: a cell that held an obstacle's face keeps
  // Non-ground while the top voxel of the face's column that marked it stays occupied (the
  // column's own cells are the obstacle memory's); rays that clear that voxel forget it.
  if (!config_.labelling.obstacle_face_margin) {
    face_memory_.clear();
  } else {
    for (const SafetyLabelling::FaceMark& f : labelling_.faceMarks()) {
      const int u = m.min_u + f.cell % m.width, v = m.min_v + f.cell / m.width;
      if (max_range2 > 0.0) {  // SafetyMapperConfig::obstacle_memory_max_range, as above
        const double du = u - m.robot_u, dv = v - m.robot_v;
        if ((du * du + dv * dv) * m.resolution * m.resolution > max_range2) continue;
      }
      const std::int32_t w = height_map_.atIndex(f.face_cell);
      if (w == HeightMap::kNoHeight) continue;
      face_memory_[memoryKey(u, v)] =
          ColumnVoxelMark{m.min_u + f.face_cell % m.width, m.min_v + f.face_cell / m.width, w};
    }
    apply(face_memory_, [&](int, int, const ColumnVoxelMark& face) {
      return grid_.logOdds(VoxelIndex{face.u, face.v, face.w}) > clear_lop;
    });
  }

  // OverhangRoofConfig::remember: the floor seen under a roof keeps Non-ground while the roof
  // column's top voxel that marked it stays occupied; rays that clear that voxel (000 Sec. IV)
  // are the free-space evidence that forgets it. A cell marked again takes its latest roof.
  if (!config_.overhang_roof.remember) {
    roof_memory_.clear();
    return;
  }
  for (const OverhangRoofMark& r : overhang_scratch_.marks) {
    const int u = m.min_u + r.cell % m.width, v = m.min_v + r.cell / m.width;
    roof_memory_[memoryKey(u, v)] = ColumnVoxelMark{r.roof_u, r.roof_v, r.roof_w};
  }
  apply(roof_memory_, [&](int, int, const ColumnVoxelMark& roof) {
    return grid_.logOdds(VoxelIndex{roof.u, roof.v, roof.w}) > clear_lop;
  });
}

void SafetyMapper::markUnseenOverhangs() {
  // SafetyMapperConfig::unseen_overhang_min_height: a hidden layer above a safe cell.
  SafetyMap& m = map_;
  const double l = grid_.config().voxel_size;
  const int rise = config_.unseen_overhang_min_height > 0.0
                       ? static_cast<int>(std::ceil(config_.unseen_overhang_min_height / l - 1e-6))
                       : 0;
  // Without free-space decrements (decr 0, the real pairs' single-frame mode) no voxel is ever
  // seen free: the rule has nothing to ask.
  const int floor_band = grid_.config().decr > 0 ? config_.unseen_floor_band : 0;
  const double res2 = m.resolution * m.resolution;
  const double floor_r2 = config_.unseen_floor_min_range * config_.unseen_floor_min_range;
  const int w_top = height_map_.topIndex();
  const double fr = config_.segmentation.footprint_radius / m.resolution;
  const double fr2 = fr * fr;
  const std::size_t n = static_cast<std::size_t>(m.width) * static_cast<std::size_t>(m.height);
  unseen_hidden_.assign(n, 0);
  unseen_core_.assign(n, 0);
  for (int v = m.min_v; v < m.min_v + m.height; ++v) {
    for (int u = m.min_u; u < m.min_u + m.width; ++u) {
      const int c = m.index(u, v);
      if (!isSafe(m.labels[c])) continue;
      const double du = u - m.robot_u, dv = v - m.robot_v;
      if (du * du + dv * dv <= fr2) continue;  // the robot stands there
      const std::int32_t w = height_map_.atIndex(c);
      if (w == HeightMap::kNoHeight) continue;
      unseen_hidden_[c] = rise > 0 && grid_.hiddenBelowObserved(u, v, w + rise, w_top,
                                                                config_.unseen_overhang_free_lop);
      if (floor_band > 0 && (du * du + dv * dv) * res2 >= floor_r2 &&
          !grid_.seenFreeWithin(u, v, w + 1, w + floor_band, config_.unseen_overhang_free_lop)) {
        // unseen_hidden_[c] stays as it is: a square of hidden cells may need this one.
        m.labels[c] = SafetyLabel::kUnknown;
        m.drop_off[c] = 0;
        ++cells_unseen_floor_;
      }
    }
  }
  // SafetyMapperConfig::unseen_overhang_min_width: an opening of the hidden cells with a square
  // of that side. A top hides a layer across its whole extent; the voxels that the rays of a
  // frame happen to miss (a wall seen at a grazing angle, one ray per voxel and frame) lie in
  // thin stripes. unseen_core_ marks the corners (lowest x, y) of the squares hidden throughout.
  const int side = config_.unseen_overhang_min_width;
  for (int y = 0; y + side <= m.height; ++y) {
    for (int x = 0; x + side <= m.width; ++x) {
      bool all = true;
      for (int yy = y; all && yy < y + side; ++yy)
        for (int xx = x; all && xx < x + side; ++xx)
          all = unseen_hidden_[static_cast<std::size_t>(yy) * m.width + xx] != 0;
      unseen_core_[static_cast<std::size_t>(y) * m.width + x] = all;
    }
  }
  auto inHiddenSquare = [&](int x, int y) {
    for (int yy = std::max(0, y - side + 1); yy <= y; ++yy)
      for (int xx = std::max(0, x - side + 1); xx <= x; ++xx)
        if (unseen_core_[static_cast<std::size_t>(yy) * m.width + xx]) return true;
    return false;
  };
  const SafetyLabel hidden =
      config_.unseen_overhang_non_ground ? SafetyLabel::kNonGround : SafetyLabel::kUnknown;
  for (int y = 0; y < m.height; ++y) {
    for (int x = 0; x < m.width; ++x) {
      const std::size_t c = static_cast<std::size_t>(y) * m.width + x;
      if (!unseen_hidden_[c] || !inHiddenSquare(x, y)) continue;
      m.labels[c] = hidden;
      m.drop_off[c] = 0;
      ++cells_unseen_overhang_;
    }
  }
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
    segmentation_.segment(height_map_, grid_.indexOf(robot_base_position), l, &segments_,
                          robot_base_position.z());
  } else {
    segmentation_.segment(height_map_, VoxelIndex(), -1.0, &segments_);  // everything empty
  }
  timings_.segmentation_ms = msSince(t);

  t = Clock::now();
  plane_fitter_.fitAll(grid_, segments_, &planes_);
  // GroundSegmentationConfig::footprint_radius: a robot segment that holds the footprint but
  // has not enough points of its own for a plane (none, or a few in a strip: PlaneFitConfig::
  // min_points, min_xy_stddev) lies on the plane the robot stands on, the base's. The footprint
  // joins the robot's segment only at the base's indexed height, so that plane is the segment's
  // height; without it nothing is reachable and the whole map is Non-ground (issue 15, "the
  // robot stands on ground"; dev seed 149: a seed column with 6 points in a line).
  const int rs = segments_.robot_segment;
  if (finite && rs >= 0 && rs < static_cast<int>(planes_.size()) && !planes_[rs].valid &&
      holdsFootprint(segments_, rs)) {
    GroundPlane& p = planes_[rs];
    p = GroundPlane();
    p.valid = true;
    p.from_base = true;
    p.c = robot_base_position.z();
    p.centroid = robot_base_position.cast<double>();
  }
  timings_.plane_fit_ms = msSince(t);

  t = Clock::now();
  labelling_.setVoxelGrid(&grid_);  // obstacle_face_reach; set per call: a copied mapper moves
  labelling_.label(height_map_, segments_, planes_, finite ? l : -1.0, &map_);
  if (!finite) {
    map_.robot_u = 0;
    map_.robot_v = 0;
  }
  // SafetyMapperConfig::overhang_roof: seen from the last frame's camera.
  cells_under_overhangs_ = 0;
  overhang_scratch_.marks.clear();
  if (config_.overhang_roof.enabled && finite) {
    cells_under_overhangs_ =
        markFloorUnderOverhangs(grid_, height_map_, last_camera_, robot_base_position.z(),
                                config_.overhang_roof, &map_, &overhang_scratch_);
  }
  cells_remembered_ = 0;
  if (config_.obstacle_memory && finite) {
    applyObstacleMemory(grid_.indexOf(robot_base_position).w, robot_base_position.z());
  }
  cells_unseen_overhang_ = 0;
  cells_unseen_floor_ = 0;
  if ((config_.unseen_overhang_min_height > 0.0 || config_.unseen_floor_band > 0) && finite)
    markUnseenOverhangs();
  // What the map can no longer vouch for, at the latest time seen (observation_age.h).
  cells_aged_ = 0;
  if (std::isfinite(latest_time_) && config_.max_cell_age > 0.0) {
    cells_aged_ = observation_age_.apply(latest_time_, config_.max_cell_age, &map_);
  }
  timings_.labelling_ms = msSince(t);
  timings_.total_ms = msSince(t0);
  return map_;
}

}  // namespace stereo_safety_map
