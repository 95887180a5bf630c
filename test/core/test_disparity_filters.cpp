// Disparity post-filters on hand-built disparity images whose answer is known by construction.
#include "stereo_safety_map/core/disparity_filters.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstring>
#include <limits>

namespace stereo_safety_map {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

cv::Mat randomTexture(int rows, int cols, std::uint64_t seed) {
  cv::Mat t(rows, cols, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(t, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(t, t, cv::Size(), 1.0);
  return t;
}

int countWhere(const cv::Mat& d, cv::Rect roi, bool valid) {
  int n = 0;
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    for (int x = roi.x; x < roi.x + roi.width; ++x) {
      n += isValidDisparity(d.at<float>(y, x)) == valid;
    }
  }
  return n;
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  // Bitwise, so that NaN == NaN.
  return a.size() == b.size() && a.type() == b.type() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

// ------------------------------------------------------------------------------------------------
TEST(DisparityConvention, ValidityAndSanitizing) {
  EXPECT_TRUE(isValidDisparity(0.5f));
  EXPECT_FALSE(isValidDisparity(0.0f));
  EXPECT_FALSE(isValidDisparity(-2.0f));
  EXPECT_FALSE(isValidDisparity(kNaN));
  EXPECT_FALSE(isValidDisparity(kInf));

  cv::Mat d(2, 3, CV_32FC1);
  d.at<float>(0, 0) = 4.0f;
  d.at<float>(0, 1) = 0.0f;
  d.at<float>(0, 2) = -1.0f;
  d.at<float>(1, 0) = kNaN;
  d.at<float>(1, 1) = kInf;
  d.at<float>(1, 2) = 0.25f;
  EXPECT_EQ(countValidDisparities(d), 2);
  EXPECT_EQ(sanitizeDisparity(&d), 3);  // -1, NaN, inf; the 0 was already canonical
  EXPECT_EQ(d.at<float>(0, 2), kInvalidDisparity);
  EXPECT_EQ(d.at<float>(1, 0), kInvalidDisparity);
  EXPECT_EQ(d.at<float>(1, 1), kInvalidDisparity);
  EXPECT_EQ(d.at<float>(0, 0), 4.0f);
  EXPECT_EQ(countValidDisparities(d), 2);

  cv::Mat wrong(2, 2, CV_16SC1);
  EXPECT_EQ(sanitizeDisparity(&wrong), -1);
  EXPECT_EQ(sanitizeDisparity(nullptr), -1);
  EXPECT_EQ(countValidDisparities(cv::Mat()), -1);
}

// ------------------------------------------------------------------------------------------------
// Left half random texture, right half flat grey: only the flat half lacks texture.
TEST(TextureValidation, RemovesTexturelessKeepsTextured) {
  cv::Mat left = randomTexture(100, 200, 1);
  left.colRange(100, 200).setTo(128);
  cv::Mat disparity(100, 200, CV_32FC1, cv::Scalar(10.0f));
  disparity.at<float>(50, 150) = 0.0f;  // already invalid: neither counted nor touched
  disparity.at<float>(50, 151) = kNaN;

  const TextureValidationConfig config;
  ASSERT_EQ(config.validate(), "");
  DisparityFilterWorkspace ws;
  const int removed = filterLowTexture(left, config, &disparity, &ws);

  // The LoG (sigma 1, support ~4 px) plus the 9x9 window reach ~9 px past the texture edge.
  const cv::Rect flat(112, 0, 88, 100), textured(0, 0, 88, 100);
  EXPECT_EQ(countWhere(disparity, flat, true), 0);
  EXPECT_EQ(countWhere(disparity, textured, false), 0);
  EXPECT_EQ(removed, 100 * 200 - countValidDisparities(disparity) - 2);
  EXPECT_GE(removed, 88 * 100 - 2);
  EXPECT_TRUE(std::isnan(disparity.at<float>(50, 151)));
  EXPECT_FLOAT_EQ(disparity.at<float>(10, 10), 10.0f);  // survivors keep their value
}

TEST(TextureValidation, ThresholdSeparatesSensorNoiseFromTexture) {
  // Sensor-like noise of 1 grey level std on a flat wall is not texture.
  cv::Mat noise(100, 100, CV_32FC1);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::NORMAL, 128.0, 1.0);
  cv::Mat noisy;
  noise.convertTo(noisy, CV_8UC1);
  cv::Mat disparity(100, 100, CV_32FC1, cv::Scalar(10.0f));
  EXPECT_EQ(filterLowTexture(noisy, TextureValidationConfig(), &disparity), 100 * 100);

  TextureValidationConfig off;
  off.min_energy = 0.0;
  disparity.setTo(10.0f);
  EXPECT_EQ(filterLowTexture(noisy, off, &disparity), 0);
}

TEST(TextureValidation, BadInputReturnsMinusOneAndLeavesDisparity) {
  const cv::Mat left = randomTexture(50, 60, 2);
  cv::Mat disparity(50, 60, CV_32FC1, cv::Scalar(3.0f));
  const cv::Mat before = disparity.clone();
  const TextureValidationConfig good;
  TextureValidationConfig bad;
  bad.window_size = 4;
  EXPECT_NE(bad.validate().find("window_size"), std::string::npos);

  EXPECT_EQ(filterLowTexture(left, bad, &disparity), -1);
  EXPECT_EQ(filterLowTexture(left.rowRange(0, 40), good, &disparity), -1);
  EXPECT_EQ(filterLowTexture(cv::Mat(50, 60, CV_8UC3), good, &disparity), -1);
  EXPECT_EQ(filterLowTexture(cv::Mat(), good, &disparity), -1);
  EXPECT_EQ(filterLowTexture(left, good, nullptr), -1);
  cv::Mat wrong_type(50, 60, CV_64FC1, cv::Scalar(3.0));
  EXPECT_EQ(filterLowTexture(left, good, &wrong_type), -1);
  EXPECT_TRUE(identical(disparity, before));

  TextureValidationConfig sigma;
  sigma.log_sigma = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(sigma.validate().find("log_sigma"), std::string::npos);
  TextureValidationConfig energy;
  energy.min_energy = -1.0;
  EXPECT_NE(energy.validate().find("min_energy"), std::string::npos);
}

// The texture energy of our own code (AVX2 + FMA CPUs, Gaussians of 7 taps or more) must be
// OpenCV's GaussianBlur + Laplacian + boxFilter bit for bit, so that the texture test keeps every
// decision (issue 18). Sizes (odd, narrower than a vector, one row / column), sigmas on both sides
// of the 7-tap switch, window sizes; textured, blurred, flat and saturated images.
TEST(TextureValidation, EnergyIsOpenCvsBitForBit) {
  cv::RNG rng(18);
  DisparityFilterWorkspace ws, opencv_ws;
  int compared = 0;
  for (int i = 0; i < 80; ++i) {
    const int rows = i < 2 ? 1 + i : 1 + rng.uniform(0, 90);
    const int cols = i == 2 || i == 3 ? i - 1 : 1 + rng.uniform(0, 170);
    cv::Mat left(rows, cols, CV_8UC1);
    rng.fill(left, cv::RNG::UNIFORM, 0, 256);
    if (i % 3 == 1) cv::GaussianBlur(left, left, cv::Size(), 2.0);
    if (i % 7 == 2) left.rowRange(0, rows / 2).setTo(i % 2 == 0 ? 0 : 255);
    TextureValidationConfig config;
    config.log_sigma = i < 10 ? 1.0 : rng.uniform(0.3, 4.0);
    config.window_size = i < 10 ? 9 : 1 + 2 * rng.uniform(0, 10);
    ASSERT_EQ(config.validate(), "");
    cv::Mat ours, opencv;
    ASSERT_TRUE(textureEnergy(left, config, &ours, &ws));
    ASSERT_TRUE(textureEnergy(left, config, &opencv, &opencv_ws, true));
    ASSERT_EQ(ours.type(), CV_32FC1);
    EXPECT_TRUE(identical(ours, opencv))
        << "case " << i << ": " << cols << "x" << rows << ", sigma " << config.log_sigma
        << ", window " << config.window_size;
    ++compared;
  }
  EXPECT_EQ(compared, 80);
  // The frame size of the pipeline, twice through the same workspace: no reallocation.
  const cv::Mat frame = randomTexture(480, 640, 5);
  cv::Mat ours, opencv;
  const TextureValidationConfig config;
  ASSERT_TRUE(textureEnergy(frame, config, &ours, &ws));
  const void* blurred = ws.texture_blurred.data();
  ASSERT_TRUE(textureEnergy(frame, config, &ours, &ws));
  EXPECT_EQ(ws.texture_blurred.data(), blurred);
  ASSERT_TRUE(textureEnergy(frame, config, &opencv, nullptr, true));
  EXPECT_TRUE(identical(ours, opencv));
  EXPECT_FALSE(textureEnergy(cv::Mat(), config, &ours));
  EXPECT_FALSE(textureEnergy(cv::Mat(5, 5, CV_8UC3), config, &ours));
}

// ------------------------------------------------------------------------------------------------
// Cost volume 1 x 4 pixels x 8 disparities (min_disparity 2 -> slice k is disparity k + 2).
cv::Mat costVolume(int cols, int num_disp, float fill) {
  const int sizes[3] = {1, cols, num_disp};
  return cv::Mat(3, sizes, CV_32FC1, cv::Scalar(fill));
}

TEST(MatchUniqueness, RatioTestOnCostVolume) {
  cv::Mat cost = costVolume(4, 8, 100.0f);
  float* c0 = cost.ptr<float>(0, 0);
  c0[3] = 10.0f;  // unique winner at disparity 5
  float* c1 = cost.ptr<float>(0, 1);
  c1[3] = 10.0f;
  c1[6] = 11.0f;  // runner-up only 10 % worse, 3 slices away: ambiguous
  float* c2 = cost.ptr<float>(0, 2);
  c2[3] = 10.0f;
  c2[4] = 10.5f;  // runner-up is the sub-pixel neighbour: does not count
  float* c3 = cost.ptr<float>(0, 3);
  c3[3] = 10.0f;
  c3[0] = 11.6f;  // 16 % worse: unique at 15 %

  cv::Mat disparity(1, 4, CV_32FC1, cv::Scalar(5.0f));
  MatchUniquenessConfig config;
  config.uniqueness_ratio = 15;
  EXPECT_EQ(filterNonUniqueMatches(cost, 2, config, &disparity), 1);
  EXPECT_EQ(disparity.at<float>(0, 0), 5.0f);
  EXPECT_EQ(disparity.at<float>(0, 1), kInvalidDisparity);
  EXPECT_EQ(disparity.at<float>(0, 2), 5.0f);
  EXPECT_EQ(disparity.at<float>(0, 3), 5.0f);

  // A stricter ratio also rejects the 16 % case.
  config.uniqueness_ratio = 20;
  disparity.setTo(5.0f);
  EXPECT_EQ(filterNonUniqueMatches(cost, 2, config, &disparity), 2);
  EXPECT_EQ(disparity.at<float>(0, 3), kInvalidDisparity);
}

TEST(MatchUniqueness, NormalizedScoreTestAndOutOfRangeDisparities) {
  cv::Mat cost = costVolume(3, 8, 10.0f);
  cost.ptr<float>(0, 0)[3] = 1.0f;  // 1 / 71 = 0.014
  // Pixel 1: flat costs, 10 / 80 = 0.125.
  cv::Mat disparity(1, 3, CV_32FC1, cv::Scalar(5.0f));
  disparity.at<float>(0, 2) = 12.0f;  // slice 10 does not exist in an 8-slice volume
  MatchUniquenessConfig config;
  config.uniqueness_ratio = 0;
  config.max_normalized_cost = 0.05;
  EXPECT_EQ(filterNonUniqueMatches(cost, 2, config, &disparity), 2);
  EXPECT_EQ(disparity.at<float>(0, 0), 5.0f);
  EXPECT_EQ(disparity.at<float>(0, 1), kInvalidDisparity);
  EXPECT_EQ(disparity.at<float>(0, 2), kInvalidDisparity);
}

TEST(MatchUniqueness, BadInput) {
  cv::Mat disparity(1, 4, CV_32FC1, cv::Scalar(5.0f));
  const MatchUniquenessConfig config;
  EXPECT_EQ(filterNonUniqueMatches(costVolume(3, 8, 1.0f), 2, config, &disparity), -1);
  EXPECT_EQ(filterNonUniqueMatches(cv::Mat(1, 4, CV_32FC1), 2, config, &disparity), -1);
  EXPECT_EQ(filterNonUniqueMatches(costVolume(4, 8, 1.0f), 2, config, nullptr), -1);
  MatchUniquenessConfig bad;
  bad.uniqueness_ratio = 101;
  EXPECT_NE(bad.validate().find("uniqueness_ratio"), std::string::npos);
  EXPECT_EQ(filterNonUniqueMatches(costVolume(4, 8, 1.0f), 2, bad, &disparity), -1);
  bad = MatchUniquenessConfig();
  bad.max_normalized_cost = 2.0;
  EXPECT_NE(bad.validate().find("max_normalized_cost"), std::string::npos);
  EXPECT_EQ(countValidDisparities(disparity), 4);
}

// ------------------------------------------------------------------------------------------------
// One scanline world: background at disparity 10, a box at disparity 30 covering left columns
// [100, 140). The right camera sees the box at [70, 110); left columns [80, 100) are background
// hidden from the right camera (occluded), where a matcher returns garbage (here 20).
TEST(LeftRightCheck, RemovesOccludedMismatchesKeepsConsistentPixels) {
  const int rows = 5, cols = 200;
  cv::Mat left(rows, cols, CV_32FC1, cv::Scalar(10.0f));
  left.colRange(0, 10).setTo(0.0f);  // no match possible left of the disparity range
  left.colRange(100, 140).setTo(30.0f);
  left.colRange(80, 100).setTo(20.0f);
  cv::Mat right(rows, cols, CV_32FC1, cv::Scalar(10.0f));
  right.colRange(70, 110).setTo(30.0f);
  right.colRange(190, 200).setTo(0.0f);  // their left match would lie outside the left image
  const int valid_before = countValidDisparities(left);

  const LeftRightCheckConfig config;
  EXPECT_EQ(filterLeftRightInconsistent(right, config, &left), rows * 20);
  EXPECT_EQ(countWhere(left, cv::Rect(80, 0, 20, rows), true), 0);
  EXPECT_EQ(countValidDisparities(left), valid_before - rows * 20);
  EXPECT_EQ(left.at<float>(2, 120), 30.0f);
  EXPECT_EQ(left.at<float>(2, 50), 10.0f);
  EXPECT_EQ(left.at<float>(2, 150), 10.0f);
}

TEST(LeftRightCheck, ToleranceRightInvalidAndOutsideMatches) {
  cv::Mat right(1, 100, CV_32FC1, cv::Scalar(10.0f));
  right.at<float>(0, 30) = 0.0f;
  cv::Mat left(1, 100, CV_32FC1, cv::Scalar(0.0f));
  left.at<float>(0, 60) = 10.8f;  // x_r = round(49.2) = 49, |10.8 - 10| <= 1: kept
  left.at<float>(0, 61) = 11.5f;  // x_r = round(49.5) = 50, 1.5 > 1: removed
  left.at<float>(0, 40) = 10.0f;  // x_r = 30 has no right disparity
  left.at<float>(0, 5) = 8.0f;    // x_r = -3: outside the right image
  cv::Mat strict = left.clone();

  LeftRightCheckConfig config;
  EXPECT_EQ(filterLeftRightInconsistent(right, config, &strict), 3);
  EXPECT_EQ(strict.at<float>(0, 60), 10.8f);
  EXPECT_EQ(strict.at<float>(0, 61), kInvalidDisparity);
  EXPECT_EQ(strict.at<float>(0, 40), kInvalidDisparity);
  EXPECT_EQ(strict.at<float>(0, 5), kInvalidDisparity);

  config.reject_if_right_invalid = false;
  config.max_difference = 2.0;
  cv::Mat lenient = left.clone();
  EXPECT_EQ(filterLeftRightInconsistent(right, config, &lenient), 1);
  EXPECT_EQ(lenient.at<float>(0, 61), 11.5f);
  EXPECT_EQ(lenient.at<float>(0, 40), 10.0f);
  EXPECT_EQ(lenient.at<float>(0, 5), kInvalidDisparity);
}

// The check runs 8 pixels at a time on AVX2 CPUs: same result as the plain rule on random rows
// (odd widths, both tolerances, invalid / NaN / inf / huge / negative values on both sides).
TEST(LeftRightCheck, MatchesThePlainRuleOnRandomImages) {
  cv::RNG rng(42);
  const float specials[] = {0.0f, -3.0f, kNaN, kInf, 1e30f, 1e-30f, 0.5f};
  for (int i = 0; i < 60; ++i) {
    const int rows = 1 + rng.uniform(0, 20), cols = 1 + rng.uniform(0, 90);
    cv::Mat left(rows, cols, CV_32FC1), right(rows, cols, CV_32FC1);
    for (cv::Mat* m : {&left, &right}) {
      for (int y = 0; y < rows; ++y) {
        for (int x = 0; x < cols; ++x) {
          m->at<float>(y, x) = rng.uniform(0, 6) == 0
                                   ? specials[rng.uniform(0, 7)]
                                   : static_cast<float>(rng.uniform(0, 640)) / 16;
        }
      }
    }
    LeftRightCheckConfig config;
    config.max_difference = i % 3 == 0 ? 0.0 : i % 3 == 1 ? 1.0 : 2.5;
    config.reject_if_right_invalid = i % 2 == 0;
    cv::Mat expected = left.clone();
    int expected_removed = 0;
    for (int y = 0; y < rows; ++y) {
      for (int x = 0; x < cols; ++x) {
        const float d = expected.at<float>(y, x);
        if (!isValidDisparity(d)) continue;
        const float xf = std::floor(static_cast<float>(x) - d + 0.5f);
        bool reject = true;
        if (xf >= 0.0f) {
          const float dr = right.at<float>(y, static_cast<int>(xf));
          reject = isValidDisparity(dr)
                       ? std::fabs(d - dr) > static_cast<float>(config.max_difference)
                       : config.reject_if_right_invalid;
        }
        if (reject) {
          expected.at<float>(y, x) = kInvalidDisparity;
          ++expected_removed;
        }
      }
    }
    cv::Mat actual = left.clone();
    EXPECT_EQ(filterLeftRightInconsistent(right, config, &actual), expected_removed)
        << "case " << i;
    EXPECT_TRUE(identical(actual, expected)) << "case " << i;
  }
}

TEST(LeftRightCheck, BadInput) {
  cv::Mat left(10, 20, CV_32FC1, cv::Scalar(3.0f));
  const LeftRightCheckConfig config;
  EXPECT_EQ(filterLeftRightInconsistent(cv::Mat(10, 21, CV_32FC1), config, &left), -1);
  EXPECT_EQ(filterLeftRightInconsistent(cv::Mat(10, 20, CV_16SC1), config, &left), -1);
  EXPECT_EQ(filterLeftRightInconsistent(cv::Mat(), config, &left), -1);
  EXPECT_EQ(filterLeftRightInconsistent(left.clone(), config, nullptr), -1);
  LeftRightCheckConfig bad;
  bad.max_difference = -1.0;
  EXPECT_NE(bad.validate().find("max_difference"), std::string::npos);
  EXPECT_EQ(filterLeftRightInconsistent(left.clone(), bad, &left), -1);
  EXPECT_EQ(countValidDisparities(left), 200);
}

// ------------------------------------------------------------------------------------------------
// Wall at disparity 5 (rows 0-59) continuing into a floor whose disparity grows 0.2 per row
// (rows 60-119): one large continuous surface.
cv::Mat wallAndFloor() {
  cv::Mat d(120, 160, CV_32FC1);
  for (int y = 0; y < d.rows; ++y) {
    d.row(y).setTo(y < 60 ? 5.0f : 5.0f + 0.2f * static_cast<float>(y - 59));
  }
  return d;
}

float floorDisparity(int y) {
  return 5.0f + 0.2f * static_cast<float>(y - 59);
}

// The tests' 10 x 10 ghost patches are spikes for a threshold above 100 pixels.
SpikeRemovalConfig spikeConfig200() {
  SpikeRemovalConfig c;
  c.min_region_size = 200;
  return c;
}

TEST(SpikeRemoval, KeepsOnePixelPoleJoinedToTheFloorRemovesGhostPatch) {
  cv::Mat d = wallAndFloor();
  // Pole one pixel wide standing on the floor at row 100: rows 30-100 at the floor disparity of
  // its base, far from the wall (5) and from the floor rows it hides (< 1 only near the base).
  const float pole = floorDisparity(100);
  for (int y = 30; y <= 100; ++y)
    d.at<float>(y, 80) = pole;
  // Ghost patch 10 x 10 floating 15 disparities in front of the wall.
  d(cv::Rect(20, 10, 10, 10)).setTo(20.0f);
  cv::Mat before = d.clone();

  SpikeRemovalConfig config;
  config.min_region_size = 200;
  ASSERT_EQ(config.validate(), "");
  DisparityFilterWorkspace ws;
  EXPECT_EQ(filterSpikes(config, &d, &ws), 100);
  EXPECT_EQ(countWhere(d, cv::Rect(20, 10, 10, 10), true), 0);
  EXPECT_EQ(countWhere(d, cv::Rect(80, 30, 1, 71), true), 71);  // the whole pole survives
  // Nothing else changed.
  d(cv::Rect(20, 10, 10, 10)).copyTo(before(cv::Rect(20, 10, 10, 10)));
  EXPECT_TRUE(identical(d, before));
}

TEST(SpikeRemoval, SamePoleCutFromTheFloorIsRemoved) {
  cv::Mat d = wallAndFloor();
  const float pole = floorDisparity(100);
  // Ends 10 rows above its base, where the floor is 2 disparities farther than the pole.
  for (int y = 30; y <= 90; ++y)
    d.at<float>(y, 80) = pole;
  SpikeRemovalConfig config;
  config.min_region_size = 200;
  EXPECT_EQ(filterSpikes(config, &d), 61);
  EXPECT_EQ(countWhere(d, cv::Rect(80, 30, 1, 61), true), 0);
}

TEST(SpikeRemoval, ContinuityThresholdDecidesMembership) {
  // Patches 0.9 and 1.5 disparities off the wall: the first joins the wall's surface, the
  // second is cut off at every border (002, Sec. 4.2: |d_j - d_i| <= 1).
  cv::Mat d = wallAndFloor();
  d(cv::Rect(20, 10, 10, 10)).setTo(5.9f);
  d(cv::Rect(60, 10, 10, 10)).setTo(6.5f);
  EXPECT_EQ(filterSpikes(spikeConfig200(), &d), 100);
  EXPECT_EQ(countWhere(d, cv::Rect(20, 10, 10, 10), true), 100);
  EXPECT_EQ(countWhere(d, cv::Rect(60, 10, 10, 10), true), 0);

  // A wider continuity tolerance merges it as well.
  cv::Mat d2 = wallAndFloor();
  d2(cv::Rect(60, 10, 10, 10)).setTo(6.5f);
  SpikeRemovalConfig wide;
  wide.max_difference = 2.0;
  EXPECT_EQ(filterSpikes(wide, &d2), 0);
}

TEST(SpikeRemoval, SurfacesCutByInvalidPixelsAndSizeThreshold) {
  cv::Mat d = wallAndFloor();
  // A 12 x 12 island of wall disparity fenced off by a ring of invalid pixels (and NaN).
  d(cv::Rect(99, 9, 16, 16)).setTo(0.0f);
  d(cv::Rect(101, 11, 12, 12)).setTo(5.0f);
  d.at<float>(9, 99) = kNaN;
  SpikeRemovalConfig config;
  config.min_region_size = 145;  // the island has 144 pixels
  EXPECT_EQ(filterSpikes(config, &d), 144);
  EXPECT_TRUE(std::isnan(d.at<float>(9, 99)));  // invalid pixels are left alone

  cv::Mat d2 = wallAndFloor();
  d2(cv::Rect(99, 9, 16, 16)).setTo(0.0f);
  d2(cv::Rect(101, 11, 12, 12)).setTo(5.0f);
  config.min_region_size = 144;  // "smaller than" the threshold only
  EXPECT_EQ(filterSpikes(config, &d2), 0);
}

TEST(SpikeRemoval, DiagonalContactDoesNotConnect) {
  // 4-connectivity: a patch touching the large surface only at a corner is its own surface.
  cv::Mat d(40, 40, CV_32FC1, cv::Scalar(0.0f));
  d(cv::Rect(0, 0, 20, 20)).setTo(8.0f);  // 400 px
  d(cv::Rect(20, 20, 5, 5)).setTo(8.0f);  // 25 px, diagonal neighbour of (19, 19)
  SpikeRemovalConfig config;
  config.min_region_size = 100;
  EXPECT_EQ(filterSpikes(config, &d), 25);
  EXPECT_EQ(countValidDisparities(d), 400);
}

TEST(SpikeRemoval, WorkspaceIsReusedWithoutReallocation) {
  DisparityFilterWorkspace ws;
  cv::Mat d = wallAndFloor();
  d(cv::Rect(20, 10, 10, 10)).setTo(20.0f);
  cv::Mat first = d.clone();
  ASSERT_EQ(filterSpikes(spikeConfig200(), &first, &ws), 100);
  const void* surface = ws.surface.data;
  const void* region = ws.region.data();
  cv::Mat second = d.clone();
  ASSERT_EQ(filterSpikes(spikeConfig200(), &second, &ws), 100);
  EXPECT_EQ(ws.surface.data, surface);
  EXPECT_EQ(ws.region.data(), region);
  EXPECT_TRUE(identical(first, second));
}

TEST(SpikeRemoval, BadInput) {
  cv::Mat wrong(10, 10, CV_16SC1, cv::Scalar(5));
  EXPECT_EQ(filterSpikes(SpikeRemovalConfig(), &wrong), -1);
  EXPECT_EQ(filterSpikes(SpikeRemovalConfig(), nullptr), -1);
  cv::Mat empty;
  EXPECT_EQ(filterSpikes(SpikeRemovalConfig(), &empty), -1);
  cv::Mat d = wallAndFloor();
  SpikeRemovalConfig bad;
  bad.min_region_size = 0;
  EXPECT_NE(bad.validate().find("min_region_size"), std::string::npos);
  EXPECT_EQ(filterSpikes(bad, &d), -1);
  bad = SpikeRemovalConfig();
  bad.max_difference = 0.0;
  EXPECT_NE(bad.validate().find("max_difference"), std::string::npos);
  EXPECT_EQ(filterSpikes(bad, &d), -1);
  // All-invalid input: nothing to remove.
  cv::Mat none(20, 20, CV_32FC1, cv::Scalar(kNaN));
  EXPECT_EQ(filterSpikes(SpikeRemovalConfig(), &none), 0);
}

// ------------------------------------------------------------------------------------------------
// Plane at disparity 10 with +-0.3 noise.
cv::Mat noisyPlane(int rows, int cols) {
  cv::Mat d(rows, cols, CV_32FC1);
  cv::RNG rng(3);
  rng.fill(d, cv::RNG::UNIFORM, 9.7f, 10.3f);
  return d;
}

TEST(NeighbourConsistency, RemovesOutliersKeepsSurfaceAndThinLines) {
  cv::Mat d = noisyPlane(60, 80);
  d.at<float>(10, 10) = 30.0f;  // single outlier: no neighbour agrees
  d.at<float>(20, 20) = 30.0f;  // outlier pair: one neighbour agrees each
  d.at<float>(20, 21) = 30.0f;
  d(cv::Rect(40, 40, 3, 3)).setTo(30.0f);  // 3 x 3 blob: a surface, spike removal's business
  for (int y = 5; y <= 35; ++y)
    d.at<float>(y, 60) = 25.0f;  // one-pixel-wide line
  const cv::Mat before = d.clone();

  const NeighbourConsistencyConfig config;
  ASSERT_EQ(config.validate(), "");
  DisparityFilterWorkspace ws;
  // Removed: the 3 outliers and the line's two end points (one agreeing neighbour each).
  EXPECT_EQ(filterInconsistentNeighbours(config, &d, &ws), 5);
  EXPECT_EQ(d.at<float>(10, 10), kInvalidDisparity);
  EXPECT_EQ(d.at<float>(20, 20), kInvalidDisparity);
  EXPECT_EQ(d.at<float>(20, 21), kInvalidDisparity);
  EXPECT_EQ(countWhere(d, cv::Rect(40, 40, 3, 3), true), 9);
  EXPECT_EQ(d.at<float>(5, 60), kInvalidDisparity);
  EXPECT_EQ(d.at<float>(35, 60), kInvalidDisparity);
  // The line's interior survives: judged on the untouched input, not after its ends went.
  EXPECT_EQ(countWhere(d, cv::Rect(60, 6, 1, 29), true), 29);
  // The noisy plane itself (neighbours within 0.6 of each other) is untouched, border included.
  EXPECT_EQ(countWhere(d, cv::Rect(0, 45, 80, 15), true), 80 * 15);
  EXPECT_EQ(d.at<float>(0, 0), before.at<float>(0, 0));
}

TEST(NeighbourConsistency, MajorityRuleRemovesThinLinesAndCorners) {
  cv::Mat d = noisyPlane(60, 80);
  for (int y = 5; y <= 35; ++y)
    d.at<float>(y, 60) = 25.0f;
  d(cv::Rect(40, 40, 3, 3)).setTo(30.0f);
  NeighbourConsistencyConfig majority;
  majority.min_agreeing_fraction = 0.5;
  // Line: 31 px (2 of 8 agree); blob: 4 corners (3 of 8) and 4 edges (5 of 8 -> kept).
  EXPECT_EQ(filterInconsistentNeighbours(majority, &d), 31 + 4);
  EXPECT_EQ(countWhere(d, cv::Rect(40, 40, 3, 3), true), 5);
}

TEST(NeighbourConsistency, IsolatedPixelsAndLargerWindows) {
  cv::Mat d(30, 30, CV_32FC1, cv::Scalar(0.0f));
  d.at<float>(15, 15) = 7.0f;  // alone in an invalid area
  cv::Mat kept = d.clone();
  EXPECT_EQ(filterInconsistentNeighbours(NeighbourConsistencyConfig(), &d), 1);
  NeighbourConsistencyConfig keep_isolated;
  keep_isolated.remove_isolated = false;
  EXPECT_EQ(filterInconsistentNeighbours(keep_isolated, &kept), 0);

  // 5 x 5 window: a 2 x 2 outlier blob has 3 of 24 agreeing neighbours: below 1/4, removed;
  // in a 3 x 3 window it has 3 of 8: kept.
  cv::Mat plane = noisyPlane(40, 40);
  plane(cv::Rect(20, 20, 2, 2)).setTo(30.0f);
  cv::Mat plane3 = plane.clone();
  NeighbourConsistencyConfig wide;
  wide.window_radius = 2;
  EXPECT_EQ(filterInconsistentNeighbours(wide, &plane), 4);
  EXPECT_EQ(filterInconsistentNeighbours(NeighbourConsistencyConfig(), &plane3), 0);
}

TEST(NeighbourConsistency, BadInput) {
  cv::Mat d = noisyPlane(10, 10);
  d.at<float>(5, 5) = kNaN;  // invalid input pixels are skipped, not counted
  d.at<float>(5, 6) = kInf;
  EXPECT_EQ(filterInconsistentNeighbours(NeighbourConsistencyConfig(), &d), 0);
  EXPECT_TRUE(std::isnan(d.at<float>(5, 5)));
  NeighbourConsistencyConfig bad;
  bad.window_radius = 0;
  EXPECT_NE(bad.validate().find("window_radius"), std::string::npos);
  EXPECT_EQ(filterInconsistentNeighbours(bad, &d), -1);
  bad = NeighbourConsistencyConfig();
  bad.min_agreeing_fraction = 0.0;
  EXPECT_NE(bad.validate().find("min_agreeing_fraction"), std::string::npos);
  bad = NeighbourConsistencyConfig();
  bad.max_difference = kNaN;
  EXPECT_NE(bad.validate().find("max_difference"), std::string::npos);
  cv::Mat wrong(10, 10, CV_8UC1);
  EXPECT_EQ(filterInconsistentNeighbours(NeighbourConsistencyConfig(), &wrong), -1);
  EXPECT_EQ(filterInconsistentNeighbours(NeighbourConsistencyConfig(), nullptr), -1);
}

}  // namespace
}  // namespace stereo_safety_map
