// First-order error model of a triangulated stereo point (paper 001, Sec. 4.1, Eq. (1)).
//
// The pixel measurement z = (row, col, disparity) is Gaussian with covariance
// diag(sigma_r^2, sigma_c^2, sigma_d^2). Triangulation lambda(z) gives the point in the left
// optical frame (x right, y down, z forward) and kappa moves it to the fixed frame. Eq. (1)
// propagates the pixel covariance through both Jacobians:
//   Sigma_g = dkappa/dx * dlambda/dz * Sigma_z * dlambda/dz^T * dkappa/dx^T.
//
// With X = (c - cx) Z / f_x, Y = (r - cy) Z / f_y, Z = f_x B / d, the Jacobian columns are
//   d/dr = (0, Z/f_y, 0),  d/dc = (Z/f_x, 0, 0),  d/dd = -(Z / (f_x B)) (X, Y, Z),
// so the camera-frame covariance has the closed form
//   Sigma_c = diag((sigma_c Z/f_x)^2, (sigma_r Z/f_y)^2, 0) + (sigma_d Z/(f_x B))^2 p p^T,
// a diagonal lateral part plus a rank-one part along the viewing ray; its depth standard
// deviation is Z^2 sigma_d / (f_x B). kappa is a rigid motion, so dkappa/dx = R and
// Sigma_g = R Sigma_c R^T (001 neglects localization error; so does this model).
//
// Deviations from 001: the paper writes z in right-image coordinates (r^R, c^R); rectified
// images share rows and the left image is the reference here, as in StereoCameraModel. The
// paper's pose is planar (x, y, theta); here it is a full rigid transform.
#pragma once

#include "stereo_safety_map/core/stereo_camera_model.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace stereo_safety_map {

/// Pixel noise of one stereo measurement (001 Sec. 4.1). 001 gives no numbers; the defaults are
/// half a pixel, a conservative value for sub-pixel correlation stereo (002 Sec. 3.1 reports
/// standard deviations "well below one pixel").
struct StereoErrorModelConfig {
  double sigma_row = 0.5;        ///< sigma_r [px], > 0
  double sigma_col = 0.5;        ///< sigma_c [px], > 0
  double sigma_disparity = 0.5;  ///< sigma_d [px], > 0

  /// Empty when valid, otherwise a message naming the first offending parameter and its range.
  std::string validate() const;
};

/// Coefficients of the closed-form camera-frame covariance at depth Z:
/// Sigma_c = diag(lateral_x, lateral_y, 0) + ray * p p^T.
struct StereoCovarianceTerms {
  double lateral_x = 0.0;  ///< (sigma_c Z / f_x)^2 [m^2]
  double lateral_y = 0.0;  ///< (sigma_r Z / f_y)^2 [m^2]
  double ray = 0.0;        ///< (sigma_d Z / (f_x B))^2, multiplies p p^T [dimensionless]
};

class StereoErrorModel {
 public:
  /// Throws std::invalid_argument when config.validate() or checkCamera(camera) is not empty.
  StereoErrorModel(const StereoCameraModel& camera,
                   const StereoErrorModelConfig& config = StereoErrorModelConfig());

  /// The checks this model needs of a camera: finite f_x, f_y > 0 and baseline > 0.
  static std::string checkCamera(const StereoCameraModel& camera);

  const StereoCameraModel& camera() const { return camera_; }
  const StereoErrorModelConfig& config() const { return config_; }

  /// Coefficients of the closed form at depth z > 0 (see the file comment).
  StereoCovarianceTerms termsAtDepth(double z) const {
    const double zx = z * inv_fx_;
    const double zy = z * inv_fy_;
    const double zr = z * inv_fb_;
    return {sc2_ * zx * zx, sr2_ * zy * zy, sd2_ * zr * zr};
  }

  /// dlambda/dz at pixel (row, col) and disparity d, columns ordered (row, col, disparity).
  /// Returns false (and leaves *jacobian untouched) when the disparity gives no positive depth.
  bool triangulationJacobian(double row, double col, double disparity,
                             Eigen::Matrix3d* jacobian) const;
  /// The same Jacobian written in terms of the triangulated point (valid for p.z() > 0).
  Eigen::Matrix3d triangulationJacobianAt(const Eigen::Vector3d& p_camera) const;

  /// Covariance in the left optical frame of the point triangulated at p_camera (z > 0);
  /// all-NaN when p_camera is not finite or not in front of the camera.
  Eigen::Matrix3d covarianceCamera(const Eigen::Vector3d& p_camera) const;
  /// Covariance in the left optical frame from the pixel measurement; all-NaN when invalid.
  Eigen::Matrix3d covarianceFromPixel(double row, double col, double disparity) const;

  /// Eq. (1): covariance in the fixed frame of a point given in the camera frame.
  Eigen::Matrix3d covarianceFixed(const Eigen::Vector3d& p_camera,
                                  const Eigen::Isometry3d& T_fixed_camera) const;

  /// Eq. (1) for a whole cloud: fixed-frame points and covariances for camera-frame points.
  /// Invalid points (non-finite, z <= 0) give NaN entries. The output vectors are reused.
  void transformWithCovariance(const std::vector<Eigen::Vector3f>& points_camera,
                               const Eigen::Isometry3f& T_fixed_camera,
                               std::vector<Eigen::Vector3f>* points_fixed,
                               std::vector<Eigen::Matrix3f>* covariances_fixed) const;

  /// Standard deviation of the depth at Z: Z^2 sigma_d / (f_x B).
  double depthSigma(double z) const { return z * z * config_.sigma_disparity * inv_fb_; }

 private:
  StereoCameraModel camera_;
  StereoErrorModelConfig config_;
  double inv_fx_ = 0.0, inv_fy_ = 0.0, inv_fb_ = 0.0;
  double sr2_ = 0.0, sc2_ = 0.0, sd2_ = 0.0;
};

}  // namespace stereo_safety_map
