// Tests of the stereo error model (001 Sec. 4.1, Eq. (1)).
#include "stereo_safety_map/core/stereo_error_model.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <random>
#include <stdexcept>

namespace stereo_safety_map {
namespace {

StereoCameraModel testCamera() {
  StereoCameraModel c;
  c.fx = 500.0;
  c.fy = 480.0;
  c.cx = 320.0;
  c.cy = 240.0;
  c.cx_right = 320.0;
  c.baseline = 0.12;
  c.width = 640;
  c.height = 480;
  return c;
}

TEST(StereoErrorModel, ClosedFormEqualsJacobianPropagation) {
  const StereoErrorModelConfig cfg{0.3, 0.7, 0.4};
  const StereoErrorModel model(testCamera(), cfg);
  for (double row : {10.0, 240.0, 470.0}) {
    for (double col : {5.0, 320.0, 600.0}) {
      for (double d : {4.0, 17.5, 60.0}) {
        const Eigen::Vector3d p = model.camera().reproject(col, row, d).cast<double>();
        const Eigen::Matrix3d from_pixel = model.covarianceFromPixel(row, col, d);
        const Eigen::Matrix3d closed = model.covarianceCamera(p);
        EXPECT_LT((from_pixel - closed).norm(), 1e-6 * from_pixel.norm())
            << "row " << row << " col " << col << " d " << d;
      }
    }
  }
}

TEST(StereoErrorModel, JacobianMatchesNumericalDerivativeOfTriangulation) {
  const StereoErrorModel model(testCamera());
  const double row = 300.0, col = 150.0, d = 12.0, h = 1e-4;
  Eigen::Matrix3d j;
  ASSERT_TRUE(model.triangulationJacobian(row, col, d, &j));
  const StereoCameraModel& cam = model.camera();
  const auto tri = [&](double r, double c, double dd) {
    const double z = cam.depthFromDisparity(dd);
    return Eigen::Vector3d((c - cam.cx) * z / cam.fx, (r - cam.cy) * z / cam.fy, z);
  };
  Eigen::Matrix3d num;
  num.col(0) = (tri(row + h, col, d) - tri(row - h, col, d)) / (2 * h);
  num.col(1) = (tri(row, col + h, d) - tri(row, col - h, d)) / (2 * h);
  num.col(2) = (tri(row, col, d + h) - tri(row, col, d - h)) / (2 * h);
  EXPECT_LT((j - num).cwiseAbs().maxCoeff(), 1e-6 * j.cwiseAbs().maxCoeff()) << j << "\n" << num;
}

TEST(StereoErrorModel, DepthSigmaGrowsAsZSquaredOverFB) {
  const StereoCameraModel cam = testCamera();
  const StereoErrorModelConfig cfg;  // sigma_d = 0.5 px
  const StereoErrorModel model(cam, cfg);
  double previous = 0.0;
  for (double z : {0.5, 1.0, 2.0, 4.0, 8.0}) {
    const Eigen::Matrix3d c = model.covarianceCamera(Eigen::Vector3d(0.0, 0.0, z));
    const double sigma_z = std::sqrt(c(2, 2));
    const double predicted = z * z * cfg.sigma_disparity / (cam.fx * cam.baseline);
    EXPECT_NEAR(sigma_z, predicted, 1e-9 * predicted) << "z " << z;
    EXPECT_NEAR(model.depthSigma(z), predicted, 1e-12);
    // Lateral standard deviation grows only linearly: Z sigma_c / f_x.
    EXPECT_NEAR(std::sqrt(c(0, 0)), z * cfg.sigma_col / cam.fx, 1e-12);
    EXPECT_NEAR(std::sqrt(c(1, 1)), z * cfg.sigma_row / cam.fy, 1e-12);
    if (previous > 0.0) {
      EXPECT_NEAR(sigma_z / previous, 4.0, 1e-9);  // doubling Z: 4x
    }
    previous = sigma_z;
  }
}

TEST(StereoErrorModel, MonteCarloTriangulationAgreesWithFirstOrderCovariance) {
  const StereoErrorModel model(testCamera(), StereoErrorModelConfig{0.5, 0.5, 0.3});
  const double row = 200.0, col = 400.0, d = 40.0;  // Z = 1.5 m: first order is accurate
  std::mt19937 rng(7);
  std::normal_distribution<double> nr(0.0, 0.5), nc(0.0, 0.5), nd(0.0, 0.3);
  const int n = 200000;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  const double z0 = model.camera().depthFromDisparity(d);
  for (int i = 0; i < n; ++i) {
    const double r = row + nr(rng), c = col + nc(rng), dd = d + nd(rng);
    const double z = model.camera().depthFromDisparity(dd);
    const Eigen::Vector3d p((c - 320.0) * z / 500.0, (r - 240.0) * z / 480.0, z);
    mean += p;
    second += p * p.transpose();
  }
  mean /= n;
  const Eigen::Matrix3d empirical = second / n - mean * mean.transpose();
  const Eigen::Matrix3d predicted = model.covarianceFromPixel(row, col, d);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(empirical(a, a), predicted(a, a), 0.03 * predicted(a, a)) << "axis " << a;
  }
  // X-Z correlation from the shared depth error.
  const double corr_pred = predicted(0, 2) / std::sqrt(predicted(0, 0) * predicted(2, 2));
  const double corr_emp = empirical(0, 2) / std::sqrt(empirical(0, 0) * empirical(2, 2));
  EXPECT_NEAR(corr_emp, corr_pred, 0.02);
  EXPECT_GT(z0, 1.0);
}

TEST(StereoErrorModel, FixedFrameCovarianceIsRotatedAndElongatedAlongTheRay) {
  const StereoErrorModel model(testCamera());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Optical frame (z forward, x right, y down) to a robot frame (x forward, y left, z up),
  // then yawed by 30 degrees and shifted.
  Eigen::Matrix3d optical_to_robot;
  optical_to_robot << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  T.linear() =
      Eigen::AngleAxisd(M_PI / 6, Eigen::Vector3d::UnitZ()).toRotationMatrix() * optical_to_robot;
  T.translation() = Eigen::Vector3d(1.0, -2.0, 1.2);
  const Eigen::Vector3d p(0.4, -0.2, 5.0);
  const Eigen::Matrix3d c_cam = model.covarianceCamera(p);
  const Eigen::Matrix3d c_fix = model.covarianceFixed(p, T);
  EXPECT_NEAR(c_fix.trace(), c_cam.trace(), 1e-12);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(c_fix);
  const Eigen::Vector3d major = es.eigenvectors().col(2);
  const Eigen::Vector3d ray = (T.linear() * p).normalized();
  EXPECT_GT(std::abs(major.dot(ray)), 0.999);
  // Major axis far larger than the lateral ones at 5 m.
  EXPECT_GT(es.eigenvalues()(2), 100.0 * es.eigenvalues()(1));

  // The batch path gives the same numbers.
  std::vector<Eigen::Vector3f> pts{p.cast<float>(), Eigen::Vector3f(std::nanf(""), 0.f, 1.f),
                                   Eigen::Vector3f(0.f, 0.f, -1.f)};
  std::vector<Eigen::Vector3f> out;
  std::vector<Eigen::Matrix3f> covs;
  model.transformWithCovariance(pts, T.cast<float>(), &out, &covs);
  ASSERT_EQ(out.size(), 3u);
  ASSERT_EQ(covs.size(), 3u);
  EXPECT_LT((out[0].cast<double>() - T * p).norm(), 1e-5);
  EXPECT_LT((covs[0].cast<double>() - c_fix).norm(), 1e-5 * c_fix.norm());
  EXPECT_FALSE(out[1].allFinite());
  EXPECT_FALSE(covs[1].allFinite());
  EXPECT_FALSE(covs[2].allFinite());
}

TEST(StereoErrorModel, BadInputIsRejectedWithoutCrashing) {
  const StereoErrorModel model(testCamera());
  Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
  EXPECT_FALSE(model.triangulationJacobian(10, 10, 0.0, &j));   // infinite depth
  EXPECT_FALSE(model.triangulationJacobian(10, 10, -3.0, &j));  // behind the camera
  EXPECT_FALSE(model.triangulationJacobian(10, std::nan(""), 5.0, &j));
  EXPECT_EQ(j, Eigen::Matrix3d::Identity());
  EXPECT_FALSE(model.covarianceCamera(Eigen::Vector3d(0, 0, 0)).allFinite());
  EXPECT_FALSE(model.covarianceCamera(Eigen::Vector3d(0, 0, INFINITY)).allFinite());
  EXPECT_FALSE(model.covarianceFromPixel(1, 1, std::nan("")).allFinite());

  std::vector<Eigen::Vector3f> out{Eigen::Vector3f::Zero()};
  std::vector<Eigen::Matrix3f> covs{Eigen::Matrix3f::Zero()};
  model.transformWithCovariance({}, Eigen::Isometry3f::Identity(), &out, &covs);
  EXPECT_TRUE(out.empty());
  EXPECT_TRUE(covs.empty());
}

TEST(StereoErrorModel, ConfigAndCameraValidation) {
  EXPECT_TRUE(StereoErrorModelConfig().validate().empty());
  StereoErrorModelConfig bad;
  bad.sigma_disparity = 0.0;
  EXPECT_NE(bad.validate().find("sigma_disparity"), std::string::npos);
  bad = StereoErrorModelConfig();
  bad.sigma_row = std::nan("");
  EXPECT_NE(bad.validate().find("sigma_row"), std::string::npos);
  EXPECT_THROW(StereoErrorModel(testCamera(), bad), std::invalid_argument);

  StereoCameraModel cam = testCamera();
  cam.baseline = 0.0;
  EXPECT_NE(StereoErrorModel::checkCamera(cam).find("baseline"), std::string::npos);
  EXPECT_THROW(StereoErrorModel{cam}, std::invalid_argument);
  cam = testCamera();
  cam.fx = -1.0;
  EXPECT_NE(StereoErrorModel::checkCamera(cam).find("fx"), std::string::npos);
  EXPECT_TRUE(StereoErrorModel::checkCamera(testCamera()).empty());
}

}  // namespace
}  // namespace stereo_safety_map
