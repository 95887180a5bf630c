#include "stereo_safety_map/core/occupancy_grid_2d_evaluation.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace stereo_safety_map {

void occupancyGridAsSafetyMap(const OccupancyGrid2D& grid, const Eigen::Vector2f& robot_xy,
                              double radius, SafetyMap* out) {
  if (out == nullptr) return;
  const GridCell2D mn = grid.minIndex();
  const double res = grid.config().resolution;
  out->min_u = mn.u;
  out->min_v = mn.v;
  out->width = grid.sizeU();
  out->height = grid.sizeV();
  out->resolution = res;
  const GridCell2D robot = grid.indexOf(robot_xy);
  out->robot_u = robot.u;
  out->robot_v = robot.v;
  out->robot_segment = -1;
  const std::size_t n = static_cast<std::size_t>(out->width) * out->height;
  out->labels.resize(n);
  out->drop_off.assign(n, 0);
  out->segment.assign(n, -1);
  out->column_height.assign(n, SafetyMap::kNoHeight);
  out->segments.clear();
  const bool limited = std::isfinite(radius) && radius > 0.0 && robot_xy.allFinite();
  const double r2 = radius * radius;
  for (int r = 0; r < out->height; ++r) {
    const int v = mn.v + r;
    for (int c = 0; c < out->width; ++c) {
      const int u = mn.u + c;
      SafetyLabel l;
      if (limited) {
        const double dx = u * res - robot_xy.x(), dy = v * res - robot_xy.y();
        if (dx * dx + dy * dy > r2) {
          out->labels[static_cast<std::size_t>(r) * out->width + c] = SafetyLabel::kUnexamined;
          continue;
        }
      }
      // 002 Sec. 3.4 planning thresholds.
      const GridCell2D cell{u, v};
      if (grid.isOccupied(cell)) {
        l = SafetyLabel::kNonGround;
      } else if (grid.isFree(cell)) {
        l = SafetyLabel::kLevel;
      } else {
        l = SafetyLabel::kUnknown;
      }
      out->labels[static_cast<std::size_t>(r) * out->width + c] = l;
    }
  }
}

const char* toString(UnsafeCause cause) {
  switch (cause) {
    case UnsafeCause::kNotUnsafe:
      return "not unsafe";
    case UnsafeCause::kObstacle:
      return "obstacle";
    case UnsafeCause::kTooSteep:
      return "too steep";
    case UnsafeCause::kLowerGround:
      return "lower ground (drop-off)";
    case UnsafeCause::kRaisedGround:
      return "raised ground (step up)";
    case UnsafeCause::kUnreachable:
      return "unreachable at the same height";
  }
  return "unknown cause";
}

UnsafeCauseCounts& UnsafeCauseCounts::operator+=(const UnsafeCauseCounts& o) {
  for (int k = 0; k < kNumUnsafeCauses; ++k) {
    occupied[k] += o.occupied[k];
    free[k] += o.free[k];
    unclassified[k] += o.unclassified[k];
  }
  return *this;
}

std::string countUnsafeCauses(const SafetyMap& map, const LabelGrid& truth,
                              const std::vector<UnsafeCause>& causes, UnsafeCauseCounts* counts) {
  if (counts == nullptr) return "counts must not be null";
  std::string err = truth.validate();
  if (!err.empty()) return err;
  if (causes.size() != truth.labels.size()) {
    std::ostringstream os;
    os << causes.size() << " causes for " << truth.labels.size() << " ground-truth cells";
    return os.str();
  }
  const std::size_t n = static_cast<std::size_t>(map.width) * static_cast<std::size_t>(map.height);
  if (map.width < 0 || map.height < 0 || map.labels.size() != n) {
    return "safety map labels do not match its size";
  }
  if (std::abs(map.resolution - truth.resolution) > 1e-6 * truth.resolution) {
    return "resolutions differ";
  }
  UnsafeCauseCounts c;
  for (int r = 0; r < map.height; ++r) {
    const int v = map.min_v + r;
    for (int col = 0; col < map.width; ++col) {
      const int u = map.min_u + col;
      if (!truth.inside(u, v)) continue;
      const int k = truth.index(u, v);
      if (truth.labels[k] != SafetyLabel::kNonGround) continue;
      const int cause = static_cast<int>(causes[k]);
      if (cause < 0 || cause >= kNumUnsafeCauses) continue;
      const SafetyLabel ml = map.labels[static_cast<std::size_t>(r) * map.width + col];
      if (ml == SafetyLabel::kUnexamined) continue;  // outside the evaluated radius
      const SafetyClass mc = safetyClassOf(ml);
      if (mc == SafetyClass::kUnsafe) {
        ++c.occupied[cause];
      } else if (mc == SafetyClass::kSafe) {
        ++c.free[cause];
      } else {
        ++c.unclassified[cause];
      }
    }
  }
  *counts += c;
  return "";
}

DropOffEdgeCounts& DropOffEdgeCounts::operator+=(const DropOffEdgeCounts& o) {
  marked += o.marked;
  safe_unmarked += o.safe_unmarked;
  unsafe += o.unsafe;
  unclassified += o.unclassified;
  return *this;
}

std::string countDropOffEdges(const SafetyMap& map, const LabelGrid& truth,
                              const std::vector<std::uint8_t>& edge, DropOffEdgeCounts* counts) {
  if (counts == nullptr) return "counts must not be null";
  std::string err = truth.validate();
  if (!err.empty()) return err;
  if (edge.size() != truth.labels.size()) return "edge mask does not match the ground truth";
  const std::size_t n = static_cast<std::size_t>(map.width) * static_cast<std::size_t>(map.height);
  if (map.width < 0 || map.height < 0 || map.labels.size() != n) {
    return "safety map labels do not match its size";
  }
  if (std::abs(map.resolution - truth.resolution) > 1e-6 * truth.resolution) {
    return "resolutions differ";
  }
  const bool has_marks = map.drop_off.size() == n;
  DropOffEdgeCounts c;
  for (int r = 0; r < map.height; ++r) {
    const int v = map.min_v + r;
    for (int col = 0; col < map.width; ++col) {
      const int u = map.min_u + col;
      if (!truth.inside(u, v) || !edge[truth.index(u, v)]) continue;
      const std::size_t k = static_cast<std::size_t>(r) * map.width + col;
      const SafetyLabel ml = map.labels[k];
      if (ml == SafetyLabel::kUnexamined) continue;
      if (isSafe(ml)) {
        if (has_marks && map.drop_off[k]) {
          ++c.marked;
        } else {
          ++c.safe_unmarked;
        }
      } else if (ml == SafetyLabel::kNonGround) {
        ++c.unsafe;
      } else {
        ++c.unclassified;
      }
    }
  }
  *counts += c;
  return "";
}

BoardCoverage boardWidthCoverage2D(const OccupancyGrid2D& grid, const BoardBox& board) {
  BoardCoverage cov;
  const double l = grid.config().resolution;
  if (!board.valid()) return cov;
  // The axes of boardWidthCoverage(); only their xy parts matter here.
  const BoardAxes axes = boardAxes(board);
  const int w_axis = axes.width, t_axis = axes.thickness;
  Eigen::Vector2d w_dir = board.rotation.col(w_axis).head<2>();
  Eigen::Vector2d t_dir = board.rotation.col(t_axis).head<2>();
  if (w_dir.norm() < 1e-9 || t_dir.norm() < 1e-9) return cov;
  w_dir.normalize();
  t_dir.normalize();
  const double half_width = board.half_size[w_axis];
  const double half_thick = board.half_size[t_axis];
  cov.bins = std::max(1, static_cast<int>(std::ceil(2.0 * half_width / l - 1e-9)));
  const double bin = 2.0 * half_width / cov.bins;

  // Each width sample is a short segment across the board, from one cell in front of its face
  // to one cell behind it (stereo's depth error), probed every half cell: covered when a probe
  // falls into an occupied cell.
  const double reach_t = half_thick + l;
  const int probes = 2 * static_cast<int>(std::ceil(reach_t / (0.5 * l))) + 1;
  const Eigen::Vector2d c0 = board.center.head<2>();
  for (int b = 0; b < cov.bins; ++b) {
    const double s = -half_width + (b + 0.5) * bin;
    for (int i = 0; i < probes; ++i) {
      const double t = -reach_t + 2.0 * reach_t * i / (probes - 1);
      const Eigen::Vector2d p = c0 + s * w_dir + t * t_dir;
      const GridCell2D c = grid.indexOf(p.cast<float>());
      if (grid.contains(c) && grid.isOccupied(c)) {
        ++cov.covered;
        break;
      }
    }
  }
  return cov;
}

}  // namespace stereo_safety_map
