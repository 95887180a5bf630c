// Rectified pinhole stereo geometry, ROS-free. The ROS layer fills it from CameraInfo through
// image_geometry::StereoCameraModel; the core only needs f, cx, cy and the baseline.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cmath>
#include <cstddef>
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

/// A disparity image as the disparity nodelet publishes it and the safety-map nodelet reads it
/// back (stereo_msgs/DisparityImage, stereo_image_proc's convention Z = f T / d): f and T travel
/// as float32, the principal-point offset cx - cx_right is removed from every disparity, and only
/// values within [min_disparity, max_disparity] of the message are valid. One definition for both
/// nodelets and for the offline path (StereoFrameProcessor::processImages), so that a frame mapped
/// offline and one that went through the two nodelets give the same points, bit for bit.
struct DisparityMessageGeometry {
  float f = 0.0f;              ///< [px]
  float T = 0.0f;              ///< baseline [m]
  float offset = 0.0f;         ///< cx - cx_right [px], subtracted from every disparity
  float min_disparity = 0.0f;  ///< the message's valid range [px]
  float max_disparity = 0.0f;
  /// The value an invalid pixel carries (stereo_image_proc writes min_disparity - 1 there).
  float invalid() const { return min_disparity - 1.0f; }
  /// The message's value for the matcher's disparity d (invalid() when d is not valid).
  float toMessage(float d) const {
    const float m = d - offset;
    return d > 0.0f && std::isfinite(d) && m > 0.0f ? m : invalid();
  }
  /// The safety-map nodelet's reading of a message value: itself when finite and within
  /// [min_disparity, max_disparity], else 0 (invalid).
  float fromMessage(float m) const {
    return std::isfinite(m) && m >= min_disparity && m <= max_disparity ? m : 0.0f;
  }
};

/// The message geometry for a camera and a matcher searching [min_disparity, min_disparity +
/// num_disparities) (its output is at most min_disparity + num_disparities - 1 in whole pixels).
DisparityMessageGeometry disparityMessageGeometry(const StereoCameraModel& camera,
                                                  int min_disparity, int num_disparities);

/// In place, every pixel of a matcher's CV_32FC1 disparity as the safety-map nodelet reads it back
/// from the message: fromMessage(toMessage(d)).
void throughDisparityMessage(const DisparityMessageGeometry& g, cv::Mat* disparity);

/// The camera model the safety-map nodelet builds for such a message and the left camera's
/// CameraInfo (conversions.h cameraModelForDisparity): f and T of the message, fy scaled by the
/// message's f over left.fx, cx, cy and the size of `left`, cx_right = cx.
StereoCameraModel messageCameraModel(const DisparityMessageGeometry& g,
                                     const StereoCameraModel& left);

/// Reprojects a float disparity image (CV_32F, invalid <= 0 or non-finite) to 3D points in the
/// left optical frame, keeping points with min_depth <= Z <= max_depth. `points` is reused
/// (cleared, not shrunk) so that the hot path does not allocate. `step` subsamples rows and
/// columns (1 = every pixel).
void reprojectDisparity(const cv::Mat& disparity, const StereoCameraModel& model, double min_depth,
                        double max_depth, int step, std::vector<Eigen::Vector3f>* points);

/// Organised variant: one entry per pixel, NaN where invalid (for range-image algorithms).
void reprojectDisparityOrganized(const cv::Mat& disparity, const StereoCameraModel& model,
                                 double max_depth, cv::Mat* xyz /* CV_32FC3 */);

/// The range image of the obstacle detector (paper 003) as the nodelet and the evaluations build
/// it: every point of `xyz` (CV_32FC3, camera optical frame) whose z is not within
/// [min_depth, max_depth] (NaN included) becomes NaN. Returns the points kept.
std::size_t limitRangeImageDepth(double min_depth, double max_depth, cv::Mat* xyz);

}  // namespace stereo_safety_map
