// Conversions between ROS messages and the core of the laser + stereo hybrid safety map (paper
// 001, core/laser_grid.h, core/hybrid_safety_map.h, core/landmark_filter.h).
//
// Like conversions.h: every function that reads a message validates it and returns an empty
// string on success, otherwise a one-line reason naming the offending field; none throws.
#pragma once

#include "stereo_safety_map/core/hybrid_safety_map.h"
#include "stereo_safety_map/core/laser_grid.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/ros/msgs.h"

#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

// ---------------------------------------------------------------------------------------------
// Hybrid class -> nav_msgs/OccupancyGrid value: the one translation table (toOccupancyValue() in
// core/hybrid_safety_map.h holds it; listed here for readers of the ROS layer).
//
//   class      value   meaning for a planner (costmap_2d static layer, lethal_cost_threshold 100)
//   Safe       0       free
//   Caution    50      drivable with care: a cost, not an obstacle (~caution_cost)
//   Hazard     100     overhang / drop-off / too steep: lethal (~hazard_cost, [1, 100])
//   Obstacle   100     lethal
//   Unknown    -1      no information

/// Checks a stereo_safety_map/SafetyMap message and copies its grid, labels and drop-off edges
/// into `out` (segments and planes are not needed by the fusion and are left empty). Refuses:
/// label / drop-off arrays of the wrong size, labels outside 0..4, a non-finite or non-positive
/// resolution, a rotated origin, an origin off the cell lattice of Eq. (1) (cell (u, v) centred at
/// (u l_v, v l_v), so the origin is the corner of cell (min_u, min_v)). An empty drop_off array is
/// accepted (no edges).
std::string safetyMapFromMsg(const SafetyMapMsg& msg, SafetyMap* out);

/// Checks a sensor_msgs/LaserScan and returns its geometry: finite angle_min / angle_increment
/// (non-zero) / range_min >= 0 / range_max > range_min; a number of ranges consistent with
/// angle_min, angle_max and angle_increment (within one beam, drivers differ in whether the last
/// angle is included); intensities empty or one per range. Non-finite ranges are not an error
/// (REP 117); the core skips NaN and treats +inf as no return.
std::string laserScanInfoFromMsg(const sensor_msgs::LaserScan& msg, LaserScanInfo* out);

/// The hybrid map as costs through toOccupancyValue() (table above; `config` holds the
/// configurable rows).
void toHybridOccupancyGrid(const HybridSafetyMap& map, const HybridSafetyMapConfig& config,
                           const std_msgs::Header& header, nav_msgs::OccupancyGrid* out);

/// The label message: hybrid classes, and per cell the vision label of `vision` (or UNKNOWN when
/// `vision_used` is false or the cell lies outside it) and the laser state at the cell's centre.
void toHybridSafetyMapMsg(const HybridSafetyMap& map, const SafetyMap& vision, bool vision_used,
                          double vision_age, const LaserGrid& laser, const std_msgs::Header& header,
                          HybridSafetyMapMsg* out);

/// The laser grid alone as an OccupancyGrid (occupied 100, free 0, unknown -1) on its own window.
void laserGridToOccupancyGrid(const LaserGrid& grid, const std_msgs::Header& header,
                              nav_msgs::OccupancyGrid* out);

/// Points (x, y, z FLOAT32, unorganised) in header.frame_id, e.g. the permanent landmarks of the
/// landmark filter (001 Sec. 4.2).
void pointsToCloud(const std::vector<Eigen::Vector3f>& points, const std_msgs::Header& header,
                   sensor_msgs::PointCloud2* out);

}  // namespace stereo_safety_map
