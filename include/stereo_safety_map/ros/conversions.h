// Conversions between ROS messages and the ROS-free core (include/stereo_safety_map/core/).
//
// Inputs are validated here: every function that reads a message returns an empty string on
// success and otherwise a one-line reason naming the offending field, and never throws, so that a
// bad message is counted and skipped by the caller instead of crashing the nodelet.
#pragma once

#include "stereo_safety_map/core/map_costs.h"
#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/core/safety_mapper.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/voxel_grid.h"
#include "stereo_safety_map/ros/msgs.h"

#include <geometry_msgs/Point.h>
#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/ColorRGBA.h>
#include <std_msgs/Header.h>
#include <stereo_msgs/DisparityImage.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

// ---------------------------------------------------------------------------------------------
// Safety label -> nav_msgs/OccupancyGrid value: the one cost table is core/map_costs.h
// (cellCost(), CostTable: Level 0, Inclined 10..50 with the slope, potential drop-off edge 100,
// Non-ground 100, Unknown / Unexamined -1 by default; the README's "Cost table").

// ---------------------------------------------------------------------------------------------
// Inputs
//
// The check*() functions read a message without converting it (no allocation): cheap enough for
// a subscriber callback, so that a malformed message is refused before it reaches a tf filter, a
// sync or a queue, where it could push a valid message out.

/// One CameraInfo on its own: non-empty size, finite P, positive focal length. `which` names it
/// in the message ("left", "right").
std::string checkCameraInfo(const sensor_msgs::CameraInfo& info, const char* which);

/// A grey view of a rectified 8-bit image (mono8 / 8UC1: onto the message's data, no copy; bgr8,
/// rgb8, bgra8, rgba8: converted into `buffer`), after checking encoding, size, step and data
/// size. `which` ("left", "right") names the image in the message. The view is valid while the
/// message (or `buffer`) lives.
std::string rectifiedImageToGrey(const sensor_msgs::Image& msg, const char* which, cv::Mat* buffer,
                                 cv::Mat* grey);

/// Rectified stereo geometry from the left / right CameraInfo pair through two
/// image_geometry::PinholeCameraModel (binning and ROI applied: the model describes the images as
/// published; baseline as image_geometry::StereoCameraModel computes it). Refuses zero or
/// non-finite focal length, zero baseline, empty images, sizes that differ, and a pair whose fx,
/// fy or cy differ (image_geometry::StereoCameraModel would assert, aborting the process).
std::string cameraModelFromCameraInfo(const sensor_msgs::CameraInfo& left,
                                      const sensor_msgs::CameraInfo& right,
                                      StereoCameraModel* model);

/// The inverse: the rectified CameraInfo of the left (right = false) or right camera of `model`,
/// no distortion, ROS stereo convention (both cameras' P in the left camera's rectified frame,
/// the right one with P[3] = Tx = -fx B). Every CameraInfo the package makes (datasets, bench,
/// tests) comes from here, so that cameraModelFromCameraInfo(toCameraInfo(m, false),
/// toCameraInfo(m, true)) gives m back.
sensor_msgs::CameraInfo toCameraInfo(const StereoCameraModel& model, bool right,
                                     const std_msgs::Header& header = std_msgs::Header());

/// Geometry for a stereo_msgs/DisparityImage: its own f and T (the message's disparities already
/// have the principal point offset removed, Z = f T / d, so cx_right = cx), the principal point
/// and fy from the left CameraInfo (through image_geometry::PinholeCameraModel). Refuses zero or
/// non-finite f, T, fy, and an image whose size differs from the CameraInfo's.
std::string cameraModelForDisparity(const stereo_msgs::DisparityImage& disparity,
                                    const sensor_msgs::CameraInfo& left_info,
                                    StereoCameraModel* model);

struct DisparityImageStats {
  std::size_t pixels = 0;
  std::size_t non_finite = 0;    ///< NaN / inf pixels (treated as invalid)
  std::size_t out_of_range = 0;  ///< outside [min_disparity, max_disparity] (invalid marker)
};

/// Everything disparityImageToMat() checks, plus positive finite f and T, without the copy;
/// `stats` counts the pixels that would be invalid.
std::string checkDisparityImage(const stereo_msgs::DisparityImage& msg,
                                DisparityImageStats* stats = nullptr);

/// Copies the disparity image into `out` (CV_32FC1, reused), checking encoding (32FC1), byte
/// order, step and data size. Pixels that are not finite or lie outside the message's
/// [min_disparity, max_disparity] (when max > min; stereo_image_proc marks invalid pixels with
/// min_disparity - 1) are set to 0, which the core treats as invalid.
std::string disparityImageToMat(const stereo_msgs::DisparityImage& msg, cv::Mat* out,
                                DisparityImageStats* stats = nullptr);

struct CloudStats {
  std::size_t points = 0;
  std::size_t non_finite = 0;  ///< NaN / inf points, dropped
};

/// Everything pointCloud2ToPoints() checks, without the copy; `stats` counts the points.
std::string checkPointCloud2(const sensor_msgs::PointCloud2& msg, CloudStats* stats = nullptr);

/// x, y, z of every finite point (sensor frame), after checking the fields (x, y, z present
/// once each, FLOAT32, count 1, inside point_step), byte order, point_step / row_step and data
/// size. `points` is reused (cleared, not shrunk).
std::string pointCloud2ToPoints(const sensor_msgs::PointCloud2& msg,
                                std::vector<Eigen::Vector3f>* points, CloudStats* stats = nullptr);

// ---------------------------------------------------------------------------------------------
// Outputs. `header.frame_id` is the fixed frame the core works in.

/// Grid geometry shared by the OccupancyGrid and SafetyMap.msg: cell (u, v) centred at
/// (u l_v, v l_v), so the origin is the corner of cell (min_u, min_v).
nav_msgs::MapMetaData mapMetaData(const SafetyMap& map, const ros::Time& load_time);

/// Costs through the cost table (core/map_costs.h: safetyMapCosts). `labelling` gives theta_T /
/// theta_max for Inclined.
void toOccupancyGrid(const SafetyMap& map, const SafetyLabellingConfig& labelling,
                     const CostTable& costs, const std_msgs::Header& header,
                     nav_msgs::OccupancyGrid* out);

/// Labels, drop-off edges, segments with their planes.
void toSafetyMapMsg(const SafetyMap& map, const Eigen::Vector3f& robot_position,
                    const std_msgs::Header& header, SafetyMapMsg* out);

/// The hybrid 3D model of paper 000 Fig. 4(b): per ground segment a TRIANGLE_LIST of its cells
/// lifted onto its plane (Level green, Inclined yellow, Non-ground ground segments - unreachable
/// or too steep - red; Unknown segments are not drawn), the slope of every drawn segment as text,
/// and the occupied voxels under Non-ground cells (up to the robot's height) as grey cubes, and
/// the potential drop-off edges (dropOffEdgeMarker()). The first marker is a DELETEALL so that
/// segments that disappeared are removed.
void toMarkerArray(const SafetyMapper& mapper, const std_msgs::Header& header,
                   visualization_msgs::MarkerArray* out);

/// The potential drop-off edges of 000 Sec. VI as magenta tiles (namespace `drop_off_edges`, one
/// CUBE_LIST, 2 cm above their segment's plane, or their column's height without one). The
/// OccupancyGrid gives them Non-ground's cost (cost_drop_off 100), so rviz's map display draws
/// them alike; this marker tells them apart. False (and no marker) when the map has none.
bool dropOffEdgeMarker(const SafetyMap& map, const std_msgs::Header& header,
                       visualization_msgs::Marker* out);

/// A marker's colour and point from their values (the package's markers: the safety map's, the
/// gate's).
std_msgs::ColorRGBA colorMsg(float r, float g, float b, float a);
geometry_msgs::Point pointMsg(double x, double y, double z);

/// The point lists of all occupied voxels (000 Sec. IV: the 3D point cloud of the model).
void occupiedPointsToCloud(const VoxelGrid& grid, const std_msgs::Header& header,
                           sensor_msgs::PointCloud2* out);

/// Per-stage timings and counters.
void toStageTimingsMsg(const StageTimings& timings, const std_msgs::Header& header,
                       StageTimingsMsg* out);

}  // namespace stereo_safety_map
