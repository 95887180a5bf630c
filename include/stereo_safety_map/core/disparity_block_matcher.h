// Left-to-right and right-to-left block matching from one SAD cost volume (issue 18).
//
// The left-right consistency check (002 Sec. 4.1, ref. [7]) needs a right-to-left disparity. The
// pipeline first got it from a second OpenCV StereoBM on the mirrored pair, which costs a whole
// second matcher. But the SAD cost of right pixel x_r at disparity k is the cost of left pixel
// x_r + k at disparity k: both directions are winners over the same cost volume (the SAD block
// matcher of 002 Sec. 2.2, OpenCV's StereoBM). This matcher builds the volume once and takes the
// left winners (per left pixel, over k) and the right winners (per right pixel, along the
// diagonal) from it, with OpenCV StereoBM's exact integer rules, so that its two outputs are bit
// for bit what StereoBM::compute() gives on the pair and on the mirrored, padded pair
// (test_disparity_block_matcher checks both):
//  - x-Sobel pre-filter clipped to [-pre_filter_cap, pre_filter_cap] (PREFILTER_XSOBEL);
//  - winner: smallest SAD, ties to the larger disparity;
//  - uniqueness (002 Sec. 2.2's quality-of-match test as OpenCV implements it): rejected when a
//    disparity other than the winner and its two neighbours costs <= min + min * ratio / 100;
//  - sub-pixel: OpenCV's parabola-like fit on the two neighbours' costs, 1/16 px;
//  - valid region: StereoBM's ROI (left), the mirrored matcher's (right); elsewhere
//    (min_disparity - 1) * 16.
// Supported: BM with min_disparity 0, textureThreshold 0 and no speckle filter, sums that fit 16
// bits, and a CPU with AVX2 (supports()); otherwise the pipeline keeps its two OpenCV matchers.
// The winner search has an AVX-512BW / VL kernel too, used where the CPU has it (allowAvx512()).
// (With min_disparity > 0 OpenCV 4.6's StereoBM writes min_disparity * 16 into a few pixels
// outside its valid region, which this matcher does not reproduce.)
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace stereo_safety_map {

struct BlockMatcherParams {
  int min_disparity = 0;
  int num_disparities = 64;  ///< multiple of 16
  int block_size = 9;        ///< odd
  int pre_filter_cap = 31;
  int uniqueness_ratio = 15;  ///< [%], 0 = off
};

class LeftRightBlockMatcher {
 public:
  /// True when this CPU and these settings can use the matcher (AVX2, min_disparity 0,
  /// num_disparities a multiple of 16, block_size odd >= 5, the window's SAD below 2^14).
  static bool supports(const BlockMatcherParams& params);

  /// The winner search runs with AVX-512BW / VL mask registers where the CPU has them (same
  /// output, faster), with AVX2 alone otherwise. false forces the AVX2 kernel in every matcher of
  /// the process (tests compare the two). Both give the same output, so a change while a
  /// compute() runs is harmless.
  static void allowAvx512(bool allowed);
  /// True when compute() uses the AVX-512 kernel now.
  static bool usesAvx512();

  /// `left`, `right`: CV_8UC1, same size, wider than min_disparity + num_disparities + block_size
  /// and higher than block_size. Writes CV_16S disparities in 1/16 px: *raw_left indexed by left
  /// pixel (StereoBM::compute on the pair), *raw_right indexed by right pixel (StereoBM::compute
  /// on the mirrored pair padded by min_disparity + num_disparities + block_size / 2 columns,
  /// mirrored back). Rows are split into `stripes` bands (>= 1) run with cv::parallel_for_; the
  /// result does not depend on it. Buffers are members: no allocation once warmed up.
  void compute(const cv::Mat& left, const cv::Mat& right, const BlockMatcherParams& params,
               int stripes, cv::Mat* raw_left, cv::Mat* raw_right);

  /// compute() in two halves, for a caller that runs the stripes on threads of its own:
  /// prepare() (pre-filter, borders; returns the stripe count), then matchStripe(s) once for
  /// every s in [0, count), in any order, concurrently if wanted.
  int prepare(const cv::Mat& left, const cv::Mat& right, const BlockMatcherParams& params,
              int stripes, cv::Mat* raw_left, cv::Mat* raw_right);
  void matchStripe(int stripe);

  struct Stripe {
    std::vector<std::int16_t> column_sums;  ///< per column X, per disparity: SAD over the rows
    std::vector<std::int16_t> costs;        ///< the window's SAD of 16 columns X (a tile)
    std::vector<std::int16_t> cost_rows;    ///< one row's SADs, per disparity: one row of X
  };

 private:
  std::vector<std::uint8_t> left_filtered_, right_filtered_;  ///< extended pre-filtered pair
  std::vector<Stripe> stripes_;
  BlockMatcherParams params_;
  cv::Mat* raw_left_ = nullptr;
  cv::Mat* raw_right_ = nullptr;
  int stripe_count_ = 1;
};

}  // namespace stereo_safety_map
