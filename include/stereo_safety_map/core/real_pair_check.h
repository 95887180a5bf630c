// Single-pair check on real camera data (the evaluation's real-data sanity check): one rectified
// stereo pair of a camera whose pose is unknown goes through the core pipeline of paper 000 in the
// single-frame mode of stereo_frame_processor.h, and the camera's height above the dominant ground
// plane and its tilt are read back from the resulting safety map.
//
// A single pair has no pose: the map needs a gravity-aligned fixed frame. It is bootstrapped by
// levelling the camera on a RANSAC plane of the pair's own points (the robot's usual extrinsic
// calibration), then the map is built and the camera is re-levelled on the map's dominant ground
// plane (the least-squares plane of the largest safe segment, 000 Sec. V-B) and the map rebuilt, so
// that the final numbers are those of the map's plane, not of the bootstrap. ROS-free.
#pragma once

#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/stereo_frame_processor.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct RealPairCheckConfig {
  /// Disparity and mapper settings; the mapper runs in singleFrameMapperConfig(mapper,
  /// seed_radius), everything else keeps the paper's values.
  StereoFrameProcessorConfig processor;
  /// [m], (0, 100]: the robot's segment may be seeded this far from the point under the camera
  /// (a camera 1.1 m high pitched 5 deg down with a 52 deg vertical field of view first sees the
  /// floor 1.8 m ahead).
  double seed_radius = 3.0;

  int ransac_iterations = 400;     ///< [1, 100000], fixed-seed RANSAC of the bootstrap plane
  double ransac_threshold = 0.03;  ///< inlier distance [m], (0, 1]
  double ransac_max_range = 6.0;   ///< only points nearer than this [m], (0, 100]
  /// Candidate ground normals must be within this angle of the camera's up direction (-y of the
  /// optical frame) [deg], (0, 90]; keeps walls out of the bootstrap.
  double max_tilt_deg = 40.0;
  int refinements = 2;  ///< re-levellings on the map's plane, [0, 10]
  std::uint32_t seed = 1;

  std::string validate() const;
};

/// Camera pose relative to a ground plane.
struct GroundPlaneEstimate {
  bool found = false;
  double camera_height = 0.0;  ///< perpendicular distance of the optical centre to the plane [m]
  double pitch_deg = 0.0;      ///< optical axis below the plane's horizon (positive = down)
  double roll_deg = 0.0;       ///< rotation of the image's x axis out of the plane
  double slope_deg = 0.0;      ///< the plane's slope in the fixed frame of the map
  SafetyLabel label = SafetyLabel::kUnknown;  ///< label of the segment it was fitted to
  int segment = -1;                           ///< its index in SafetyMap::segments
  int cells = 0;                              ///< its number of cells
};

/// The camera's height, pitch and roll relative to the plane n . p + d = 0 given in the camera's
/// optical frame (n unit; any sign).
GroundPlaneEstimate cameraPoseFromPlane(const Eigen::Vector3d& n_camera, double d);

/// The largest Level or Inclined segment with a valid plane fitted to points of `map` (else the
/// largest segment with such a plane, so that a floor that came out Non-ground is still reported)
/// and the pose of the camera at T_fixed_camera relative to its plane. The base's plane that a
/// robot segment without a plane of its own gets (GroundPlane::from_base) never counts.
/// found = false when no segment has a fitted plane.
GroundPlaneEstimate dominantGroundPlane(const SafetyMap& map,
                                        const Eigen::Isometry3d& T_fixed_camera);

/// RANSAC plane (fixed seed, then a least-squares refit on the inliers) of camera-frame points
/// below the optical centre whose normal is within max_tilt_deg of the camera's up direction.
/// Writes n (unit, pointing to the camera's side) and d with n . p + d = 0. False when no plane
/// with at least 50 inliers is found.
bool fitGroundPlaneRansac(const std::vector<Eigen::Vector3f>& points_camera,
                          const RealPairCheckConfig& config, Eigen::Vector3d* n, double* d);

/// A fixed frame levelled on the plane n . p + d = 0 (camera frame): z along the plane's normal,
/// the plane at z = 0, the camera above the origin, x along the optical axis projected onto the
/// plane. Returns T_fixed_camera.
Eigen::Isometry3d levelledCameraPose(const Eigen::Vector3d& n_camera, double d);

struct RealPairResult {
  std::string error;              ///< empty when the check ran
  std::size_t points = 0;         ///< reprojected points
  GroundPlaneEstimate bootstrap;  ///< from the RANSAC plane
  GroundPlaneEstimate map_plane;  ///< from the final map's dominant plane
  Eigen::Isometry3d T_fixed_camera = Eigen::Isometry3d::Identity();  ///< of the final map
  SafetyMap map;                                                     ///< the final map
  /// The left image's disparity (CV_32F, pixels, invalid <= 0) the map was built from, for
  /// scoring the map against hand labels of the left image (image_labels.h).
  cv::Mat disparity;
  int level_cells = 0;
  int inclined_cells = 0;
  int non_ground_cells = 0;
};

/// Runs the check on one rectified pair. Returns false (with result->error) for bad input or when
/// no ground plane is found.
bool checkRealPair(const cv::Mat& left, const cv::Mat& right, const StereoCameraModel& camera,
                   const RealPairCheckConfig& config, RealPairResult* result);

/// Reads a rectified camera model from an OpenCV YAML calibration with projection_matrix (ROS
/// camera_info layout) for the left and right camera; the baseline is -P_right[0][3] /
/// P_right[0][0].
std::string loadStereoCalibration(const std::string& left_yaml, const std::string& right_yaml,
                                  StereoCameraModel* model);

/// Reads "f=... cx=... cy=... baseline_m=..." (one line of key=value pairs) for a rectified pair
/// of the given image size.
std::string loadRectifiedCalibText(const std::string& path, int width, int height,
                                   StereoCameraModel* model);

}  // namespace stereo_safety_map
