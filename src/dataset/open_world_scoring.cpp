#include "stereo_safety_map/dataset/open_world_scoring.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <stdexcept>

namespace stereo_safety_map {
namespace dataset {

namespace {

// Lines naming forgotten cells kept per scene (SceneScore::forgotten).
constexpr std::size_t kMaxForgottenLines = 12;

std::int64_t cellKey(int u, int v) {
  return (static_cast<std::int64_t>(u) << 32) ^ static_cast<std::uint32_t>(v);
}

// A Chebyshev neighbour of GT cell (u, v) in class `c` (tolerance at label boundaries).
bool neighbourOfClass(const GroundTruthMap& gt, int u, int v, SafetyClass c) {
  for (int dv = -1; dv <= 1; ++dv) {
    for (int du = -1; du <= 1; ++du) {
      if (!gt.inside(u + du, v + dv)) continue;
      if (safetyClassOf(gt.labelAt(u + du, v + dv)) == c) return true;
    }
  }
  return false;
}

void add(ConfusionCounts* c, CellOutcome o) {
  switch (o) {
    case CellOutcome::kTruePositive:
      ++c->tp;
      break;
    case CellOutcome::kFalsePositive:
      ++c->fp;
      break;
    case CellOutcome::kFalseNegative:
      ++c->fn;
      break;
    case CellOutcome::kTrueNegative:
      ++c->tn;
      break;
    case CellOutcome::kUnclassified:
      break;
  }
}

}  // namespace

std::string OpenWorldScoringConfig::validate() const {
  if (!(planning_radius > 0.0 && planning_radius < 100.0)) return "planning_radius in (0, 100) m";
  if (!(min_range >= 0.0 && max_range > min_range)) return "0 <= min_range < max_range";
  if (!(robot_height > clearance && clearance >= 0.0)) return "0 <= clearance < robot_height";
  if (!(obstacle_min_width >= 0.0 && obstacle_min_height >= 0.0)) return "obstacle sizes >= 0";
  if (obstacle_min_pixels < 1 || obstacle_lenient_frames < 1) return "pixels and frames >= 1";
  if (!(segment_grace_s >= 0.0)) return "segment_grace_s >= 0";
  if (!(stuck_area >= 0.0 && std::isfinite(stuck_area))) return "stuck_area >= 0";
  if (!(footprint_radius >= 0.0 && footprint_radius < 100.0)) return "footprint_radius in [0, 100)";
  return "";
}

double DetectionScore::precision() const {
  const std::uint64_t judged = raised_points - raised_no_truth;
  return judged > 0 ? static_cast<double>(raised_true) / static_cast<double>(judged)
                    : std::numeric_limits<double>::quiet_NaN();
}

double DetectionScore::recall() const {
  return checks > 0 ? static_cast<double>(checks_detected) / checks
                    : std::numeric_limits<double>::quiet_NaN();
}

DetectionScore& DetectionScore::operator+=(const DetectionScore& o) {
  frames += o.frames;
  raised_points += o.raised_points;
  raised_true += o.raised_true;
  raised_no_truth += o.raised_no_truth;
  accepted += o.accepted;
  accepted_false += o.accepted_false;
  checks += o.checks;
  checks_detected += o.checks_detected;
  return *this;
}

SceneScore& SceneScore::operator+=(const SceneScore& o) {
  tol0 += o.tol0;
  tol1 += o.tol1;
  local_tol1 += o.local_tol1;
  for (int k = 0; k < kHazardClassCount; ++k)
    by_class[k] += o.by_class[k];
  coverage_cells += o.coverage_cells;
  coverage_classified += o.coverage_classified;
  maps += o.maps;
  maps_after_grace += o.maps_after_grace;
  maps_without_robot_segment += o.maps_without_robot_segment;
  maps_stuck += o.maps_stuck;
  maps_stuck_truth += o.maps_stuck_truth;
  forgotten_events += o.forgotten_events;
  forgotten_cells += o.forgotten_cells;
  obstacles += o.obstacles;
  obstacles_in_view += o.obstacles_in_view;
  obstacles_missed_strict += o.obstacles_missed_strict;
  obstacles_missed_lenient += o.obstacles_missed_lenient;
  obstacle_maps_strict += o.obstacle_maps_strict;
  obstacle_maps_missed_strict += o.obstacle_maps_missed_strict;
  obstacle_maps_lenient += o.obstacle_maps_lenient;
  obstacle_maps_missed_lenient += o.obstacle_maps_missed_lenient;
  obstacle_safe_cells += o.obstacle_safe_cells;
  for (std::size_t k = 0; k < fp_sources.size(); ++k)
    fp_sources[k] += o.fp_sources[k];
  misses.insert(misses.end(), o.misses.begin(), o.misses.end());
  forgotten.insert(forgotten.end(), o.forgotten.begin(), o.forgotten.end());
  detection += o.detection;
  tilt_frames += o.tilt_frames;
  tilt_used += o.tilt_used;
  tilt_reported += o.tilt_reported;
  return *this;
}

SceneScore::TiltError& SceneScore::TiltError::operator+=(const TiltError& o) {
  pitch += o.pitch;
  roll += o.roll;
  pitch2 += o.pitch2;
  roll2 += o.roll2;
  return *this;
}

OpenWorldScorer::OpenWorldScorer(const Scene& scene, const GroundTruthMap& gt,
                                 const std::vector<HazardClass>& classes,
                                 const OpenWorldScoringConfig& config, int variants)
    : config_(config), gt_(gt), classes_(classes) {
  const std::string err = config.validate();
  if (!err.empty()) throw std::invalid_argument("OpenWorldScoringConfig: " + err);
  const std::size_t n = gt.labels.size();
  if (classes_.size() != n) throw std::invalid_argument("hazard classes do not match the GT");
  if (variants < 1) throw std::invalid_argument("at least one variant");
  seen_.assign(n, 0);
  obstacle_of_.assign(n, -1);
  obstacle_cell_.assign(n, 0);
  group_of_primitive_.assign(scene.primitives.size(), -1);

  // Obstacles by scene-file entry (group): the GT cells whose column (clearance .. robot height
  // above the cell's ground) one of its solids occupies, sampled like the GT's obstacle test.
  const double res = gt.resolution;
  std::map<std::string, int> index_of_group;
  std::vector<double> top_of_group, width_of_group;
  constexpr int kS = 5;
  for (std::size_t i = 0; i < scene.primitives.size(); ++i) {
    const Primitive& p = scene.primitives[i];
    if (p.ground) continue;
    const std::string group = p.group.empty() ? p.name : p.group;
    auto it = index_of_group.find(group);
    if (it == index_of_group.end()) {
      it = index_of_group.emplace(group, static_cast<int>(obstacles_.size())).first;
      obstacles_.push_back(Obstacle());
      obstacles_.back().group = group;
      top_of_group.push_back(-std::numeric_limits<double>::infinity());
      width_of_group.push_back(0.0);
    }
    const int o = it->second;
    group_of_primitive_[i] = o;
    // Horizontal size of the solid: its narrowest horizontal extent.
    double width;
    if (p.shape == Primitive::Shape::kCylinder) {
      width = 2.0 * p.radius;
    } else {
      const Eigen::Vector3d ext = p.bounds.sizes();
      width = std::min(ext.x(), ext.y());
      const Eigen::Vector3d hs = 2.0 * p.obb.half_size;
      // An oriented box's own horizontal axes (the two with the smallest z component).
      double w = std::numeric_limits<double>::infinity();
      for (int a = 0; a < 3; ++a)
        if (std::abs(p.obb.rotation.col(a).z()) < 0.7) w = std::min(w, hs[a]);
      if (std::isfinite(w)) width = std::min(width, w);
    }
    const int u0 = std::max(gt.min_u, static_cast<int>(std::floor(p.bounds.min().x() / res)) - 1);
    const int u1 = std::min(gt.min_u + gt.width - 1,
                            static_cast<int>(std::ceil(p.bounds.max().x() / res)) + 1);
    const int v0 = std::max(gt.min_v, static_cast<int>(std::floor(p.bounds.min().y() / res)) - 1);
    const int v1 = std::min(gt.min_v + gt.height - 1,
                            static_cast<int>(std::ceil(p.bounds.max().y() / res)) + 1);
    bool occupies = false;
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        const int k = gt.index(u, v);
        const float g = gt.ground_height[k];
        if (!std::isfinite(g)) continue;
        Ray ray;
        ray.dir = Eigen::Vector3d(0.0, 0.0, -1.0);
        const double len = config.robot_height - config.clearance;
        bool hit = false;
        for (int s = 0; s < kS * kS && !hit; ++s) {
          const double ox = ((s % kS + 0.5) / kS - 0.5) * res;
          const double oy = ((s / kS + 0.5) / kS - 0.5) * res;
          ray.origin = Eigen::Vector3d(u * res + ox, v * res + oy, g + config.robot_height);
          double tin, tout;
          int face;
          hit = p.interval(ray, &tin, &tout, &face) && tin <= len && tout >= 0.0;
        }
        if (!hit) continue;
        occupies = true;
        obstacle_cell_[k] = 1;
        if (obstacle_of_[k] < 0) obstacle_of_[k] = o;
        obstacles_[o].cells.push_back(k);
        top_of_group[o] = std::max(top_of_group[o], p.bounds.max().z() - g);
      }
    }
    if (occupies) width_of_group[o] = std::max(width_of_group[o], width);
  }
  // Only obstacles at least min_width wide and min_height high are checked.
  std::vector<Obstacle> kept;
  std::vector<int> renumber(obstacles_.size(), -1);
  for (std::size_t o = 0; o < obstacles_.size(); ++o) {
    Obstacle& ob = obstacles_[o];
    std::sort(ob.cells.begin(), ob.cells.end());
    ob.cells.erase(std::unique(ob.cells.begin(), ob.cells.end()), ob.cells.end());
    if (ob.cells.empty() || width_of_group[o] < config.obstacle_min_width - 1e-9 ||
        top_of_group[o] < config.obstacle_min_height - 1e-9) {
      continue;
    }
    for (const int k : ob.cells) {
      const int u = gt.min_u + k % gt.width, v = gt.min_v + k / gt.width;
      for (int dv = -1; dv <= 1; ++dv)
        for (int du = -1; du <= 1; ++du)
          if (gt.inside(u + du, v + dv)) ob.cells_dilated.push_back(gt.index(u + du, v + dv));
    }
    std::sort(ob.cells_dilated.begin(), ob.cells_dilated.end());
    ob.cells_dilated.erase(std::unique(ob.cells_dilated.begin(), ob.cells_dilated.end()),
                           ob.cells_dilated.end());
    renumber[o] = static_cast<int>(kept.size());
    kept.push_back(std::move(ob));
  }
  obstacles_ = std::move(kept);
  for (int& g : group_of_primitive_)
    if (g >= 0) g = renumber[g];
  for (std::int32_t& g : obstacle_of_)
    if (g >= 0) g = renumber[g];
  variants_.resize(variants);
  for (VariantState& s : variants_) {
    s.missed_strict.assign(obstacles_.size(), 0);
    s.missed_lenient.assign(obstacles_.size(), 0);
  }
}

int OpenWorldScorer::gtIndexOf(const Eigen::Vector2d& w) const {
  const int u = gt_.cellOf(w.x()), v = gt_.cellOf(w.y());
  return gt_.inside(u, v) ? gt_.index(u, v) : -1;
}

void OpenWorldScorer::observeFrame(const Eigen::Isometry3d& T_world_camera,
                                   const StereoCameraModel& cam, const cv::Mat& depth,
                                   const cv::Mat& ids, const Eigen::Vector2d& robot) {
  frame_T_world_camera_ = T_world_camera;
  frame_camera_ = cam;
  frame_depth_ = depth;
  frame_ids_ = ids;
  in_view_now_.assign(obstacles_.size(), 0);
  // Obstacles in view: enough rendered pixels, and within R_max of the robot.
  if (!ids.empty() && ids.type() == CV_32S) {
    std::vector<int> pixels(obstacles_.size(), 0);
    for (int r = 0; r < ids.rows; ++r) {
      const std::int32_t* row = ids.ptr<std::int32_t>(r);
      for (int c = 0; c < ids.cols; ++c) {
        const int p = row[c];
        if (p < 0 || p >= static_cast<int>(group_of_primitive_.size())) continue;
        const int o = group_of_primitive_[p];
        if (o >= 0) ++pixels[o];
      }
    }
    const double r2 = config_.planning_radius * config_.planning_radius;
    for (std::size_t o = 0; o < obstacles_.size(); ++o) {
      if (pixels[o] < config_.obstacle_min_pixels) continue;
      bool near = false;
      for (const int k : obstacles_[o].cells) {
        const Eigen::Vector2d c =
            gt_.cellCenter(gt_.min_u + k % gt_.width, gt_.min_v + k / gt_.width);
        if ((c - robot).squaredNorm() <= r2) {
          near = true;
          break;
        }
      }
      if (near) {
        ++obstacles_[o].frames_in_view;
        in_view_now_[o] = 1;
      }
    }
  }
  // The swept field of view: GT cells whose ground (obstacle cells: the obstacle's lower part)
  // projects into the left image in range and is not hidden behind something nearer.
  if (depth.empty() || depth.type() != CV_32F) return;
  const Eigen::Isometry3d T_cw = T_world_camera.inverse();
  const Eigen::Vector3d o = T_world_camera.translation();
  const double res = gt_.resolution;
  const int reach = static_cast<int>(std::ceil(config_.max_range / res));
  const int cu = gt_.cellOf(o.x()), cv_ = gt_.cellOf(o.y());
  for (int v = std::max(gt_.min_v, cv_ - reach);
       v <= std::min(gt_.min_v + gt_.height - 1, cv_ + reach); ++v) {
    for (int u = std::max(gt_.min_u, cu - reach);
         u <= std::min(gt_.min_u + gt_.width - 1, cu + reach); ++u) {
      const int k = gt_.index(u, v);
      if (seen_[k]) continue;
      const float g = gt_.ground_height[k];
      if (!std::isfinite(g)) continue;
      const bool obstacle = obstacle_cell_[k] != 0;
      const Eigen::Vector3d p_w(u * res, v * res, g + (obstacle ? 0.1 : 0.0));
      const Eigen::Vector3d p = T_cw * p_w;
      if (!(p.z() > config_.min_range) || p.norm() > config_.max_range) continue;
      const double x = cam.fx * p.x() / p.z() + cam.cx;
      const double y = cam.fy * p.y() / p.z() + cam.cy;
      const int xi = static_cast<int>(std::lround(x)), yi = static_cast<int>(std::lround(y));
      if (xi < 0 || yi < 0 || xi >= depth.cols || yi >= depth.rows) continue;
      const float z = depth.at<float>(yi, xi);
      // Seen when nothing nearer hides it (an obstacle cell is seen on the obstacle's face).
      const double tolerance = obstacle ? 0.3 : std::max(0.05, 0.03 * p.z());
      if (z >= p.z() - tolerance) seen_[k] = 1;
    }
  }
}

void OpenWorldScorer::scoreDetection(const ObstacleDetectionResult& result,
                                     DetectionScore* s) const {
  ++s->frames;
  const cv::Mat& depth = frame_depth_;
  const cv::Mat& ids = frame_ids_;
  // A decimated detection (the nodelet's decimation): its pixel (r, c) is the image's (n r, n c).
  const int n = result.mask.cols > 0
                    ? std::max(1, (depth.cols + result.mask.cols - 1) / result.mask.cols)
                    : 1;
  const bool truth = !depth.empty() && depth.type() == CV_32F && !ids.empty() &&
                     ids.type() == CV_32S && (depth.cols + n - 1) / n == result.mask.cols &&
                     (depth.rows + n - 1) / n == result.mask.rows && ids.size() == depth.size();
  const bool labelled = !result.labels.empty() && result.labels.size() == result.mask.size();
  std::vector<int> raised(result.obstacles.size() + 1, 0), raised_true(raised.size(), 0);
  std::vector<std::uint8_t> detected(obstacles_.size(), 0);
  const StereoCameraModel& cam = frame_camera_;
  for (int r = 0; r < result.mask.rows; ++r) {
    const std::uint8_t* m = result.mask.ptr<std::uint8_t>(r);
    const std::int32_t* l = labelled ? result.labels.ptr<std::int32_t>(r) : nullptr;
    for (int c = 0; c < result.mask.cols; ++c) {
      if (m[c] != ObstacleDetectionResult::kRaised) continue;
      ++s->raised_points;
      const int label =
          l != nullptr && l[c] > 0 && l[c] < static_cast<int>(raised.size()) ? l[c] : 0;
      ++raised[label];
      if (!truth) {
        ++s->raised_no_truth;
        continue;
      }
      const int p = ids.at<std::int32_t>(n * r, n * c);
      const int o =
          p >= 0 && p < static_cast<int>(group_of_primitive_.size()) ? group_of_primitive_[p] : -1;
      bool ok = false;
      if (o >= 0) {
        ok = true;
        detected[o] = 1;
      } else {
        const float z = depth.at<float>(n * r, n * c);
        if (!std::isfinite(z) || !(z > 0.0f)) {
          ++s->raised_no_truth;
          continue;
        }
        const Eigen::Vector3d pc((n * c - cam.cx) * z / cam.fx, (n * r - cam.cy) * z / cam.fy, z);
        const Eigen::Vector3d pw = frame_T_world_camera_ * pc;
        const int u0 = gt_.cellOf(pw.x()), v0 = gt_.cellOf(pw.y());
        for (int dv = -1; dv <= 1 && !ok; ++dv) {
          for (int du = -1; du <= 1 && !ok; ++du) {
            const int u = u0 + du, v = v0 + dv;
            if (u < gt_.min_u || v < gt_.min_v || u >= gt_.min_u + gt_.width ||
                v >= gt_.min_v + gt_.height) {
              continue;
            }
            const int g = gt_.index(u, v);
            ok = obstacle_cell_[g] != 0 || gtClass(g) == SafetyClass::kUnsafe;
          }
        }
      }
      if (ok) {
        ++s->raised_true;
        ++raised_true[label];
      }
    }
  }
  for (std::size_t k = 0; k < result.obstacles.size(); ++k) {
    if (result.obstacles[k].rejected) continue;
    ++s->accepted;
    const int label = result.obstacles[k].label;
    if (label > 0 && label < static_cast<int>(raised.size()) &&
        2 * raised_true[label] < raised[label]) {
      ++s->accepted_false;
    }
  }
  for (std::size_t o = 0; o < obstacles_.size() && o < in_view_now_.size(); ++o) {
    if (!in_view_now_[o]) continue;
    ++s->checks;
    if (detected[o]) ++s->checks_detected;
  }
}

double reachableSafeArea(const SafetyMap& map, double footprint_radius,
                         const std::vector<std::uint8_t>* unseen) {
  const int w = map.width, h = map.height;
  const std::size_t n = static_cast<std::size_t>(std::max(0, w)) * std::max(0, h);
  if (n == 0 || map.labels.size() != n || !(map.resolution > 0.0)) return 0.0;
  if (unseen != nullptr && unseen->size() != n) unseen = nullptr;
  // A cell the flood may enter: safe ground, or an Unknown / Unexamined cell whose ground the
  // camera never saw (passed through, not counted).
  auto passable = [&](std::size_t c) {
    const SafetyLabel l = map.labels[c];
    if (isSafe(l)) return true;
    return unseen != nullptr && (*unseen)[c] != 0 &&
           (l == SafetyLabel::kUnknown || l == SafetyLabel::kUnexamined);
  };
  std::vector<std::uint8_t> reached(n, 0);
  std::vector<int> stack;
  const int r = static_cast<int>(std::floor(footprint_radius / map.resolution + 1e-9));
  const long long r2 = static_cast<long long>(r) * r;
  for (int dv = -r; dv <= r; ++dv) {
    for (int du = -r; du <= r; ++du) {
      const int u = map.robot_u + du, v = map.robot_v + dv;
      if (static_cast<long long>(du) * du + static_cast<long long>(dv) * dv > r2) continue;
      if (!map.inside(u, v)) continue;
      const int c = map.index(u, v);
      if (reached[c] || !passable(c)) continue;
      reached[c] = 1;
      stack.push_back(c);
    }
  }
  std::size_t count = 0;
  while (!stack.empty()) {
    const int c = stack.back();
    stack.pop_back();
    if (isSafe(map.labels[c])) ++count;
    const int cu = c % w, cv = c / w;
    for (int dv = -1; dv <= 1; ++dv) {
      for (int du = -1; du <= 1; ++du) {
        const int u = cu + du, v = cv + dv;
        if (u < 0 || v < 0 || u >= w || v >= h) continue;
        const int k = v * w + u;
        if (reached[k] || !passable(k)) continue;
        reached[k] = 1;
        stack.push_back(k);
      }
    }
  }
  return static_cast<double>(count) * map.resolution * map.resolution;
}

void OpenWorldScorer::scoreMap(int variant, const SafetyMap& map, double t,
                               const Eigen::Isometry2d& T_world_odom, const Eigen::Vector2d& robot,
                               SceneScore* s) {
  VariantState& state = variants_.at(variant);
  ++s->maps;
  if (t >= config_.segment_grace_s) {
    ++s->maps_after_grace;
    if (map.robot_segment < 0) ++s->maps_without_robot_segment;
    // Cells whose ground the camera never saw (the blind zone in front of a chair at rest,
    // ground behind it) cannot be known: the chair is not stuck behind them.
    unseen_.assign(map.labels.size(), 0);
    for (int v = map.min_v; v < map.min_v + map.height; ++v) {
      for (int u = map.min_u; u < map.min_u + map.width; ++u) {
        const int g =
            gtIndexOf(T_world_odom * Eigen::Vector2d(u * map.resolution, v * map.resolution));
        unseen_[map.index(u, v)] = g < 0 || !seen_[g];
      }
    }
    if (reachableSafeArea(map, config_.footprint_radius, &unseen_) < config_.stuck_area) {
      ++s->maps_stuck;
    }
    // The same measure on the ground truth at the true robot position: the check that the
    // scenes leave the chair free ground (maps_stuck_truth should stay 0).
    truth_map_.min_u = gt_.min_u;
    truth_map_.min_v = gt_.min_v;
    truth_map_.width = gt_.width;
    truth_map_.height = gt_.height;
    truth_map_.resolution = gt_.resolution;
    truth_map_.robot_u = gt_.cellOf(robot.x());
    truth_map_.robot_v = gt_.cellOf(robot.y());
    truth_map_.labels = gt_.labels;
    if (reachableSafeArea(truth_map_, config_.footprint_radius) < config_.stuck_area) {
      ++s->maps_stuck_truth;
    }
  }
  const double res = map.resolution;
  const double r2 = config_.planning_radius * config_.planning_radius;

  // Rates: every map cell against the GT cell under its centre.
  for (int v = map.min_v; v < map.min_v + map.height; ++v) {
    for (int u = map.min_u; u < map.min_u + map.width; ++u) {
      const SafetyLabel l = map.labelAt(u, v);
      const SafetyClass mc = safetyClassOf(l);
      const Eigen::Vector2d w = T_world_odom * Eigen::Vector2d(u * res, v * res);
      const int g = gtIndexOf(w);
      const std::int64_t key = cellKey(u, v);
      if (g >= 0 && obstacle_cell_[g]) {
        // Forgotten obstacles: this map cell was Non-ground over an obstacle and is now safe.
        if (l == SafetyLabel::kNonGround) {
          state.non_ground.emplace(key, 0);
        } else if (isSafe(l)) {
          const auto it = state.non_ground.find(key);
          if (it != state.non_ground.end()) {
            ++s->forgotten_events;
            if (it->second == 0) {
              ++s->forgotten_cells;
              if (s->forgotten.size() < kMaxForgottenLines) {
                const int o = obstacle_of_[g];
                char line[256];
                std::snprintf(line, sizeof(line),
                              "%s at t = %.1f s: cell (%.2f, %.2f) %.2f m from the robot -> %s",
                              o >= 0 ? obstacles_[o].group.c_str() : "(solid)", t, w.x(), w.y(),
                              (w - robot).norm(), toString(l));
                s->forgotten.push_back(line);
              }
            }
            it->second = 1;
          }
        }
      }
      if (mc == SafetyClass::kUnclassified || g < 0) continue;
      const SafetyLabel truth = gt_.labels[g];
      const CellOutcome o0 = cellOutcome(l, truth);
      add(&s->tol0, o0);
      CellOutcome o1 = o0;
      const int gu = gt_.min_u + g % gt_.width, gv = gt_.min_v + g / gt_.width;
      if (o0 == CellOutcome::kFalsePositive &&
          neighbourOfClass(gt_, gu, gv, SafetyClass::kUnsafe)) {
        o1 = CellOutcome::kTruePositive;
      } else if (o0 == CellOutcome::kFalseNegative &&
                 neighbourOfClass(gt_, gu, gv, SafetyClass::kSafe)) {
        o1 = CellOutcome::kTrueNegative;
      }
      add(&s->tol1, o1);
      if (o1 == CellOutcome::kFalsePositive) {
        const int k = map.segment[map.index(u, v)];
        const int src = k < 0 || k >= static_cast<int>(map.segments.size())
                            ? SceneScore::kFpNoSegment
                            : (isSafe(map.segments[k].label) ? SceneScore::kFpSafeSegment
                                                             : SceneScore::kFpUnsafeSegment);
        const double d = (w - robot).norm();
        const int bin = std::min(SceneScore::kFpRangeBins - 1,
                                 std::max(0, static_cast<int>(std::floor(d - 0.5))));
        ++s->fp_sources[src * SceneScore::kFpRangeBins + bin];
      }
      add(&s->by_class[static_cast<int>(classes_[g])], o1);
      if (local_ != nullptr) {
        const SafetyLabel lt = local_->labels[g];
        CellOutcome ol = cellOutcome(l, lt);
        if (ol == CellOutcome::kFalsePositive &&
            neighbourOfClass(*local_, gu, gv, SafetyClass::kUnsafe)) {
          ol = CellOutcome::kTruePositive;
        } else if (ol == CellOutcome::kFalseNegative &&
                   neighbourOfClass(*local_, gu, gv, SafetyClass::kSafe)) {
          ol = CellOutcome::kTrueNegative;
        }
        add(&s->local_tol1, ol);
      }
    }
  }
  s->tol0.maps += 1;
  s->tol1.maps += 1;
  s->local_tol1.maps += 1;

  // Coverage: GT-classified cells within R_max of the robot, seen by the camera so far.
  const Eigen::Isometry2d T_odom_world = T_world_odom.inverse();
  const int reach = static_cast<int>(std::ceil(config_.planning_radius / gt_.resolution));
  const int ru = gt_.cellOf(robot.x()), rv = gt_.cellOf(robot.y());
  for (int v = std::max(gt_.min_v, rv - reach);
       v <= std::min(gt_.min_v + gt_.height - 1, rv + reach); ++v) {
    for (int u = std::max(gt_.min_u, ru - reach);
         u <= std::min(gt_.min_u + gt_.width - 1, ru + reach); ++u) {
      const int k = gt_.index(u, v);
      if (!seen_[k] || gtClass(k) == SafetyClass::kUnclassified) continue;
      const Eigen::Vector2d w = gt_.cellCenter(u, v);
      if ((w - robot).squaredNorm() > r2) continue;
      ++s->coverage_cells;
      const Eigen::Vector2d q = T_odom_world * w;
      const int mu = static_cast<int>(std::lround(q.x() / res));
      const int mv = static_cast<int>(std::lround(q.y() / res));
      if (map.inside(mu, mv) && safetyClassOf(map.labelAt(mu, mv)) != SafetyClass::kUnclassified) {
        ++s->coverage_classified;
      }
    }
  }

  // Obstacle checks.
  auto mapLabelOfGt = [&](int k, bool* inside) {
    const Eigen::Vector2d q =
        T_odom_world * gt_.cellCenter(gt_.min_u + k % gt_.width, gt_.min_v + k / gt_.width);
    const int mu = static_cast<int>(std::lround(q.x() / res));
    const int mv = static_cast<int>(std::lround(q.y() / res));
    *inside = map.inside(mu, mv);
    return *inside ? map.labelAt(mu, mv) : SafetyLabel::kUnknown;
  };
  const double examined2 = (config_.planning_radius - 2.0 * gt_.resolution) *
                           (config_.planning_radius - 2.0 * gt_.resolution);
  for (std::size_t o = 0; o < obstacles_.size(); ++o) {
    const Obstacle& ob = obstacles_[o];
    if (ob.frames_in_view < 1) continue;
    bool within = false;
    for (const int k : ob.cells) {
      const Eigen::Vector2d c =
          gt_.cellCenter(gt_.min_u + k % gt_.width, gt_.min_v + k / gt_.width);
      if ((c - robot).squaredNorm() <= examined2) {
        within = true;
        break;
      }
    }
    if (!within) continue;
    bool detected = false;
    for (const int k : ob.cells_dilated) {
      bool inside;
      if (mapLabelOfGt(k, &inside) == SafetyLabel::kNonGround) {
        detected = true;
        break;
      }
    }
    int safe_inside = 0;
    for (const int k : ob.cells) {
      bool inside;
      if (isSafe(mapLabelOfGt(k, &inside))) ++safe_inside;
    }
    const bool missed = !detected || safe_inside > 0;
    ++s->obstacle_maps_strict;
    if (missed) {
      ++s->obstacle_maps_missed_strict;
      if (!state.missed_strict[o]) {
        state.missed_strict[o] = 1;
        ++s->obstacles_missed_strict;
      }
    }
    if (ob.frames_in_view >= config_.obstacle_lenient_frames) {
      ++s->obstacle_maps_lenient;
      s->obstacle_safe_cells += safe_inside;
      if (missed) {
        ++s->obstacle_maps_missed_lenient;
        if (!state.missed_lenient[o]) {
          state.missed_lenient[o] = 1;
          ++s->obstacles_missed_lenient;
          char line[256];
          std::snprintf(line, sizeof(line), "%s at t = %.1f s: %s%s", ob.group.c_str(), t,
                        detected ? "" : "no Non-ground cell",
                        safe_inside > 0 ? (detected ? "cells inside Level / Inclined"
                                                    : ", cells inside Level / Inclined")
                                        : "");
          s->misses.push_back(line);
        }
      }
    }
  }
}

void OpenWorldScorer::finish(SceneScore* s) const {
  s->obstacles = static_cast<int>(obstacles_.size());
  s->obstacles_in_view =
      static_cast<int>(std::count_if(obstacles_.begin(), obstacles_.end(),
                                     [](const Obstacle& o) { return o.frames_in_view > 0; }));
}

}  // namespace dataset
}  // namespace stereo_safety_map
