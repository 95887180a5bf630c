// Row gap fill (disparity_gap_fill.h): rows whose answer is known by construction.
#include "stereo_safety_map/core/disparity_gap_fill.h"

#include <gtest/gtest.h>

#include <limits>

namespace stereo_safety_map {
namespace {

StereoCameraModel camera() {
  StereoCameraModel c;
  c.width = 200;
  c.height = 4;
  c.fx = c.fy = 500.0;
  c.cx = c.cx_right = 100.0;
  c.cy = 2.0;
  c.baseline = 0.1;  // lateral width of g px at disparity d: g * 0.1 / d [m]
  return c;
}

RowGapFillConfig on(double max_width = 0.4, double max_step = 0.25) {
  RowGapFillConfig c;
  c.enabled = true;
  c.max_width = max_width;
  c.max_step = max_step;
  return c;
}

// One row: `d` on [x0, x1] (inclusive), 0 elsewhere.
void run(cv::Mat* m, int x0, int x1, float d, int y = 0) {
  for (int x = x0; x <= x1; ++x)
    m->at<float>(y, x) = d;
}

TEST(RowGapFill, FillsTheGapBetweenTwoAgreeingRunsLinearly) {
  cv::Mat m(4, 200, CV_32FC1, cv::Scalar(0));
  run(&m, 10, 14, 20.0f);
  run(&m, 45, 50, 20.2f);  // 30 px at d = 20: 0.15 m wide
  EXPECT_EQ(fillRowGaps(on(), camera(), &m), 30);
  EXPECT_FLOAT_EQ(m.at<float>(0, 15), 20.0f + 0.2f / 31.0f);
  EXPECT_NEAR(m.at<float>(0, 30), 20.0f + 0.2f * 16.0f / 31.0f, 1e-5);
  EXPECT_EQ(m.at<float>(0, 9), 0.0f);  // nothing outside the two runs
  EXPECT_EQ(m.at<float>(0, 51), 0.0f);
  EXPECT_EQ(m.at<float>(1, 30), 0.0f);  // other rows untouched
}

TEST(RowGapFill, OffChangesNothing) {
  cv::Mat m(4, 200, CV_32FC1, cv::Scalar(0));
  run(&m, 10, 14, 20.0f);
  run(&m, 45, 50, 20.0f);
  const cv::Mat before = m.clone();
  RowGapFillConfig off = on();
  off.enabled = false;
  EXPECT_EQ(fillRowGaps(off, camera(), &m), 0);
  EXPECT_EQ(cv::countNonZero(m != before), 0);
}

TEST(RowGapFill, ADepthStepAcrossTheRowIsNotBridged) {
  // Upper and lower floor of a drop-off seen on one row: 0.5 px apart.
  cv::Mat m(4, 200, CV_32FC1, cv::Scalar(0));
  run(&m, 10, 14, 20.0f);
  run(&m, 45, 50, 19.5f);
  EXPECT_EQ(fillRowGaps(on(), camera(), &m), 0);
  EXPECT_EQ(m.at<float>(0, 30), 0.0f);
}

TEST(RowGapFill, AnObstacleBetweenFloorRunsKeepsItsOwnDisparity) {
  // Floor | pole edge ... pole edge | floor: only the pole's inside is filled, at the pole's
  // disparity; the floor never reaches across the pole's edges.
  cv::Mat m(4, 200, CV_32FC1, cv::Scalar(0));
  run(&m, 10, 14, 20.0f);
  run(&m, 30, 33, 40.0f);
  run(&m, 50, 53, 40.0f);
  run(&m, 70, 75, 20.0f);
  EXPECT_EQ(fillRowGaps(on(), camera(), &m), 16);
  for (int x = 15; x < 30; ++x)
    EXPECT_EQ(m.at<float>(0, x), 0.0f) << x;
  for (int x = 34; x < 50; ++x)
    EXPECT_FLOAT_EQ(m.at<float>(0, x), 40.0f) << x;
  for (int x = 54; x < 70; ++x)
    EXPECT_EQ(m.at<float>(0, x), 0.0f) << x;
}

TEST(RowGapFill, ALoneValidPixelAnchorsNothing) {
  // A single survivor of the filters (no agreeing neighbour) neither starts nor ends a fill.
  cv::Mat m(4, 200, CV_32FC1, cv::Scalar(0));
  run(&m, 10, 14, 20.0f);
  m.at<float>(0, 30) = 20.0f;
  run(&m, 50, 55, 20.0f);
  m.at<float>(0, 80) = 20.0f;
  m.at<float>(0, 81) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(fillRowGaps(on(), camera(), &m), 0);
  EXPECT_EQ(m.at<float>(0, 20), 0.0f);
  EXPECT_EQ(m.at<float>(0, 40), 0.0f);
  EXPECT_EQ(m.at<float>(0, 70), 0.0f);
}

TEST(RowGapFill, TheWidestGapIsMetresAtItsDepth) {
  // max_width 0.4 m: at d = 20 (Z = 2.5 m) at most 80 px, at d = 10 (Z = 5 m) at most 40 px.
  cv::Mat near(4, 200, CV_32FC1, cv::Scalar(0));
  run(&near, 0, 4, 20.0f);
  run(&near, 85, 90, 20.0f);  // 80 px
  EXPECT_EQ(fillRowGaps(on(), camera(), &near), 80);
  cv::Mat far(4, 200, CV_32FC1, cv::Scalar(0));
  run(&far, 0, 4, 10.0f);
  run(&far, 85, 90, 10.0f);  // 80 px at d = 10: 0.8 m
  EXPECT_EQ(fillRowGaps(on(), camera(), &far), 0);
  run(&far, 0, 4, 10.0f, 1);
  run(&far, 45, 50, 10.0f, 1);  // 40 px at d = 10: 0.4 m
  EXPECT_EQ(fillRowGaps(on(), camera(), &far), 40);
}

TEST(RowGapFill, NothingIsFilledUnderSomethingNearer) {
  // Row 0: a table top's edge at d = 30 over columns 20..40; row 2: the floor under it at d = 20
  // with a gap over columns 15..44. The floor in row 3 has its gap where nothing nearer is above.
  cv::Mat m(4, 200, CV_32FC1, cv::Scalar(0));
  run(&m, 20, 40, 30.0f, 0);
  run(&m, 10, 14, 20.0f, 2);
  run(&m, 45, 50, 20.0f, 2);
  run(&m, 60, 64, 20.0f, 3);
  run(&m, 90, 95, 20.0f, 3);
  EXPECT_EQ(fillRowGaps(on(), camera(), &m), 25);
  EXPECT_EQ(m.at<float>(2, 30), 0.0f);
  EXPECT_FLOAT_EQ(m.at<float>(3, 80), 20.0f);
  // Something farther above (the floor beyond, a wall behind) does not stop the fill.
  cv::Mat f(4, 200, CV_32FC1, cv::Scalar(0));
  run(&f, 20, 40, 10.0f, 0);
  run(&f, 10, 14, 20.0f, 2);
  run(&f, 45, 50, 20.0f, 2);
  EXPECT_EQ(fillRowGaps(on(), camera(), &f), 30);
}

TEST(RowGapFill, ValidateNamesTheParameter) {
  EXPECT_TRUE(on().validate().empty());
  EXPECT_NE(on(0.0).validate().find("row_gap_fill_max_width"), std::string::npos);
  EXPECT_NE(on(0.4, 5.0).validate().find("row_gap_fill_max_step"), std::string::npos);
}

}  // namespace
}  // namespace stereo_safety_map
