#include "stereo_safety_map/dataset/ground_truth.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

namespace stereo_safety_map {
namespace dataset {

namespace {

constexpr double kRad = 180.0 / M_PI;
constexpr long kMaxCells = 25'000'000;

const char* labelName(SafetyLabel l) {
  switch (l) {
    case SafetyLabel::kUnexamined:
      return "unexamined";
    case SafetyLabel::kUnknown:
      return "unknown";
    case SafetyLabel::kLevel:
      return "level";
    case SafetyLabel::kInclined:
      return "inclined";
    case SafetyLabel::kNonGround:
      return "non_ground";
  }
  return "unknown";
}

bool drivable(const GroundTruthMap& m, int k, double theta_max_deg) {
  return m.ground[k] >= 0 && !m.obstacle[k] && m.slope_deg[k] <= theta_max_deg;
}

std::string vec(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << std::setprecision(9) << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
  return s.str();
}

// Double-quoted YAML scalar (scene names are free text).
std::string q(const std::string& v) {
  std::string out = "\"";
  for (char c : v) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string writePgm(const std::string& path, int w, int h, const std::vector<std::uint8_t>& px) {
  std::ofstream f(path, std::ios::binary);
  if (!f) return "cannot write " + path;
  f << "P5\n" << w << " " << h << "\n255\n";
  f.write(reinterpret_cast<const char*>(px.data()), static_cast<std::streamsize>(px.size()));
  return f ? "" : "error writing " + path;
}

// Image rows run from the largest v (top) down, as map_server expects.
template <class F>
std::vector<std::uint8_t> toImage(const GroundTruthMap& m, F value) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(m.width) * m.height);
  for (int r = 0; r < m.height; ++r)
    for (int c = 0; c < m.width; ++c)
      px[static_cast<std::size_t>(r) * m.width + c] = value((m.height - 1 - r) * m.width + c);
  return px;
}

}  // namespace

std::string GroundTruthConfig::validate() const {
  if (!(resolution >= 0.01 && resolution <= 1.0)) return "gt.resolution must be in [0.01, 1] [m]";
  if (!(theta_max_deg > 0.0 && theta_max_deg < 60.0))
    return "gt.theta_max_deg must be in (0, 60) [deg]";
  if (!(theta_t_deg >= 0.0 && theta_t_deg <= theta_max_deg))
    return "gt.theta_t_deg must be in [0, theta_max_deg] [deg]";
  if (!(h_t > 0.0 && h_t <= 1.0)) return "gt.h_t must be in (0, 1] [m]";
  if (!(robot_height > 0.0 && robot_height <= 10.0))
    return "gt.robot_height must be in (0, 10] [m]";
  if (!(clearance >= 0.0 && clearance < robot_height))
    return "gt.clearance must be in [0, robot_height) [m]";
  if (samples_per_cell < 1 || samples_per_cell > 32)
    return "gt.samples_per_cell must be in [1, 32]";
  if (!(margin >= 0.0 && margin <= 100.0)) return "gt.margin must be in [0, 100] [m]";
  return "";
}

int GroundTruthMap::cellOf(double x) const {
  return static_cast<int>(std::lround(x / resolution));
}

SafetyLabel GroundTruthMap::labelAtPoint(double x, double y) const {
  const int u = cellOf(x), v = cellOf(y);
  return inside(u, v) ? labelAt(u, v) : SafetyLabel::kUnknown;
}

std::string computeGroundTruth(const Scene& scene, const GroundTruthConfig& config,
                               const Eigen::Vector2d& start, GroundTruthMap* map) {
  *map = GroundTruthMap();
  std::string e = config.validate();
  if (e.empty()) e = scene.validate();
  if (!e.empty()) return e;
  if (!start.allFinite()) return "start position must be finite";
  Eigen::AlignedBox2d area;
  for (const Primitive& p : scene.primitives)
    if (p.ground)
      area.extend(Eigen::AlignedBox2d(p.bounds.min().head<2>(), p.bounds.max().head<2>()));
  if (area.isEmpty()) return "the scene has no ground surface";
  area.extend(start);
  const double res = config.resolution;
  GroundTruthMap m;
  m.resolution = res;
  m.min_u = static_cast<int>(std::lround((area.min().x() - config.margin) / res));
  m.min_v = static_cast<int>(std::lround((area.min().y() - config.margin) / res));
  const int max_u = static_cast<int>(std::lround((area.max().x() + config.margin) / res));
  const int max_v = static_cast<int>(std::lround((area.max().y() + config.margin) / res));
  m.width = max_u - m.min_u + 1;
  m.height = max_v - m.min_v + 1;
  if (static_cast<long>(m.width) * m.height > kMaxCells) return "scene too large for the GT grid";
  const std::size_t n = static_cast<std::size_t>(m.width) * m.height;
  m.labels.assign(n, SafetyLabel::kUnknown);
  m.ground_height.assign(n, std::numeric_limits<float>::quiet_NaN());
  m.slope_deg.assign(n, std::numeric_limits<float>::quiet_NaN());
  m.ground.assign(n, -1);
  m.obstacle.assign(n, 0);
  m.reachable.assign(n, 0);
  m.drop_off.assign(n, 0);

  auto cellRange = [&](const Eigen::AlignedBox3d& b, double pad, int* u0, int* u1, int* v0,
                       int* v1) {
    *u0 = std::max(m.min_u, static_cast<int>(std::floor((b.min().x() - pad) / res)));
    *u1 = std::min(m.min_u + m.width - 1, static_cast<int>(std::ceil((b.max().x() + pad) / res)));
    *v0 = std::max(m.min_v, static_cast<int>(std::floor((b.min().y() - pad) / res)));
    *v1 = std::min(m.min_v + m.height - 1, static_cast<int>(std::ceil((b.max().y() + pad) / res)));
  };

  // The ground surface of a cell: the highest ground top face above its centre.
  std::vector<double> top(n, -std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < scene.primitives.size(); ++i) {
    const Primitive& p = scene.primitives[i];
    if (!p.ground) continue;
    int u0, u1, v0, v1;
    cellRange(p.bounds, 0.0, &u0, &u1, &v0, &v1);
    const double slope = std::acos(std::min(1.0, p.planes[p.top_face].n.z())) * kRad;
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        double z;
        if (!p.topHeightAt(u * res, v * res, &z, 1e-9)) continue;
        const int k = m.index(u, v);
        if (z > top[k]) {
          top[k] = z;
          m.ground[k] = static_cast<std::int32_t>(i);
          m.ground_height[k] = static_cast<float>(z);
          m.slope_deg[k] = static_cast<float>(slope);
        }
      }
    }
  }

  // Obstacles and overhangs: any non-ground solid between clearance and robot height above the
  // cell's ground anywhere in the cell (000 Sec. V-A: the robot passes under higher ones). A
  // lattice of vertical segments stands for the cell's area so that thin posts are not missed.
  const double start_z = [&]() {
    const int k = m.inside(m.cellOf(start.x()), m.cellOf(start.y()))
                      ? m.index(m.cellOf(start.x()), m.cellOf(start.y()))
                      : -1;
    return (k >= 0 && m.ground[k] >= 0) ? top[k] : 0.0;
  }();
  const int S = config.samples_per_cell;
  for (const Primitive& p : scene.primitives) {
    if (p.ground) continue;
    int u0, u1, v0, v1;
    cellRange(p.bounds, 0.5 * res, &u0, &u1, &v0, &v1);
    for (int v = v0; v <= v1; ++v) {
      for (int u = u0; u <= u1; ++u) {
        const int k = m.index(u, v);
        if (m.obstacle[k]) continue;
        const bool has_ground = m.ground[k] >= 0;
        Ray ray;
        ray.dir = Eigen::Vector3d(0.0, 0.0, -1.0);
        const double z_top = (has_ground ? top[k] : start_z) + config.robot_height;
        const double len = has_ground ? config.robot_height - config.clearance : 1e6;
        for (int i = 0; i < S * S && !m.obstacle[k]; ++i) {
          const double ox = ((i % S + 0.5) / S - 0.5) * res, oy = ((i / S + 0.5) / S - 0.5) * res;
          ray.origin = Eigen::Vector3d(u * res + ox, v * res + oy, z_top);
          double tin, tout;
          int face;
          if (p.interval(ray, &tin, &tout, &face) && tin <= len && tout >= 0.0) m.obstacle[k] = 1;
        }
      }
    }
  }
  m.start_u = m.cellOf(start.x());
  m.start_v = m.cellOf(start.y());
  *map = std::move(m);
  e = relabelGroundTruth(config, start, 0.0, map);
  if (!e.empty()) *map = GroundTruthMap();
  return e;
}

std::string relabelGroundTruth(const GroundTruthConfig& config, const Eigen::Vector2d& robot,
                               double planning_radius, GroundTruthMap* map) {
  std::string e = config.validate();
  if (!e.empty()) return e;
  GroundTruthMap& m = *map;
  const std::size_t n = static_cast<std::size_t>(m.width) * m.height;
  if (m.width <= 0 || m.height <= 0 || m.labels.size() != n || m.ground.size() != n ||
      m.obstacle.size() != n || m.ground_height.size() != n || m.slope_deg.size() != n)
    return "ground-truth map is empty or inconsistent";
  if (!robot.allFinite() || !std::isfinite(planning_radius)) return "robot position must be finite";
  const int ru = m.cellOf(robot.x()), rv = m.cellOf(robot.y());
  if (!m.inside(ru, rv)) return "robot position is outside the ground-truth map";
  const int rk = m.index(ru, rv);
  if (!drivable(m, rk, config.theta_max_deg)) {
    std::ostringstream s;
    s << "robot cell (" << ru << ", " << rv << ") at (" << robot.x() << ", " << robot.y()
      << ") is not drivable ground (no ground, an obstacle, or too steep)";
    return s.str();
  }
  m.reachable.assign(n, 0);
  m.drop_off.assign(n, 0);
  const double r2 = planning_radius * planning_radius;
  auto examined = [&](int u, int v) {
    if (planning_radius <= 0.0) return true;
    const double dx = u * m.resolution - robot.x(), dy = v * m.resolution - robot.y();
    return dx * dx + dy * dy <= r2;
  };
  // Reachability (000 Alg. 2): flood fill from the robot's cell over drivable cells whose
  // neighbours differ in ground height by less than h_T (4-neighbourhood, so that the robot never
  // slips between two diagonal obstacle cells).
  std::deque<int> queue;
  m.reachable[rk] = 1;
  queue.push_back(rk);
  const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
  while (!queue.empty()) {
    const int k = queue.front();
    queue.pop_front();
    const int u = m.min_u + k % m.width, v = m.min_v + k / m.width;
    for (int d = 0; d < 4; ++d) {
      const int nu = u + du[d], nv = v + dv[d];
      if (!m.inside(nu, nv) || !examined(nu, nv)) continue;
      const int nk = m.index(nu, nv);
      if (m.reachable[nk] || !drivable(m, nk, config.theta_max_deg)) continue;
      if (!(std::abs(m.ground_height[nk] - m.ground_height[k]) < config.h_t)) continue;
      m.reachable[nk] = 1;
      queue.push_back(nk);
    }
  }
  for (int v = m.min_v; v < m.min_v + m.height; ++v) {
    for (int u = m.min_u; u < m.min_u + m.width; ++u) {
      const int k = m.index(u, v);
      SafetyLabel l;
      if (!examined(u, v)) {
        l = SafetyLabel::kUnexamined;
      } else if (m.obstacle[k]) {
        l = SafetyLabel::kNonGround;
      } else if (m.ground[k] < 0) {
        l = SafetyLabel::kUnknown;
      } else if (m.reachable[k]) {
        l = m.slope_deg[k] <= config.theta_t_deg ? SafetyLabel::kLevel : SafetyLabel::kInclined;
      } else {
        l = SafetyLabel::kNonGround;  // unreachable or too steep (000 Alg. 2 steps 2, 27)
      }
      m.labels[k] = l;
    }
  }
  // Drop-off edges (000 Sec. VI): safe cells beside ground lower by at least h_T, or beside a
  // cell without ground.
  for (int v = m.min_v; v < m.min_v + m.height; ++v) {
    for (int u = m.min_u; u < m.min_u + m.width; ++u) {
      const int k = m.index(u, v);
      if (!isSafe(m.labels[k])) continue;
      bool edge = false;
      for (int dy = -1; dy <= 1 && !edge; ++dy) {
        for (int dx = -1; dx <= 1 && !edge; ++dx) {
          if (dx == 0 && dy == 0) continue;
          if (!m.inside(u + dx, v + dy)) {
            edge = true;
            continue;
          }
          const int nk = m.index(u + dx, v + dy);
          edge = m.ground[nk] < 0 || m.ground_height[nk] <= m.ground_height[k] - config.h_t;
        }
      }
      m.drop_off[k] = edge ? 1 : 0;
    }
  }
  return "";
}

std::vector<GroundTruthPlane> groundTruthPlanes(const Scene& scene, const GroundTruthMap& map) {
  std::vector<GroundTruthPlane> out;
  for (std::size_t i = 0; i < scene.primitives.size(); ++i) {
    const Primitive& p = scene.primitives[i];
    if (!p.ground || p.top_face < 0) continue;
    const HalfSpace& h = p.planes[p.top_face];
    GroundTruthPlane g;
    g.name = p.name;
    g.group = p.group;
    g.a = -h.n.x() / h.n.z();
    g.b = -h.n.y() / h.n.z();
    g.c = h.d / h.n.z();
    g.normal = h.n;
    g.slope_deg = std::acos(std::min(1.0, h.n.z())) * kRad;
    g.polygon = p.topPolygon();
    int counts[5] = {0, 0, 0, 0, 0};
    for (std::size_t k = 0; k < map.ground.size(); ++k) {
      if (map.ground[k] != static_cast<std::int32_t>(i)) continue;
      ++g.cells;
      ++counts[static_cast<int>(map.labels[k])];
    }
    int best = static_cast<int>(SafetyLabel::kUnknown);
    for (int l = 0; l < 5; ++l)
      if (counts[l] > counts[best]) best = l;
    g.label = static_cast<SafetyLabel>(best);
    out.push_back(g);
  }
  return out;
}

std::vector<GroundTruthObstacle> groundTruthObstacles(const Scene& scene) {
  std::vector<GroundTruthObstacle> out;
  for (const Primitive& p : scene.primitives) {
    if (p.ground) continue;
    GroundTruthObstacle o;
    o.name = p.name;
    o.group = p.group;
    o.type = p.type;
    o.shape = p.shape == Primitive::Shape::kCylinder ? "cylinder" : "box";
    o.obb = p.obb;
    o.bounds = p.bounds;
    o.radius = p.shape == Primitive::Shape::kCylinder ? p.radius : 0.0;
    out.push_back(o);
  }
  return out;
}

std::uint8_t labelGrey(SafetyLabel l) {
  switch (l) {
    case SafetyLabel::kLevel:
      return 254;
    case SafetyLabel::kInclined:
      return 220;
    case SafetyLabel::kUnknown:
      return 128;
    case SafetyLabel::kUnexamined:
      return 160;
    case SafetyLabel::kNonGround:
      return 0;
  }
  return 128;
}

std::string writeGroundTruthFiles(const std::string& dir, const Scene& scene,
                                  const GroundTruthConfig& config, const GroundTruthMap& m,
                                  const std::vector<GroundTruthPlane>& planes,
                                  const std::vector<GroundTruthObstacle>& obstacles) {
  if (m.width <= 0 || m.height <= 0 ||
      m.labels.size() != static_cast<std::size_t>(m.width) * m.height)
    return "ground-truth map is empty";
  std::string e = writePgm(dir + "/gt_map.pgm", m.width, m.height,
                           toImage(m, [&](int k) { return labelGrey(m.labels[k]); }));
  if (e.empty())
    e = writePgm(dir + "/gt_labels.pgm", m.width, m.height,
                 toImage(m, [&](int k) { return static_cast<std::uint8_t>(m.labels[k]); }));
  if (e.empty())
    e = writePgm(dir + "/gt_drop_off.pgm", m.width, m.height, toImage(m, [&](int k) {
                   return static_cast<std::uint8_t>(m.drop_off[k] ? 255 : 0);
                 }));
  if (!e.empty()) return e;

  int counts[5] = {0, 0, 0, 0, 0};
  for (SafetyLabel l : m.labels)
    ++counts[static_cast<int>(l)];
  {
    std::ofstream f(dir + "/gt_map.yaml");
    if (!f) return "cannot write " + dir + "/gt_map.yaml";
    f << std::setprecision(9);
    f << "# Ground-truth safety map of scene '" << scene.name << "' (map_server format).\n"
      << "# Cell (u, v) is centred at (u * resolution, v * resolution) in odom (Eq. (1) of\n"
      << "# paper 000); image rows run from the largest v down. gt_map.pgm grey levels:\n"
      << "# level 254, inclined 220, unknown 128, unexamined 160, non_ground 0, so that\n"
      << "# map_server's trinary mode reads safe cells as free and non-ground as occupied.\n"
      << "# gt_labels.pgm holds the raw label values (SafetyMap.msg constants):\n"
      << "# unexamined 0, unknown 1, level 2, inclined 3, non_ground 4.\n"
      << "# gt_drop_off.pgm: 255 on potential drop-off edges (safe cells beside lower ground).\n"
      << "image: gt_map.pgm\n"
      << "resolution: " << m.resolution << "\n"
      << "origin: [" << (m.min_u - 0.5) * m.resolution << ", " << (m.min_v - 0.5) * m.resolution
      << ", 0.0]\n"
      << "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n"
      << "scene: " << q(scene.name) << "\n"
      << "frame_id: odom\n"
      << "grid: {min_u: " << m.min_u << ", min_v: " << m.min_v << ", width: " << m.width
      << ", height: " << m.height << "}\n"
      << "start_cell: [" << m.start_u << ", " << m.start_v << "]\n"
      << "label_grey: {level: 254, inclined: 220, unknown: 128, unexamined: 160, non_ground: 0}\n"
      << "label_values: {unexamined: 0, unknown: 1, level: 2, inclined: 3, non_ground: 4}\n"
      << "robot: {theta_max_deg: " << config.theta_max_deg
      << ", theta_t_deg: " << config.theta_t_deg << ", h_t: " << config.h_t
      << ", robot_height: " << config.robot_height << ", clearance: " << config.clearance << "}\n"
      << "cell_counts: {level: " << counts[2] << ", inclined: " << counts[3]
      << ", non_ground: " << counts[4] << ", unknown: " << counts[1]
      << ", unexamined: " << counts[0] << "}\n";
    if (!f) return "error writing gt_map.yaml";
  }
  {
    std::ofstream f(dir + "/gt_planes.yaml");
    if (!f) return "cannot write " + dir + "/gt_planes.yaml";
    f << std::setprecision(9);
    f << "# Ground-truth planes of the ground surfaces of scene '" << scene.name << "' in odom:\n"
      << "# z = a x + b y + c over the polygon (000 Sec. V-B, VII-C). label: majority GT label of\n"
      << "# the cells where the surface is the top ground.\n"
      << "frame_id: odom\nplanes:\n";
    for (const GroundTruthPlane& p : planes) {
      f << "  - name: " << q(p.name) << "\n    group: " << q(p.group) << "\n    a: " << p.a
        << "\n    b: " << p.b << "\n    c: " << p.c << "\n    normal: " << vec(p.normal)
        << "\n    slope_deg: " << p.slope_deg << "\n    label: " << labelName(p.label)
        << "\n    cells: " << p.cells << "\n    polygon:\n";
      for (const auto& q : p.polygon)
        f << "      - " << vec(q) << "\n";
    }
    if (!f) return "error writing gt_planes.yaml";
  }
  {
    std::ofstream f(dir + "/gt_obstacles.yaml");
    if (!f) return "cannot write " + dir + "/gt_obstacles.yaml";
    f << std::setprecision(9);
    f << "# Ground-truth obstacles (non-ground solids) of scene '" << scene.name << "' in odom.\n"
      << "# Oriented box: centre, full size along its axes, rotation as quaternion [x, y, z, w];\n"
      << "# cylinders: the box's z axis is the cylinder axis, radius given.\n"
      << "frame_id: odom\nobstacles:\n";
    for (const GroundTruthObstacle& o : obstacles) {
      const Eigen::Quaterniond rot(o.obb.rotation);
      f << "  - name: " << q(o.name) << "\n    group: " << q(o.group) << "\n    type: " << q(o.type)
        << "\n    shape: " << o.shape << "\n    center: " << vec(o.obb.center)
        << "\n    size: " << vec(2.0 * o.obb.half_size) << "\n    rotation: [" << rot.x() << ", "
        << rot.y() << ", " << rot.z() << ", " << rot.w()
        << "]\n    bounds_min: " << vec(o.bounds.min())
        << "\n    bounds_max: " << vec(o.bounds.max()) << "\n";
      if (o.shape == "cylinder") f << "    radius: " << o.radius << "\n";
    }
    if (!f) return "error writing gt_obstacles.yaml";
  }
  return "";
}

}  // namespace dataset
}  // namespace stereo_safety_map
