#include "stereo_safety_map/core/overhang_roof.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace stereo_safety_map {

std::string OverhangRoofConfig::validate() const {
  if (!std::isfinite(min_clearance) || min_clearance < 0.0 || min_clearance > 5.0) {
    return "overhang_roof_min_clearance must be in [0, 5] m";
  }
  if (!std::isfinite(max_span) || max_span <= 0.0 || max_span > 10.0) {
    return "overhang_roof_max_span must be in (0, 10] m";
  }
  if (min_free_voxels < 1 || min_free_voxels > 100) {
    return "overhang_roof_min_free_voxels must be in [1, 100]";
  }
  return "";
}

int markFloorUnderOverhangs(const VoxelGrid& grid, const HeightMap& hm,
                            const Eigen::Vector3f& camera, float base_z,
                            const OverhangRoofConfig& config, SafetyMap* map,
                            OverhangRoofScratch* scratch) {
  if (map == nullptr || scratch == nullptr) return 0;
  scratch->marks.clear();
  if (!config.enabled) return 0;
  SafetyMap& m = *map;
  const int n = hm.numCells();
  const int width = hm.width();
  if (n == 0 || m.width != width || m.height != hm.height() || m.min_u != hm.minU() ||
      m.min_v != hm.minV() || static_cast<int>(m.labels.size()) != n ||
      static_cast<int>(m.drop_off.size()) != n || !camera.allFinite() || !std::isfinite(base_z)) {
    return 0;
  }
  const double l = grid.config().voxel_size;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::int32_t w_base = grid.indexOf(Eigen::Vector3f(0.0f, 0.0f, base_z)).w;
  const std::int32_t w_min_roof =
      w_base + static_cast<std::int32_t>(std::ceil(config.min_clearance / l - 1e-6));

  // The overhang columns: a top high enough, and rays observed passing below it.
  std::vector<float>& roof_z = scratch->roof_z;
  roof_z.assign(n, nan);
  bool any = false;
  for (int c = 0; c < n; ++c) {
    const std::int32_t w = hm.atIndex(c);
    if (w == HeightMap::kNoHeight || w < w_min_roof) continue;
    const int u = hm.minU() + c % width, v = hm.minV() + c / width;
    // Between the floor's band (the base's voxel and the one above it, which the floor's noise
    // reaches) and the top, at most one more occupied voxel (a thick top, a front face) and the
    // rest clear: a pole's, a wall's or a box's column is occupied further down, or never reached.
    int free_voxels = 0, occupied = 0;
    for (std::int32_t k = w_base + 2; k < w && occupied <= 1; ++k) {
      const VoxelIndex i{u, v, k};
      if (grid.isOccupied(i)) {
        ++occupied;
      } else if (grid.logOdds(i) < 0) {
        ++free_voxels;
      }
    }
    if (occupied > 1 || free_voxels < config.min_free_voxels) continue;
    const float z = hm.surfaceHeightAtIndex(c);
    roof_z[c] = std::isfinite(z) ? z : static_cast<float>(w * l);
    any = true;
  }
  if (!any) return 0;

  // The cell under the fixed-frame point (x, y), -1 outside the map.
  auto cellAt = [&](double x, double y) -> int {
    const int u = static_cast<int>(std::lround(x / l)) - hm.minU();
    const int v = static_cast<int>(std::lround(y / l)) - hm.minV();
    if (u < 0 || v < 0 || u >= width || v >= hm.height()) return -1;
    return v * width + u;
  };

  const double step = 0.5 * l;
  int marked = 0;
  for (int c = 0; c < n; ++c) {
    if (!isSafe(m.labels[c])) continue;
    const double x = (hm.minU() + c % width) * l, y = (hm.minV() + c / width) * l;
    const double dx = x - camera.x(), dy = y - camera.y();
    const double d = std::hypot(dx, dy);
    if (d < l) continue;
    const double ex = dx / d, ey = dy / d;
    const float zc =
        std::isfinite(hm.surfaceHeightAtIndex(c)) ? hm.surfaceHeightAtIndex(c) : base_z;
    // A front edge within max_span before the cell: an overhang column between it and the
    // camera whose top the sight line to the cell's floor passes below.
    int roof = -1;
    for (double s = d - step; s > std::max(0.0, d - config.max_span); s -= step) {
      const int e = cellAt(camera.x() + ex * s, camera.y() + ey * s);
      if (e < 0 || e == c || !std::isfinite(roof_z[e])) continue;
      const double z_line = camera.z() + (zc - camera.z()) * (s / d);
      if (z_line < roof_z[e]) {
        roof = e;
        break;
      }
    }
    if (roof < 0) continue;
    m.labels[c] = SafetyLabel::kNonGround;
    m.drop_off[c] = 0;
    ++marked;
    OverhangRoofMark mark;
    mark.cell = c;
    mark.roof_u = hm.minU() + roof % width;
    mark.roof_v = hm.minV() + roof / width;
    // The roof column's highest occupied voxel: the indexed height can lie below it
    // (HeightMapConfig::mass_bands puts it where the points' mean lies), and the memory must
    // watch a voxel that is occupied, or it forgets the mark at once.
    mark.roof_w = hm.atIndex(roof);
    for (std::int32_t k = std::max(hm.topIndex(), mark.roof_w); k > mark.roof_w; --k) {
      if (grid.isOccupied(VoxelIndex{mark.roof_u, mark.roof_v, k})) {
        mark.roof_w = k;
        break;
      }
    }
    scratch->marks.push_back(mark);
  }
  return marked;
}

}  // namespace stereo_safety_map
