// Every CameraInfo <-> camera model conversion in one place (conversions.h): toCameraInfo and
// cameraModelFromCameraInfo are inverses, and the disparity message's geometry read back by
// cameraModelForDisparity is the core's messageCameraModel (what the offline path reprojects
// with), so that the nodelets and the offline evaluation see the same camera bit for bit.
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/ros/conversions.h"

#include <gtest/gtest.h>
#include <stereo_msgs/DisparityImage.h>

#include <cstring>

namespace stereo_safety_map {
namespace {

StereoCameraModel oddCamera() {
  StereoCameraModel m;
  m.fx = 554.2562584220407;  // not exact in float32
  m.fy = 554.2562584220407;
  m.cx = 319.5;
  m.cy = 239.5;
  m.cx_right = 317.25;  // principal points apart: the message removes the offset
  m.baseline = 0.1197;
  m.width = 640;
  m.height = 480;
  return m;
}

TEST(CameraInfo, ToCameraInfoAndBackIsTheSameModel) {
  const StereoCameraModel m = oddCamera();
  std_msgs::Header h;
  h.frame_id = "optical";
  const sensor_msgs::CameraInfo l = toCameraInfo(m, false, h), r = toCameraInfo(m, true, h);
  EXPECT_EQ(l.header.frame_id, "optical");
  EXPECT_DOUBLE_EQ(r.P[3], -m.fx * m.baseline);
  EXPECT_DOUBLE_EQ(l.P[3], 0.0);
  StereoCameraModel back;
  ASSERT_EQ(cameraModelFromCameraInfo(l, r, &back), "");
  EXPECT_DOUBLE_EQ(back.fx, m.fx);
  EXPECT_DOUBLE_EQ(back.fy, m.fy);
  EXPECT_DOUBLE_EQ(back.cx, m.cx);
  EXPECT_DOUBLE_EQ(back.cy, m.cy);
  EXPECT_DOUBLE_EQ(back.cx_right, m.cx_right);
  EXPECT_NEAR(back.baseline, m.baseline, 1e-15);
  EXPECT_EQ(back.width, m.width);
  EXPECT_EQ(back.height, m.height);
}

TEST(CameraInfo, DisparityMessageGeometryIsWhatTheSafetyMapReadsBack) {
  const StereoCameraModel m = oddCamera();
  const DisparityMessageGeometry g = disparityMessageGeometry(m, 0, 64);
  EXPECT_FLOAT_EQ(g.offset, 2.25f);
  // The message as the disparity nodelet fills it.
  stereo_msgs::DisparityImage msg;
  msg.f = g.f;
  msg.T = g.T;
  msg.min_disparity = g.min_disparity;
  msg.max_disparity = g.max_disparity;
  msg.image.width = 4;
  msg.image.height = 1;
  msg.image.encoding = "32FC1";
  msg.image.step = 16;
  const float matcher[4] = {0.0f, 2.0f, 30.5f, 63.9375f};  // invalid, below the offset, valid, top
  float values[4];
  for (int i = 0; i < 4; ++i)
    values[i] = g.toMessage(matcher[i]);
  msg.image.data.resize(16);
  std::memcpy(msg.image.data.data(), values, 16);
  StereoCameraModel left = m;
  left.width = 4;
  left.height = 1;
  left.cx = 1.5;  // keep the principal point inside the tiny image
  const sensor_msgs::CameraInfo info = toCameraInfo(left, false);
  StereoCameraModel read;
  ASSERT_EQ(cameraModelForDisparity(msg, info, &read), "");
  const StereoCameraModel expected = messageCameraModel(g, left);
  EXPECT_EQ(read.fx, expected.fx);
  EXPECT_EQ(read.fy, expected.fy);
  EXPECT_EQ(read.cx, expected.cx);
  EXPECT_EQ(read.cx_right, expected.cx_right);
  EXPECT_EQ(read.cy, expected.cy);
  EXPECT_EQ(read.baseline, expected.baseline);
  cv::Mat mat;
  ASSERT_EQ(disparityImageToMat(msg, &mat), "");
  cv::Mat offline(1, 4, CV_32FC1);
  for (int i = 0; i < 4; ++i)
    offline.at<float>(0, i) = matcher[i];
  throughDisparityMessage(g, &offline);
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(mat.at<float>(0, i), offline.at<float>(0, i)) << i;
  EXPECT_EQ(offline.at<float>(0, 0), 0.0f);
  EXPECT_EQ(offline.at<float>(0, 1), 0.0f);
  EXPECT_EQ(offline.at<float>(0, 2), 30.5f - 2.25f);
  EXPECT_EQ(offline.at<float>(0, 3), 0.0f);  // above max_disparity once the offset is removed
}

}  // namespace
}  // namespace stereo_safety_map
