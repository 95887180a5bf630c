// Fusion of the single-frame obstacle cue into the safety map. See obstacle_cue.h.
#include "stereo_safety_map/core/obstacle_cue.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace stereo_safety_map {

std::string ObstacleCueConfig::validate() const {
  std::ostringstream os;
  if (!std::isfinite(lifetime) || lifetime < 0.0 || lifetime > 60.0) {
    os << "lifetime = " << lifetime << ", must be in [0, 60] s";
  } else if (min_points_per_cell < 1 || min_points_per_cell > 1000000) {
    os << "min_points_per_cell = " << min_points_per_cell << ", must be in [1, 1000000]";
  } else if (max_cues < 1 || max_cues > 10000) {
    os << "max_cues = " << max_cues << ", must be in [1, 10000]";
  }
  return os.str();
}

ObstacleCueFusion::ObstacleCueFusion(const ObstacleCueConfig& config) : config_(config) {
  const std::string err = config_.validate();
  if (!err.empty()) throw std::invalid_argument("ObstacleCueConfig: " + err);
}

void ObstacleCueFusion::clear() {
  count_ = 0;  // slots keep their capacity
}

void ObstacleCueFusion::forget(std::size_t k) {
  // Keep arrival order: rotate the slot (and its buffer) to the end of the live ones.
  std::rotate(cues_.begin() + static_cast<std::ptrdiff_t>(k),
              cues_.begin() + static_cast<std::ptrdiff_t>(k) + 1,
              cues_.begin() + static_cast<std::ptrdiff_t>(count_));
  --count_;
}

bool ObstacleCueFusion::addCue(double stamp, const std::vector<Eigen::Vector3f>& points_fixed) {
  if (!std::isfinite(stamp)) return false;
  if (count_ == static_cast<std::size_t>(config_.max_cues)) forget(0);  // the oldest
  if (cues_.size() == count_) cues_.emplace_back();
  Cue& cue = cues_[count_++];
  cue.stamp = stamp;
  cue.points.clear();
  for (const Eigen::Vector3f& p : points_fixed) {
    if (p.allFinite()) cue.points.push_back(p);
  }
  return true;
}

ObstacleCueStats ObstacleCueFusion::apply(double stamp, float max_z, SafetyMap* map,
                                          std::vector<std::uint8_t>* marked) {
  ObstacleCueStats stats;
  if (marked != nullptr) marked->clear();
  if (map == nullptr || !std::isfinite(stamp)) return stats;
  // Forget the cues outside the window around the map's stamp.
  for (std::size_t k = 0; k < count_;) {
    if (std::fabs(cues_[k].stamp - stamp) > config_.lifetime) {
      forget(k);
    } else {
      ++k;
    }
  }
  stats.live_cues = static_cast<int>(count_);
  const std::size_t cells = static_cast<std::size_t>(std::max(0, map->width)) *
                            static_cast<std::size_t>(std::max(0, map->height));
  if (count_ == 0 || cells == 0 || map->labels.size() != cells || !(map->resolution > 0.0)) {
    return stats;
  }
  counts_.assign(cells, 0u);
  if (marked != nullptr) marked->assign(cells, 0);
  // Cell (u, v) is centred at (u l_v, v l_v) (000 Eq. (1)): u = floor(x / l_v + 1/2).
  const double inv = 1.0 / map->resolution;
  for (std::size_t k = 0; k < count_; ++k) {
    for (const Eigen::Vector3f& p : cues_[k].points) {
      if (!(p.z() <= max_z)) continue;  // overhang (or NaN max_z: nothing counts)
      const double fu = std::floor(p.x() * inv + 0.5), fv = std::floor(p.y() * inv + 0.5);
      if (fu < map->min_u || fv < map->min_v || fu >= map->min_u + map->width ||
          fv >= map->min_v + map->height) {
        continue;
      }
      ++counts_[static_cast<std::size_t>(map->index(static_cast<int>(fu), static_cast<int>(fv)))];
      ++stats.points_used;
    }
  }
  const std::uint32_t need = static_cast<std::uint32_t>(config_.min_points_per_cell);
  const bool has_drop_off = map->drop_off.size() == cells;
  for (std::size_t i = 0; i < cells; ++i) {
    if (counts_[i] < need) continue;
    ++stats.cells_marked;
    if (marked != nullptr) (*marked)[i] = 1;
    if (has_drop_off) map->drop_off[i] = 0;  // drop-off edges annotate safe cells only
    SafetyLabel& l = map->labels[i];
    if (l == SafetyLabel::kNonGround) continue;
    if (isSafe(l)) ++stats.safe_cells_changed;
    l = SafetyLabel::kNonGround;
    ++stats.cells_changed;
  }
  return stats;
}

}  // namespace stereo_safety_map
