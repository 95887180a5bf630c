// Safety labelling of the ground segments (000 Sec. VI, Alg. 2). See safety_labelling.h.
//
// Why one file of ~800 lines (issue 17 asks for a reason above ~800): it is Alg. 2, one pass
// over the segments in the paper's step order (small / thin, slope, the border contacts of
// steps 15-21, reachability, steps 27-28) with the switches that amend single steps beside the
// step they amend; split by step, each part would need the whole pass's state.
#include "stereo_safety_map/core/safety_labelling.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

// Internal segment states of Alg. 2 before step 28 turns Safe into Level / Inclined.
enum SegState : std::uint8_t { kStUnexamined, kStUnknown, kStNonGround, kStSafe };

constexpr int kDu[8] = {1, -1, 0, 0, 1, 1, -1, -1};
// Distinct segments one boundary cell is compared with: its 8 neighbours and, across gaps, at
// most (2 (max_gap_cells + 1) + 1)^2 - 1 = 528 cells; more than 64 distinct segments around one
// cell do not occur in a height map (each needs its own cells).
constexpr int kMaxNeighbourSegments = 64;
// Marks a cell whose local surface height is not computed yet (heights are far below it).
constexpr float kLocalZPending = -1e30f;
constexpr int kDv[8] = {0, 0, 1, -1, 1, -1, 1, -1};

std::int16_t toInt16Height(std::int32_t w) {
  if (w == HeightMap::kNoHeight) return SafetyMap::kNoHeight;
  return static_cast<std::int16_t>(std::clamp<std::int32_t>(w, -32767, 32767));
}

}  // namespace

std::string SafetyLabellingConfig::validate() const {
  if (!std::isfinite(max_slope_deg) || max_slope_deg <= 0.0 || max_slope_deg >= 90.0) {
    return "max_slope_deg (theta_max) must be in (0, 90) deg";
  }
  if (min_segment_cells < 0 || min_segment_cells > 1000000) {
    return "min_segment_cells (n_small) must be in [0, 1000000]";
  }
  if (!std::isfinite(thin_ratio) || thin_ratio < 0.0 || thin_ratio > 1000.0) {
    return "thin_ratio (r_thin) must be in [0, 1000]";
  }
  if (!std::isfinite(max_step_height) || max_step_height <= 0.0 || max_step_height > 10.0) {
    return "max_step_height (h_T) must be in (0, 10] m";
  }
  if (!std::isfinite(step_height_margin) || step_height_margin < 0.0 ||
      step_height_margin >= max_step_height) {
    return "step_height_margin must be in [0, max_step_height) m";
  }
  if (min_passage_cells < 1 || min_passage_cells > 100000) {
    return "min_passage_cells (num_T) must be in [1, 100000]";
  }
  if (!std::isfinite(level_slope_deg) || level_slope_deg < 0.0 || level_slope_deg > max_slope_deg) {
    return "level_slope_deg (theta_T) must be in [0, max_slope_deg] deg";
  }
  if (!std::isfinite(slope_margin_deg) || slope_margin_deg < 0.0 ||
      slope_margin_deg > max_slope_deg - level_slope_deg) {
    return "slope_margin_deg must be in [0, max_slope_deg - level_slope_deg] deg";
  }
  if (max_gap_cells < 0 || max_gap_cells > 10) return "max_gap_cells must be in [0, 10]";
  if (!std::isfinite(small_obstacle_min_rise) || small_obstacle_min_rise < 0.0 ||
      small_obstacle_min_rise > 10.0) {
    return "small_obstacle_min_rise must be in [0, 10] m";
  }
  if (!std::isfinite(floor_fragment_tolerance) || floor_fragment_tolerance < 0.0 ||
      floor_fragment_tolerance > 1.0) {
    return "floor_fragment_tolerance must be in [0, 1] m";
  }
  if (!std::isfinite(footprint_bridge) || footprint_bridge < 0.0 || footprint_bridge > 10.0) {
    return "footprint_bridge must be in [0, 10] m (0 = off)";
  }
  if (!std::isfinite(bridge_tilt_deg) || bridge_tilt_deg < 0.0 || bridge_tilt_deg > 10.0) {
    return "bridge_tilt_deg must be in [0, 10] deg";
  }
  if (!std::isfinite(drop_off_radius) || drop_off_radius < 0.0 || drop_off_radius > 10.0) {
    return "drop_off_radius must be in [0, 10] m";
  }
  if (!std::isfinite(drop_off_min_drop) || drop_off_min_drop < 0.0 || drop_off_min_drop > 10.0) {
    return "drop_off_min_drop must be in [0, 10] m";
  }
  if (!std::isfinite(drop_off_sink) || drop_off_sink < 0.0 || drop_off_sink > 10.0) {
    return "drop_off_sink must be in [0, 10] m (0 = off)";
  }
  if (!std::isfinite(obstacle_face_min_rise) || obstacle_face_min_rise < 0.0 ||
      obstacle_face_min_rise > 10.0) {
    return "obstacle_face_min_rise must be in [0, 10] m";
  }
  if (!std::isfinite(obstacle_face_reach) || obstacle_face_reach < 0.0 ||
      obstacle_face_reach > 10.0) {
    return "obstacle_face_reach must be in [0, 10] m";
  }
  if (!std::isfinite(obstacle_face_reach_sigmas) || obstacle_face_reach_sigmas < 0.0 ||
      obstacle_face_reach_sigmas > 100.0) {
    return "obstacle_face_reach_sigmas must be in [0, 100]";
  }
  return "";
}

SafetyLabelling::SafetyLabelling(const SafetyLabellingConfig& config) : config_(config) {
  const std::string err = config_.validate();
  if (!err.empty()) throw std::invalid_argument("SafetyLabellingConfig: " + err);
}

bool SafetyLabelling::faceReaches(const HeightMap& hm, int c, int cn, double voxel_size) const {
  if (grid_ == nullptr || config_.obstacle_face_reach >= voxel_size) return true;
  const int width = hm.width();
  const int u = hm.minU() + c % width, v = hm.minV() + c / width;
  const int du = hm.minU() + cn % width - u, dv = hm.minV() + cn / width - v;
  // The border of cell (u, v) towards the face column, per axis the neighbour steps along
  // (cells are centred on i * l_v, Eq. (1)).
  const double bx = (u + 0.5 * du) * voxel_size, by = (v + 0.5 * dv) * voxel_size;
  const double reach = config_.obstacle_face_reach;
  // obstacle_face_reach_sigmas: k sigma_d / (f b), times r^2 per point (001 Sec. 4.1).
  const double fb = grid_->focalBaseline();
  const double per_r2 =
      config_.obstacle_face_reach_sigmas > 0.0 && fb > 0.0
          ? config_.obstacle_face_reach_sigmas * grid_->config().disparity_sigma / fb
          : 0.0;
  const std::int32_t top = hm.atIndex(cn);
  const int un = u + du, vn = v + dv;
  for (std::int32_t w = top; w >= top - 1; --w) {
    for (const VoxelPoint& p : grid_->points(VoxelIndex{un, vn, w})) {
      // How deep the point stands in the face's column, from the shared border (or corner).
      double depth = 0.0;
      if (du != 0) depth = std::max(depth, du * (p.position.x() - bx));
      if (dv != 0) depth = std::max(depth, dv * (p.position.y() - by));
      const double r = p.range;
      if (depth <= std::max(reach, per_r2 * r * r)) return true;
    }
  }
  return false;
}

float SafetyLabelling::localSurfaceHeight(const HeightMap& hm, const GroundSegments& segs, int c) {
  float& z = local_z_[c];
  if (z != kLocalZPending) return z;  // computed before (NaN included)
  const int k = segs.segment_of[c];
  const int width = segs.width, u = c % width, v = c / width;
  const int r = kLocalSurfaceRadius;
  double sum = 0.0;
  int count = 0;
  for (int vn = std::max(0, v - r); vn <= std::min(segs.height - 1, v + r); ++vn) {
    for (int un = std::max(0, u - r); un <= std::min(width - 1, u + r); ++un) {
      const int cn = vn * width + un;
      if (segs.segment_of[cn] != k) continue;
      const float zn = hm.surfaceHeightAtIndex(cn);
      if (std::isnan(zn)) continue;
      sum += zn;
      ++count;
    }
  }
  z = count > 0 ? static_cast<float>(sum / count) : std::numeric_limits<float>::quiet_NaN();
  return z;
}

const SafetyLabelling::Edge* SafetyLabelling::edgeOf(int s, int r) const {
  const auto first = edges_.begin() + edge_begin_[s];
  const auto last = edges_.begin() + edge_begin_[s + 1];
  const auto it =
      std::lower_bound(first, last, r, [](const Edge& e, int key) { return e.r < key; });
  return (it != last && it->r == r) ? &*it : nullptr;
}

int SafetyLabelling::okCount(int s, int r) const {
  const Edge* e = edgeOf(s, r);
  return e != nullptr ? e->ok : 0;
}

int SafetyLabelling::farCount(int s, int r) const {
  const Edge* e = edgeOf(s, r);
  return e != nullptr ? e->far : 0;
}

bool SafetyLabelling::borderFailed(int s, int r) const {
  auto failedOn = [&](int a, int b) {
    const Edge* e = edgeOf(a, b);
    return e != nullptr && e->failed > 0;
  };
  return failedOn(s, r) || failedOn(r, s);
}

bool SafetyLabelling::label(const HeightMap& hm, const GroundSegments& segs,
                            const std::vector<GroundPlane>& planes, double voxel_size,
                            SafetyMap* map) {
  face_marks_.clear();
  if (map == nullptr) return false;
  SafetyMap& m = *map;
  const int n = hm.numCells();
  const int width = hm.width();
  m.min_u = hm.minU();
  m.min_v = hm.minV();
  m.width = width;
  m.height = hm.height();
  m.resolution = voxel_size;
  m.robot_u = segs.robot.u;
  m.robot_v = segs.robot.v;
  m.robot_segment = -1;
  m.labels.assign(n, SafetyLabel::kUnknown);
  m.segment.assign(n, -1);
  m.drop_off.assign(n, 0);
  m.column_height.resize(n);
  for (int c = 0; c < n; ++c)
    m.column_height[c] = toInt16Height(hm.atIndex(c));

  const int nseg = segs.numSegments();
  const bool consistent =
      std::isfinite(voxel_size) && voxel_size > 0.0 && segs.width == width &&
      segs.height == hm.height() && segs.min_u == hm.minU() && segs.min_v == hm.minV() &&
      static_cast<int>(segs.segment_of.size()) == n &&
      static_cast<int>(segs.examined.size()) == n &&
      static_cast<int>(segs.segment_begin.size()) == nseg + 1 && segs.segment_begin.front() == 0 &&
      segs.segment_begin.back() == static_cast<int>(segs.segment_cells.size()) &&
      std::is_sorted(segs.segment_begin.begin(), segs.segment_begin.end()) &&
      segs.robot_segment < nseg &&
      std::all_of(segs.segment_cells.begin(), segs.segment_cells.end(),
                  [n](int c) { return c >= 0 && c < n; });
  if (!consistent) {
    m.segments.clear();
    return false;
  }
  m.robot_segment = segs.robot_segment;
  const double l = voxel_size;
  auto planeOf = [&](int k) -> const GroundPlane* {
    return (k < static_cast<int>(planes.size()) && planes[k].valid) ? &planes[k] : nullptr;
  };

  // Interior and boundary cells (000, Sec. VI): interior cells have all 8 neighbours in their
  // own segment; cells on the map's edge have fewer than 8 and are boundary cells.
  const int gap = config_.max_gap_cells;
  const int reach = gap + 1;
  const bool measured = config_.measured_step_test;
  // h_T less the measurement's margin (SafetyLabellingConfig::step_height_margin).
  const double crossable = config_.crossableStep();
  // Local surface heights are needed by the step test, the small-obstacle rule and the floor
  // fragments.
  const bool heights = measured || config_.small_obstacles;
  m.segments.resize(nseg);
  boundary_.assign(n, 0);
  if (heights) local_z_.assign(n, kLocalZPending);
  contacts_.clear();
  for (int k = 0; k < nseg; ++k) {
    SegmentInfo& info = m.segments[k];
    info.id = k;
    info.indexed_height = segs.segment_height[k];
    info.cells.assign(segs.cellsBegin(k), segs.cellsEnd(k));
    info.num_interior = 0;
    info.num_boundary = 0;
    info.plane = k < static_cast<int>(planes.size()) ? planes[k] : GroundPlane();
    info.reachable = false;
    info.island = k < static_cast<int>(segs.segment_island.size()) && segs.segment_island[k] != 0;
    info.obstacle = false;
    info.merged_into = -1;
    const GroundPlane* ps = planeOf(k);
    for (const int c : info.cells) {
      const int u = c % width, v = c / width;
      int nb_seg[kMaxNeighbourSegments];
      bool nb_close[kMaxNeighbourSegments];  // a cell of it has a measured height within h_T
      bool nb_near[kMaxNeighbourSegments];   // ... within floor_fragment_tolerance
      float nb_rise[kMaxNeighbourSegments];  // largest rise of c over its cells
      int num_nb_seg = 0;
      const float zc = heights ? localSurfaceHeight(hm, segs, c) : 0.0f;
      // Records cell cn of segment r as a neighbour of c.
      auto addNeighbour = [&](int r, int cn) {
        int j = 0;
        while (j < num_nb_seg && nb_seg[j] != r)
          ++j;
        if (j == num_nb_seg) {
          if (num_nb_seg >= kMaxNeighbourSegments) return;
          nb_seg[num_nb_seg] = r;
          nb_rise[num_nb_seg] = std::numeric_limits<float>::quiet_NaN();
          nb_near[num_nb_seg] = false;
          nb_close[num_nb_seg++] = false;
        }
        if (heights) {
          const float zn = localSurfaceHeight(hm, segs, cn);
          nb_close[j] = nb_close[j] || std::abs(zc - zn) < crossable;  // NaN: no
          nb_near[j] = nb_near[j] || std::abs(zc - zn) < config_.floor_fragment_tolerance;
          const float rise = zc - zn;
          if (!(nb_rise[j] >= rise)) nb_rise[j] = rise;  // NaN-safe max
        }
      };
      bool interior = true;
      for (int j = 0; j < 8; ++j) {
        const int un = u + kDu[j], vn = v + kDv[j];
        if (un < 0 || vn < 0 || un >= width || vn >= m.height) {
          interior = false;
          continue;
        }
        const int r = segs.segment_of[vn * width + un];
        if (r == k) continue;
        interior = false;
        if (r >= 0) addNeighbour(r, vn * width + un);
      }
      if (interior) {
        ++info.num_interior;
        continue;
      }
      ++info.num_boundary;
      boundary_[c] = 1;
      if (gap > 0) {
        // Segments across a gap of unobserved columns (SafetyLabellingConfig::max_gap_cells).
        for (int dv = -reach; dv <= reach; ++dv) {
          const int vn = v + dv;
          if (vn < 0 || vn >= m.height) continue;
          for (int du = -reach; du <= reach; ++du) {
            const int un = u + du;
            const int steps = std::max(std::abs(du), std::abs(dv));
            if (steps < 2 || un < 0 || un >= width) continue;
            const int r = segs.segment_of[vn * width + un];
            if (r < 0 || r == k) continue;
            bool open = true;
            for (int t = 1; t < steps && open; ++t) {
              const int ut = u + static_cast<int>(std::lround(static_cast<double>(du) * t / steps));
              const int vt = v + static_cast<int>(std::lround(static_cast<double>(dv) * t / steps));
              open = hm.atIndex(vt * width + ut) == HeightMap::kNoHeight;
            }
            if (open) addNeighbour(r, vn * width + un);
          }
        }
      }
      // Alg. 2 steps 14-19 for this cell against every neighbouring segment: the planes'
      // heights at the cell's centre (000), or the local measured surface heights of the two
      // segments at this cell and at a neighbouring cell of the other segment
      // (SafetyLabellingConfig::measured_step_test).
      const double xc = (m.min_u + u) * l, yc = (m.min_v + v) * l;
      for (int j = 0; j < num_nb_seg; ++j) {
        const GroundPlane* pr = planeOf(nb_seg[j]);
        int ok = 0;
        if (ps != nullptr && pr != nullptr) {
          // Two sides of a step that GroundSegmentationConfig::split_steps measured are judged
          // by their planes alone: their top voxels' points, the upper tail of the lower
          // side's noise, stand within h_T of the upper side's.
          ok = std::abs(ps->heightAt(xc, yc) - pr->heightAt(xc, yc)) < crossable ||
               (measured && nb_close[j] && !segs.splitSiblings(k, nb_seg[j]));
        }
        contacts_.push_back(Contact{k, nb_seg[j], ok, nb_rise[j], c, nb_near[j] ? 1 : 0});
      }
    }
  }

  // SafetyLabellingConfig::footprint_bridge: the robot's footprint and the ground beyond the
  // camera's blind zone are neighbours across unobserved cells.
  const int rs = segs.robot_segment;
  if (config_.footprint_bridge > 0.0 && rs >= 0 && planeOf(rs) != nullptr &&
      static_cast<int>(segs.footprint.size()) == n) {
    bridge_from_.clear();
    int u_lo = width, u_hi = -1, v_lo = m.height, v_hi = -1;
    for (const int c : m.segments[rs].cells) {
      if (!segs.footprint[c] || !boundary_[c]) continue;
      bridge_from_.push_back(c);
      u_lo = std::min(u_lo, c % width);
      u_hi = std::max(u_hi, c % width);
      v_lo = std::min(v_lo, c / width);
      v_hi = std::max(v_hi, c / width);
    }
    const int reach_cells = static_cast<int>(std::floor(config_.footprint_bridge / l + 1e-9));
    const long long reach2 = static_cast<long long>(reach_cells) * reach_cells;
    bridge_to_.clear();
    if (!bridge_from_.empty() && reach_cells >= 2) {
      for (int v = std::max(0, v_lo - reach_cells); v <= std::min(m.height - 1, v_hi + reach_cells);
           ++v) {
        for (int u = std::max(0, u_lo - reach_cells); u <= std::min(width - 1, u_hi + reach_cells);
             ++u) {
          const int c = v * width + u;
          const int r = segs.segment_of[c];
          if (r >= 0 && r != rs && boundary_[c]) bridge_to_.push_back(c);
        }
      }
    }
    const GroundPlane* prs = planeOf(rs);
    const double tan_tilt = std::tan(config_.bridge_tilt_deg * M_PI / 180.0);
    // A cell already next to a segment (touching, or across max_gap_cells) keeps that one
    // contact: a border cell counts once towards num_T.
    const std::size_t main_contacts = contacts_.size();
    auto hasContact = [&](int cell, int s, int r) {
      return std::any_of(contacts_.begin(), contacts_.begin() + main_contacts,
                         [&](const Contact& k) { return k.cell == cell && k.s == s && k.r == r; });
    };
    // Only unobserved cells (and the footprint's own) between f and c.
    auto open = [&](int f, int c) {
      const int uf = f % width, vf = f / width, uc = c % width, vc = c / width;
      const int du = uc - uf, dv = vc - vf;
      const int steps = std::max(std::abs(du), std::abs(dv));
      for (int t = 1; t < steps; ++t) {
        const int ut = uf + static_cast<int>(std::lround(static_cast<double>(du) * t / steps));
        const int vt = vf + static_cast<int>(std::lround(static_cast<double>(dv) * t / steps));
        const int ct = vt * width + ut;
        if (hm.atIndex(ct) != HeightMap::kNoHeight) return false;
        if (segs.segment_of[ct] >= 0 && !segs.footprint[ct]) return false;
      }
      return true;
    };
    // For each far boundary cell: does it see the footprint, crossably? The two planes differ
    // by an affine function along the straight line from a footprint cell f to the far cell c:
    // the ground can run on without a step when they meet on it (the difference changes sign,
    // e.g. a ramp that starts in the blind zone) or differ by less than the tolerance at one
    // end (at c: 000's test at the far cell; at f: the far plane carried back to the footprint).
    // For each footprint boundary cell: which segments does it see, crossably?
    std::vector<std::pair<int, int>> seen;  // (footprint cell, segment) with its best ok
    for (const int c : bridge_to_) {
      const int r = segs.segment_of[c];
      const GroundPlane* pr = planeOf(r);
      const double xc = (m.min_u + c % width) * l, yc = (m.min_v + c / width) * l;
      // SafetyLabellingConfig::bridge_tilt_deg: the footprint's level plane extrapolated d m.
      const double d = std::hypot(xc - m.robot_u * l, yc - m.robot_v * l);
      const double tolerance = config_.max_step_height + d * tan_tilt;
      const double dz_c = pr != nullptr ? pr->heightAt(xc, yc) - prs->heightAt(xc, yc) : 0.0;
      int ok = 0;
      bool any = false;
      for (const int f : bridge_from_) {
        const long long du = c % width - f % width, dv = c / width - f / width;
        if (du * du + dv * dv > reach2 || std::max(std::llabs(du), std::llabs(dv)) < 2) continue;
        if (!open(f, c)) continue;
        any = true;
        int pair_ok = 0;
        if (pr != nullptr) {
          const double xf = (m.min_u + f % width) * l, yf = (m.min_v + f / width) * l;
          const double dz_f = pr->heightAt(xf, yf) - prs->heightAt(xf, yf);
          pair_ok = std::abs(dz_c) < tolerance || std::abs(dz_f) < tolerance ||
                    (dz_c > 0.0) != (dz_f > 0.0);
        }
        ok = ok || pair_ok;
        seen.emplace_back(f, pair_ok ? r : -1 - r);
      }
      if (any && !hasContact(c, r, rs)) {
        contacts_.push_back(Contact{r, rs, ok, std::numeric_limits<float>::quiet_NaN(), c, 0});
      }
    }
    // The footprint's side: one contact per footprint cell and segment, ok when any of its
    // lines to that segment is.
    std::sort(seen.begin(), seen.end());
    for (std::size_t i = 0; i < seen.size();) {
      const int f = seen[i].first;
      std::size_t j = i;
      while (j < seen.size() && seen[j].first == f)
        ++j;
      // Segments seen from f: r (ok) or -1 - r (not ok).
      for (std::size_t a = i; a < j; ++a) {
        const int code = seen[a].second;
        const int r = code >= 0 ? code : -1 - code;
        bool first = true, ok = false;
        for (std::size_t b = i; b < j; ++b) {
          const int other = seen[b].second >= 0 ? seen[b].second : -1 - seen[b].second;
          if (other != r) continue;
          if (b < a) first = false;
          ok = ok || seen[b].second >= 0;
        }
        if (first && !hasContact(f, rs, r)) {
          contacts_.push_back(
              Contact{rs, r, ok ? 1 : 0, std::numeric_limits<float>::quiet_NaN(), f, 0});
        }
      }
      i = j;
    }
  }

  // Segment neighbourhood (000, Sec. VI): segments whose boundary cells are neighbours. Each
  // side of a border keeps its own count of crossable cells.
  std::sort(contacts_.begin(), contacts_.end(),
            [](const Contact& a, const Contact& b) { return a.s != b.s ? a.s < b.s : a.r < b.r; });
  edges_.clear();
  edge_begin_.assign(nseg + 1, 0);
  for (std::size_t i = 0; i < contacts_.size();) {
    std::size_t j = i;
    int ok = 0, failed = 0, far = 0;
    float rise = std::numeric_limits<float>::quiet_NaN();
    while (j < contacts_.size() && contacts_[j].s == contacts_[i].s &&
           contacts_[j].r == contacts_[i].r) {
      ok += contacts_[j].ok;
      failed += contacts_[j].ok ? 0 : 1;
      far += contacts_[j].close ? 0 : 1;
      if (!(rise >= contacts_[j].rise)) rise = contacts_[j].rise;  // NaN-safe max
      ++j;
    }
    edges_.push_back(Edge{contacts_[i].r, ok, failed, rise, far});
    ++edge_begin_[contacts_[i].s + 1];
    i = j;
  }
  for (int k = 0; k < nseg; ++k)
    edge_begin_[k + 1] += edge_begin_[k];

  // Alg. 2 steps 1-4.
  seg_state_.assign(nseg, kStUnexamined);
  small_.assign(nseg, 0);
  for (int k = 0; k < nseg; ++k) {
    const SegmentInfo& info = m.segments[k];
    const GroundPlane* p = planeOf(k);
    if (p == nullptr) {
      seg_state_[k] = kStUnknown;  // no plane, nothing to judge the segment by
      small_[k] = 1;
      continue;
    }
    // Step 2, with SafetyLabellingConfig::slope_margin_deg taken off theta_max.
    if (p->slope_deg > config_.traversableSlope()) seg_state_[k] = kStNonGround;
    if (static_cast<int>(info.cells.size()) < config_.min_segment_cells) {  // step 3
      seg_state_[k] = kStUnknown;
      small_[k] = 1;
    }
    if (info.num_interior < config_.thin_ratio * info.num_boundary) {  // step 4
      seg_state_[k] = kStUnknown;
      small_[k] = 1;
    }
  }

  // Steps 5-26: grow the safe set from the robot's segment. The paper assumes the robot's segment
  // is safe, so step 6 overrides steps 2-4 for it; without a valid plane there is nothing to
  // compare its neighbours with and nothing is reachable.
  neighbours_examined_.assign(nseg, 0);
  to_examine_.clear();
  const bool robot_fragment = config_.robot_fragment_passage && rs >= 0 && small_[rs] != 0;
  if (rs >= 0 && planeOf(rs) != nullptr) {
    seg_state_[rs] = kStSafe;
    to_examine_.push_back(rs);
  }
  std::size_t head = 0;
  while (head < to_examine_.size()) {
    const int s = to_examine_[head++];
    if (neighbours_examined_[s]) continue;
    for (int e = edge_begin_[s]; e < edge_begin_[s + 1]; ++e) {
      const int r = edges_[e].r;
      // num_RS: num_T is the robot's width in cells (Sec. VI), so the crossable cells are
      // counted on each side of the border and the smaller count is the passage width (the
      // union of both sides would count every position of the border twice).
      int num_rs = std::min(edges_[e].ok, okCount(r, s));
      // SafetyLabellingConfig::robot_fragment_passage: a robot's segment that steps 3-4 would
      // call small or thin is a fragment of the ground the robot stands on, not a passage;
      // across a border with no failed contact on its side the width is counted on the other
      // side.
      if (s == rs && robot_fragment && edges_[e].failed == 0) num_rs = okCount(r, s);
      if (num_rs >= config_.min_passage_cells && seg_state_[r] == kStUnexamined) {
        seg_state_[r] = kStSafe;  // step 22
        to_examine_.push_back(r);
      }
    }
    neighbours_examined_[s] = 1;
  }

  // SafetyLabellingConfig::isolated_ground_unknown: what step 27 would call Non-ground only
  // because no observed border leads to it.
  if (config_.isolated_ground_unknown && !to_examine_.empty()) labelIsolatedGround(hm, m, segs);

  // SafetyLabellingConfig::small_obstacles: what steps 3-4 left Unknown but stands above the safe
  // ground beside it by more than h_T is the top of an obstacle.
  if (config_.small_obstacles) {
    const double min_rise = std::max(config_.max_step_height, config_.small_obstacle_min_rise);
    for (int k = 0; k < nseg; ++k) {
      if (!small_[k] || seg_state_[k] != kStUnknown || k == rs) continue;
      // Above every safe segment beside it: a patch at the foot of a ramp continues the ramp,
      // a patch in a floor's noise is not above the floor by that much.
      bool beside_safe = false, above_all = true;
      for (int e = edge_begin_[k]; e < edge_begin_[k + 1]; ++e) {
        if (seg_state_[edges_[e].r] != kStSafe) continue;
        beside_safe = true;
        above_all = above_all && edges_[e].rise > min_rise;  // NaN: not above
      }
      if (beside_safe && above_all) {
        seg_state_[k] = kStNonGround;
        m.segments[k].obstacle = true;
      }
    }
  }

  // SafetyLabellingConfig::floor_fragments: what steps 3-4 left Unknown amid safe ground, within
  // floor_fragment_tolerance of it all along its border, is that ground. Fragments may border each
  // other; the loop passes the host on from fragment to fragment (a cluster with no safe border
  // stays Unknown).
  host_.assign(nseg, -1);
  if (config_.floor_fragments && heights) {
    bool changed = true;
    while (changed) {
      changed = false;
      for (int k = 0; k < nseg; ++k) {
        if (!small_[k] || seg_state_[k] != kStUnknown || host_[k] >= 0 || k == rs) continue;
        bool all = edge_begin_[k] < edge_begin_[k + 1];
        int host = -1, host_contacts = 0;
        for (int e = edge_begin_[k]; e < edge_begin_[k + 1] && all; ++e) {
          const Edge& ed = edges_[e];
          const bool safe = seg_state_[ed.r] == kStSafe;
          const bool fragment = small_[ed.r] && seg_state_[ed.r] == kStUnknown;
          // Both sides of the border: every contact of k's and of r's within the tolerance.
          all = (safe || fragment) && ed.far == 0 && farCount(ed.r, k) == 0;
          if (!all) break;
          const int h = safe ? ed.r : host_[ed.r];
          const int contacts = ed.ok + ed.failed;
          if (h >= 0 && contacts > host_contacts) {
            host = h;
            host_contacts = contacts;
          }
        }
        if (all && host >= 0) {
          host_[k] = host;
          changed = true;
        }
      }
    }
    for (int k = 0; k < nseg; ++k) {
      if (host_[k] < 0) continue;
      seg_state_[k] = kStSafe;
      m.segments[k].merged_into = host_[k];
      m.segments[k].plane = m.segments[host_[k]].plane;
    }
  }

  // Steps 27-28.
  for (int k = 0; k < nseg; ++k) {
    SegmentInfo& info = m.segments[k];
    switch (seg_state_[k]) {
      case kStUnexamined:
      case kStNonGround:
        info.label = SafetyLabel::kNonGround;
        break;
      case kStUnknown:
        info.label = SafetyLabel::kUnknown;
        break;
      case kStSafe:
        info.reachable = true;
        info.label = info.plane.slope_deg > config_.level_slope_deg ? SafetyLabel::kInclined
                                                                    : SafetyLabel::kLevel;
        break;
    }
  }

  // The cell map (000, Sec. VI).
  for (int c = 0; c < n; ++c) {
    const int k = segs.segment_of[c];
    if (k >= 0 && k < nseg) {
      m.labels[c] = m.segments[k].label;
      m.segment[c] = k;
    } else if (!segs.examined[c]) {
      m.labels[c] = SafetyLabel::kUnexamined;
    } else if (hm.atIndex(c) != HeightMap::kNoHeight) {
      m.labels[c] = SafetyLabel::kNonGround;  // non-traversable column
    }
  }

  const bool face = config_.obstacle_face_margin;
  if (config_.drop_off_margin || face) {
    // SafetyLabellingConfig::drop_off_margin: border cells of safe segments beside an observed
    // surface lower by more than the drop (local surface heights) are Non-ground. Heights are
    // read, labels written, so the margin does not spread.
    // SafetyLabellingConfig::obstacle_face_margin: the same beside an observed column that is in
    // no safe segment and whose measured surface stands above the cell's by more than the rise.
    if (!measured) local_z_.assign(n, kLocalZPending);
    const bool drops = config_.drop_off_margin;
    const double drop = std::max(config_.max_step_height, config_.drop_off_min_drop);
    const double rise = std::max(config_.max_step_height, config_.obstacle_face_min_rise);
    const double sink = drops ? config_.drop_off_sink : 0.0;
    margin_.clear();
    for (int k = 0; k < nseg; ++k) {
      if (!isSafe(m.segments[k].label)) continue;
      const GroundPlane& pk = m.segments[k].plane;
      for (const int c : m.segments[k].cells) {
        if (!boundary_[c]) continue;
        const float zc = localSurfaceHeight(hm, segs, c);
        if (std::isnan(zc)) continue;
        const int u = c % width, v = c / width;
        // SafetyLabellingConfig::drop_off_sink: the cell's own measured surface below the
        // segment's plane, beside a cell that was never seen.
        const float z_own = hm.surfaceHeightAtIndex(c);
        const bool sunk =
            sink > 0.0 && z_own < pk.heightAt((m.min_u + u) * l, (m.min_v + v) * l) - sink;
        for (int j = 0; j < 8; ++j) {
          const int un = u + kDu[j], vn = v + kDv[j];
          if (un < 0 || vn < 0 || un >= width || vn >= m.height) continue;
          const int cn = vn * width + un;
          if (sunk && segs.examined[cn] && segs.segment_of[cn] < 0 &&
              hm.atIndex(cn) == HeightMap::kNoHeight) {
            margin_.push_back(c);
            break;
          }
          if (segs.segment_of[cn] == k || hm.atIndex(cn) == HeightMap::kNoHeight) continue;
          const int kn = segs.segment_of[cn];
          if (face && (kn < 0 || kn >= nseg || !isSafe(m.segments[kn].label)) &&
              hm.surfaceHeightAtIndex(cn) > zc + rise &&  // NaN: false
              faceReaches(hm, c, cn, l)) {
            // The face of an obstacle, a wall or a table's edge may stand within this cell:
            // its column was seen beside it, not always in it.
            margin_.push_back(c);
            face_marks_.push_back(FaceMark{c, cn});
            break;
          }
          if (!drops) continue;
          const float zn = kn >= 0 ? localSurfaceHeight(hm, segs, cn) : hm.surfaceHeightAtIndex(cn);
          // A drop is a discontinuity: lower than the cell's own surface and than the
          // segment's plane carried on to the neighbour. At a ramp's foot the ramp's plane
          // comes down to the floor (its local surface, averaged up the slope, does not).
          const double z_plane = pk.heightAt((m.min_u + un) * l, (m.min_v + vn) * l);
          if (zn < zc - drop && zn < z_plane - drop) {  // NaN: false
            margin_.push_back(c);
            break;
          }
        }
      }
    }
    for (const int c : margin_) {
      m.labels[c] = SafetyLabel::kNonGround;
      m.drop_off[c] = 0;
    }
  }

  if (!config_.mark_drop_offs) return true;
  // Potential drop-off edges (000, Sec. VI), see SafetyLabellingConfig.
  // Any radius beyond the map's diagonal reaches the whole map: clamped there, so that a tiny
  // voxel size cannot overflow the conversion (fuzzing found it).
  const double rr = config_.drop_off_radius / l;
  const double diagonal2 =
      static_cast<double>(width) * width + static_cast<double>(hm.height()) * hm.height();
  const long long r2 =
      static_cast<long long>(std::floor(std::min(rr * rr + 1e-6, diagonal2 + 1.0)));
  const int rc = static_cast<int>(std::floor(std::sqrt(static_cast<double>(r2))));
  for (int k = 0; k < nseg; ++k) {
    const SegmentInfo& info = m.segments[k];
    if (!isSafe(info.label)) continue;
    for (const int c : info.cells) {
      if (!boundary_[c] || !isSafe(m.labels[c])) continue;  // margin cells are Non-ground
      const int u = c % width, v = c / width;
      bool next_to_unknown = false;
      for (int j = 0; j < 8 && !next_to_unknown; ++j) {
        const int un = u + kDu[j], vn = v + kDv[j];
        if (un < 0 || vn < 0 || un >= width || vn >= m.height) continue;
        next_to_unknown = m.labels[vn * width + un] == SafetyLabel::kUnknown;
      }
      if (!next_to_unknown) continue;
      const double h = info.plane.heightAt((m.min_u + u) * l, (m.min_v + v) * l);
      // Highest indexed height that is lower than h by more than the minimum drop.
      const double w_lower = std::ceil((h - config_.drop_off_min_drop) / l) - 1.0;
      bool lower = false;
      for (int dv = -rc; dv <= rc && !lower; ++dv) {
        const int vn = v + dv;
        if (vn < 0 || vn >= m.height) continue;
        for (int du = -rc; du <= rc; ++du) {
          const int un = u + du;
          if (un < 0 || un >= width || static_cast<long long>(du) * du + dv * dv > r2) continue;
          const std::int32_t w = hm.atIndex(vn * width + un);
          if (w != HeightMap::kNoHeight && w <= w_lower) {
            lower = true;
            break;
          }
        }
      }
      if (lower) m.drop_off[c] = 1;
    }
  }
  return true;
}

void SafetyLabelling::labelIsolatedGround(const HeightMap& hm, const SafetyMap& m,
                                          const GroundSegments& segs) {
  const int nseg = static_cast<int>(m.segments.size());
  // Groups of unreached segments joined by borders crossable from either side.
  group_.assign(nseg, -1);
  group_blocked_.clear();
  int groups = 0;
  for (int k = 0; k < nseg; ++k) {
    if (seg_state_[k] != kStUnexamined || group_[k] >= 0) continue;
    const int g = groups++;
    group_blocked_.push_back(0);
    group_stack_.assign(1, k);
    group_[k] = g;
    while (!group_stack_.empty()) {
      const int s = group_stack_.back();
      group_stack_.pop_back();
      for (int e = edge_begin_[s]; e < edge_begin_[s + 1]; ++e) {
        const int r = edges_[e].r;
        // A border to safe ground with a step the robot cannot cross. One whose every contact
        // is crossable but that is narrower than num_T measured no discontinuity: the footprint
        // bridge's reach grazing ground seen beyond the blind zone, a few cells of two patches
        // of sparse stereo that touch.
        if (seg_state_[r] == kStSafe && borderFailed(s, r)) group_blocked_[g] = 1;
        if (seg_state_[r] != kStUnexamined || group_[r] >= 0) continue;
        if (edges_[e].ok > 0 || okCount(r, s) > 0) {
          group_[r] = g;
          group_stack_.push_back(r);
        }
      }
    }
  }
  if (groups == 0) return;
  // Borders recorded on the safe side only (the footprint bridge records both, gaps may not).
  for (int s = 0; s < nseg; ++s) {
    if (seg_state_[s] != kStSafe) continue;
    for (int e = edge_begin_[s]; e < edge_begin_[s + 1]; ++e) {
      const int g = group_[edges_[e].r];
      if (g >= 0 && borderFailed(s, edges_[e].r)) group_blocked_[g] = 1;
    }
  }
  if (std::all_of(group_blocked_.begin(), group_blocked_.end(), [](std::uint8_t b) { return b; }))
    return;

  // The nearest safe cell of every cell: propagation of the nearest site in two raster passes
  // (an 8-neighbour approximation of the Euclidean feature transform).
  const int width = m.width, height = m.height, n = width * height;
  nearest_safe_.assign(n, -1);
  safe_distance_.assign(n, std::numeric_limits<float>::infinity());
  for (int c = 0; c < n; ++c) {
    const int k = segs.segment_of[c];
    if (k >= 0 && k < nseg && seg_state_[k] == kStSafe) {
      nearest_safe_[c] = c;
      safe_distance_[c] = 0.0f;
    }
  }
  auto relax = [&](int c, int u, int v, int un, int vn) {
    if (un < 0 || vn < 0 || un >= width || vn >= height) return;
    const int src = nearest_safe_[vn * width + un];
    if (src < 0) return;
    const float du = static_cast<float>(u - src % width), dv = static_cast<float>(v - src / width);
    const float d = std::sqrt(du * du + dv * dv);
    if (d < safe_distance_[c]) {
      safe_distance_[c] = d;
      nearest_safe_[c] = src;
    }
  };
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const int c = v * width + u;
      relax(c, u, v, u - 1, v);
      relax(c, u, v, u - 1, v - 1);
      relax(c, u, v, u, v - 1);
      relax(c, u, v, u + 1, v - 1);
    }
  }
  for (int v = height - 1; v >= 0; --v) {
    for (int u = width - 1; u >= 0; --u) {
      const int c = v * width + u;
      relax(c, u, v, u + 1, v);
      relax(c, u, v, u + 1, v + 1);
      relax(c, u, v, u, v + 1);
      relax(c, u, v, u - 1, v + 1);
    }
  }

  // A group within max_gap_cells + 2 cells of safe ground borders it across a failed step or
  // the non-traversable columns of a face (a curb's, a wall's): Non-ground as in 000. Farther
  // away, it could be reached when one of its cells could be from its nearest safe cell along a
  // slope of at most theta_max and one step of h_T, over cells of which nothing was seen (a
  // line that crosses observed columns, the group's own included, is no evidence).
  const double l = m.resolution;
  const double tan_max = std::tan(config_.max_slope_deg * M_PI / 180.0);
  const float near_cells = static_cast<float>(config_.max_gap_cells + 2) + 1e-3f;
  std::vector<std::uint8_t>& state = group_blocked_;  // 0 Non-ground, 1 Unknown, 2 undecided
  for (int g = 0; g < groups; ++g)
    state[g] = state[g] ? 0 : 2;
  for (int k = 0; k < nseg; ++k) {
    const int g = group_[k];
    if (g < 0 || state[g] == 0) continue;
    for (const int c : m.segments[k].cells) {
      if (safe_distance_[c] <= near_cells) {
        state[g] = 0;
        break;
      }
    }
  }
  auto openLine = [&](int a, int b) {
    const int ua = a % width, va = a / width;
    const int du = b % width - ua, dv = b / width - va;
    const int steps = std::max(std::abs(du), std::abs(dv));
    for (int t = 1; t < steps; ++t) {
      const int ut = ua + static_cast<int>(std::lround(static_cast<double>(du) * t / steps));
      const int vt = va + static_cast<int>(std::lround(static_cast<double>(dv) * t / steps));
      if (hm.atIndex(vt * width + ut) != HeightMap::kNoHeight) return false;
    }
    return true;
  };
  for (int k = 0; k < nseg; ++k) {
    const int g = group_[k];
    if (g < 0 || state[g] != 2) continue;
    const GroundPlane& pk = m.segments[k].plane;
    for (const int c : m.segments[k].cells) {
      const int src = nearest_safe_[c];
      if (src < 0 || !boundary_[c]) continue;
      const GroundPlane& ps = m.segments[segs.segment_of[src]].plane;
      const double x = (m.min_u + c % width) * l, y = (m.min_v + c / width) * l;
      const double xs = (m.min_u + src % width) * l, ys = (m.min_v + src / width) * l;
      const double dz = std::abs(pk.heightAt(x, y) - ps.heightAt(xs, ys));
      if (dz <= config_.crossableStep() + safe_distance_[c] * l * tan_max && openLine(c, src)) {
        state[g] = 1;
        break;
      }
    }
  }
  for (int k = 0; k < nseg; ++k) {
    if (group_[k] >= 0 && state[group_[k]] == 1) seg_state_[k] = kStUnknown;
  }
}

}  // namespace stereo_safety_map
