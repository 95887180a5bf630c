#include "stereo_safety_map/core/hybrid_safety_map.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

bool visionUsable(const SafetyMap& m) {
  return m.width > 0 && m.height > 0 && std::isfinite(m.resolution) && m.resolution > 0.0 &&
         m.labels.size() == static_cast<std::size_t>(m.width) * m.height;
}

bool isUnsafe(HybridLabel l) {
  return l == HybridLabel::kObstacle || l == HybridLabel::kHazard;
}

// The table in the header, merged column by column.
HybridLabel mergedLabel(SafetyLabel vision, LaserCellState laser,
                        const HybridSafetyMapConfig& cfg) {
  if (laser == LaserCellState::kOccupied) return HybridLabel::kObstacle;
  const bool laser_free = laser == LaserCellState::kFree;
  switch (vision) {
    case SafetyLabel::kNonGround:
      return HybridLabel::kHazard;
    case SafetyLabel::kInclined:
      return laser_free || !cfg.laser_free_required_for_safe ? HybridLabel::kCaution
                                                             : HybridLabel::kUnknown;
    case SafetyLabel::kLevel:
      return laser_free || !cfg.laser_free_required_for_safe ? HybridLabel::kSafe
                                                             : HybridLabel::kUnknown;
    case SafetyLabel::kUnknown:
    case SafetyLabel::kUnexamined:
    default:
      return laser_free && cfg.laser_free_vision_unknown_is_safe ? HybridLabel::kSafe
                                                                 : HybridLabel::kUnknown;
  }
}

HybridLabel laserOnlyLabel(LaserCellState laser) {
  switch (laser) {
    case LaserCellState::kOccupied:
      return HybridLabel::kObstacle;
    case LaserCellState::kFree:
      return HybridLabel::kSafe;  // 001 Sec. 5: clear areas are considered safe
    default:
      return HybridLabel::kUnknown;
  }
}

HybridLabel stereoOnlyLabel(SafetyLabel vision) {
  switch (vision) {
    case SafetyLabel::kNonGround:
      return HybridLabel::kObstacle;  // 001 Sec. 5: no hazard / obstacle distinction
    case SafetyLabel::kInclined:
      return HybridLabel::kCaution;
    case SafetyLabel::kLevel:
      return HybridLabel::kSafe;
    default:
      return HybridLabel::kUnknown;
  }
}

}  // namespace

const char* toString(HybridLabel label) {
  switch (label) {
    case HybridLabel::kUnknown:
      return "unknown";
    case HybridLabel::kSafe:
      return "safe";
    case HybridLabel::kCaution:
      return "caution";
    case HybridLabel::kHazard:
      return "hazard";
    case HybridLabel::kObstacle:
      return "obstacle";
  }
  return "invalid";
}

std::int8_t toOccupancyValue(HybridLabel label, const HybridSafetyMapConfig& config) {
  // The one translation table to nav_msgs/OccupancyGrid (-1 unknown, 0..100 cost).
  switch (label) {
    case HybridLabel::kSafe:
      return 0;
    case HybridLabel::kCaution:
      return static_cast<std::int8_t>(config.caution_cost);
    case HybridLabel::kHazard:
      return static_cast<std::int8_t>(config.hazard_cost);
    case HybridLabel::kObstacle:
      return 100;
    case HybridLabel::kUnknown:
    default:
      return -1;
  }
}

std::string HybridSafetyMapConfig::validate() const {
  if (!std::isfinite(min_passage_width) || min_passage_width <= 0.0 || min_passage_width > 100.0) {
    std::ostringstream s;
    s << "min_passage_width = " << min_passage_width << " is out of range (0, 100] m";
    return s.str();
  }
  if (hazard_cost < 1 || hazard_cost > 100) {
    return "hazard_cost = " + std::to_string(hazard_cost) + " is out of range [1, 100]";
  }
  if (caution_cost < 0 || caution_cost > 99) {
    return "caution_cost = " + std::to_string(caution_cost) +
           " is out of range [0, 99] (below lethal: Caution is drivable)";
  }
  return {};
}

HybridSafetyMapBuilder::HybridSafetyMapBuilder(const HybridSafetyMapConfig& config)
    : config_(config) {
  const std::string why = config_.validate();
  if (!why.empty()) throw std::invalid_argument("HybridSafetyMapConfig: " + why);
}

void HybridSafetyMapBuilder::build(HybridSource source, const SafetyMap& vision,
                                   const LaserGrid& laser, HybridSafetyMap* out) {
  const bool use_vision = visionUsable(vision);
  if (use_vision) {
    out->min_u = vision.min_u;
    out->min_v = vision.min_v;
    out->width = vision.width;
    out->height = vision.height;
    out->resolution = vision.resolution;
  } else {
    out->min_u = laser.minU();
    out->min_v = laser.minV();
    out->width = laser.width();
    out->height = laser.height();
    out->resolution = laser.resolution();
  }
  const std::size_t n = static_cast<std::size_t>(out->width) * out->height;
  out->labels.assign(n, HybridLabel::kUnknown);
  const bool has_drop_off = use_vision && vision.drop_off.size() == n;

  for (int row = 0; row < out->height; ++row) {
    const int v = out->min_v + row;
    for (int col = 0; col < out->width; ++col) {
      const int u = out->min_u + col;
      const std::size_t i = static_cast<std::size_t>(row) * out->width + col;
      const SafetyLabel vl = use_vision ? vision.labels[i] : SafetyLabel::kUnknown;
      // The laser cell under this cell's centre (the grids need not coincide).
      const LaserCellState ls = laser.stateAt(u * out->resolution, v * out->resolution);
      HybridLabel label;
      switch (source) {
        case HybridSource::kLaserOnly:
          label = laserOnlyLabel(ls);
          break;
        case HybridSource::kStereoOnly:
          label = stereoOnlyLabel(vl);
          break;
        case HybridSource::kMerged:
        default:
          label = mergedLabel(vl, ls, config_);
          break;
      }
      // Potential Drop-off Edges need further observation (000 Sec. VI). A planner must not
      // cross one before it was observed: Hazard (lethal) by default; Caution (a cost below
      // lethal, which a trinary costmap reads as free) only when drop_off_edges_are_hazard is off.
      const bool on_edge = has_drop_off && vision.drop_off[i] && source != HybridSource::kLaserOnly;
      if (on_edge && config_.drop_off_edges_are_hazard &&
          (label == HybridLabel::kSafe || label == HybridLabel::kCaution)) {
        label = HybridLabel::kHazard;
      } else if (on_edge && label == HybridLabel::kSafe && config_.drop_off_edges_are_caution) {
        label = HybridLabel::kCaution;
      }
      out->labels[i] = label;
    }
  }
  if (config_.detect_narrow_passages) markNarrowPassages(out);
}

void HybridSafetyMapBuilder::markNarrowPassages(HybridSafetyMap* map) {
  const int w = map->width, h = map->height;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  if (n == 0) return;
  narrow_.assign(n, 0);
  run_back_.resize(n);
  run_fwd_.resize(n);
  bounded_back_.resize(n);
  bounded_fwd_.resize(n);
  const auto unsafe = [map](std::size_t i) { return isUnsafe(map->labels[i]); };
  constexpr double kEps = 1e-9;

  // Directions 0, 90, 45 and 135 degrees. Along each, a cell's span is the run of consecutive
  // non-unsafe cells through it; it is a passage only when unsafe cells close it at both ends
  // (the map border or nothing does not).
  const int dirs[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  for (const auto& d : dirs) {
    const int du = d[0], dv = d[1];
    const double step = map->resolution * ((du != 0 && dv != 0) ? std::sqrt(2.0) : 1.0);
    // Visiting rows in the order that puts a cell's predecessor (u - du, v - dv) first.
    const auto sweep = [&](bool forward, std::vector<std::int32_t>* run,
                           std::vector<std::uint8_t>* bounded) {
      const int su = forward ? -du : du, sv = forward ? -dv : dv;  // offset to the predecessor
      const bool rows_up = sv < 0 || (sv == 0 && forward);
      const bool cols_up = su < 0 || (su == 0 && forward);
      for (int k = 0; k < h; ++k) {
        const int row = rows_up ? k : h - 1 - k;
        for (int j = 0; j < w; ++j) {
          const int col = cols_up ? j : w - 1 - j;
          const std::size_t i = static_cast<std::size_t>(row) * w + col;
          if (unsafe(i)) {
            (*run)[i] = 0;
            (*bounded)[i] = 1;
            continue;
          }
          const int pr = row + sv, pc = col + su;
          if (pr < 0 || pr >= h || pc < 0 || pc >= w) {
            (*run)[i] = 1;
            (*bounded)[i] = 0;
            continue;
          }
          const std::size_t p = static_cast<std::size_t>(pr) * w + pc;
          (*run)[i] = (*run)[p] + 1;
          (*bounded)[i] = unsafe(p) ? 1 : (*bounded)[p];
        }
      }
    };
    sweep(true, &run_back_, &bounded_back_);
    sweep(false, &run_fwd_, &bounded_fwd_);
    for (std::size_t i = 0; i < n; ++i) {
      if (unsafe(i) || !bounded_back_[i] || !bounded_fwd_[i]) continue;
      const double span = (run_back_[i] + run_fwd_[i] - 1) * step;
      if (span < config_.min_passage_width - kEps) narrow_[i] = 1;
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (narrow_[i] && map->labels[i] == HybridLabel::kSafe) {
      map->labels[i] = HybridLabel::kCaution;  // narrow region (001 Sec. 2.1)
    }
  }
}

SafetyClass safetyClassOf(HybridLabel label) {
  switch (label) {
    case HybridLabel::kSafe:
    case HybridLabel::kCaution:
      return SafetyClass::kSafe;
    case HybridLabel::kHazard:
    case HybridLabel::kObstacle:
      return SafetyClass::kUnsafe;
    default:
      return SafetyClass::kUnclassified;
  }
}

std::string countHybridConfusion(const HybridSafetyMap& map, const HybridSafetyMap& ground_truth,
                                 ConfusionCounts* counts) {
  if (counts == nullptr) return "counts must not be null";
  for (const HybridSafetyMap* m : {&map, &ground_truth}) {
    const char* which = m == &map ? "map" : "ground truth";
    if (m->width < 0 || m->height < 0 ||
        m->labels.size() != static_cast<std::size_t>(m->width) * m->height) {
      std::ostringstream os;
      os << which << " has " << m->labels.size() << " labels for " << m->width << " x " << m->height
         << " cells";
      return os.str();
    }
    if (!std::isfinite(m->resolution) || m->resolution <= 0.0) {
      return std::string(which) + " resolution must be finite and > 0";
    }
  }
  if (std::abs(map.resolution - ground_truth.resolution) > 1e-6 * ground_truth.resolution) {
    std::ostringstream os;
    os << "resolutions differ: map " << map.resolution << " m, ground truth "
       << ground_truth.resolution << " m";
    return os.str();
  }
  ConfusionCounts c;
  c.maps = 1;
  for (int row = 0; row < map.height; ++row) {
    for (int col = 0; col < map.width; ++col) {
      const SafetyClass mc =
          safetyClassOf(map.labels[static_cast<std::size_t>(row) * map.width + col]);
      const SafetyClass tc = safetyClassOf(ground_truth.labelAt(map.min_u + col, map.min_v + row));
      if (mc == SafetyClass::kUnclassified || tc == SafetyClass::kUnclassified) {
        if (mc != SafetyClass::kUnclassified) ++c.unclassified_in_gt;
        if (tc != SafetyClass::kUnclassified) ++c.unclassified_in_map;
        continue;
      }
      const bool m_unsafe = mc == SafetyClass::kUnsafe;
      const bool t_unsafe = tc == SafetyClass::kUnsafe;
      if (m_unsafe && t_unsafe) ++c.tp;
      if (m_unsafe && !t_unsafe) ++c.fp;
      if (!m_unsafe && t_unsafe) ++c.fn;
      if (!m_unsafe && !t_unsafe) ++c.tn;
    }
  }
  *counts += c;
  return {};
}

}  // namespace stereo_safety_map
