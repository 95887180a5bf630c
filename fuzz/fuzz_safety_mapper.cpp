// libFuzzer target: segmentation (000 Alg. 1), plane fit (Sec. V-B) and labelling (Alg. 2) on
// random height maps, and the core's frame path (StereoFrameProcessor::processPoints: the
// SafetyMapper and the obstacle cue, the entry point the nodelet calls) on random frames, cues and
// log-odds.
//
// Two modes:
//  - units: a HeightMap with random windows and heights, random robot cell, voxel size, configs
//    and planes (NaN, inf, huge coefficients, too few, too many), through GroundSegmentation and
//    SafetyLabelling directly; fitPlane on random points.
//  - mapper: a small StereoFrameProcessor (obstacle cue on or off) fed random log-odds
//    (grid().setLogOdds), random frames of points near stepped ground with special values mixed
//    in, random poses and robot positions, frame stamps (going back, NaN, huge), obstacle cues,
//    aging (max_cell_age, ageSafetyMap) and reconfigureMapper().
//
// Contracts checked: constructors throw std::invalid_argument exactly when validate() is not
// empty; segments partition their cells, each of one indexed height; the safety map covers the
// height map's window with one valid label, segment id and drop-off flag per cell; aging only
// ever turns a Level / Inclined cell into Unknown, and says how many; reconfigure() refuses
// exactly the configurations validate() refuses and then changes nothing; the cue only ever makes
// cells Non-ground.
#include "fuzz_common.h"

#include "stereo_safety_map/core/ground_segmentation.h"
#include "stereo_safety_map/core/height_map.h"
#include "stereo_safety_map/core/plane_fit.h"
#include "stereo_safety_map/core/safety_labelling.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/core/safety_mapper.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"
#include "stereo_safety_map/core/voxel_grid.h"

#include <Eigen/Geometry>

#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

using namespace stereo_safety_map;
using ssm_fuzz::mostlyInRange;
using ssm_fuzz::mostlyIntInRange;
using ssm_fuzz::specialDouble;
using ssm_fuzz::specialFloat;

namespace {

int saturatedSum(int a, int b) {
  const std::int64_t s = static_cast<std::int64_t>(a) + b;
  return static_cast<int>(std::max<std::int64_t>(
      std::numeric_limits<int>::min(), std::min<std::int64_t>(std::numeric_limits<int>::max(), s)));
}

template <typename T, typename Config>
bool constructsExactlyWhenValid(const Config& config) {
  const bool valid = config.validate().empty();
  bool threw = false;
  try {
    T object(config);
  } catch (const std::invalid_argument&) {
    threw = true;
  }
  FUZZ_CHECK(threw == !valid);
  return valid;
}

GroundSegmentationConfig randomSegmentationConfig(FuzzedDataProvider& fdp) {
  GroundSegmentationConfig c;
  c.planning_radius = mostlyInRange(fdp, 0.1, 6.0, 16);
  c.height_tolerance = mostlyIntInRange(fdp, 0, 3, 16);
  c.connectivity = fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? mostlyIntInRange(fdp, 0, 9)
                                                               : (fdp.ConsumeBool() ? 4 : 8);
  c.seed_radius = mostlyInRange(fdp, 0.0, 2.0, 16);
  return c;
}

SafetyLabellingConfig randomLabellingConfig(FuzzedDataProvider& fdp) {
  SafetyLabellingConfig c;
  c.max_slope_deg = mostlyInRange(fdp, 1.0, 45.0, 16);
  c.min_segment_cells = mostlyIntInRange(fdp, 0, 10, 16);
  c.thin_ratio = mostlyInRange(fdp, 0.0, 2.0, 16);
  c.max_step_height = mostlyInRange(fdp, 0.01, 0.5, 16);
  c.min_passage_cells = mostlyIntInRange(fdp, 1, 8, 16);
  c.level_slope_deg = mostlyInRange(fdp, 0.0, 10.0, 16);
  c.mark_drop_offs = fdp.ConsumeBool();
  c.drop_off_radius = mostlyInRange(fdp, 0.0, 1.0, 16);
  c.drop_off_min_drop = mostlyInRange(fdp, 0.0, 0.5, 16);
  return c;
}

// Indexed heights: mostly a few steps around 0, sometimes the extremes a grid can give (indices
// are clamped to +-2^30) and, rarely, any int32.
std::int32_t randomHeight(FuzzedDataProvider& fdp, bool wild) {
  const int pick = fdp.ConsumeIntegralInRange<int>(0, 31);
  if (pick == 0) return HeightMap::kNoHeight;
  if (pick == 1) return fdp.ConsumeBool() ? (1 << 30) : -(1 << 30);
  if (pick == 2 && wild) return fdp.ConsumeIntegral<std::int32_t>();
  return fdp.ConsumeIntegralInRange<std::int32_t>(-4, 4);
}

GroundPlane randomPlane(FuzzedDataProvider& fdp) {
  GroundPlane p;
  p.valid = fdp.ConsumeIntegralInRange<int>(0, 3) != 0;
  p.a = mostlyInRange(fdp, -0.5, 0.5);
  p.b = mostlyInRange(fdp, -0.5, 0.5);
  p.c = mostlyInRange(fdp, -1.0, 1.0);
  if (fdp.ConsumeBool()) {
    p.normal = Eigen::Vector3d(-p.a, -p.b, 1.0).normalized();
    p.slope_deg = std::acos(std::min(1.0, std::abs(p.normal.z()))) * 180.0 / M_PI;
  } else {
    p.normal = Eigen::Vector3d(specialDouble(fdp, -1, 1), specialDouble(fdp, -1, 1),
                               specialDouble(fdp, -1, 1));
    p.slope_deg = specialDouble(fdp, 0.0, 90.0);
  }
  p.residual_rms = mostlyInRange(fdp, 0.0, 0.1);
  p.num_points = fdp.ConsumeIntegralInRange<std::size_t>(0, 100);
  p.centroid = Eigen::Vector3d(mostlyInRange(fdp, -5, 5), mostlyInRange(fdp, -5, 5),
                               mostlyInRange(fdp, -1, 1));
  return p;
}

void checkSegments(const HeightMap& hm, const GroundSegments& s) {
  FUZZ_CHECK(s.width == hm.width() && s.height == hm.height());
  const int n = s.numCells();
  FUZZ_CHECK(static_cast<int>(s.segment_of.size()) == n);
  FUZZ_CHECK(static_cast<int>(s.examined.size()) == n);
  FUZZ_CHECK(static_cast<int>(s.footprint.size()) == n);
  const int k_max = s.numSegments();
  FUZZ_CHECK(static_cast<int>(s.segment_begin.size()) == k_max + 1);
  FUZZ_CHECK(s.segment_begin[0] == 0);
  FUZZ_CHECK(s.segment_begin[k_max] == static_cast<int>(s.segment_cells.size()));
  FUZZ_CHECK(s.robot_segment == -1 || (s.robot_segment == 0 && k_max > 0));
  FUZZ_CHECK(s.seed_cell >= -1 && s.seed_cell < n);
  for (int k = 0; k < k_max; ++k) {
    FUZZ_CHECK(s.segment_begin[k] <= s.segment_begin[k + 1]);
    FUZZ_CHECK(s.segmentSize(k) > 0);
    for (const int* c = s.cellsBegin(k); c != s.cellsEnd(k); ++c) {
      FUZZ_CHECK(*c >= 0 && *c < n);
      FUZZ_CHECK(s.segment_of[*c] == k);
      // A footprint cell has no observed height; Alg. 1 takes it at the base's height
      // (GroundSegmentationConfig::footprint_radius), which is the segment's.
      if (s.footprint[*c]) {
        FUZZ_CHECK(hm.atIndex(*c) == HeightMap::kNoHeight);
      } else {
        FUZZ_CHECK(hm.atIndex(*c) == s.segment_height[k]);
      }
      FUZZ_CHECK(s.examined[*c] == 1);
    }
  }
  int in_segments = 0;
  for (int c = 0; c < n; ++c) {
    FUZZ_CHECK(s.segment_of[c] >= -1 && s.segment_of[c] < k_max);
    in_segments += s.segment_of[c] >= 0 ? 1 : 0;
  }
  FUZZ_CHECK(in_segments == static_cast<int>(s.segment_cells.size()));
  for (const int c : s.non_traversable) {
    FUZZ_CHECK(c >= 0 && c < n);
    FUZZ_CHECK(s.segment_of[c] == -1);
  }
}

void checkMap(const HeightMap& hm, const SafetyMap& m) {
  FUZZ_CHECK(m.width == hm.width() && m.height == hm.height());
  FUZZ_CHECK(m.min_u == hm.minU() && m.min_v == hm.minV());
  const std::size_t n = static_cast<std::size_t>(m.width) * m.height;
  FUZZ_CHECK(m.labels.size() == n);
  FUZZ_CHECK(m.segment.size() == n);
  FUZZ_CHECK(m.drop_off.size() == n);
  FUZZ_CHECK(m.column_height.size() == n);
  const int ns = static_cast<int>(m.segments.size());
  FUZZ_CHECK(m.robot_segment >= -1 && m.robot_segment < ns);
  for (std::size_t i = 0; i < n; ++i) {
    FUZZ_CHECK(static_cast<int>(m.labels[i]) <= static_cast<int>(SafetyLabel::kNonGround));
    FUZZ_CHECK(m.segment[i] >= -1 && m.segment[i] < ns);
    FUZZ_CHECK(m.drop_off[i] <= 1);
    if (m.drop_off[i]) FUZZ_CHECK(isSafe(m.labels[i]));
  }
  for (const SegmentInfo& s : m.segments) {
    for (const int c : s.cells)
      FUZZ_CHECK(c >= 0 && static_cast<std::size_t>(c) < n);
    FUZZ_CHECK(static_cast<int>(s.label) <= static_cast<int>(SafetyLabel::kNonGround));
  }
}

void fuzzUnits(FuzzedDataProvider& fdp) {
  const bool wild = fdp.ConsumeIntegralInRange<int>(0, 63) == 0;

  // Plane fit on random points.
  {
    PlaneFitConfig pc;
    pc.min_points = mostlyIntInRange(fdp, 3, 8, 16);
    pc.min_xy_stddev = mostlyInRange(fdp, 0.001, 0.05, 16);
    if (pc.validate().empty()) {
      std::vector<Eigen::Vector3d> pts(fdp.ConsumeIntegralInRange<int>(0, 12));
      const double ox = mostlyInRange(fdp, -10.0, 10.0), oy = mostlyInRange(fdp, -10.0, 10.0);
      for (Eigen::Vector3d& p : pts) {
        p = Eigen::Vector3d(ox + mostlyInRange(fdp, -1.0, 1.0), oy + mostlyInRange(fdp, -1.0, 1.0),
                            mostlyInRange(fdp, -0.5, 0.5));
      }
      const GroundPlane plane = fitPlane(pts, pc);
      if (plane.valid) {
        FUZZ_CHECK(std::isfinite(plane.a) && std::isfinite(plane.b) && std::isfinite(plane.c));
        FUZZ_CHECK(std::isfinite(plane.slope_deg) && plane.slope_deg >= 0.0 &&
                   plane.slope_deg <= 90.0);
        FUZZ_CHECK(plane.normal.allFinite() && plane.normal.z() >= 0.0);
      }
    }
  }

  // A height map window.
  HeightMap hm;
  const int extreme = fdp.ConsumeIntegralInRange<int>(0, 15);
  const int min_u = extreme == 0
                        ? (1 << 30) - 40
                        : (extreme == 1 ? -(1 << 30) : fdp.ConsumeIntegralInRange<int>(-30, 30));
  const int min_v = fdp.ConsumeIntegralInRange<int>(-30, 30);
  const int width = fdp.ConsumeIntegralInRange<int>(-2, 40);
  const int height = fdp.ConsumeIntegralInRange<int>(-2, 40);
  hm.reset(min_u, min_v, width, height);
  FUZZ_CHECK(hm.width() == std::max(0, width) && hm.height() == std::max(0, height));
  // Heights: a few patches of constant height (so that segments form), then single cells.
  const int patches = fdp.ConsumeIntegralInRange<int>(0, 6);
  for (int p = 0; p < patches; ++p) {
    const int u0 = min_u + fdp.ConsumeIntegralInRange<int>(-2, 40);
    const int v0 = min_v + fdp.ConsumeIntegralInRange<int>(-2, 40);
    const int pw = fdp.ConsumeIntegralInRange<int>(1, 20),
              ph = fdp.ConsumeIntegralInRange<int>(1, 20);
    const std::int32_t w = randomHeight(fdp, wild);
    for (int v = v0; v < v0 + ph; ++v) {
      for (int u = u0; u < u0 + pw; ++u)
        hm.set(u, v, w);
    }
  }
  const int singles = fdp.ConsumeIntegralInRange<int>(0, 40);
  for (int i = 0; i < singles; ++i) {
    hm.set(min_u + fdp.ConsumeIntegralInRange<int>(-3, 43),
           min_v + fdp.ConsumeIntegralInRange<int>(-3, 43), randomHeight(fdp, wild));
  }

  const GroundSegmentationConfig sc = randomSegmentationConfig(fdp);
  if (!constructsExactlyWhenValid<GroundSegmentation>(sc)) return;
  GroundSegmentation segmentation(sc);
  VoxelIndex robot;
  robot.u = saturatedSum(min_u, mostlyIntInRange(fdp, -5, 45, 32));
  robot.v = saturatedSum(min_v, mostlyIntInRange(fdp, -5, 45, 32));
  robot.w = fdp.ConsumeIntegralInRange<int>(0, 31) == 0 ? mostlyIntInRange(fdp, -3, 3, 1)
                                                        : fdp.ConsumeIntegralInRange<int>(-3, 3);
  if (fdp.ConsumeIntegralInRange<int>(0, 31) == 0) {  // anywhere, e.g. INT_MIN
    robot.u = mostlyIntInRange(fdp, -100, 100, 1);
    robot.v = mostlyIntInRange(fdp, -100, 100, 1);
  }
  const double voxel_size =
      fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? specialDouble(fdp, 0.01, 1.0) : 0.1;
  GroundSegments segments;
  const bool segmented = segmentation.segment(hm, robot, voxel_size, &segments);
  if (!segmented) FUZZ_CHECK(segments.numSegments() == 0);
  checkSegments(hm, segments);

  // Planes: usually one per segment, sometimes too few or too many.
  std::vector<GroundPlane> planes;
  int num_planes = segments.numSegments();
  if (fdp.ConsumeIntegralInRange<int>(0, 7) == 0)
    num_planes = fdp.ConsumeIntegralInRange<int>(0, num_planes + 3);
  for (int k = 0; k < num_planes; ++k)
    planes.push_back(randomPlane(fdp));

  const SafetyLabellingConfig lc = randomLabellingConfig(fdp);
  if (!constructsExactlyWhenValid<SafetyLabelling>(lc)) return;
  SafetyLabelling labelling(lc);
  SafetyMap map;
  // Now and then segments of another window: label() must refuse them.
  HeightMap other;
  const bool mismatch = fdp.ConsumeIntegralInRange<int>(0, 15) == 0 && hm.height() > 0;
  if (mismatch) other.reset(min_u, min_v, hm.width() + 1, hm.height());
  const HeightMap& used = mismatch ? other : hm;
  const bool labelled = labelling.label(used, segments, planes, voxel_size, &map);
  if (mismatch) FUZZ_CHECK(!labelled);
  checkMap(used, map);
  // A second pass reuses the buffers.
  if (fdp.ConsumeBool()) {
    labelling.label(hm, segments, planes, voxel_size, &map);
    checkMap(hm, map);
  }
}

Eigen::Isometry3f randomCameraPose(FuzzedDataProvider& fdp, const Eigen::Vector3f& robot) {
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  if (fdp.ConsumeIntegralInRange<int>(0, 15) == 0) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c)
        T.matrix()(r, c) = specialFloat(fdp, -2.0f, 2.0f);
    }
    return T;
  }
  // Camera 1.1 m above the robot, looking forward and down (optical z forward, y down).
  const float yaw = fdp.ConsumeFloatingPointInRange<float>(-3.2f, 3.2f);
  const float pitch = fdp.ConsumeFloatingPointInRange<float>(0.0f, 1.0f);
  const Eigen::Matrix3f base_to_optical =
      (Eigen::Matrix3f() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished();
  T.linear() = (Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitZ()) *
                Eigen::AngleAxisf(pitch, Eigen::Vector3f::UnitY()))
                   .toRotationMatrix() *
               base_to_optical;
  T.translation() = robot + Eigen::Vector3f(0.0f, 0.0f, 1.1f);
  return T;
}

void fuzzMapper(FuzzedDataProvider& fdp) {
  SafetyMapperConfig c;
  c.grid.voxel_size = fdp.ConsumeIntegralInRange<int>(0, 31) == 0 ? specialDouble(fdp, 0.05, 0.3)
                                                                  : (fdp.ConsumeBool() ? 0.1 : 0.2);
  c.grid.size_x = fdp.ConsumeFloatingPointInRange<double>(1.0, 4.0);
  c.grid.size_y = fdp.ConsumeFloatingPointInRange<double>(1.0, 4.0);
  c.grid.size_z = fdp.ConsumeFloatingPointInRange<double>(1.0, 2.5);
  c.grid.z_below_robot = fdp.ConsumeFloatingPointInRange<double>(0.0, 1.0);
  if (fdp.ConsumeIntegralInRange<int>(0, 31) == 0) {  // tiny grid of tiny voxels
    c.grid.size_x = c.grid.size_y = c.grid.size_z = c.grid.voxel_size;
    c.grid.z_below_robot = 0.0;
  }
  c.grid.occ_threshold = fdp.ConsumeIntegralInRange<int>(1, 100);
  c.grid.decr = fdp.ConsumeIntegralInRange<int>(0, 3);
  c.height_map.robot_height = mostlyInRange(fdp, 0.3, 2.0, 32);
  c.segmentation = randomSegmentationConfig(fdp);
  c.plane_fit.min_points = mostlyIntInRange(fdp, 3, 8, 32);
  c.labelling = randomLabellingConfig(fdp);
  c.skip_stationary_frames = fdp.ConsumeBool();
  c.scroll_with_robot = fdp.ConsumeBool();
  c.max_cell_age = fdp.ConsumeIntegralInRange<int>(0, 15) == 0
                       ? specialDouble(fdp, 0.0, 10.0)
                       : fdp.ConsumeFloatingPointInRange<double>(0.0, 3.0);
  if (!c.validate().empty()) {
    bool threw = false;
    try {
      SafetyMapper refused(c);
    } catch (const std::invalid_argument&) {
      threw = true;
    }
    FUZZ_CHECK(threw);
    return;
  }
  const double voxels = std::round(c.grid.size_x / c.grid.voxel_size) *
                        std::round(c.grid.size_y / c.grid.voxel_size) *
                        std::round(c.grid.size_z / c.grid.voxel_size);
  if (voxels > 2e5) return;  // the harness's budget
  StereoFrameProcessorConfig pc;
  pc.mapper = c;
  pc.obstacle_cue = fdp.ConsumeBool();
  pc.cue.lifetime = fdp.ConsumeFloatingPointInRange<double>(0.0, 3.0);
  pc.cue.min_points_per_cell = fdp.ConsumeIntegralInRange<int>(1, 4);
  pc.cue.max_cues = fdp.ConsumeIntegralInRange<int>(1, 8);
  StereoFrameProcessor processor(pc);
  SafetyMapper& mapper = processor.mapper();

  std::vector<Eigen::Vector3f> points;
  Eigen::Vector3f robot(0.0f, 0.0f, 0.0f);
  double clock = 100.0;
  // The next stamp: mostly forward, sometimes back, sometimes anything.
  auto next_stamp = [&fdp, &clock]() {
    switch (fdp.ConsumeIntegralInRange<int>(0, 15)) {
      case 0:
        return specialDouble(fdp, -1e3, 1e3);
      case 1:
        clock -= fdp.ConsumeFloatingPointInRange<double>(0.0, 5.0);
        return clock;
      default:
        clock += fdp.ConsumeFloatingPointInRange<double>(0.0, 2.0);
        return clock;
    }
  };
  const int ops = fdp.ConsumeIntegralInRange<int>(1, 8);
  for (int op = 0; op < ops && fdp.remaining_bytes() > 0; ++op) {
    switch (fdp.ConsumeIntegralInRange<int>(0, 8)) {
      case 0: {  // direct log-odds around the robot
        VoxelGrid& grid = mapper.grid();
        const VoxelIndex m = grid.minIndex();
        const int n = fdp.ConsumeIntegralInRange<int>(1, 64);
        for (int i = 0; i < n; ++i) {
          grid.setLogOdds(VoxelIndex{m.u + fdp.ConsumeIntegralInRange<int>(-1, grid.sizeU()),
                                     m.v + fdp.ConsumeIntegralInRange<int>(-1, grid.sizeV()),
                                     m.w + fdp.ConsumeIntegralInRange<int>(-1, grid.sizeW())},
                          fdp.ConsumeIntegralInRange<int>(-200, 300));
        }
        break;
      }
      case 1: {
        Eigen::Vector3f p = robot;
        if (fdp.ConsumeIntegralInRange<int>(0, 7) == 0) {
          p = Eigen::Vector3f(specialFloat(fdp, -2, 2), specialFloat(fdp, -2, 2),
                              specialFloat(fdp, -0.5f, 0.5f));
        }
        const SafetyMap& map = processor.recompute(p, clock);
        checkMap(mapper.heightMap(), map);
        checkSegments(mapper.heightMap(), mapper.segments());
        break;
      }
      case 2:
        processor.reset();
        break;
      case 3: {  // aging without a frame
        const SafetyMap before = mapper.safetyMap();
        const std::size_t aged = mapper.ageSafetyMap(next_stamp());
        const SafetyMap& after = mapper.safetyMap();
        FUZZ_CHECK(after.labels.size() == before.labels.size());
        std::size_t changed = 0;
        for (std::size_t k = 0; k < after.labels.size(); ++k) {
          if (after.labels[k] == before.labels[k]) continue;
          FUZZ_CHECK(isSafe(before.labels[k]) && after.labels[k] == SafetyLabel::kUnknown);
          ++changed;
        }
        FUZZ_CHECK(changed == aged);
        break;
      }
      case 4: {  // a new configuration, valid or not
        SafetyMapperConfig n = mapper.config();
        n.labelling = randomLabellingConfig(fdp);
        n.max_cell_age = specialDouble(fdp, 0.0, 5.0);
        if (fdp.ConsumeBool()) n.grid.decr = fdp.ConsumeIntegralInRange<int>(-1, 3);
        const SafetyMapperConfig old = mapper.config();
        const std::uint32_t frames = mapper.grid().frameCount();
        bool grid_reset = false;
        const std::string err = processor.reconfigureMapper(n, &grid_reset);
        FUZZ_CHECK(err.empty() == n.validate().empty());
        if (!err.empty()) {
          FUZZ_CHECK(!grid_reset);
          FUZZ_CHECK(mapper.config().grid.decr == old.grid.decr);
          FUZZ_CHECK(mapper.grid().frameCount() == frames);
        } else {
          FUZZ_CHECK(grid_reset == (n.grid.decr != old.grid.decr));
        }
        break;
      }
      case 5: {  // an obstacle cue: points near the robot, some special, any stamp
        std::vector<Eigen::Vector3f> cue;
        const int n = fdp.ConsumeIntegralInRange<int>(0, 32);
        for (int i = 0; i < n && fdp.remaining_bytes() > 0; ++i) {
          cue.emplace_back(robot.x() + specialFloat(fdp, -2, 2),
                           robot.y() + specialFloat(fdp, -2, 2), specialFloat(fdp, -1, 2));
        }
        const double stamp = next_stamp();
        FUZZ_CHECK(processor.addObstacleCue(stamp, cue) ==
                   (pc.obstacle_cue && std::isfinite(stamp)));
        break;
      }
      default: {
        // A frame: points on stepped ground (fixed frame) seen from the camera, moved into the
        // camera frame; some special ones.
        if (fdp.ConsumeIntegralInRange<int>(0, 3) == 0) {
          robot += Eigen::Vector3f(fdp.ConsumeFloatingPointInRange<float>(-0.5f, 0.5f),
                                   fdp.ConsumeFloatingPointInRange<float>(-0.5f, 0.5f), 0.0f);
        }
        Eigen::Vector3f robot_arg = robot;
        if (fdp.ConsumeIntegralInRange<int>(0, 15) == 0) {
          robot_arg = Eigen::Vector3f(specialFloat(fdp, -2, 2), specialFloat(fdp, -2, 2),
                                      specialFloat(fdp, -0.5f, 0.5f));
        }
        const Eigen::Isometry3f T = randomCameraPose(fdp, robot);
        const Eigen::Isometry3f T_inv = T.matrix().allFinite() ? T.inverse() : T;
        points.clear();
        const float step_x = fdp.ConsumeFloatingPointInRange<float>(-2.0f, 2.0f);
        const float step_h = fdp.ConsumeFloatingPointInRange<float>(-0.4f, 0.4f);
        const float slope = fdp.ConsumeFloatingPointInRange<float>(-0.3f, 0.3f);
        const int n = fdp.ConsumeIntegralInRange<int>(0, 400);
        const int special_one_in = fdp.ConsumeIntegralInRange<int>(4, 200);
        for (int i = 0; i < n; ++i) {
          if (fdp.remaining_bytes() > 0 &&
              fdp.ConsumeIntegralInRange<int>(1, special_one_in) == 1) {
            points.emplace_back(specialFloat(fdp, -5, 5), specialFloat(fdp, -5, 5),
                                specialFloat(fdp, -5, 5));
            continue;
          }
          // Deterministic spread so that short inputs still give a dense patch of ground.
          const float x = robot.x() - 1.8f + 3.6f * static_cast<float>((i * 37) % 97) / 97.0f;
          const float y = robot.y() - 1.8f + 3.6f * static_cast<float>((i * 61) % 89) / 89.0f;
          float z = robot.z() + slope * (x - robot.x()) + (x - robot.x() > step_x ? step_h : 0.0f);
          if (fdp.remaining_bytes() > 0 && fdp.ConsumeIntegralInRange<int>(0, 15) == 0) {
            z += fdp.ConsumeFloatingPointInRange<float>(0.0f, 1.5f);  // obstacle
          }
          points.push_back(T_inv * Eigen::Vector3f(x, y, z));
        }
        StereoFrameResult frame;
        const bool stamped = fdp.ConsumeBool();
        const double stamp = stamped ? next_stamp() : StereoFrameProcessor::kNoStamp;
        std::string error;
        const bool ok = processor.processPoints(points, T, robot_arg, stamp, &frame, &error);
        const FrameResult& result = frame.mapper;
        if (!stamped) FUZZ_CHECK(result.cells_aged == 0 || std::isfinite(mapper.latestTime()));
        FUZZ_CHECK(ok == (result.status == FrameStatus::kIntegrated));
        FUZZ_CHECK(ok || !error.empty());
        if (ok && frame.cue_applied) {
          // The cue only makes cells Non-ground.
          const std::vector<std::uint8_t>& marked = processor.cueMarked();
          const SafetyMap& map = mapper.safetyMap();
          // Empty when no cue was live (ObstacleCueFusion::apply): nothing marked.
          FUZZ_CHECK(marked.empty() || marked.size() == map.labels.size());
          for (std::size_t k = 0; k < marked.size(); ++k) {
            if (marked[k]) FUZZ_CHECK(map.labels[k] == SafetyLabel::kNonGround);
          }
        }
        if (ok) {
          checkMap(mapper.heightMap(), mapper.safetyMap());
          checkSegments(mapper.heightMap(), mapper.segments());
          FUZZ_CHECK(mapper.planes().size() ==
                     static_cast<std::size_t>(mapper.segments().numSegments()));
        }
        break;
      }
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider fdp(data, size);
  if (fdp.ConsumeBool()) {
    fuzzUnits(fdp);
  } else {
    fuzzMapper(fdp);
  }
  return 0;
}
