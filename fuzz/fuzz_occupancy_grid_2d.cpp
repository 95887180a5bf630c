// libFuzzer target: the 2D stereo occupancy grid of paper 002 (occupancy_grid_2d.h) under random
// disparity images (sizes, types, steps, NaN / inf / huge disparities), camera models (zero, NaN,
// huge f, baseline, principal point), camera poses (non-rigid, NaN, far away), floor heights,
// window moves and reduced rows handed in directly.
//
// Contracts checked: the constructor throws std::invalid_argument exactly when validate() is not
// empty; a refused update leaves the grid unchanged; counters stay within the window; an
// uncertainty trapezoid has 0 <= z_near <= z_far.
#include "fuzz_common.h"

#include "stereo_safety_map/core/occupancy_grid_2d.h"
#include "stereo_safety_map/core/stereo_camera_model.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <vector>

using namespace stereo_safety_map;
using ssm_fuzz::mostlyInRange;
using ssm_fuzz::mostlyIntInRange;
using ssm_fuzz::specialDouble;
using ssm_fuzz::specialFloat;

namespace {

OccupancyGrid2DConfig randomConfig(FuzzedDataProvider& fdp) {
  OccupancyGrid2DConfig c;
  c.resolution = mostlyInRange(fdp, 0.05, 0.5, 16);
  c.size_x = mostlyInRange(fdp, 0.0, 12.0, 16);
  c.size_y = mostlyInRange(fdp, 0.0, 12.0, 16);
  c.k = mostlyIntInRange(fdp, 1, 255, 16);
  c.free_threshold = mostlyIntInRange(fdp, 0, 128, 16);
  c.occupied_threshold = mostlyIntInRange(fdp, 128, 255, 16);
  c.floor_clearance = mostlyInRange(fdp, -0.2, 0.5, 16);
  c.robot_height = mostlyInRange(fdp, 0.5, 2.0, 16);
  c.disparity_half_width = mostlyInRange(fdp, 0.1, 2.0, 16);
  c.accuracy_preservation = fdp.ConsumeBool();
  return c;
}

StereoCameraModel randomModel(FuzzedDataProvider& fdp, int width, int height) {
  StereoCameraModel m;
  m.fx = mostlyInRange(fdp, 20.0, 600.0, 16);
  m.fy = fdp.ConsumeBool() ? m.fx : mostlyInRange(fdp, 20.0, 600.0, 16);
  m.cx = mostlyInRange(fdp, 0.0, width, 16);
  m.cy = mostlyInRange(fdp, 0.0, height, 16);
  m.cx_right = fdp.ConsumeIntegralInRange<int>(0, 3) != 0 ? m.cx : mostlyInRange(fdp, -5.0, width);
  m.baseline = mostlyInRange(fdp, 0.02, 0.5, 16);
  m.width = fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? mostlyIntInRange(fdp, 0, 64) : width;
  m.height = fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? mostlyIntInRange(fdp, 0, 48) : height;
  return m;
}

// Camera 1.1 m above the floor looking forward and down, mostly; sometimes anything.
Eigen::Isometry3f randomPose(FuzzedDataProvider& fdp) {
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  const int pick = fdp.ConsumeIntegralInRange<int>(0, 15);
  if (pick == 0) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c)
        T.matrix()(r, c) = specialFloat(fdp, -2.0f, 2.0f);
    }
    return T;
  }
  const Eigen::Matrix3f base_to_optical =
      (Eigen::Matrix3f() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished();
  T.linear() = (Eigen::AngleAxisf(fdp.ConsumeFloatingPointInRange<float>(-3.2f, 3.2f),
                                  Eigen::Vector3f::UnitZ()) *
                Eigen::AngleAxisf(fdp.ConsumeFloatingPointInRange<float>(-0.3f, 1.2f),
                                  Eigen::Vector3f::UnitY()))
                   .toRotationMatrix() *
               base_to_optical;
  if (pick == 1) {  // any position, e.g. 1e30 away
    T.translation() = Eigen::Vector3f(specialFloat(fdp, -20, 20), specialFloat(fdp, -20, 20),
                                      specialFloat(fdp, -1, 3));
  } else {
    T.translation() = Eigen::Vector3f(fdp.ConsumeFloatingPointInRange<float>(-8.0f, 8.0f),
                                      fdp.ConsumeFloatingPointInRange<float>(-8.0f, 8.0f),
                                      fdp.ConsumeFloatingPointInRange<float>(0.2f, 2.0f));
  }
  return T;
}

bool sameImage(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  for (int r = 0; r < a.rows; ++r) {
    if (std::memcmp(a.ptr(r), b.ptr(r), static_cast<std::size_t>(a.cols) * a.elemSize()) != 0) {
      return false;
    }
  }
  return true;
}

void checkStats(const OccupancyGrid2D& grid, const Grid2DUpdateStats& s) {
  const int cells = grid.sizeU() * grid.sizeV();
  FUZZ_CHECK(s.cells_raised >= 0 && s.cells_lowered >= 0);
  FUZZ_CHECK(s.cells_raised + s.cells_lowered <= cells);
  FUZZ_CHECK(s.columns_with_reading <= s.columns);
  FUZZ_CHECK(s.columns_explained <= s.columns_with_reading);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider fdp(data, size);

  // Free functions first: trapezoid and projection on arbitrary numbers.
  {
    const StereoCameraModel m = randomModel(fdp, 64, 48);
    UncertaintyTrapezoid tr;
    const double x = specialDouble(fdp, -10.0, 70.0);
    const double d = specialDouble(fdp, -2.0, 64.0);
    const double hw = specialDouble(fdp, 0.0, 2.0);
    if (computeUncertaintyTrapezoid(m, x, d, hw, &tr)) {
      // >= 0, not > 0: a valid model may have a denormal focal length, whose f B underflows.
      FUZZ_CHECK(!(tr.z_near < 0.0) && !(tr.z_far < tr.z_near));
    }
    GroundRegion g;
    projectUncertaintyRegion(m, x, specialDouble(fdp, -10.0, 50.0), d, hw, randomPose(fdp),
                             specialDouble(fdp, 0.0, 30.0), &g);
  }

  const OccupancyGrid2DConfig config = randomConfig(fdp);
  const bool valid = config.validate().empty();
  if (!valid || (config.size_x / config.resolution) * (config.size_y / config.resolution) > 2e5) {
    if (!valid) {
      bool threw = false;
      try {
        OccupancyGrid2D refused(config);
      } catch (const std::invalid_argument&) {
        threw = true;
      }
      FUZZ_CHECK(threw);
    }
    return 0;  // valid but larger than the harness's budget: not built
  }
  OccupancyGrid2D grid(config);
  const std::size_t total = static_cast<std::size_t>(grid.sizeU()) * grid.sizeV();

  cv::Mat before, after, storage;
  std::vector<ColumnReading> row;
  const int ops = fdp.ConsumeIntegralInRange<int>(1, 6);
  for (int op = 0; op < ops && fdp.remaining_bytes() > 0; ++op) {
    switch (fdp.ConsumeIntegralInRange<int>(0, 5)) {
      case 0: {
        const Eigen::Vector2f p(specialFloat(fdp, -20, 20), specialFloat(fdp, -20, 20));
        FUZZ_CHECK(grid.recenter(p) <= total);
        break;
      }
      case 1: {
        GridCell2D c{grid.minIndex().u + fdp.ConsumeIntegralInRange<int>(-2, grid.sizeU() + 1),
                     grid.minIndex().v + fdp.ConsumeIntegralInRange<int>(-2, grid.sizeV() + 1)};
        if (fdp.ConsumeIntegralInRange<int>(0, 15) == 0) {  // anywhere, INT_MIN included
          c = GridCell2D{mostlyIntInRange(fdp, -100, 100, 1), mostlyIntInRange(fdp, -100, 100, 1)};
        }
        grid.setCell(c, fdp.ConsumeIntegral<std::uint8_t>(), specialFloat(fdp, 0, 64));
        FUZZ_CHECK(std::isfinite(grid.storedDisparity(c)));
        const Eigen::Vector2f centre = grid.centerOf(c);
        // Float centres resolve cells only up to ~1e5 cells from the origin.
        if (grid.contains(c) && std::abs(c.u) < 100000 && std::abs(c.v) < 100000) {
          FUZZ_CHECK(grid.indexOf(centre) == c);
        }
        break;
      }
      case 2: {
        // A reduced row handed in directly.
        const int width = fdp.ConsumeIntegralInRange<int>(0, 64);
        const StereoCameraModel m = randomModel(fdp, width, 48);
        row.assign(static_cast<std::size_t>(width), ColumnReading());
        for (ColumnReading& r : row) {
          if (fdp.ConsumeIntegralInRange<int>(0, 3) == 0) continue;
          r.disparity = fdp.ConsumeIntegralInRange<int>(0, 7) == 0
                            ? specialFloat(fdp, 0, 64)
                            : fdp.ConsumeFloatingPointInRange<float>(0.0f, 64.0f);
          r.row = mostlyIntInRange(fdp, 0, 47);
        }
        const Eigen::Isometry3f T = randomPose(fdp);
        grid.toImage(&before);
        const Grid2DUpdateStats s = grid.updateFromRow(row, m, T);
        if (!s.ok()) {
          grid.toImage(&after);
          FUZZ_CHECK(sameImage(before, after));
        }
        checkStats(grid, s);
        break;
      }
      default: {
        // A disparity image.
        const int rows = fdp.ConsumeIntegralInRange<int>(0, 48);
        const int cols = fdp.ConsumeIntegralInRange<int>(0, 64);
        static const int kTypes[] = {CV_32FC1, CV_32FC1, CV_32FC1, CV_32FC1,
                                     CV_32FC1, CV_32FC1, CV_64FC1, CV_8UC1};
        const int type = fdp.PickValueInArray(kTypes);
        cv::Mat disparity;
        if (rows > 0 && cols > 0) {
          disparity = ssm_fuzz::makeStridedMat(fdp, rows, cols, type, &storage);
          if (type == CV_32FC1) {
            ssm_fuzz::fillFloats(fdp, 64.0f, &disparity);
          } else {
            ssm_fuzz::fillBytes(fdp, &disparity);
          }
        }
        const StereoCameraModel m = randomModel(fdp, cols, rows);
        const Eigen::Isometry3f T = randomPose(fdp);
        const float floor_z =
            fdp.ConsumeIntegralInRange<int>(0, 15) == 0 ? specialFloat(fdp, -1, 1) : 0.0f;
        grid.toImage(&before);
        const Grid2DUpdateStats s = grid.update(disparity, m, T, floor_z);
        if (!s.ok()) {
          grid.toImage(&after);
          FUZZ_CHECK(sameImage(before, after));
        } else {
          FUZZ_CHECK(s.columns == cols);
          FUZZ_CHECK(grid.lastRow().size() == static_cast<std::size_t>(cols));
        }
        checkStats(grid, s);
        break;
      }
    }
  }
  return 0;
}
