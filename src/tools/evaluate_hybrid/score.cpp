// evaluate_hybrid: scores. The ground truth as hybrid classes, the cells all three maps classify,
// the Non-ground cells the laser cannot see, ghost points, statistics.
#include "evaluate_hybrid.h"

#include <algorithm>
#include <cmath>

namespace evaluate_hybrid {

// ---------------------------------------------------------------------------------------------
// Ground truth and maps

// 000's ground-truth labels as hybrid classes: only safe / unsafe / unclassified matters for the
// scores (Non-ground counts as unsafe whatever its kind).
HybridSafetyMap hybridTruth(const ssm::LabelGrid& gt) {
  HybridSafetyMap h;
  h.min_u = gt.min_u;
  h.min_v = gt.min_v;
  h.width = gt.width;
  h.height = gt.height;
  h.resolution = gt.resolution;
  h.labels.resize(gt.labels.size());
  for (std::size_t i = 0; i < gt.labels.size(); ++i) {
    switch (gt.labels[i]) {
      case ssm::SafetyLabel::kLevel:
        h.labels[i] = HybridLabel::kSafe;
        break;
      case ssm::SafetyLabel::kInclined:
        h.labels[i] = HybridLabel::kCaution;
        break;
      case ssm::SafetyLabel::kNonGround:
        h.labels[i] = HybridLabel::kObstacle;
        break;
      default:
        h.labels[i] = HybridLabel::kUnknown;
        break;
    }
  }
  return h;
}

// Copies of the three maps (same cells) in which a cell keeps its class only when all three
// classify it (not Unknown).
void commonCells(const HybridSafetyMap (&in)[kSources], HybridSafetyMap (*out)[kSources]) {
  for (int s = 0; s < kSources; ++s)
    (*out)[s] = in[s];
  for (std::size_t i = 0; i < in[0].labels.size(); ++i) {
    bool all = true;
    for (int s = 0; s < kSources; ++s)
      all = all && in[s].labels[i] != HybridLabel::kUnknown;
    if (!all) {
      for (int s = 0; s < kSources; ++s)
        (*out)[s].labels[i] = HybridLabel::kUnknown;
    }
  }
}

// Axis-aligned xy bounds of an oriented box.
void xyBounds(const ssm::BoardBox& b, double* x0, double* y0, double* x1, double* y1) {
  *x0 = *y0 = std::numeric_limits<double>::infinity();
  *x1 = *y1 = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c((k & 1 ? 1 : -1) * b.half_size.x(), (k & 2 ? 1 : -1) * b.half_size.y(),
                            (k & 4 ? 1 : -1) * b.half_size.z());
    const Eigen::Vector3d p = b.center + b.rotation * c;
    *x0 = std::min(*x0, p.x());
    *y0 = std::min(*y0, p.y());
    *x1 = std::max(*x1, p.x());
    *y1 = std::max(*y1, p.y());
  }
}

double zMin(const ssm::BoardBox& b) {
  double z = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c((k & 1 ? 1 : -1) * b.half_size.x(), (k & 2 ? 1 : -1) * b.half_size.y(),
                            (k & 4 ? 1 : -1) * b.half_size.z());
    z = std::min(z, (b.center + b.rotation * c).z());
  }
  return z;
}
double zMax(const ssm::BoardBox& b) {
  double z = -std::numeric_limits<double>::infinity();
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c((k & 1 ? 1 : -1) * b.half_size.x(), (k & 2 ? 1 : -1) * b.half_size.y(),
                            (k & 4 ? 1 : -1) * b.half_size.z());
    z = std::max(z, (b.center + b.rotation * c).z());
  }
  return z;
}

LaserBlindCells laserBlindCells(const ssm::Dataset& d, double laser_z, double robot_height,
                                double margin) {
  LaserBlindCells out;
  const double res = d.gt.resolution;
  struct Xy {
    double x0, y0, x1, y1;
    int kind;  // 0 above, 1 below, 2 through the laser plane, 3 above the robot
    std::string name;
    bool used;
  };
  std::vector<Xy> boxes;
  for (const ssm::DatasetObstacle& o : d.obstacles) {
    Xy b;
    xyBounds(o.box, &b.x0, &b.y0, &b.x1, &b.y1);
    const double z0 = zMin(o.box), z1 = zMax(o.box);
    b.kind = z0 > laser_z + 0.02 ? (z0 < robot_height ? 0 : 3) : (z1 < laser_z - 0.02 ? 1 : 2);
    b.name = o.name;
    b.used = false;
    boxes.push_back(b);
  }
  for (int v = d.gt.min_v; v < d.gt.min_v + d.gt.height; ++v) {
    for (int u = d.gt.min_u; u < d.gt.min_u + d.gt.width; ++u) {
      if (d.gt.at(u, v) != ssm::SafetyLabel::kNonGround) continue;
      const double x = u * res, y = v * res;
      const auto inside = [x, y](const Xy& b, double m) {
        return x >= b.x0 - m && x <= b.x1 + m && y >= b.y0 - m && y <= b.y1 + m;
      };
      bool near_through = false, near_any = false;
      Xy* low = nullptr;
      Xy* above = nullptr;
      for (Xy& b : boxes) {
        if (b.kind == 3) continue;  // above the robot: not why the cell is Non-ground
        near_any = near_any || inside(b, margin);
        if (b.kind == 2) near_through = near_through || inside(b, margin);
        if (b.kind == 1 && inside(b, 0.0)) low = &b;
        if (b.kind == 0 && inside(b, 0.0)) above = &b;
      }
      if (near_through) continue;
      if (low) {
        out.cells[1].emplace_back(u, v);
        low->used = true;
      } else if (above) {
        out.cells[0].emplace_back(u, v);
        above->used = true;
      } else if (!near_any) {
        out.cells[2].emplace_back(u, v);
      }
    }
  }
  for (const Xy& b : boxes) {
    if (b.used) out.names[b.kind].push_back(b.name);
  }
  return out;
}

// Ghost points (001 Sec. 4: "false positives, e.g., points in free space") among camera-frame
// points: the point's disparity differs from the ground-truth depth's at its pixel by more than
// `ghost_px`. Points on pixels without ground truth are not counted.
void countGhosts(const std::vector<Eigen::Vector3f>& points, const cv::Mat& depth,
                 const ssm::StereoCameraModel& cam, double ghost_px, std::uint64_t* checked,
                 std::uint64_t* ghosts) {
  if (depth.empty()) return;
  for (const Eigen::Vector3f& p : points) {
    if (!(p.z() > 0.0f)) continue;
    const int col = static_cast<int>(std::lround(cam.fx * p.x() / p.z() + cam.cx));
    const int row = static_cast<int>(std::lround(cam.fy * p.y() / p.z() + cam.cy));
    if (col < 0 || row < 0 || col >= depth.cols || row >= depth.rows) continue;
    const float z_gt = depth.at<float>(row, col);
    if (!std::isfinite(z_gt) || z_gt <= 0.0f) continue;
    ++*checked;
    const double d = cam.disparityFromDepth(p.z());
    const double d_gt = cam.disparityFromDepth(z_gt);
    if (std::abs(d - d_gt) > ghost_px) ++*ghosts;
  }
}

Stats statsOf(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  double sum = 0.0;
  for (double x : v)
    sum += x;
  s.mean = sum / v.size();
  s.median = v[v.size() / 2];
  s.max = v.back();
  return s;
}

}  // namespace evaluate_hybrid
