// Reprojection of disparities to 3D: worlds whose answer follows from Z = f B / d.
#include "stereo_safety_map/core/stereo_camera_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace stereo_safety_map {
namespace {

StereoCameraModel makeModel() {
  StereoCameraModel m;
  m.fx = 500.0;
  m.fy = 480.0;
  m.cx = 320.0;
  m.cy = 240.0;
  m.cx_right = 320.0;
  m.baseline = 0.12;
  m.width = 640;
  m.height = 480;
  return m;
}

// Pixel and disparity of a left-frame point, as the ideal rectified pair sees it.
void project(const StereoCameraModel& m, const Eigen::Vector3d& p, double* u, double* v,
             double* d) {
  *u = m.fx * p.x() / p.z() + m.cx;
  *v = m.fy * p.y() / p.z() + m.cy;
  *d = m.disparityFromDepth(p.z());
}

TEST(StereoCameraModel, ValidModelPasses) {
  EXPECT_EQ(makeModel().validate(), "");
}

TEST(StereoCameraModel, BadModelsAreRejectedNamingTheParameter) {
  struct Case {
    void (*mutate)(StereoCameraModel*);
    const char* name;
  };
  const Case cases[] = {
      {[](StereoCameraModel* m) { m->fx = 0.0; }, "fx"},
      {[](StereoCameraModel* m) { m->fx = -1.0; }, "fx"},
      {[](StereoCameraModel* m) { m->fy = std::numeric_limits<double>::quiet_NaN(); }, "fy"},
      {[](StereoCameraModel* m) { m->baseline = 0.0; }, "baseline"},
      {[](StereoCameraModel* m) { m->baseline = -0.1; }, "baseline"},
      {[](StereoCameraModel* m) { m->baseline = std::numeric_limits<double>::infinity(); },
       "baseline"},
      {[](StereoCameraModel* m) { m->cx = std::numeric_limits<double>::quiet_NaN(); }, "cx"},
      {[](StereoCameraModel* m) { m->width = 0; }, "size"},
      {[](StereoCameraModel* m) { m->height = -5; }, "size"},
  };
  for (const Case& c : cases) {
    StereoCameraModel m = makeModel();
    c.mutate(&m);
    const std::string e = m.validate();
    EXPECT_NE(e.find(c.name), std::string::npos) << "'" << e << "' should name " << c.name;
  }
}

TEST(StereoCameraModel, DepthIsFocalTimesBaselineOverDisparity) {
  const StereoCameraModel m = makeModel();
  EXPECT_DOUBLE_EQ(m.depthFromDisparity(30.0), 500.0 * 0.12 / 30.0);  // 2 m
  EXPECT_DOUBLE_EQ(m.disparityFromDepth(2.0), 30.0);
  StereoCameraModel shifted = m;
  shifted.cx_right = 310.0;  // principal points 10 px apart: d = f B / Z + 10
  EXPECT_DOUBLE_EQ(shifted.disparityFromDepth(2.0), 40.0);
  EXPECT_DOUBLE_EQ(shifted.depthFromDisparity(40.0), 2.0);
}

TEST(StereoCameraModel, KnownPointProjectsAndReprojectsBack) {
  for (const double cx_right : {320.0, 305.5}) {
    StereoCameraModel m = makeModel();
    m.cx_right = cx_right;
    // Chosen so that the point lands on a pixel centre: u = 420, v = 120 at Z = 2.5.
    const Eigen::Vector3d p((420.0 - m.cx) * 2.5 / m.fx, (120.0 - m.cy) * 2.5 / m.fy, 2.5);
    double u, v, d;
    project(m, p, &u, &v, &d);
    ASSERT_DOUBLE_EQ(u, 420.0);
    ASSERT_DOUBLE_EQ(v, 120.0);

    cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(0.0f));
    disparity.at<float>(120, 420) = static_cast<float>(d);
    std::vector<Eigen::Vector3f> points;
    reprojectDisparity(disparity, m, 0.1, 10.0, 1, &points);
    ASSERT_EQ(points.size(), 1u);
    EXPECT_NEAR(points[0].x(), p.x(), 1e-5);
    EXPECT_NEAR(points[0].y(), p.y(), 1e-5);
    EXPECT_NEAR(points[0].z(), p.z(), 1e-5);
    EXPECT_TRUE(points[0].isApprox(m.reproject(420.0, 120.0, d), 1e-5f));

    cv::Mat xyz;
    reprojectDisparityOrganized(disparity, m, 10.0, &xyz);
    ASSERT_EQ(xyz.type(), CV_32FC3);
    ASSERT_EQ(xyz.size(), disparity.size());
    const cv::Vec3f q = xyz.at<cv::Vec3f>(120, 420);
    EXPECT_NEAR(q[0], p.x(), 1e-5);
    EXPECT_NEAR(q[1], p.y(), 1e-5);
    EXPECT_NEAR(q[2], p.z(), 1e-5);
  }
}

TEST(StereoCameraModel, EveryPixelOfAPlaneReprojectsToItsDepth) {
  const StereoCameraModel m = makeModel();
  cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(20.0f));  // Z = 60 / 20 = 3 m everywhere
  std::vector<Eigen::Vector3f> points;
  reprojectDisparity(disparity, m, 0.0, std::numeric_limits<double>::infinity(), 1, &points);
  ASSERT_EQ(points.size(), 640u * 480u);
  for (const auto& p : points)
    ASSERT_NEAR(p.z(), 3.0f, 1e-5f);
  // First pixel (0, 0), last pixel (639, 479).
  EXPECT_NEAR(points.front().x(), (0 - 320.0) * 3.0 / 500.0, 1e-5);
  EXPECT_NEAR(points.front().y(), (0 - 240.0) * 3.0 / 480.0, 1e-5);
  EXPECT_NEAR(points.back().x(), (639 - 320.0) * 3.0 / 500.0, 1e-5);
  EXPECT_NEAR(points.back().y(), (479 - 240.0) * 3.0 / 480.0, 1e-5);
}

TEST(StereoCameraModel, InvalidDisparitiesAreSkipped) {
  const StereoCameraModel m = makeModel();
  cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(0.0f));
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  disparity.at<float>(10, 10) = -1.0f;
  disparity.at<float>(10, 11) = nan;
  disparity.at<float>(10, 12) = inf;
  disparity.at<float>(10, 13) = -inf;
  disparity.at<float>(10, 14) = 30.0f;  // the only valid one
  std::vector<Eigen::Vector3f> points;
  reprojectDisparity(disparity, m, 0.0, 100.0, 1, &points);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_NEAR(points[0].z(), 2.0f, 1e-5f);

  cv::Mat xyz;
  reprojectDisparityOrganized(disparity, m, 100.0, &xyz);
  int finite = 0;
  for (int y = 0; y < xyz.rows; ++y) {
    for (int x = 0; x < xyz.cols; ++x) {
      const cv::Vec3f q = xyz.at<cv::Vec3f>(y, x);
      const bool all_finite = std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]);
      const bool all_nan = std::isnan(q[0]) && std::isnan(q[1]) && std::isnan(q[2]);
      ASSERT_TRUE(all_finite || all_nan);
      finite += all_finite;
    }
  }
  EXPECT_EQ(finite, 1);
  EXPECT_TRUE(std::isfinite(xyz.at<cv::Vec3f>(10, 14)[2]));
}

TEST(StereoCameraModel, DisparityAtOrBelowThePrincipalPointOffsetIsSkipped) {
  StereoCameraModel m = makeModel();
  m.cx_right = 310.0;  // offset 10 px: d <= 10 is at or beyond infinity
  cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(0.0f));
  disparity.at<float>(5, 5) = 10.0f;
  disparity.at<float>(5, 6) = 5.0f;
  disparity.at<float>(5, 7) = 40.0f;  // Z = 60 / 30 = 2 m
  std::vector<Eigen::Vector3f> points;
  reprojectDisparity(disparity, m, 0.0, 1e9, 1, &points);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_NEAR(points[0].z(), 2.0f, 1e-5f);
}

TEST(StereoCameraModel, DepthLimitsAreInclusiveAndApplied) {
  const StereoCameraModel m = makeModel();
  cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(0.0f));
  disparity.at<float>(0, 0) = 60.0f;  // 1 m
  disparity.at<float>(0, 1) = 30.0f;  // 2 m
  disparity.at<float>(0, 2) = 15.0f;  // 4 m
  disparity.at<float>(0, 3) = 12.0f;  // 5 m
  std::vector<Eigen::Vector3f> points;
  reprojectDisparity(disparity, m, 2.0, 4.0, 1, &points);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_NEAR(points[0].z(), 2.0f, 1e-5f);
  EXPECT_NEAR(points[1].z(), 4.0f, 1e-5f);

  cv::Mat xyz;
  reprojectDisparityOrganized(disparity, m, 4.0, &xyz);
  EXPECT_NEAR(xyz.at<cv::Vec3f>(0, 0)[2], 1.0f, 1e-5f);  // no minimum depth here
  EXPECT_NEAR(xyz.at<cv::Vec3f>(0, 2)[2], 4.0f, 1e-5f);
  EXPECT_TRUE(std::isnan(xyz.at<cv::Vec3f>(0, 3)[2]));
}

TEST(StereoCameraModel, StepSubsamplesRowsAndColumns) {
  const StereoCameraModel m = makeModel();
  cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(20.0f));
  disparity.at<float>(4, 8) = 40.0f;  // on the step-4 grid
  disparity.at<float>(5, 8) = 0.0f;   // off the grid: ignored either way
  std::vector<Eigen::Vector3f> points;
  reprojectDisparity(disparity, m, 0.0, 100.0, 4, &points);
  ASSERT_EQ(points.size(), 160u * 120u);
  int near_points = 0;
  for (const auto& p : points)
    near_points += std::fabs(p.z() - 1.5f) < 1e-5f;
  EXPECT_EQ(near_points, 1);
  reprojectDisparity(disparity, m, 0.0, 100.0, 3, &points);
  EXPECT_EQ(points.size(), 160u * 214u);  // ceil(480 / 3) x ceil(640 / 3)
}

TEST(StereoCameraModel, OutputIsReusedWithoutReallocation) {
  const StereoCameraModel m = makeModel();
  cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(20.0f));
  std::vector<Eigen::Vector3f> points;
  reprojectDisparity(disparity, m, 0.0, 100.0, 1, &points);
  const Eigen::Vector3f* data = points.data();
  const std::size_t capacity = points.capacity();
  disparity(cv::Rect(0, 0, 320, 480)).setTo(0.0f);
  reprojectDisparity(disparity, m, 0.0, 100.0, 1, &points);
  EXPECT_EQ(points.size(), 320u * 480u);  // cleared, not appended
  EXPECT_EQ(points.data(), data);
  EXPECT_EQ(points.capacity(), capacity);

  cv::Mat xyz;
  reprojectDisparityOrganized(disparity, m, 100.0, &xyz);
  const uchar* xyz_data = xyz.data;
  reprojectDisparityOrganized(disparity, m, 100.0, &xyz);
  EXPECT_EQ(xyz.data, xyz_data);
}

TEST(StereoCameraModel, BadInputProducesNoPointsAndNoCrash) {
  const StereoCameraModel good = makeModel();
  StereoCameraModel bad = good;
  bad.baseline = 0.0;
  const cv::Mat disparity(480, 640, CV_32FC1, cv::Scalar(20.0f));
  std::vector<Eigen::Vector3f> points(5);

  reprojectDisparity(disparity, bad, 0.0, 100.0, 1, &points);
  EXPECT_TRUE(points.empty());
  reprojectDisparity(cv::Mat(), good, 0.0, 100.0, 1, &points);
  EXPECT_TRUE(points.empty());
  reprojectDisparity(cv::Mat(480, 640, CV_16SC1, cv::Scalar(320)), good, 0.0, 100.0, 1, &points);
  EXPECT_TRUE(points.empty());
  reprojectDisparity(cv::Mat(240, 320, CV_32FC1, cv::Scalar(20.0f)), good, 0.0, 100.0, 1,
                     &points);  // model is for another resolution
  EXPECT_TRUE(points.empty());
  reprojectDisparity(disparity, good, 0.0, 100.0, 0, &points);
  EXPECT_TRUE(points.empty());
  reprojectDisparity(disparity, good, 0.0, std::numeric_limits<double>::quiet_NaN(), 1, &points);
  EXPECT_TRUE(points.empty());
  reprojectDisparity(disparity, good, 0.0, 100.0, 1, nullptr);  // must not crash

  cv::Mat xyz(2, 2, CV_32FC3);
  reprojectDisparityOrganized(disparity, bad, 100.0, &xyz);
  EXPECT_TRUE(xyz.empty());
  xyz.create(2, 2, CV_32FC3);
  reprojectDisparityOrganized(cv::Mat(480, 640, CV_32FC2), good, 100.0, &xyz);
  EXPECT_TRUE(xyz.empty());
  reprojectDisparityOrganized(disparity, good, 100.0, nullptr);
}

}  // namespace
}  // namespace stereo_safety_map
