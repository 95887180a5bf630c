// libFuzzer target: the 3D log-odds voxel grid (000 Sec. IV) under random configurations, poses
// (non-rigid, NaN, inf, huge translations), points (NaN, inf, huge), window moves and direct
// log-odds writes.
//
// Contracts checked (voxel_grid.h): the constructor throws std::invalid_argument exactly when
// validate() is not empty; integrate()'s counters add up; every log-odds stays within
// [lop_min, lop_max]; every point list holds at most point_list_capacity finite points ordered by
// ascending range, each inside its own voxel by Eq. (1) (indexOf).
#include "fuzz_common.h"

#include "stereo_safety_map/core/voxel_grid.h"

#include <Eigen/Geometry>

#include <cstdint>
#include <stdexcept>
#include <vector>

using namespace stereo_safety_map;
using ssm_fuzz::mostlyInRange;
using ssm_fuzz::mostlyIntInRange;
using ssm_fuzz::specialFloat;

namespace {

// The harness's own budget: larger (valid) grids are only validated, not built, to keep each
// input fast.
constexpr double kMaxFuzzVoxels = 1.5e4;

VoxelGridConfig randomConfig(FuzzedDataProvider& fdp) {
  VoxelGridConfig c;
  c.voxel_size = mostlyInRange(fdp, 0.1, 0.4, 16);
  c.size_x = mostlyInRange(fdp, 0.0, 2.5, 16);
  c.size_y = mostlyInRange(fdp, 0.0, 2.5, 16);
  c.size_z = mostlyInRange(fdp, 0.0, 2.0, 16);
  c.z_below_robot = mostlyInRange(fdp, 0.0, 1.5, 16);
  c.incr_high = mostlyIntInRange(fdp, 0, 40, 16);
  c.incr_low = mostlyIntInRange(fdp, 0, 20, 16);
  c.decr = mostlyIntInRange(fdp, 0, 10, 16);
  c.occ_threshold = mostlyIntInRange(fdp, 1, 300, 16);
  c.lop_min = mostlyIntInRange(fdp, -300, -1, 16);
  c.lop_max = mostlyIntInRange(fdp, 1, 300, 16);
  c.point_list_capacity = mostlyIntInRange(fdp, 1, 12, 16);
  c.min_range = mostlyInRange(fdp, 0.0, 1.0, 16);
  c.max_range = mostlyInRange(fdp, 0.5, 12.0, 16);
  return c;
}

Eigen::Vector3f randomPoint(FuzzedDataProvider& fdp, float extent) {
  return Eigen::Vector3f(specialFloat(fdp, -extent, extent), specialFloat(fdp, -extent, extent),
                         specialFloat(fdp, -extent, extent));
}

// Mostly plausible (rigid, near the window), sometimes anything.
Eigen::Isometry3f randomPose(FuzzedDataProvider& fdp) {
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  switch (fdp.ConsumeIntegralInRange<int>(0, 7)) {
    case 0: {  // any 3x4 matrix, not rigid
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c)
          T.matrix()(r, c) = specialFloat(fdp, -3.0f, 3.0f);
      }
      return T;
    }
    case 1:  // identity, camera at a special position
      T.translation() = randomPoint(fdp, 3.0f);
      return T;
    default: {
      Eigen::Quaternionf q(fdp.ConsumeFloatingPointInRange<float>(-1.0f, 1.0f),
                           fdp.ConsumeFloatingPointInRange<float>(-1.0f, 1.0f),
                           fdp.ConsumeFloatingPointInRange<float>(-1.0f, 1.0f),
                           fdp.ConsumeFloatingPointInRange<float>(-1.0f, 1.0f));
      if (q.norm() < 1e-3f) q = Eigen::Quaternionf::Identity();
      T.linear() = q.normalized().toRotationMatrix();
      T.translation() = Eigen::Vector3f(fdp.ConsumeFloatingPointInRange<float>(-3.0f, 3.0f),
                                        fdp.ConsumeFloatingPointInRange<float>(-3.0f, 3.0f),
                                        fdp.ConsumeFloatingPointInRange<float>(-1.0f, 2.0f));
      return T;
    }
  }
}

VoxelIndex randomIndex(FuzzedDataProvider& fdp, const VoxelGrid& grid) {
  const VoxelIndex m = grid.minIndex();
  if (fdp.ConsumeIntegralInRange<int>(0, 3) == 0) {
    return VoxelIndex{mostlyIntInRange(fdp, -50, 50, 2), mostlyIntInRange(fdp, -50, 50, 2),
                      mostlyIntInRange(fdp, -50, 50, 2)};
  }
  // Near the window (slightly outside included), no overflow: |min| <= 2^30 + 5e7.
  return VoxelIndex{m.u + fdp.ConsumeIntegralInRange<int>(-2, grid.sizeU() + 1),
                    m.v + fdp.ConsumeIntegralInRange<int>(-2, grid.sizeV() + 1),
                    m.w + fdp.ConsumeIntegralInRange<int>(-2, grid.sizeW() + 1)};
}

void checkVoxel(const VoxelGrid& grid, const VoxelIndex& i) {
  const VoxelGridConfig& c = grid.config();
  const int lop = grid.logOdds(i);
  const VoxelPointList list = grid.points(i);
  if (!grid.contains(i)) {
    FUZZ_CHECK(lop == 0);
    FUZZ_CHECK(list.empty());
    FUZZ_CHECK(!grid.isOccupied(i));
    return;
  }
  FUZZ_CHECK(lop >= c.lop_min && lop <= c.lop_max);
  FUZZ_CHECK(grid.isOccupied(i) == (lop >= c.occ_threshold));
  FUZZ_CHECK(list.size <= static_cast<std::size_t>(c.point_list_capacity));
  float last_range = 0.0f;
  for (const VoxelPoint& p : list) {
    FUZZ_CHECK(p.position.allFinite());
    FUZZ_CHECK(std::isfinite(p.range) && p.range >= last_range);
    last_range = p.range;
    FUZZ_CHECK(grid.indexOf(p.position) == i);
  }
}

void checkWholeGrid(const VoxelGrid& grid) {
  const VoxelIndex m = grid.minIndex();
  for (int u = 0; u < grid.sizeU(); ++u) {
    for (int v = 0; v < grid.sizeV(); ++v) {
      for (int w = 0; w < grid.sizeW(); ++w)
        checkVoxel(grid, VoxelIndex{m.u + u, m.v + v, m.w + w});
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider fdp(data, size);
  const VoxelGridConfig config = randomConfig(fdp);
  const std::string err = config.validate();
  if (!err.empty()) {
    bool threw = false;
    try {
      VoxelGrid refused(config);
    } catch (const std::invalid_argument&) {
      threw = true;
    }
    FUZZ_CHECK(threw);
    return 0;
  }
  const double voxels = std::round(config.size_x / config.voxel_size) *
                        std::round(config.size_y / config.voxel_size) *
                        std::round(config.size_z / config.voxel_size);
  if (voxels > kMaxFuzzVoxels) return 0;
  VoxelGrid grid(config);
  const std::size_t total = static_cast<std::size_t>(grid.sizeU()) * grid.sizeV() * grid.sizeW();
  FUZZ_CHECK(grid.sizeU() >= 1 && grid.sizeV() >= 1 && grid.sizeW() >= 1);

  std::vector<Eigen::Vector3f> points;
  const int ops = fdp.ConsumeIntegralInRange<int>(1, 12);
  for (int op = 0; op < ops && fdp.remaining_bytes() > 0; ++op) {
    switch (fdp.ConsumeIntegralInRange<int>(0, 7)) {
      case 0: {
        const std::size_t cleared = grid.recenter(randomPoint(fdp, 4.0f));
        FUZZ_CHECK(cleared <= total);
        break;
      }
      case 1: {
        const VoxelIndex i = randomIndex(fdp, grid);
        grid.setLogOdds(i, mostlyIntInRange(fdp, -400, 400, 4));
        checkVoxel(grid, i);
        break;
      }
      case 2:
        grid.clear();
        break;
      case 3: {
        const Eigen::Vector3f p = randomPoint(fdp, 5.0f);
        const VoxelIndex i = grid.indexOf(p);
        checkVoxel(grid, i);
        const Eigen::Vector3f c = grid.centerOf(randomIndex(fdp, grid));
        (void)c;
        break;
      }
      default: {
        // One frame: points in the sensor frame around the camera, a few special ones.
        const Eigen::Isometry3f T = randomPose(fdp);
        points.clear();
        const int n = fdp.ConsumeIntegralInRange<int>(0, 96);
        const int special_one_in = fdp.ConsumeIntegralInRange<int>(2, 40);
        for (int k = 0; k < n; ++k) {
          if (fdp.ConsumeIntegralInRange<int>(1, special_one_in) == 1) {
            points.push_back(randomPoint(fdp, 10.0f));
          } else {
            points.emplace_back(fdp.ConsumeFloatingPointInRange<float>(-4.0f, 4.0f),
                                fdp.ConsumeFloatingPointInRange<float>(-4.0f, 4.0f),
                                fdp.ConsumeFloatingPointInRange<float>(-1.0f, 8.0f));
          }
        }
        const std::uint32_t frames = grid.frameCount();
        const IntegrationStats s = grid.integrate(points, T);
        FUZZ_CHECK(grid.frameCount() == frames + 1);
        FUZZ_CHECK(s.points_in == points.size());
        FUZZ_CHECK(s.points_in == s.points_non_finite + s.points_out_of_range + s.points_duplicate +
                                      s.points_used);
        FUZZ_CHECK(s.points_outside_grid <= s.points_used);
        break;
      }
    }
  }
  checkWholeGrid(grid);
  return 0;
}
