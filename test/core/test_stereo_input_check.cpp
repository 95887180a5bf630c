// StereoInputCheck on pairs built by hand: textured, black, saturated, covered-but-noisy, frozen
// on one side or both, and strided views.
#include "stereo_safety_map/core/stereo_input_check.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include <random>
#include <string>

namespace stereo_safety_map {
namespace {

using P = StereoInputProblem;

cv::Mat textured(unsigned seed, int rows = 48, int cols = 64) {
  cv::Mat m(rows, cols, CV_8UC1);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> d(0, 255);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      m.at<std::uint8_t>(r, c) = static_cast<std::uint8_t>(d(rng));
  return m;
}

// A covered lens: dark, with a little sensor noise (std dev about 0.5 grey levels).
cv::Mat covered(unsigned seed) {
  cv::Mat m(48, 64, CV_8UC1);
  std::mt19937 rng(seed);
  std::bernoulli_distribution one(0.3);
  for (int r = 0; r < m.rows; ++r)
    for (int c = 0; c < m.cols; ++c)
      m.at<std::uint8_t>(r, c) = one(rng) ? 4 : 3;
  return m;
}

TEST(StereoInputCheck, ConfigValidate) {
  StereoInputCheckConfig c;
  EXPECT_EQ(c.validate(), "");
  EXPECT_DOUBLE_EQ(c.min_contrast, 2.0);
  EXPECT_TRUE(c.reject_frozen);
  c.min_contrast = -1.0;
  EXPECT_NE(c.validate().find("min_contrast"), std::string::npos);
  EXPECT_THROW(StereoInputCheck{c}, std::invalid_argument);
  c.min_contrast = std::nan("");
  EXPECT_NE(c.validate(), "");
}

TEST(StereoInputCheck, LiveTexturedPairsPass) {
  StereoInputCheck check;
  for (unsigned k = 0; k < 5; ++k) {
    std::string detail = "x";
    EXPECT_EQ(check.check(textured(2 * k), textured(2 * k + 1), &detail), P::kNone);
    EXPECT_EQ(detail, "");
  }
  EXPECT_GT(check.lastLeftContrast(), 50.0);
}

TEST(StereoInputCheck, BlackSaturatedOrCoveredImagesHaveNoContrast) {
  StereoInputCheck check;
  std::string detail;
  EXPECT_EQ(check.check(cv::Mat::zeros(48, 64, CV_8UC1), textured(1), &detail), P::kLeftNoContrast);
  EXPECT_NE(detail.find("left image has no contrast"), std::string::npos) << detail;
  EXPECT_EQ(check.check(textured(2), cv::Mat(48, 64, CV_8UC1, cv::Scalar(255)), &detail),
            P::kRightNoContrast);
  EXPECT_NE(detail.find("right"), std::string::npos) << detail;
  EXPECT_EQ(check.check(covered(3), textured(4)), P::kLeftNoContrast);
  EXPECT_LT(check.lastLeftContrast(), 1.0);
  // Off: passes (a noisy dark image is not a repeated one either).
  StereoInputCheckConfig off;
  off.min_contrast = 0.0;
  StereoInputCheck lenient(off);
  EXPECT_EQ(lenient.check(covered(5), textured(6)), P::kNone);
}

TEST(StereoInputCheck, FrozenCamerasAreNamed) {
  StereoInputCheck check;
  const cv::Mat l0 = textured(10), r0 = textured(11);
  EXPECT_EQ(check.check(l0, r0), P::kNone);  // nothing to compare with yet
  std::string detail;
  EXPECT_EQ(check.check(l0.clone(), textured(12), &detail), P::kLeftFrozen);
  EXPECT_NE(detail.find("left camera frozen"), std::string::npos) << detail;
  EXPECT_EQ(check.check(textured(13), textured(12), &detail), P::kRightFrozen);
  EXPECT_NE(detail.find("right camera frozen"), std::string::npos) << detail;
  EXPECT_EQ(check.check(textured(13), textured(12), &detail), P::kBothFrozen);
  EXPECT_NE(detail.find("reject_frozen_images"), std::string::npos) << detail;
  // One pixel changed is a live camera.
  cv::Mat l = textured(13);
  l.at<std::uint8_t>(20, 30) ^= 1;
  EXPECT_EQ(check.check(l, textured(14)), P::kNone);
  // After reset() the next pair has nothing to repeat.
  check.reset();
  EXPECT_EQ(check.check(l, textured(14)), P::kNone);

  StereoInputCheckConfig c;
  c.reject_frozen = false;
  StereoInputCheck sim(c);
  EXPECT_EQ(sim.check(l0, r0), P::kNone);
  EXPECT_EQ(sim.check(l0, r0), P::kNone);
}

TEST(StereoInputCheck, StridedViewsAreComparedByContent) {
  StereoInputCheck check;
  const cv::Mat big_l = textured(20, 60, 80), big_r = textured(21, 60, 80);
  const cv::Rect roi(5, 4, 64, 48);
  EXPECT_EQ(check.check(big_l(roi), big_r(roi)), P::kNone);
  // The same content in continuous copies is the same frame.
  EXPECT_EQ(check.check(big_l(roi).clone(), textured(22)), P::kLeftFrozen);
}

TEST(StereoInputCheck, BadImagesAreRefusedWithoutCrashing) {
  StereoInputCheck check;
  std::string detail;
  EXPECT_EQ(check.check(cv::Mat(), textured(1), &detail), P::kBadImage);
  EXPECT_FALSE(detail.empty());
  EXPECT_EQ(check.check(textured(1), textured(2, 40, 64)), P::kBadImage);
  EXPECT_EQ(check.check(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(9)), textured(2)), P::kBadImage);
  EXPECT_EQ(check.check(textured(3), textured(4)), P::kNone);
}

}  // namespace
}  // namespace stereo_safety_map
