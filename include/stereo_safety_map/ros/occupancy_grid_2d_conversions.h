// The 2D occupancy grid of paper 002 (core/occupancy_grid_2d.h) as a nav_msgs/OccupancyGrid.
//
// Grid value G (0..255, unknown = 128) -> OccupancyGrid value: the one translation table, the
// planning thresholds of 002 Sec. 3.4 ("G < 50 free of obstacles, G > 150 definitely
// obstructed"; ~free_threshold / ~occupied_threshold):
//
//   G                                          value   meaning for a planner
//   G < free_threshold            (0 .. 49)     0      free
//   free_threshold <= G <= occupied_threshold   -1     unknown: never seen (128) or evidence not
//                                 (50 .. 150)          yet decisive either way
//   G > occupied_threshold        (151 .. 255)  100    occupied (lethal)
//
// With costmap_2d's static layer keep lethal_cost_threshold at 100 and unknown_cost_value at -1
// (trinary_costmap true or false gives the same result: the values are 0, 100 and -1 only).
//
// Geometry: cell (u, v) is centred at (u l, v l) in the fixed frame (000 Eq. (1)), exactly as
// the safety map's cells, so both grids line up cell for cell; the message's origin is the corner
// of the window's first cell, ((min_u - 0.5) l, (min_v - 0.5) l).
#pragma once

#include "stereo_safety_map/core/occupancy_grid_2d.h"

#include <nav_msgs/OccupancyGrid.h>
#include <std_msgs/Header.h>

#include <array>
#include <cstdint>

namespace stereo_safety_map {

enum class OccupancyGrid2DClass : std::uint8_t { kFree = 0, kUnknown = 1, kOccupied = 2 };

/// One row of the translation table, indexed by OccupancyGrid2DClass.
struct OccupancyGrid2DValue {
  OccupancyGrid2DClass cls;
  std::int8_t value;
};
constexpr OccupancyGrid2DValue kOccupancyGrid2DValueTable[] = {
    {OccupancyGrid2DClass::kFree, 0},
    {OccupancyGrid2DClass::kUnknown, -1},
    {OccupancyGrid2DClass::kOccupied, 100},
};

/// Class of a grid value under the planning thresholds (002 Sec. 3.4).
OccupancyGrid2DClass occupancyGrid2DClass(std::uint8_t g, int free_threshold,
                                          int occupied_threshold);

/// OccupancyGrid value of a grid value through kOccupancyGrid2DValueTable.
std::int8_t occupancyGrid2DValue(std::uint8_t g, int free_threshold, int occupied_threshold);

/// The table expanded for every G (what the conversion below uses).
std::array<std::int8_t, 256> occupancyGrid2DLookup(int free_threshold, int occupied_threshold);

/// The window of `grid` as an OccupancyGrid in `header.frame_id` (the fixed frame the grid was
/// built in). `image` is a scratch buffer (reused between calls).
void toOccupancyGrid(const OccupancyGrid2D& grid, const std_msgs::Header& header,
                     nav_msgs::OccupancyGrid* out, cv::Mat* image);

}  // namespace stereo_safety_map
