#include "stereo_safety_map/core/stereo_error_model.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace stereo_safety_map {

namespace {

bool positiveFinite(double v) {
  return std::isfinite(v) && v > 0.0;
}

std::string rangeMessage(const char* name, double value, const char* range) {
  std::ostringstream s;
  s << name << " = " << value << " is out of range " << range;
  return s.str();
}

Eigen::Matrix3d nanMatrix() {
  return Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
}

}  // namespace

std::string StereoErrorModelConfig::validate() const {
  if (!positiveFinite(sigma_row)) return rangeMessage("sigma_row", sigma_row, "(0, inf) px");
  if (!positiveFinite(sigma_col)) return rangeMessage("sigma_col", sigma_col, "(0, inf) px");
  if (!positiveFinite(sigma_disparity)) {
    return rangeMessage("sigma_disparity", sigma_disparity, "(0, inf) px");
  }
  return {};
}

std::string StereoErrorModel::checkCamera(const StereoCameraModel& camera) {
  if (!positiveFinite(camera.fx)) return rangeMessage("camera fx", camera.fx, "(0, inf) px");
  if (!positiveFinite(camera.fy)) return rangeMessage("camera fy", camera.fy, "(0, inf) px");
  if (!positiveFinite(camera.baseline)) {
    return rangeMessage("camera baseline", camera.baseline, "(0, inf) m");
  }
  if (!std::isfinite(camera.cx) || !std::isfinite(camera.cy) || !std::isfinite(camera.cx_right)) {
    return "camera principal point (cx, cy, cx_right) must be finite";
  }
  return {};
}

StereoErrorModel::StereoErrorModel(const StereoCameraModel& camera,
                                   const StereoErrorModelConfig& config)
    : camera_(camera), config_(config) {
  std::string why = config_.validate();
  if (why.empty()) why = checkCamera(camera_);
  if (!why.empty()) throw std::invalid_argument("StereoErrorModel: " + why);
  inv_fx_ = 1.0 / camera_.fx;
  inv_fy_ = 1.0 / camera_.fy;
  inv_fb_ = 1.0 / (camera_.fx * camera_.baseline);
  sr2_ = config_.sigma_row * config_.sigma_row;
  sc2_ = config_.sigma_col * config_.sigma_col;
  sd2_ = config_.sigma_disparity * config_.sigma_disparity;
}

bool StereoErrorModel::triangulationJacobian(double row, double col, double disparity,
                                             Eigen::Matrix3d* jacobian) const {
  if (!std::isfinite(row) || !std::isfinite(col) || !std::isfinite(disparity)) return false;
  const double z = camera_.depthFromDisparity(disparity);
  if (!std::isfinite(z) || z <= 0.0) return false;
  const double x = (col - camera_.cx) * z * inv_fx_;
  const double y = (row - camera_.cy) * z * inv_fy_;
  *jacobian = triangulationJacobianAt(Eigen::Vector3d(x, y, z));
  return true;
}

Eigen::Matrix3d StereoErrorModel::triangulationJacobianAt(const Eigen::Vector3d& p) const {
  // dZ/dd = -f_x B / d'^2 = -Z^2 / (f_x B); X and Y scale with Z (001 Sec. 4.1, [10]).
  const double k = p.z() * inv_fb_;
  Eigen::Matrix3d j;
  j << 0.0, p.z() * inv_fx_, -k * p.x(),  //
      p.z() * inv_fy_, 0.0, -k * p.y(),   //
      0.0, 0.0, -k * p.z();
  return j;
}

Eigen::Matrix3d StereoErrorModel::covarianceCamera(const Eigen::Vector3d& p) const {
  if (!p.allFinite() || p.z() <= 0.0) return nanMatrix();
  const StereoCovarianceTerms t = termsAtDepth(p.z());
  Eigen::Matrix3d c = t.ray * (p * p.transpose());
  c(0, 0) += t.lateral_x;
  c(1, 1) += t.lateral_y;
  return c;
}

Eigen::Matrix3d StereoErrorModel::covarianceFromPixel(double row, double col,
                                                      double disparity) const {
  Eigen::Matrix3d j;
  if (!triangulationJacobian(row, col, disparity, &j)) return nanMatrix();
  // Eq. (1) literally, without the closed form (the tests compare both).
  const Eigen::Vector3d sigma2(sr2_, sc2_, sd2_);
  return j * sigma2.asDiagonal() * j.transpose();
}

Eigen::Matrix3d StereoErrorModel::covarianceFixed(const Eigen::Vector3d& p_camera,
                                                  const Eigen::Isometry3d& T_fixed_camera) const {
  const Eigen::Matrix3d r = T_fixed_camera.linear();
  return r * covarianceCamera(p_camera) * r.transpose();
}

void StereoErrorModel::transformWithCovariance(const std::vector<Eigen::Vector3f>& points_camera,
                                               const Eigen::Isometry3f& T_fixed_camera,
                                               std::vector<Eigen::Vector3f>* points_fixed,
                                               std::vector<Eigen::Matrix3f>* covariances) const {
  const std::size_t n = points_camera.size();
  points_fixed->resize(n);
  covariances->resize(n);
  const Eigen::Matrix3d r = T_fixed_camera.linear().cast<double>();
  const Eigen::Vector3d t = T_fixed_camera.translation().cast<double>();
  // R diag(a, b, 0) R^T = a r0 r0^T + b r1 r1^T with r0, r1 the first two columns of R, and
  // R (k p p^T) R^T = k (R p)(R p)^T: no 3x3 products per point.
  const Eigen::Vector3d r0 = r.col(0);
  const Eigen::Vector3d r1 = r.col(1);
  const Eigen::Matrix3d r00 = r0 * r0.transpose();
  const Eigen::Matrix3d r11 = r1 * r1.transpose();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = points_camera[i].cast<double>();
    if (!p.allFinite() || p.z() <= 0.0) {
      (*points_fixed)[i].setConstant(nan);
      (*covariances)[i].setConstant(nan);
      continue;
    }
    const StereoCovarianceTerms s = termsAtDepth(p.z());
    const Eigen::Vector3d rp = r * p;
    (*points_fixed)[i] = (rp + t).cast<float>();
    (*covariances)[i] =
        (s.lateral_x * r00 + s.lateral_y * r11 + s.ray * (rp * rp.transpose())).cast<float>();
  }
}

}  // namespace stereo_safety_map
