#include "stereo_safety_map/core/ground_segmentation.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

namespace stereo_safety_map {

std::string GroundSegmentationConfig::validate() const {
  if (!std::isfinite(planning_radius) || planning_radius <= 0.0 || planning_radius > 1000.0) {
    return "planning_radius must be in (0, 1000] m";
  }
  if (height_tolerance < 0 || height_tolerance > 1000) {
    return "height_tolerance must be in [0, 1000] voxels";
  }
  if (connectivity != 4 && connectivity != 8) return "connectivity must be 4 or 8";
  if (!std::isfinite(seed_radius) || seed_radius < 0.0 || seed_radius > 1000.0) {
    return "seed_radius must be in [0, 1000] m";
  }
  if (!std::isfinite(footprint_radius) || footprint_radius < 0.0 || footprint_radius > 5.0) {
    return "footprint_radius must be in [0, 5] m (0 = off)";
  }
  if (island_max_span < 0 || island_max_span > 1000) {
    return "island_max_span must be in [0, 1000] voxels";
  }
  return "";
}

GroundSegmentation::GroundSegmentation(const GroundSegmentationConfig& config) : config_(config) {
  const std::string err = config_.validate();
  if (!err.empty()) throw std::invalid_argument("GroundSegmentationConfig: " + err);
}

namespace {

// Squared radius in cells, widened by a hair so that a radius that is a whole number of cells
// includes the cells exactly on it despite rounding of R / l_v.
// Clamped to 2^60: a radius of any size over a tiny voxel converts without overflow (beyond the
// window anyway).
long long radiusSquaredCells(double radius, double voxel_size) {
  const double r = radius / voxel_size;
  const double r2 = std::floor(r * r + 1e-6);
  constexpr double kMax = 1152921504606846976.0;  // 2^60
  return !(r2 < kMax) ? static_cast<long long>(kMax) : static_cast<long long>(r2);
}

}  // namespace

bool GroundSegmentation::segment(const HeightMap& hm, const VoxelIndex& robot, double voxel_size,
                                 GroundSegments* out) {
  if (out == nullptr) return false;
  GroundSegments& s = *out;
  s.min_u = hm.minU();
  s.min_v = hm.minV();
  s.width = hm.width();
  s.height = hm.height();
  s.robot = robot;
  s.seed_cell = -1;
  s.robot_segment = -1;
  const int n = hm.numCells();
  s.segment_of.assign(n, -1);
  s.examined.assign(n, 0);
  s.segment_begin.assign(1, 0);
  s.segment_cells.clear();
  s.segment_height.clear();
  s.segment_island.clear();
  s.non_traversable.clear();
  s.footprint.assign(n, 0);
  if (!std::isfinite(voxel_size) || voxel_size <= 0.0) return false;

  // Alg. 1 step 3: cells farther than R_max from the robot's cell are "not to be examined".
  const long long r2 = radiusSquaredCells(config_.planning_radius, voxel_size);
  const long long rc = static_cast<long long>(std::floor(std::sqrt(static_cast<double>(r2))));
  {
    const long long v_lo = std::max<long long>(s.min_v, robot.v - rc);
    const long long v_hi = std::min<long long>(s.min_v + s.height - 1, robot.v + rc);
    const long long u_lo = std::max<long long>(s.min_u, robot.u - rc);
    const long long u_hi = std::min<long long>(s.min_u + s.width - 1, robot.u + rc);
    for (long long v = v_lo; v <= v_hi; ++v) {
      const long long dv = v - robot.v;
      for (long long u = u_lo; u <= u_hi; ++u) {
        const long long du = u - robot.u;
        if (du * du + dv * dv <= r2) {
          s.examined[s.index(static_cast<int>(u), static_cast<int>(v))] = 1;
        }
      }
    }
  }

  // The robot's footprint: ground at the base's height where nothing was observed
  // (GroundSegmentationConfig::footprint_radius).
  if (config_.footprint_radius > 0.0) {
    const long long f2 = radiusSquaredCells(config_.footprint_radius, voxel_size);
    const long long fc = static_cast<long long>(std::floor(std::sqrt(static_cast<double>(f2))));
    for (long long v = std::max<long long>(s.min_v, robot.v - fc);
         v <= std::min<long long>(s.min_v + s.height - 1, robot.v + fc); ++v) {
      for (long long u = std::max<long long>(s.min_u, robot.u - fc);
           u <= std::min<long long>(s.min_u + s.width - 1, robot.u + fc); ++u) {
        const long long du = u - robot.u, dv = v - robot.v;
        if (du * du + dv * dv > f2) continue;
        const int cell = s.index(static_cast<int>(u), static_cast<int>(v));
        if (s.examined[cell] && hm.atIndex(cell) == HeightMap::kNoHeight) s.footprint[cell] = 1;
      }
    }
  }
  // Heights as Alg. 1 sees them: the height map's, the base's on footprint cells.
  const std::int32_t robot_w = robot.w;
  auto heightOf = [&](int cell) { return s.footprint[cell] ? robot_w : hm.atIndex(cell); };
  auto lowestOf = [&](int cell) { return s.footprint[cell] ? robot_w : hm.lowestAtIndex(cell); };

  // Seed of the robot's segment (Alg. 1 steps 2 and 5, with the seed rule of the config):
  // least height difference to the robot's base first, then an observed cell before a footprint
  // cell, then nearest, then scan order. Observed ground at the base's height within seed_radius
  // is the robot's segment as in 000; the footprint joins it (below), and carries it alone only
  // when nothing within seed_radius was observed at that height.
  const int w_t = config_.height_tolerance;
  const long long s2 = std::min(r2, radiusSquaredCells(config_.seed_radius, voxel_size));
  const long long sc = static_cast<long long>(std::floor(std::sqrt(static_cast<double>(s2))));
  {
    long long best_dw = std::numeric_limits<long long>::max();
    long long best_d2 = std::numeric_limits<long long>::max();
    int best_fp = 2;
    const long long v_lo = std::max<long long>(s.min_v, robot.v - sc);
    const long long v_hi = std::min<long long>(s.min_v + s.height - 1, robot.v + sc);
    const long long u_lo = std::max<long long>(s.min_u, robot.u - sc);
    const long long u_hi = std::min<long long>(s.min_u + s.width - 1, robot.u + sc);
    for (long long v = v_lo; v <= v_hi; ++v) {
      for (long long u = u_lo; u <= u_hi; ++u) {
        const long long du = u - robot.u, dv = v - robot.v;
        const long long d2 = du * du + dv * dv;
        if (d2 > s2) continue;
        const int cell = s.index(static_cast<int>(u), static_cast<int>(v));
        const std::int32_t w = heightOf(cell);
        if (w == HeightMap::kNoHeight || !s.examined[cell]) continue;
        const long long dw = std::llabs(static_cast<long long>(w) - robot.w);
        if (dw > w_t) continue;
        const int fp = s.footprint[cell];
        if (dw < best_dw || (dw == best_dw && (fp < best_fp || (fp == best_fp && d2 < best_d2)))) {
          best_dw = dw;
          best_fp = fp;
          best_d2 = d2;
          s.seed_cell = cell;
        }
      }
    }
  }

  const int w_cells = s.width;
  const bool eight = config_.connectivity == 8;
  static constexpr int kDu[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static constexpr int kDv[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  const int num_nb = eight ? 8 : 4;

  compared_.assign(n, 0);
  locked_.assign(n, 0);
  const int max_span = config_.island_max_span;
  // May a column join an island segment? Not when Alg. 1 compared it and left it out, not when
  // its occupied voxels span more than island_max_span (the face of an obstacle), and not when
  // an observed neighbour differs from it by more than w_T: beside a height discontinuity (an
  // obstacle's edge, the floor under a table's edge) 000 calls a column non-traversable, and
  // an island must not overrule that.
  auto groundLike = [&](int cell) {
    if (locked_[cell]) return false;
    const std::int32_t w = heightOf(cell);
    if (static_cast<long long>(w) - lowestOf(cell) > max_span) return false;
    const int u = cell % w_cells, v = cell / w_cells;
    for (int j = 0; j < 8; ++j) {
      const int un = u + kDu[j], vn = v + kDv[j];
      if (un < 0 || vn < 0 || un >= w_cells || vn >= s.height) continue;
      const std::int32_t wn = heightOf(vn * w_cells + un);
      if (wn != HeightMap::kNoHeight && std::llabs(static_cast<long long>(wn) - w) > w_t)
        return false;
    }
    return true;
  };
  // Grows segments from cell c by Alg. 1 steps 5-21; island segments do not take columns that
  // are locked or span more than island_max_span voxels.
  // with_footprint: the first segment also holds the footprint's cells when they are at its
  // height (the robot's segment seeded on observed ground: the robot stands on it).
  auto grow = [&](int c, bool island, bool with_footprint) {
    pending_.clear();
    std::size_t pending_head = 0;
    auto admissible = [&](int cell) { return !island || groundLike(cell); };
    while (c >= 0) {
      // Step 5: new segment S_k holding cell c.
      const int k = s.numSegments();
      const std::int32_t wk = heightOf(c);
      s.segment_height.push_back(wk);
      s.segment_island.push_back(island ? 1 : 0);
      s.segment_of[c] = k;
      s.segment_cells.push_back(c);
      to_compare_.clear();
      to_compare_.push_back(c);
      if (with_footprint && k == 0 && wk == robot_w) {
        for (int f = 0; f < n; ++f) {
          if (!s.footprint[f] || s.segment_of[f] >= 0) continue;
          s.segment_of[f] = k;
          s.segment_cells.push_back(f);
          to_compare_.push_back(f);
        }
      }
      // Steps 6-18: compare every cell of S_k with its examined neighbours.
      while (!to_compare_.empty()) {
        const int ci = to_compare_.back();
        to_compare_.pop_back();
        const int ui = ci % w_cells, vi = ci / w_cells;
        for (int j = 0; j < num_nb; ++j) {
          const int un = ui + kDu[j], vn = vi + kDv[j];
          if (un < 0 || vn < 0 || un >= w_cells || vn >= s.height) continue;
          const int cn = vn * w_cells + un;
          if (!s.examined[cn]) continue;
          const std::int32_t wn = heightOf(cn);
          if (wn == HeightMap::kNoHeight) continue;
          compared_[cn] = 1;
          if (!admissible(cn)) continue;
          if (wn == wk) {
            // Step 12. Equal-height neighbours always end up in the same segment, so a cell
            // of this height already in a segment is in this one.
            if (s.segment_of[cn] < 0) {
              s.segment_of[cn] = k;
              s.segment_cells.push_back(cn);
              to_compare_.push_back(cn);
            }
          } else if (std::llabs(static_cast<long long>(wn) - wk) <= w_t) {
            // Step 14: close in height, may start a new segment.
            if (s.segment_of[cn] < 0) pending_.push_back(cn);
          }
        }
      }
      s.segment_begin.push_back(static_cast<int>(s.segment_cells.size()));
      // Steps 19-21: pop L_U until a cell in no segment is found.
      c = -1;
      while (pending_head < pending_.size()) {
        const int p = pending_[pending_head++];
        if (s.segment_of[p] < 0) {
          c = p;
          break;
        }
      }
    }
  };
  grow(s.seed_cell, false, true);
  if (s.seed_cell >= 0) s.robot_segment = 0;

  if (config_.segment_islands) {
    // Columns Alg. 1 compared and left out keep 000's verdict: non-traversable.
    for (int cell = 0; cell < n; ++cell)
      locked_[cell] = compared_[cell] && s.segment_of[cell] < 0;
    for (int cell = 0; cell < n; ++cell) {
      if (!s.examined[cell] || s.segment_of[cell] >= 0 || locked_[cell] || compared_[cell])
        continue;
      if (heightOf(cell) == HeightMap::kNoHeight || !groundLike(cell)) continue;
      grow(cell, true, false);
    }
  }

  // Non-traversable columns (000, Sec. V-A): a height, within R_max, in no segment.
  for (int cell = 0; cell < n; ++cell) {
    if (s.examined[cell] && s.segment_of[cell] < 0 && hm.atIndex(cell) != HeightMap::kNoHeight) {
      s.non_traversable.push_back(cell);
    }
  }
  return true;
}

}  // namespace stereo_safety_map
