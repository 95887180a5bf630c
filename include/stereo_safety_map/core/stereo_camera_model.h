// Rectified pinhole stereo geometry, ROS-free. The ROS layer fills it from CameraInfo through
// image_geometry::StereoCameraModel; the core only needs f, cx, cy and the baseline.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace stereo_safety_map {

/// Rectified stereo pair, left camera optical frame (x right, y down, z forward).
struct StereoCameraModel {
  double fx = 0.0;  ///< focal length [px]
  double fy = 0.0;  ///< focal length [px]
  double cx = 0.0;  ///< principal point of the left camera [px]
  double cy = 0.0;
  double cx_right = 0.0;  ///< principal point x of the right camera (usually == cx) [px]
  double baseline = 0.0;  ///< [m], positive
  int width = 0;
  int height = 0;

  /// Empty when usable, otherwise why not (zero focal length, zero baseline, bad size...).
  std::string validate() const;

  /// Z = f B / (d - (cx - cx_right)) (002 Sec. 3.2).
  double depthFromDisparity(double d) const { return fx * baseline / (d - (cx - cx_right)); }
  double disparityFromDepth(double z) const { return fx * baseline / z + (cx - cx_right); }

  /// Point in the left optical frame for pixel (x, y) and disparity d > 0.
  Eigen::Vector3f reproject(double x, double y, double d) const {
    const double z = depthFromDisparity(d);
    return Eigen::Vector3f(static_cast<float>((x - cx) * z / fx),
                           static_cast<float>((y - cy) * z / fy), static_cast<float>(z));
  }
};

/// Reprojects a float disparity image (CV_32F, invalid <= 0 or non-finite) to 3D points in the
/// left optical frame, keeping points with min_depth <= Z <= max_depth. `points` is reused
/// (cleared, not shrunk) so that the hot path does not allocate. `step` subsamples rows and
/// columns (1 = every pixel).
void reprojectDisparity(const cv::Mat& disparity, const StereoCameraModel& model, double min_depth,
                        double max_depth, int step, std::vector<Eigen::Vector3f>* points);

/// Organised variant: one entry per pixel, NaN where invalid (for range-image algorithms).
void reprojectDisparityOrganized(const cv::Mat& disparity, const StereoCameraModel& model,
                                 double max_depth, cv::Mat* xyz /* CV_32FC3 */);

}  // namespace stereo_safety_map
