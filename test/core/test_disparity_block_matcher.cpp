// LeftRightBlockMatcher (issue 18) against OpenCV: its left output must be StereoBM::compute() on
// the pair and its right output StereoBM::compute() on the mirrored pair padded as the pipeline's
// reference path pads it, every pixel of the CV_16S output, over image sizes (odd widths and
// heights), disparity ranges, block sizes, pre-filter caps, uniqueness ratios and stripe counts.
#include "layered_stereo_pair.h"
#include "stereo_safety_map/core/disparity_block_matcher.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace {

cv::Ptr<cv::StereoBM> openCvMatcher(const BlockMatcherParams& p) {
  cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(p.num_disparities, p.block_size);
  bm->setMinDisparity(p.min_disparity);
  bm->setPreFilterType(cv::StereoBM::PREFILTER_XSOBEL);
  bm->setPreFilterCap(p.pre_filter_cap);
  bm->setTextureThreshold(0);
  bm->setUniquenessRatio(p.uniqueness_ratio);
  bm->setSpeckleWindowSize(0);
  bm->setDisp12MaxDiff(-1);
  return bm;
}

// The right-to-left disparity as DisparityPipeline's reference path computes it: StereoBM on the
// mirrored pair, padded on the side where it leaves no result, mirrored back.
cv::Mat openCvRight(const cv::Mat& left, const cv::Mat& right, const BlockMatcherParams& p) {
  const int pad = p.min_disparity + p.num_disparities + p.block_size / 2;
  cv::Mat ml, mr;
  cv::flip(right, ml, 1);
  cv::flip(left, mr, 1);
  cv::copyMakeBorder(ml, ml, 0, 0, pad, 0, cv::BORDER_REPLICATE);
  cv::copyMakeBorder(mr, mr, 0, 0, pad, 0, cv::BORDER_REPLICATE);
  cv::Mat raw, out;
  openCvMatcher(p)->compute(ml, mr, raw);
  cv::flip(raw.colRange(pad, pad + left.cols), out, 1);
  return out;
}

// Random-dot layers at several disparities with occlusions, a flat patch and a repetitive one.
void makePair(int rows, int cols, int seed, cv::Mat* left, cv::Mat* right) {
  cv::RNG rng(seed);
  const int tex_cols = cols + 128;
  auto dots = [&](double sigma) {
    cv::Mat t(rows, tex_cols, CV_8UC1);
    rng.fill(t, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(t, t, cv::Size(), sigma);
    return t;
  };
  cv::Mat stripes(rows, tex_cols, CV_8UC1);
  for (int x = 0; x < tex_cols; ++x)
    stripes.col(x).setTo(x % 8 < 4 ? 60 : 190);
  std::vector<test::StereoLayer> layers{{cv::Rect(0, 0, tex_cols, rows), 3 + seed % 7, dots(1.0)}};
  layers.push_back({cv::Rect(cols / 4, rows / 5, cols / 4, rows / 2), 20 + seed % 13, dots(0.7)});
  layers.push_back({cv::Rect(cols / 2, rows / 2, 9, rows / 3), 40, dots(1.5)});
  layers.push_back({cv::Rect(cols / 8, 2 * rows / 3, cols / 5, rows / 4), 11,
                    cv::Mat(rows, tex_cols, CV_8UC1, 128)});
  layers.push_back({cv::Rect(2 * cols / 3, rows / 8, cols / 5, rows / 5), 15, stripes});
  test::renderLayers(layers, rows, cols, left, right);
  // Sensor noise, different in the two images.
  cv::Mat noise(rows, cols, CV_16SC1);
  rng.fill(noise, cv::RNG::NORMAL, 0, 2);
  cv::add(*left, noise, *left, cv::noArray(), CV_8U);
  rng.fill(noise, cv::RNG::NORMAL, 0, 2);
  cv::add(*right, noise, *right, cv::noArray(), CV_8U);
}

int countDifferences(const cv::Mat& expected, const cv::Mat& actual, cv::Point* first) {
  int n = 0;
  for (int y = 0; y < expected.rows; ++y) {
    for (int x = 0; x < expected.cols; ++x) {
      if (expected.at<short>(y, x) != actual.at<short>(y, x) && n++ == 0) *first = {x, y};
    }
  }
  return n;
}

void check(const cv::Mat& left, const cv::Mat& right, const BlockMatcherParams& p, int stripes,
           LeftRightBlockMatcher* matcher, const std::string& what) {
  ASSERT_TRUE(LeftRightBlockMatcher::supports(p)) << what;
  cv::Mat expected_left;
  openCvMatcher(p)->compute(left, right, expected_left);
  const cv::Mat expected_right = openCvRight(left, right, p);
  cv::Mat raw_left, raw_right;
  matcher->compute(left, right, p, stripes, &raw_left, &raw_right);
  ASSERT_EQ(raw_left.type(), CV_16SC1);
  ASSERT_EQ(raw_right.type(), CV_16SC1);
  cv::Point first(-1, -1);
  int n = countDifferences(expected_left, raw_left, &first);
  EXPECT_EQ(n, 0) << what << ": left differs first at " << first << ": OpenCV "
                  << (n ? expected_left.at<short>(first) : 0) << ", ours "
                  << (n ? raw_left.at<short>(first) : 0);
  n = countDifferences(expected_right, raw_right, &first);
  EXPECT_EQ(n, 0) << what << ": right differs first at " << first << ": OpenCV "
                  << (n ? expected_right.at<short>(first) : 0) << ", ours "
                  << (n ? raw_right.at<short>(first) : 0);
  // Something was matched at all.
  EXPECT_GT(cv::countNonZero(raw_left > 0), 0) << what;
  EXPECT_GT(cv::countNonZero(raw_right > 0), 0) << what;
}

// The winner kernels this CPU can run: AVX-512 (when present) and AVX2.
std::vector<bool> kernels() {
  LeftRightBlockMatcher::allowAvx512(true);
  if (LeftRightBlockMatcher::usesAvx512()) return {true, false};
  return {false};
}

TEST(LeftRightBlockMatcher, MatchesOpenCvStereoBmBothWays) {
  if (!LeftRightBlockMatcher::supports(BlockMatcherParams())) {
    GTEST_SKIP() << "no AVX2 on this CPU: the pipeline uses its two OpenCV matchers";
  }
  struct Case {
    int rows, cols, min_disparity, num_disparities, block_size, cap, ratio, stripes;
  };
  const Case cases[] = {
      {240, 320, 0, 64, 9, 31, 15, 1}, {240, 320, 0, 64, 9, 31, 15, 3},
      {241, 317, 0, 64, 9, 31, 15, 2}, {239, 300, 0, 32, 5, 31, 0, 1},
      {200, 333, 0, 48, 7, 20, 25, 1}, {180, 260, 0, 16, 11, 63, 5, 2},
      {150, 400, 0, 80, 9, 31, 15, 1}, {120, 250, 0, 64, 15, 31, 100, 1},
      {480, 640, 0, 64, 9, 31, 15, 1}, {480, 640, 0, 64, 9, 31, 15, 2},
      {97, 130, 0, 16, 5, 1, 15, 4},
  };
  // Both winner kernels where the CPU has AVX-512 (the AVX2 one forced), the AVX2 one elsewhere.
  for (const bool avx512 : kernels()) {
    LeftRightBlockMatcher::allowAvx512(avx512);
    LeftRightBlockMatcher matcher;  // one for every case: buffers reused across sizes
    int seed = 1;
    for (const Case& c : cases) {
      BlockMatcherParams p;
      p.min_disparity = c.min_disparity;
      p.num_disparities = c.num_disparities;
      p.block_size = c.block_size;
      p.pre_filter_cap = c.cap;
      p.uniqueness_ratio = c.ratio;
      for (int k = 0; k < 2; ++k, ++seed) {
        cv::Mat left, right;
        makePair(c.rows, c.cols, seed, &left, &right);
        const std::string what =
            std::to_string(c.cols) + "x" + std::to_string(c.rows) + " min " +
            std::to_string(c.min_disparity) + " n " + std::to_string(c.num_disparities) +
            " block " + std::to_string(c.block_size) + " cap " + std::to_string(c.cap) + " ratio " +
            std::to_string(c.ratio) + " stripes " + std::to_string(c.stripes) + " seed " +
            std::to_string(seed) + (avx512 ? " (AVX-512 kernel)" : " (AVX2 kernel)");
        check(left, right, p, c.stripes, &matcher, what);
      }
    }
  }
  LeftRightBlockMatcher::allowAvx512(true);
}

TEST(LeftRightBlockMatcher, UnsupportedSettings) {
  BlockMatcherParams p;
  p.min_disparity = 3;  // OpenCV 4.6 writes min_disparity * 16 outside its ROI: not reproduced
  EXPECT_FALSE(LeftRightBlockMatcher::supports(p));
  p = BlockMatcherParams();
  p.block_size = 51;  // the window's SAD would overflow 16 bits
  EXPECT_FALSE(LeftRightBlockMatcher::supports(p));
  p = BlockMatcherParams();
  p.num_disparities = 40;
  EXPECT_FALSE(LeftRightBlockMatcher::supports(p));
}

TEST(LeftRightBlockMatcher, FlatAndSaturatedImages) {
  if (!LeftRightBlockMatcher::supports(BlockMatcherParams())) GTEST_SKIP() << "no AVX2";
  // Ties everywhere: the winner's index and the uniqueness test decide alone.
  BlockMatcherParams p;
  for (const bool avx512 : kernels()) {
    LeftRightBlockMatcher::allowAvx512(avx512);
    LeftRightBlockMatcher matcher;
    for (const int value : {0, 128, 255}) {
      const cv::Mat flat(120, 200, CV_8UC1, cv::Scalar(value));
      cv::Mat expected_left, raw_left, raw_right;
      openCvMatcher(p)->compute(flat, flat, expected_left);
      matcher.compute(flat, flat, p, 1, &raw_left, &raw_right);
      cv::Point first;
      EXPECT_EQ(countDifferences(expected_left, raw_left, &first), 0) << value;
      EXPECT_EQ(countDifferences(openCvRight(flat, flat, p), raw_right, &first), 0) << value;
    }
  }
  LeftRightBlockMatcher::allowAvx512(true);
}

}  // namespace
}  // namespace stereo_safety_map
