#include "stereo_safety_map/core/height_map.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

namespace stereo_safety_map {

std::string HeightMapConfig::validate() const {
  if (!std::isfinite(robot_height) || robot_height <= 0.0 || robot_height > 100.0) {
    return "robot_height must be in (0, 100] m";
  }
  if (!std::isfinite(near_view_ratio) ||
      (near_view_ratio != 0.0 && (near_view_ratio < 1.0 || near_view_ratio > 100.0))) {
    return "near_view_ratio must be 0 or in [1, 100]";
  }
  if (!std::isfinite(tail_share) || tail_share < 0.0 || tail_share > 1.0) {
    return "tail_share must be in [0, 1]";
  }
  if (!std::isfinite(sparse_edge_share) || sparse_edge_share < 0.0 || sparse_edge_share > 1.0) {
    return "sparse_edge_share must be in [0, 1]";
  }
  return "";
}

HeightMap::HeightMap(const HeightMapConfig& config) : config_(config) {
  const std::string err = config_.validate();
  if (!err.empty()) throw std::invalid_argument("HeightMapConfig: " + err);
}

void HeightMap::reset(int min_u, int min_v, int width, int height) {
  min_u_ = min_u;
  min_v_ = min_v;
  width_ = std::max(0, width);
  height_ = std::max(0, height);
  w_.assign(static_cast<std::size_t>(width_) * height_, kNoHeight);
  w_low_.assign(w_.size(), kNoHeight);
  surface_z_.assign(w_.size(), std::numeric_limits<float>::quiet_NaN());
  ground_z_.assign(w_.size(), std::numeric_limits<float>::quiet_NaN());
  sparse_edge_columns_ = 0;
  if (config_.sparse_edge_share > 0.0) mass_.assign(w_.size(), 0.0f);
}

void HeightMap::setSurfaceHeight(int u, int v, float z) {
  if (inside(u, v)) surface_z_[index(u, v)] = z;
}

void HeightMap::setGroundHeight(int u, int v, float z) {
  if (inside(u, v)) ground_z_[index(u, v)] = z;
}

void HeightMap::set(int u, int v, std::int32_t w) {
  set(u, v, w, w);
}

void HeightMap::set(int u, int v, std::int32_t w, std::int32_t w_low) {
  if (!inside(u, v)) return;
  w_[index(u, v)] = w;
  w_low_[index(u, v)] = w == kNoHeight ? kNoHeight : std::min(w, w_low);
  if (w == kNoHeight) {
    surface_z_[index(u, v)] = std::numeric_limits<float>::quiet_NaN();
    ground_z_[index(u, v)] = std::numeric_limits<float>::quiet_NaN();
  }
}

bool HeightMap::build(const VoxelGrid& grid, float robot_base_z) {
  const VoxelIndex lo = grid.minIndex();
  reset(lo.u, lo.v, grid.sizeU(), grid.sizeV());
  if (!std::isfinite(robot_base_z)) return false;

  // A voxel counts when its centre w * l_v is strictly below the robot's top (000, Sec. V-A:
  // the robot travels under occupied voxels higher than itself).
  const double l = grid.config().voxel_size;
  const double top = (static_cast<double>(robot_base_z) + config_.robot_height) / l;
  // The 1e-4 voxel margin keeps a centre that is on the top up to float rounding of the base
  // height (e.g. 0.4f + 1.5 = 1.9000000006) above it.
  const double w_limit = std::ceil(top - 1e-4) - 1.0;
  const int w_lo = lo.w;
  const int w_hi_window = lo.w + grid.sizeW() - 1;
  if (w_limit < static_cast<double>(w_lo)) {
    top_w_ = w_lo - 1;
    return true;  // the whole window is above the robot's top
  }
  const int w_hi = static_cast<int>(std::min<double>(w_limit, w_hi_window));
  top_w_ = w_hi;

  for (int v = lo.v; v < lo.v + height_; ++v) {
    std::int32_t* row = &w_[static_cast<std::size_t>(v - lo.v) * width_];
    std::int32_t* row_low = &w_low_[static_cast<std::size_t>(v - lo.v) * width_];
    float* row_z = &surface_z_[static_cast<std::size_t>(v - lo.v) * width_];
    float* row_g = &ground_z_[static_cast<std::size_t>(v - lo.v) * width_];
    for (int u = lo.u; u < lo.u + width_; ++u) {
      // Scanning down from the robot's top, the first occupied voxel is the column's height,
      // the last one its lowest.
      int top = 0, bottom = 0;
      if (!grid.occupiedExtent(u, v, w_lo, w_hi, &top, &bottom)) continue;
      if (config_.near_view_ratio > 0.0 && top > bottom &&
          grid.isOccupied(VoxelIndex{u, v, top - 1})) {
        // HeightMapConfig::near_view_ratio: the far views' noise tail over a surface seen
        // from nearer. Lists are in ascending range: the first point is the nearest.
        const VoxelPointList upper = grid.points(VoxelIndex{u, v, top});
        const VoxelPointList lower = grid.points(VoxelIndex{u, v, top - 1});
        if (!upper.empty() && !lower.empty() &&
            upper.data[0].range > config_.near_view_ratio * lower.data[0].range) {
          --top;
        }
      }
      if (config_.tail_share > 0.0 && top > bottom && grid.isOccupied(VoxelIndex{u, v, top - 1})) {
        // HeightMapConfig::tail_share: the surface is where the points are.
        // A tail hugs the surface below it: its points' mean lies within half a voxel of that
        // surface's. The foot of a wall seen edge-on beside a densely seen floor has few points
        // in its voxel too, spread over it (dev seed 32).
        const float upper = grid.hitMass(VoxelIndex{u, v, top});
        const float lower = grid.hitMass(VoxelIndex{u, v, top - 1});
        if (upper < static_cast<float>(config_.tail_share) * lower &&
            grid.hitMeanZ(VoxelIndex{u, v, top}) - grid.hitMeanZ(VoxelIndex{u, v, top - 1}) <
                0.5f * static_cast<float>(l)) {
          --top;
        }
      }
      row[u - lo.u] = top;
      row_low[u - lo.u] = bottom;
      if (config_.sparse_edge_share > 0.0) {
        mass_[static_cast<std::size_t>(v - lo.v) * width_ + (u - lo.u)] =
            grid.columnMass(u, v, top - 1, top + 1);
      }
      if (config_.mass_heights) {
        // HeightMapConfig::mass_heights: every point of the surface's voxels; the column's
        // indexed height is the voxel its surface lies in, within its occupied extent.
        const float z = grid.massMeanZ(u, v, top - 1, top + 1);
        row_z[u - lo.u] = z;
        row_g[u - lo.u] = z;
        if (config_.mass_bands && std::isfinite(z)) {
          const double ws = std::floor(static_cast<double>(z) / l + 0.5);
          if (ws < top && ws >= bottom) row[u - lo.u] = static_cast<std::int32_t>(ws);
        }
        continue;
      }
      if (config_.observation_means) {
        // Every point counts once (HeightMapConfig::observation_means).
        const VoxelMoments m = grid.moments(VoxelIndex{u, v, top});
        float sum = m.sz, weight = m.weight;
        if (weight > 0.0f) row_z[u - lo.u] = sum / weight;
        if (top - 1 >= w_lo) {
          const VoxelMoments below = grid.moments(VoxelIndex{u, v, top - 1});
          sum += below.sz;
          weight += below.weight;
        }
        if (weight > 0.0f) row_g[u - lo.u] = sum / weight;
        continue;
      }
      const VoxelPointList pts = grid.points(VoxelIndex{u, v, top});
      float sum = 0.0f;
      for (const VoxelPoint& p : pts)
        sum += p.position.z();
      if (!pts.empty()) row_z[u - lo.u] = sum / static_cast<float>(pts.size);
      // groundHeightAtIndex(): the top voxel's points and those of the voxel below it.
      std::size_t count = pts.size;
      if (top - 1 >= w_lo) {
        const VoxelPointList below = grid.points(VoxelIndex{u, v, top - 1});
        for (const VoxelPoint& p : below)
          sum += p.position.z();
        count += below.size;
      }
      if (count > 0) row_g[u - lo.u] = sum / static_cast<float>(count);
    }
  }
  if (config_.sparse_edge_share > 0.0) clearSparseEdges();
  return true;
}

void HeightMap::clearSparseEdges() {
  // HeightMapConfig::sparse_edge_share, one pass over the built heights (a cleared column makes
  // no new edge in the same build, so the test never eats into a surface). The test is asked
  // along a line: the unobserved 4-neighbour on one side, the better-observed column on the
  // other, as a strip beyond an edge lies between the surface it was fattened from and what
  // was not seen. A one-column stripe of readings between unobserved columns has no such line
  // across it and is kept, whatever a denser crossing stripe beside it received (this alone
  // does not mend dev 41's pale floor: docs/evaluation.md).
  sparse_cells_.clear();
  const float share = static_cast<float>(config_.sparse_edge_share);
  const int dx[4] = {1, -1, 0, 0};
  const int dy[4] = {0, 0, 1, -1};
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      const int c = y * width_ + x;
      const std::int32_t w = w_[c];
      if (w == kNoHeight) continue;
      for (int k = 0; k < 4; ++k) {
        const int xo = x + dx[k], yo = y + dy[k];  // the unobserved side
        const int xi = x - dx[k], yi = y - dy[k];  // the observed side
        if (xo < 0 || yo < 0 || xo >= width_ || yo >= height_) continue;
        if (xi < 0 || yi < 0 || xi >= width_ || yi >= height_) continue;
        if (w_[yo * width_ + xo] != kNoHeight) continue;
        const int n = yi * width_ + xi;
        if (w_[n] == kNoHeight || std::abs(w - w_[n]) > 1) continue;
        if (mass_[c] < share * mass_[n]) {
          sparse_cells_.push_back(c);
          break;
        }
      }
    }
  }
  for (const std::int32_t c : sparse_cells_) {
    w_[c] = kNoHeight;
    w_low_[c] = kNoHeight;
    surface_z_[c] = std::numeric_limits<float>::quiet_NaN();
    ground_z_[c] = std::numeric_limits<float>::quiet_NaN();
  }
  sparse_edge_columns_ = static_cast<int>(sparse_cells_.size());
}

}  // namespace stereo_safety_map
