// Post-filters that invalidate unreliable stereo disparities, ROS-free.
//
// Convention shared by every function here and by the disparity pipeline: a disparity image is
// CV_32FC1 in pixels; a pixel is valid when its value is finite and > 0, and every filter writes
// exactly 0 (kInvalidDisparity) into the pixels it invalidates. Pixels that are already invalid
// (<= 0, NaN, inf) are never counted and never rewritten, except by sanitizeDisparity().
//
// Each filter works in place, returns how many valid pixels it invalidated, and returns -1
// (leaving the image untouched) for unusable input: empty or wrong-type images, mismatched sizes
// or a config whose validate() is not empty. None of them throws.
//
// Hot paths do not allocate once warmed up when the caller passes the same
// DisparityFilterWorkspace every frame; passing nullptr uses a temporary one (allocates).
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace stereo_safety_map {

/// The value written into invalidated pixels.
constexpr float kInvalidDisparity = 0.0f;

/// True for a usable disparity: finite and > 0 (NaN fails both comparisons).
inline bool isValidDisparity(float d) {
  return d > 0.0f && d <= std::numeric_limits<float>::max();
}

/// Buffers reused by the filters between calls. Opaque to callers: keep one per thread and pass
/// it to every call.
struct DisparityFilterWorkspace {
  cv::Mat grey_f;                      ///< texture (OpenCV path): left image as float
  cv::Mat blurred;                     ///< texture (OpenCV path): Gaussian-smoothed
  cv::Mat log;                         ///< texture (OpenCV path): |Laplacian of Gaussian|
  cv::Mat energy;                      ///< texture: window mean of |LoG|
  std::vector<float> texture_kernel;   ///< texture (own path): the Gaussian taps of
  double texture_kernel_sigma = 0.0;   ///< this sigma
  std::vector<float> texture_row;      ///< texture (own path): one row, borders replicated
  std::vector<float> texture_rows;     ///< texture (own path): Gaussian along rows
  std::vector<float> texture_blurred;  ///< texture (own path): Gaussian-smoothed
  std::vector<float> texture_log;    ///< texture (own path): |LoG| of four rows, borders replicated
  std::vector<double> texture_sums;  ///< texture (own path): window sums along rows (a ring)
  std::vector<double> texture_column;  ///< texture (own path): running column sums
  cv::Mat padded;                      ///< neighbour consistency: input copy with an invalid border
  std::vector<float> valid_count;      ///< neighbour consistency: per-column counts of one row
  std::vector<float> agree_count;
  cv::Mat surface;  ///< spike removal: input copy with an invalid border, < 0 once labelled
  std::vector<std::int32_t> region;  ///< spike removal: BFS queue = pixels of the current surface
};

/// Rewrites every invalid pixel (<= 0, NaN, inf) of a CV_32FC1 image as kInvalidDisparity.
/// Returns how many pixels were rewritten that were not already exactly 0, or -1 for a non
/// CV_32FC1 / empty image.
int sanitizeDisparity(cv::Mat* disparity);

/// Number of valid pixels (finite, > 0) of a CV_32FC1 image; -1 for an empty / non CV_32FC1 one.
int countValidDisparities(const cv::Mat& disparity);

// ------------------------------------------------------------------------------------------------
/// "Sufficient texture" test (002, Sec. 2.2): the local sum of the Laplacian of Gaussian of the
/// left image over the matching window must be large enough, otherwise the match is ambiguous.
/// We use the window mean of |LoG| (a signed sum cancels to ~0 on any texture), so the threshold
/// is in grey levels and does not depend on the window size. 002 gives no numbers: the defaults
/// are ours. With sigma = 1, sensor noise of 3 grey levels std scores ~0.8 and a blurred
/// random-dot texture ~7.5.
struct TextureValidationConfig {
  double log_sigma = 1.0;   ///< Gaussian sigma of the LoG [px], (0, 10]
  int window_size = 9;      ///< odd, [1, 255]; should equal the matcher's block size (002 Sec. 2.2)
  double min_energy = 1.0;  ///< window mean of |LoG| below this -> invalid [grey levels], >= 0

  std::string validate() const;
};

/// Invalidates disparities whose left-image window has too little texture. `left` is the
/// rectified left image, CV_8UC1, same size as `disparity`.
/// The energy is OpenCV's float GaussianBlur, Laplacian (ksize 1) and normalised boxFilter, all
/// with BORDER_REPLICATE. On a CPU with AVX2 and FMA, for a Gaussian of 7 taps or more (log_sigma
/// >= 0.5625) and an image of at least 2 x 2 pixels, it is computed by our own code into the
/// workspace (no allocation once warmed up),
/// with OpenCV's arithmetic step for step, so bit for bit the same (test_disparity_filters checks
/// it against OpenCV); otherwise by OpenCV's calls (36 allocations per call).
int filterLowTexture(const cv::Mat& left, const TextureValidationConfig& config, cv::Mat* disparity,
                     DisparityFilterWorkspace* workspace = nullptr);

/// The texture energy of filterLowTexture() (window mean of |LoG|, CV_32FC1) into *energy; for
/// tests and tools. `opencv_only`: OpenCV's calls even where our own path applies. False for
/// unusable input.
bool textureEnergy(const cv::Mat& left, const TextureValidationConfig& config, cv::Mat* energy,
                   DisparityFilterWorkspace* workspace = nullptr, bool opencv_only = false);

// ------------------------------------------------------------------------------------------------
/// "Quality of match" test (002, Sec. 2.2): reject matches whose best score does not clearly stand
/// out. Two forms:
///  - uniqueness_ratio: the best cost must beat every other cost, except its two direct neighbours
///    (sub-pixel peak), by this many percent. This is exactly OpenCV's StereoBM / StereoSGBM
///    `uniquenessRatio`, which is where the disparity pipeline applies it (inside the matcher,
///    where the cost volume exists; OpenCV does not expose it).
///  - max_normalized_cost: 002's literal form, best cost divided by the sum of all costs of the
///    pixel must be below this. Needs a cost volume, so only filterNonUniqueMatches() applies it;
///    0 disables it (002 gives no value; flat costs score 1 / num_disparities).
struct MatchUniquenessConfig {
  int uniqueness_ratio = 15;         ///< [%], [0, 100], 0 disables; OpenCV's customary 15 (ours)
  double max_normalized_cost = 0.0;  ///< [0, 1], 0 disables

  std::string validate() const;
};

/// Standalone uniqueness check on a cost volume (for matchers that expose one, and for offline
/// evaluation). `cost_volume` is CV_32F with 3 dims {rows, cols, num_disparities}, lower = better
/// (SAD, SSD...); slice k holds disparity min_disparity + k. The winner of each valid pixel is the
/// slice nearest its disparity; a disparity outside the volume's range is invalidated.
int filterNonUniqueMatches(const cv::Mat& cost_volume, int min_disparity,
                           const MatchUniquenessConfig& config, cv::Mat* disparity);

// ------------------------------------------------------------------------------------------------
/// Left-right consistency (002 Sec. 4.1 cites it as the standard mismatch check [7]): the left
/// pixel x with disparity d_L matches right pixel x - d_L, whose own right-to-left disparity d_R
/// must agree. Occluded pixels fail it because their (wrong) match lands on a surface that
/// matches elsewhere. Tolerance is ours (OpenCV's customary disp12MaxDiff = 1).
struct LeftRightCheckConfig {
  double max_difference = 1.0;  ///< |d_L(x) - d_R(x - d_L(x))| above this -> invalid [px], >= 0
  bool reject_if_right_invalid = true;  ///< no right-to-left match to confirm with -> invalid

  std::string validate() const;
};

/// `right_disparity`: CV_32FC1, same size, indexed by right-image pixel, positive values (a right
/// pixel x_r matches left pixel x_r + d_R). The pipeline obtains it by matching the mirrored pair.
int filterLeftRightInconsistent(const cv::Mat& right_disparity, const LeftRightCheckConfig& config,
                                cv::Mat* disparity);

// ------------------------------------------------------------------------------------------------
/// Spike removal by disparity-surface segmentation (002, Sec. 4.2): 4-connected neighbours whose
/// disparities differ by at most max_difference belong to the same surface; surfaces with fewer
/// than min_region_size pixels are coherent mismatches ("spikes", ghost patches) and are
/// invalidated. A one-pixel-wide pole survives when it joins a larger surface. 002 uses a
/// difference of 1 (integer disparities) and gives no size threshold; ours is for 640x480.
struct SpikeRemovalConfig {
  double max_difference = 1.0;  ///< |d_j - d_i| <= this joins neighbours [px] (002 Sec. 4.2), > 0
  /// Surfaces smaller than this are removed [px] (ours), >= 1. 002 gives no number. On the
  /// benchmark datasets' low-texture ground block matching leaves fragments of 50-200 px that
  /// are mostly correct; 200 removed them and left the safety map's floor sparse (FP 22.9 % vs
  /// 5.6 % at 50 over the five datasets, docs/evaluation.md), 50 still removes the 10 x 10 px
  /// coherent ghost patches of repetitive texture that 002 Sec. 4.2 is about only partly, so
  /// scale it with the image area and raise it where repetitive texture dominates.
  int min_region_size = 50;

  std::string validate() const;
};

int filterSpikes(const SpikeRemovalConfig& config, cv::Mat* disparity,
                 DisparityFilterWorkspace* workspace = nullptr);

// ------------------------------------------------------------------------------------------------
/// Removal of readings that differ strongly from their neighbours (000, Sec. III). A valid pixel
/// is kept when at least min_agreeing_fraction of the valid pixels in its window (centre
/// excluded) lie within max_difference of it. 000 gives no rule or numbers; ours: 3x3 window and
/// a fraction of 1/4, so that a one-pixel-wide line (2 of 8 neighbours agree) and a convex corner
/// (3 of 8) survive, as 002 Sec. 4.1 asks for thin structures, while a reading supported by at
/// most one neighbour goes. Use 0.5 for "differs from most of its neighbours".
struct NeighbourConsistencyConfig {
  int window_radius = 1;                ///< window is (2r + 1)^2, [1, 5]
  double max_difference = 1.0;          ///< agreement tolerance [px], >= 0
  double min_agreeing_fraction = 0.25;  ///< (0, 1]
  bool remove_isolated = true;          ///< a pixel with no valid neighbour at all is removed

  std::string validate() const;
};

int filterInconsistentNeighbours(const NeighbourConsistencyConfig& config, cv::Mat* disparity,
                                 DisparityFilterWorkspace* workspace = nullptr);

}  // namespace stereo_safety_map
