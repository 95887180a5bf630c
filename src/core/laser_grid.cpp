#include "stereo_safety_map/core/laser_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

template <typename T>
std::string rangeMessage(const char* name, T value, const char* range) {
  std::ostringstream s;
  s << name << " = " << value << " is out of range " << range;
  return s.str();
}

int positiveModulo(int a, int m) {
  const int r = a % m;
  return r < 0 ? r + m : r;
}

// Liang-Barsky: clips the segment a + t (b - a), t in [0, 1], to [x0, x1] x [y0, y1].
bool clipSegment(double x0, double y0, double x1, double y1, double* ax, double* ay, double* bx,
                 double* by, bool* end_clipped) {
  const double dx = *bx - *ax, dy = *by - *ay;
  double t0 = 0.0, t1 = 1.0;
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {*ax - x0, x1 - *ax, *ay - y0, y1 - *ay};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0.0) {
      if (q[i] < 0.0) return false;
      continue;
    }
    const double t = q[i] / p[i];
    if (p[i] < 0.0) {
      if (t > t1) return false;
      t0 = std::max(t0, t);
    } else {
      if (t < t0) return false;
      t1 = std::min(t1, t);
    }
  }
  *end_clipped = t1 < 1.0;
  const double sx = *ax, sy = *ay;
  *ax = sx + t0 * dx;
  *ay = sy + t0 * dy;
  *bx = sx + t1 * dx;
  *by = sy + t1 * dy;
  return true;
}

}  // namespace

std::string LaserGridConfig::validate() const {
  if (!std::isfinite(resolution) || resolution <= 0.0) {
    return rangeMessage("resolution", resolution, "(0, inf) m");
  }
  if (width < 1 || width > 100000) return rangeMessage("width", width, "[1, 100000] cells");
  if (height < 1 || height > 100000) return rangeMessage("height", height, "[1, 100000] cells");
  if (static_cast<long long>(width) * height > 100000000LL) {
    return "width * height = " + std::to_string(static_cast<long long>(width) * height) +
           " cells is out of range [1, 1e8]";
  }
  if (!std::isfinite(log_odds_hit) || log_odds_hit <= 0.0) {
    return rangeMessage("log_odds_hit", log_odds_hit, "(0, inf)");
  }
  if (!std::isfinite(log_odds_miss) || log_odds_miss >= 0.0) {
    return rangeMessage("log_odds_miss", log_odds_miss, "(-inf, 0)");
  }
  if (!std::isfinite(free_threshold) || free_threshold >= 0.0) {
    return rangeMessage("free_threshold", free_threshold, "[log_odds_min, 0)");
  }
  if (!std::isfinite(occupied_threshold) || occupied_threshold <= 0.0) {
    return rangeMessage("occupied_threshold", occupied_threshold, "(0, log_odds_max]");
  }
  if (!std::isfinite(log_odds_min) || log_odds_min > free_threshold) {
    return rangeMessage("log_odds_min", log_odds_min, "(-inf, free_threshold]");
  }
  if (!std::isfinite(log_odds_max) || log_odds_max < occupied_threshold) {
    return rangeMessage("log_odds_max", log_odds_max, "[occupied_threshold, inf)");
  }
  return {};
}

LaserGrid::LaserGrid(const LaserGridConfig& config) : config_(config) {
  const std::string why = config_.validate();
  if (!why.empty()) throw std::invalid_argument("LaserGridConfig: " + why);
  const std::size_t n = static_cast<std::size_t>(config_.width) * config_.height;
  log_odds_.assign(n, 0.0f);
  hit_scan_.assign(n, 0);
  miss_scan_.assign(n, 0);
  min_u_ = -config_.width / 2;
  min_v_ = -config_.height / 2;
}

int LaserGrid::cellU(double x) const {
  return static_cast<int>(std::floor(x / config_.resolution + 0.5));
}
int LaserGrid::cellV(double y) const {
  return static_cast<int>(std::floor(y / config_.resolution + 0.5));
}

std::size_t LaserGrid::storageIndex(int u, int v) const {
  return static_cast<std::size_t>(positiveModulo(v, config_.height)) * config_.width +
         positiveModulo(u, config_.width);
}

void LaserGrid::clear() {
  std::fill(log_odds_.begin(), log_odds_.end(), 0.0f);
}

void LaserGrid::clearColumn(int u) {
  const int c = positiveModulo(u, config_.width);
  for (int r = 0; r < config_.height; ++r) {
    log_odds_[static_cast<std::size_t>(r) * config_.width + c] = 0.0f;
  }
}

void LaserGrid::clearRow(int v) {
  const std::size_t r = static_cast<std::size_t>(positiveModulo(v, config_.height));
  std::fill_n(log_odds_.begin() + r * config_.width, config_.width, 0.0f);
}

std::size_t LaserGrid::moveTo(int min_u, int min_v) {
  const long long du = static_cast<long long>(min_u) - min_u_;
  const long long dv = static_cast<long long>(min_v) - min_v_;
  const int w = config_.width, h = config_.height;
  if (du == 0 && dv == 0) return 0;
  if (std::llabs(du) >= w || std::llabs(dv) >= h) {
    clear();
    min_u_ = min_u;
    min_v_ = min_v;
    return static_cast<std::size_t>(w) * h;
  }
  // The storage column of a global u that leaves is the one of the u that enters (ring buffer).
  if (du > 0) {
    for (int u = min_u_; u < min_u_ + du; ++u) {
      clearColumn(u);
    }
  } else {
    for (int u = min_u_ + w + static_cast<int>(du); u < min_u_ + w; ++u) {
      clearColumn(u);
    }
  }
  if (dv > 0) {
    for (int v = min_v_; v < min_v_ + dv; ++v) {
      clearRow(v);
    }
  } else {
    for (int v = min_v_ + h + static_cast<int>(dv); v < min_v_ + h; ++v) {
      clearRow(v);
    }
  }
  min_u_ = min_u;
  min_v_ = min_v;
  const long long adu = std::llabs(du), adv = std::llabs(dv);
  return static_cast<std::size_t>(adu * h + adv * w - adu * adv);
}

std::size_t LaserGrid::recenter(double x, double y) {
  if (!std::isfinite(x) || !std::isfinite(y)) return 0;
  return moveTo(cellU(x) - config_.width / 2, cellV(y) - config_.height / 2);
}

float LaserGrid::logOdds(int u, int v) const {
  return inside(u, v) ? log_odds_[storageIndex(u, v)] : 0.0f;
}

LaserCellState LaserGrid::state(int u, int v) const {
  if (!inside(u, v)) return LaserCellState::kUnknown;
  const float l = log_odds_[storageIndex(u, v)];
  if (l >= config_.occupied_threshold) return LaserCellState::kOccupied;
  if (l <= config_.free_threshold) return LaserCellState::kFree;
  return LaserCellState::kUnknown;
}

void LaserGrid::setLogOdds(int u, int v, float log_odds) {
  if (!inside(u, v) || !std::isfinite(log_odds)) return;
  log_odds_[storageIndex(u, v)] = static_cast<float>(
      std::min(config_.log_odds_max, std::max(config_.log_odds_min, double{log_odds})));
}

void LaserGrid::applyMiss(int u, int v, LaserIntegrationStats* stats) {
  if (!inside(u, v)) return;
  const std::size_t k = storageIndex(u, v);
  if (hit_scan_[k] == scan_ || miss_scan_[k] == scan_) return;
  miss_scan_[k] = scan_;
  log_odds_[k] =
      static_cast<float>(std::max(config_.log_odds_min, log_odds_[k] + config_.log_odds_miss));
  ++stats->cells_freed;
}

void LaserGrid::castRay(double ax, double ay, double bx, double by, bool end_is_hit,
                        LaserIntegrationStats* stats) {
  // Amanatides-Woo traversal of the cells the segment crosses.
  int u = static_cast<int>(std::floor(ax));
  int v = static_cast<int>(std::floor(ay));
  const int end_u = static_cast<int>(std::floor(bx));
  const int end_v = static_cast<int>(std::floor(by));
  const double dx = bx - ax, dy = by - ay;
  const int step_u = dx > 0.0 ? 1 : -1;
  const int step_v = dy > 0.0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double delta_u = dx != 0.0 ? std::abs(1.0 / dx) : inf;
  const double delta_v = dy != 0.0 ? std::abs(1.0 / dy) : inf;
  double t_u = dx > 0.0 ? (u + 1 - ax) * delta_u : (dx < 0.0 ? (ax - u) * delta_u : inf);
  double t_v = dy > 0.0 ? (v + 1 - ay) * delta_v : (dy < 0.0 ? (ay - v) * delta_v : inf);
  // Bounded even if rounding makes the walk miss the end cell.
  const long long max_steps = std::llabs(static_cast<long long>(end_u) - u) +
                              std::llabs(static_cast<long long>(end_v) - v) + 1;
  for (long long i = 0; i < max_steps; ++i) {
    if (u == end_u && v == end_v) break;
    applyMiss(u, v, stats);
    if (t_u < t_v) {
      t_u += delta_u;
      u += step_u;
    } else {
      t_v += delta_v;
      v += step_v;
    }
  }
  if (!end_is_hit) applyMiss(end_u, end_v, stats);
}

LaserIntegrationStats LaserGrid::integrate(const LaserScanInfo& scan,
                                           const std::vector<float>& ranges,
                                           const Eigen::Isometry3f& T_fixed_laser) {
  LaserIntegrationStats stats;
  stats.beams = ranges.size();
  const bool geometry_ok = std::isfinite(scan.angle_min) && std::isfinite(scan.angle_increment) &&
                           scan.angle_increment != 0.0 && std::isfinite(scan.range_min) &&
                           std::isfinite(scan.range_max) && scan.range_min >= 0.0 &&
                           scan.range_max > scan.range_min;
  if (!geometry_ok || !T_fixed_laser.matrix().allFinite()) {
    stats.rejected = true;
    return stats;
  }
  if (ranges.empty()) return stats;
  if (++scan_ == 0) {  // wrapped: forget the stamps of 2^32 scans ago
    std::fill(hit_scan_.begin(), hit_scan_.end(), 0);
    std::fill(miss_scan_.begin(), miss_scan_.end(), 0);
    scan_ = 1;
  }

  const double inv_res = 1.0 / config_.resolution;
  const Eigen::Isometry3d T = T_fixed_laser.cast<double>();
  // Cell coordinates: cell u spans [u, u + 1), i.e. x / resolution + 0.5.
  const double ox = T.translation().x() * inv_res + 0.5;
  const double oy = T.translation().y() * inv_res + 0.5;

  // Pass 1: endpoints and hits, so that no beam of this scan clears a cell another one hit.
  endpoints_.clear();
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    const double r = ranges[i];
    bool hit;
    double range;
    if (std::isnan(r) || r < scan.range_min) {
      ++stats.invalid;
      continue;
    }
    if (r >= scan.range_max) {  // includes +inf: nothing within range (REP 117)
      ++stats.no_return;
      if (!config_.clear_no_return) continue;
      hit = false;
      range = scan.range_max;
    } else {
      ++stats.returns;
      hit = true;
      range = r;
    }
    const double a = scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    const Eigen::Vector3d p = T * Eigen::Vector3d(range * std::cos(a), range * std::sin(a), 0.0);
    const float ex = static_cast<float>(p.x() * inv_res + 0.5);
    const float ey = static_cast<float>(p.y() * inv_res + 0.5);
    endpoints_.push_back({ex, ey, hit});
    if (!hit) continue;
    const int u = static_cast<int>(std::floor(ex));
    const int v = static_cast<int>(std::floor(ey));
    if (!inside(u, v)) continue;
    const std::size_t k = storageIndex(u, v);
    if (hit_scan_[k] == scan_) continue;
    hit_scan_[k] = scan_;
    log_odds_[k] =
        static_cast<float>(std::min(config_.log_odds_max, log_odds_[k] + config_.log_odds_hit));
    ++stats.cells_occupied;
  }

  // Pass 2: free space along every beam, clipped to the window.
  const double x0 = min_u_, y0 = min_v_;
  const double x1 = static_cast<double>(min_u_) + config_.width;
  const double y1 = static_cast<double>(min_v_) + config_.height;
  for (const Endpoint& e : endpoints_) {
    double ax = ox, ay = oy, bx = e.x, by = e.y;
    bool end_clipped = false;
    if (!clipSegment(x0, y0, x1, y1, &ax, &ay, &bx, &by, &end_clipped)) continue;
    castRay(ax, ay, bx, by, e.hit && !end_clipped, &stats);
  }
  return stats;
}

}  // namespace stereo_safety_map
