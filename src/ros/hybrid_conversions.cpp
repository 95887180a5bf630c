#include "stereo_safety_map/ros/hybrid_conversions.h"

#include <sensor_msgs/point_cloud2_iterator.h>

#include <cmath>
#include <sstream>

namespace stereo_safety_map {

namespace {

// Cell index of the lattice corner `origin` (the corner of cell min), or false when `origin` is
// not within 1e-3 cells of a corner.
bool cornerCell(double origin, double resolution, int* min) {
  const double c = origin / resolution + 0.5;  // corner of cell k lies at (k - 0.5) l_v
  if (!std::isfinite(c) || std::abs(c) > 1e9) return false;
  const double k = std::round(c);
  if (std::abs(c - k) > 1e-3) return false;
  *min = static_cast<int>(k);
  return true;
}

}  // namespace

std::string safetyMapFromMsg(const SafetyMapMsg& msg, SafetyMap* out) {
  const nav_msgs::MapMetaData& info = msg.info;
  const double res = info.resolution;
  if (!std::isfinite(res) || res <= 0.0) {
    std::ostringstream os;
    os << "info.resolution = " << res << " must be finite and > 0";
    return os.str();
  }
  const std::size_t n = static_cast<std::size_t>(info.width) * info.height;
  if (info.width > 100000 || info.height > 100000 || n > 100000000) {
    return "info.width x info.height is too large (" + std::to_string(info.width) + " x " +
           std::to_string(info.height) + ")";
  }
  if (msg.labels.size() != n) {
    return "labels has " + std::to_string(msg.labels.size()) + " entries for " +
           std::to_string(info.width) + " x " + std::to_string(info.height) + " cells";
  }
  if (!msg.drop_off.empty() && msg.drop_off.size() != n) {
    return "drop_off has " + std::to_string(msg.drop_off.size()) + " entries for " +
           std::to_string(n) + " cells";
  }
  const geometry_msgs::Quaternion& q = info.origin.orientation;
  const double qn = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (!(qn > 0.5) || std::abs(q.x) / qn > 1e-6 || std::abs(q.y) / qn > 1e-6 ||
      std::abs(q.z) / qn > 1e-6) {
    return "info.origin is rotated (the fusion needs an axis-aligned grid)";
  }
  int min_u = 0, min_v = 0;
  if (!cornerCell(info.origin.position.x, res, &min_u) ||
      !cornerCell(info.origin.position.y, res, &min_v)) {
    std::ostringstream os;
    os << "info.origin (" << info.origin.position.x << ", " << info.origin.position.y
       << ") is not the corner of a cell centred at (u l_v, v l_v) (000 Eq. (1))";
    return os.str();
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (msg.labels[i] > SafetyMapMsg::NON_GROUND) {
      return "labels[" + std::to_string(i) + "] = " + std::to_string(msg.labels[i]) +
             " is not a SafetyMap label (0..4)";
    }
  }
  out->min_u = min_u;
  out->min_v = min_v;
  out->width = static_cast<int>(info.width);
  out->height = static_cast<int>(info.height);
  out->resolution = res;
  out->labels.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    out->labels[i] = static_cast<SafetyLabel>(msg.labels[i]);
  }
  if (msg.drop_off.empty()) {
    out->drop_off.assign(n, 0);
  } else {
    out->drop_off = msg.drop_off;
  }
  out->segment.clear();
  out->segments.clear();
  out->column_height.clear();
  out->robot_segment = msg.robot_segment;
  return "";
}

std::string laserScanInfoFromMsg(const sensor_msgs::LaserScan& msg, LaserScanInfo* out) {
  std::ostringstream os;
  if (!std::isfinite(msg.angle_min) || !std::isfinite(msg.angle_max) ||
      !std::isfinite(msg.angle_increment) || msg.angle_increment == 0.0f) {
    os << "bad angles: angle_min " << msg.angle_min << ", angle_max " << msg.angle_max
       << ", angle_increment " << msg.angle_increment << " (finite, increment non-zero)";
    return os.str();
  }
  if (!std::isfinite(msg.range_min) || !std::isfinite(msg.range_max) || msg.range_min < 0.0f ||
      msg.range_max <= msg.range_min) {
    os << "bad range limits: range_min " << msg.range_min << ", range_max " << msg.range_max
       << " (finite, 0 <= range_min < range_max)";
    return os.str();
  }
  if (msg.ranges.empty()) return "no ranges";
  const double span = (static_cast<double>(msg.angle_max) - msg.angle_min) / msg.angle_increment;
  if (span < -0.5 || span > 1e6) {
    os << "angle_max - angle_min and angle_increment disagree in sign or give " << span << " beams";
    return os.str();
  }
  const double expected = std::floor(span + 1e-3) + 1.0;
  if (std::abs(static_cast<double>(msg.ranges.size()) - expected) > 1.0) {
    os << msg.ranges.size() << " ranges, but angle_min .. angle_max in steps of angle_increment "
       << "gives " << expected;
    return os.str();
  }
  if (!msg.intensities.empty() && msg.intensities.size() != msg.ranges.size()) {
    os << msg.intensities.size() << " intensities for " << msg.ranges.size() << " ranges";
    return os.str();
  }
  out->angle_min = msg.angle_min;
  out->angle_increment = msg.angle_increment;
  out->range_min = msg.range_min;
  out->range_max = msg.range_max;
  return "";
}

void toHybridOccupancyGrid(const HybridSafetyMap& map, const HybridSafetyMapConfig& config,
                           const std_msgs::Header& header, nav_msgs::OccupancyGrid* out) {
  out->header = header;
  nav_msgs::MapMetaData& info = out->info;
  info.map_load_time = header.stamp;
  info.resolution = static_cast<float>(map.resolution);
  info.width = static_cast<std::uint32_t>(std::max(map.width, 0));
  info.height = static_cast<std::uint32_t>(std::max(map.height, 0));
  info.origin.position.x = (map.min_u - 0.5) * map.resolution;
  info.origin.position.y = (map.min_v - 0.5) * map.resolution;
  info.origin.position.z = 0.0;
  info.origin.orientation = geometry_msgs::Quaternion();
  info.origin.orientation.w = 1.0;
  out->data.resize(map.labels.size());
  for (std::size_t i = 0; i < map.labels.size(); ++i) {
    out->data[i] = toOccupancyValue(map.labels[i], config);
  }
}

void toHybridSafetyMapMsg(const HybridSafetyMap& map, const SafetyMap& vision, bool vision_used,
                          double vision_age, const LaserGrid& laser, const std_msgs::Header& header,
                          HybridSafetyMapMsg* out) {
  nav_msgs::OccupancyGrid grid;  // for its MapMetaData only
  toHybridOccupancyGrid(
      HybridSafetyMap{map.min_u, map.min_v, map.width, map.height, map.resolution, {}},
      HybridSafetyMapConfig(), header, &grid);
  out->header = header;
  out->info = grid.info;
  const std::size_t n = map.labels.size();
  out->labels.resize(n);
  out->vision_labels.resize(n);
  out->laser_states.resize(n);
  const bool vision_ok =
      vision_used && vision.width > 0 && vision.height > 0 &&
      vision.labels.size() == static_cast<std::size_t>(vision.width) * vision.height;
  for (int row = 0; row < map.height; ++row) {
    const int v = map.min_v + row;
    for (int col = 0; col < map.width; ++col) {
      const int u = map.min_u + col;
      const std::size_t i = static_cast<std::size_t>(row) * map.width + col;
      out->labels[i] = static_cast<std::uint8_t>(map.labels[i]);
      out->vision_labels[i] = static_cast<std::uint8_t>(
          vision_ok && vision.inside(u, v) ? vision.labelAt(u, v) : SafetyLabel::kUnknown);
      out->laser_states[i] =
          static_cast<std::uint8_t>(laser.stateAt(u * map.resolution, v * map.resolution));
    }
  }
  out->vision_used = vision_used;
  out->vision_age = vision_age;
}

void laserGridToOccupancyGrid(const LaserGrid& grid, const std_msgs::Header& header,
                              nav_msgs::OccupancyGrid* out) {
  out->header = header;
  nav_msgs::MapMetaData& info = out->info;
  info.map_load_time = header.stamp;
  info.resolution = static_cast<float>(grid.resolution());
  info.width = static_cast<std::uint32_t>(grid.width());
  info.height = static_cast<std::uint32_t>(grid.height());
  info.origin.position.x = (grid.minU() - 0.5) * grid.resolution();
  info.origin.position.y = (grid.minV() - 0.5) * grid.resolution();
  info.origin.position.z = 0.0;
  info.origin.orientation = geometry_msgs::Quaternion();
  info.origin.orientation.w = 1.0;
  out->data.resize(static_cast<std::size_t>(grid.width()) * grid.height());
  std::size_t i = 0;
  for (int v = grid.minV(); v < grid.minV() + grid.height(); ++v) {
    for (int u = grid.minU(); u < grid.minU() + grid.width(); ++u) {
      switch (grid.state(u, v)) {
        case LaserCellState::kOccupied:
          out->data[i++] = 100;
          break;
        case LaserCellState::kFree:
          out->data[i++] = 0;
          break;
        default:
          out->data[i++] = -1;
          break;
      }
    }
  }
}

void pointsToCloud(const std::vector<Eigen::Vector3f>& points, const std_msgs::Header& header,
                   sensor_msgs::PointCloud2* out) {
  out->header = header;
  sensor_msgs::PointCloud2Modifier modifier(*out);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(points.size());
  out->height = 1;
  out->width = static_cast<std::uint32_t>(points.size());
  out->row_step = out->width * out->point_step;
  out->is_dense = true;
  // An iterator over an empty cloud reads data.front() of an empty vector (UBSan found it).
  if (points.empty()) return;
  sensor_msgs::PointCloud2Iterator<float> x(*out, "x"), y(*out, "y"), z(*out, "z");
  for (const Eigen::Vector3f& p : points) {
    *x = p.x();
    *y = p.y();
    *z = p.z();
    ++x;
    ++y;
    ++z;
  }
}

}  // namespace stereo_safety_map
