// Stereo disparity stage, ROS-free: OpenCV block matching (or SGBM) followed by the papers'
// post-filters (disparity_filters.h). Shared by the disparity nodelet, the offline evaluation
// tool and the occupancy-grid mapper.
//
// Output convention (as in disparity_filters.h): CV_32FC1 disparity in pixels of the left image,
// valid = finite and > 0, every invalid pixel exactly 0.
//
// Steps, in order (each can be switched off):
//  1. matching: StereoBM / StereoSGBM; 002's "quality of match" test runs inside it as OpenCV's
//     uniquenessRatio, since only the matcher sees the costs (002, Sec. 2.2);
//  2. texture validation: mean |LoG| of the left image over the window (002, Sec. 2.2);
//  3. left-right consistency: right-to-left disparities (002, Sec. 4.1, ref. [7]). With BM on the
//     default settings they come with the left ones from one SAD cost volume
//     (disparity_block_matcher.h, bit for bit what the reference path gives); otherwise the
//     mirrored pair is matched by a second matcher with the same settings;
//  4. neighbour consistency: drop readings unlike their neighbours (000, Sec. III);
//  5. spike removal: drop small continuous-disparity surfaces (002, Sec. 4.2); last, so that it
//     also removes fragments the earlier steps left behind;
//  6. coarse fill (multi-scale, off by default): the same pipeline on the pair shrunk 2x fills
//     the pixels the full-resolution steps left invalid (000 Sec. III used a multi-scale
//     correlation matcher; the fill rule is ours, see DisparityPipelineConfig::coarse_fill_levels).
#pragma once

#include "stereo_safety_map/core/disparity_block_matcher.h"
#include "stereo_safety_map/core/disparity_filters.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <array>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace stereo_safety_map {

enum class StereoMatcherType { kBlockMatching, kSemiGlobal };

/// How the left-right consistency check (002 Sec. 4.1, its ref. [7]) gets the right-to-left
/// matches.
enum class LeftRightMode {
  /// A full right-to-left match of the mirrored pair (for BM from the left matcher's own SAD
  /// volume, disparity_block_matcher.h), checked with filterLeftRightInconsistent(): every rule
  /// of LeftRightCheckConfig. The default.
  kFull,
  /// OpenCV's check inside the left matcher (disp12MaxDiff = floor(left_right.max_difference)):
  /// the left match's winners compete for each right pixel on the left costs, no second match.
  /// Cheaper but weaker: a pixel whose right pixel no winner claimed is kept
  /// (left_right.reject_if_right_invalid does not apply), see docs/performance.md (issue 18).
  kOpenCV,
  /// The right-to-left match of the mirrored pair at half resolution (both images shrunk 2x by
  /// area averaging; half the disparities, min_disparity / 2, block (block_size / 2) | 1), its
  /// disparities doubled and each applied to the 2 x 2 full-resolution right pixels it covers,
  /// then filterLeftRightInconsistent() with every rule of LeftRightCheckConfig as in kFull.
  /// About 1/8 of a full matcher's work; a different right-to-left estimate, so not bit for bit
  /// kFull (docs/performance.md, issue 18). The half-size pair must fit the matcher too.
  kHalfResolution,
};

/// Matcher settings and one enable flag + config per post-filter. The papers used a Triclops
/// SAD matcher (002 Sec. 2.2) and a commercial multi-scale correlation matcher (000 Sec. III) and
/// give no matcher numbers; the defaults below are ours, for 640x480 images.
struct DisparityPipelineConfig {
  StereoMatcherType matcher = StereoMatcherType::kBlockMatching;
  int min_disparity = 0;     ///< [0, 256]; disparities <= 0 are invalid by convention
  int num_disparities = 64;  ///< multiple of 16, [16, 256]
  int block_size = 9;        ///< odd; BM: [5, 255], SGBM: [1, 255]; keep texture.window_size equal
  int pre_filter_cap = 31;   ///< [1, 63], clips the x-derivative pre-filter of BM / SGBM
  /// OpenCV's own texture test (BM only), 0 = off: the LoG test below replaces it.
  int bm_texture_threshold = 0;
  /// OpenCV's speckle filter inside the matcher (size [px], >= 0), 0 = off: spike removal below
  /// is 002's version of it.
  int speckle_window_size = 0;
  int speckle_range = 1;        ///< its disparity continuity [px], [0, 64]
  int sgbm_p1 = 0;              ///< SGBM smoothness penalties, 0 = 8 * block_size^2
  int sgbm_p2 = 0;              ///< 0 = 32 * block_size^2; when both set, p2 > p1
  bool sgbm_three_way = false;  ///< StereoSGBM::MODE_SGBM_3WAY (faster) instead of MODE_SGBM

  bool enable_uniqueness = true;     ///< uniqueness.uniqueness_ratio -> matcher (002 Sec. 2.2)
  MatchUniquenessConfig uniqueness;  ///< max_normalized_cost must stay 0: no cost volume here
  bool enable_texture = true;
  TextureValidationConfig texture;
  bool enable_left_right = true;
  LeftRightCheckConfig left_right;
  LeftRightMode left_right_mode = LeftRightMode::kFull;
  bool enable_neighbour_consistency = true;
  NeighbourConsistencyConfig neighbour_consistency;
  bool enable_spike_removal = true;
  SpikeRemovalConfig spike_removal;

  /// Keep a per-pixel removal reason and a colour debug image (see DisparityPipeline). When the
  /// uniqueness test is on this runs one extra matcher pass without it, to attribute its pixels.
  bool debug = false;

  /// Run the right-to-left matcher of the left-right check on a second thread (owned by the
  /// pipeline, started at the first frame that needs it) while this one matches left-to-right
  /// and runs the texture test; with the one-volume BM matcher (disparity_block_matcher.h) the
  /// helper thread matches the lower half of the rows instead. Same output bit for bit, same CPU
  /// time; the latency drops when a second core is free. Ours, not in the papers.
  bool parallel_left_right = false;

  /// Multi-scale fill (000 Sec. III: its matcher was a multi-scale correlation matcher; the rule
  /// is ours, issue 15 "low texture"): 0 = off; k >= 1 runs this pipeline, every step with the
  /// same settings (num_disparities halved and rounded up to a multiple of 16, min_disparity
  /// halved, the window sides unchanged, so twice as wide in the scene), on the pair shrunk 2x
  /// by area averaging, itself with k - 1 coarser levels, and writes its disparities, doubled,
  /// into the 2 x 2 full-resolution pixels each covers where the full-resolution output is
  /// invalid. Averaging halves the image noise and the wider
  /// window sees the weak, smooth texture of a pale floor that a 9 x 9 window under noise cannot
  /// match. A 2 x 2 block is left alone when a valid full-resolution disparity in it differs
  /// from the coarse one by more than left_right.max_difference + 1 px (the coarse level's
  /// resolution), or when one within block_size px of it is larger (nearer) by more than that:
  /// the full-resolution reading wins, and nothing is filled behind the thin edge of a table
  /// top or a step that the coarse window fattens the far surface over (the rays of such points
  /// would carve the nearer surface's voxels free). Block matching picks one disparity per
  /// window, so a step stays a jump. The coarse level keeps spike_min_region_size in its own
  /// pixels (4x the area). Does nothing when the shrunk pair is too small to match.
  int coarse_fill_levels = 0;
  /// The coarse fill's reach [m], 0 = any range: a coarse reading farther than this from the
  /// camera (disparity below f b / coarse_fill_max_depth, with the camera's f b given by
  /// setFocalBaseline(); without it the fill reaches any range) fills nothing. The coarse window
  /// is twice as wide (four times at the second level) and smooths a step's height over its
  /// rows; near the chair a window covers little ground and a step stays steep, far away a 6 cm
  /// curb becomes a gentle slope (docs/evaluation.md). [0, 100].
  double coarse_fill_max_depth = 0.0;

  std::string validate() const;
};

/// Steps of the pipeline, in execution order (index into DisparityStats::steps).
enum class DisparityStep : int {
  kPreprocess = 0,  ///< checks, conversion to grey
  kMatching,        ///< left-to-right matcher (uniqueness test included)
  kUniqueness,      ///< only measured in debug mode (extra matcher pass), else ran = false
  kTexture,         ///< LoG texture test
  kRightMatching,   ///< right-to-left matcher on the mirrored pair (for the left-right check);
                    ///< 0 ms when the one-volume matcher gave it with kMatching
  kLeftRight,       ///< left-right consistency check
  kNeighbourConsistency,
  kSpikeRemoval,
  kCoarseFill,  ///< coarse_fill_levels: valid_after - valid_before pixels filled
};
constexpr int kNumDisparitySteps = 9;
const char* disparityStepName(DisparityStep step);

struct DisparityStepStats {
  bool ran = false;
  int valid_before = 0;  ///< valid left disparities before the step (right ones for kRightMatching)
  int valid_after = 0;
  double ms = 0.0;
};

struct DisparityStats {
  std::array<DisparityStepStats, kNumDisparitySteps> steps{};
  int pixels = 0;  ///< image size
  int valid = 0;   ///< valid pixels in the output
  double total_ms = 0.0;
  const DisparityStepStats& step(DisparityStep s) const { return steps[static_cast<int>(s)]; }
  DisparityStepStats& step(DisparityStep s) { return steps[static_cast<int>(s)]; }
};

/// Why a pixel of the last output is invalid (debug mode only).
enum class DisparityRemoval : std::uint8_t {
  kValid = 0,       ///< debug colour: grey, brighter = nearer
  kMatcher = 1,     ///< matcher found nothing (image border, OpenCV texture / speckle): black
  kUniqueness = 2,  ///< 002 Sec. 2.2 quality-of-match test: green (0, 200, 0)
  kTexture = 3,     ///< 002 Sec. 2.2 texture test: blue (255, 0, 0 in BGR)
  kLeftRight = 4,   ///< left-right check: red (0, 0, 255 in BGR)
  kNeighbour = 5,   ///< 000 Sec. III neighbour consistency: yellow (0, 255, 255 in BGR)
  kSpike = 6,       ///< 002 Sec. 4.2 spike removal: magenta (255, 0, 255 in BGR)
};

/// BGR colour of a removal reason in the debug image (kValid: the colour of the nearest depth).
cv::Vec3b disparityRemovalColour(DisparityRemoval reason);

namespace detail {
/// One persistent helper thread that runs one task at a time (DisparityPipelineConfig::
/// parallel_left_right). Copies start without a thread of their own.
class TaskThread {
 public:
  TaskThread() = default;
  TaskThread(const TaskThread&) {}
  TaskThread& operator=(const TaskThread&) { return *this; }
  ~TaskThread();
  /// Starts fn(arg) on the thread (created at the first call); the previous task must have been
  /// waited for.
  void start(void (*fn)(void*), void* arg);
  /// Blocks until the task started last has returned; no-op when none is running.
  void wait();

 private:
  void loop();
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  void (*fn_)(void*) = nullptr;
  void* arg_ = nullptr;
  bool busy_ = false;
  bool stop_ = false;
};
}  // namespace detail

/// Not thread-safe (matchers and buffers are members, reused every frame): one per thread.
class DisparityPipeline {
 public:
  DisparityPipeline() = default;
  explicit DisparityPipeline(const DisparityPipelineConfig& config) : config_(config) {}

  /// Replaces the configuration (checked at the next compute(); matchers are rebuilt only when
  /// a matcher setting changed).
  void setConfig(const DisparityPipelineConfig& config) { config_ = config; }
  /// f b [px m] of the camera of the next pairs (focal length times baseline), for
  /// DisparityPipelineConfig::coarse_fill_max_depth; 0 or non-finite = unknown.
  void setFocalBaseline(double focal_times_baseline) {
    focal_baseline_ = std::isfinite(focal_times_baseline) && focal_times_baseline > 0.0
                          ? focal_times_baseline
                          : 0.0;
  }
  const DisparityPipelineConfig& config() const { return config_; }

  /// Rectified pair, CV_8UC1, CV_8UC3 (BGR or RGB: the channel order only changes the grey
  /// weights, identically for both images) or CV_8UC4, same size, at least
  /// min_disparity + num_disparities + block_size wide and block_size high. Writes a CV_32FC1
  /// disparity (pixels) to *disparity_out and, when stats != nullptr, per-step counts and times.
  /// Returns false with a message in *error (when non-null) for bad input or config; never
  /// throws. On false *disparity_out must not be used.
  bool compute(const cv::Mat& left, const cv::Mat& right, cv::Mat* disparity_out,
               DisparityStats* stats, std::string* error);

  /// Debug mode only (else empty): per-pixel DisparityRemoval (CV_8UC1) and its colour image
  /// (CV_8UC3, BGR, colours as documented on DisparityRemoval) of the last successful compute().
  const cv::Mat& removalReasons() const { return removal_; }
  const cv::Mat& debugImage() const { return debug_image_; }

  /// Right-to-left disparity of the last compute() (right-image pixels), when the left-right
  /// check ran; else empty.
  const cv::Mat& rightDisparity() const { return right_ran_ ? right_disparity_ : empty_; }

  /// Which pixels of the last compute()'s output the coarse fill gave (CV_8UC1, 255 there, 0
  /// elsewhere); empty when coarse_fill_levels is 0 or the last compute() failed. The safety map
  /// integrates these readings as occupancy evidence that carves no free space
  /// (StereoFrameProcessorConfig::coarse_free_space).
  const cv::Mat& coarseMask() const { return coarse_mask_; }

  /// How many times the matchers were (re)built; for checking the cache.
  int matcherBuilds() const { return matcher_builds_; }

  /// OpenCV's matcher alone with the settings compute() gives it (fixed-point output): for the
  /// disparity reference test and the bench, which run it without the pipeline's filters.
  static cv::Ptr<cv::StereoMatcher> matcherFor(const DisparityPipelineConfig& config);

 private:
  struct MatcherKey {
    StereoMatcherType type = StereoMatcherType::kBlockMatching;
    int min_disparity = -1, num_disparities = -1, block_size = -1, pre_filter_cap = -1;
    int texture_threshold = -1, uniqueness_ratio = -1, speckle_window_size = -1;
    int speckle_range = -1, p1 = -1, p2 = -1;
    int disp12_max_diff = -1;  ///< OpenCV's own left-right check, -1 = off (LeftRightMode)
    bool three_way = false;
    bool operator==(const MatcherKey& o) const;
  };
  static MatcherKey keyOf(const DisparityPipelineConfig& config);
  // disp12_max_diff: the key's, or -1 for a matcher without OpenCV's left-right check.
  static cv::Ptr<cv::StereoMatcher> createMatcher(const MatcherKey& key, int uniqueness_ratio,
                                                  int disp12_max_diff);
  void ensureMatchers();
  bool toGrey(const cv::Mat& in, cv::Mat* buffer, const cv::Mat** grey, const char* which,
              std::string* error) const;
  void convertMatcherOutput(const cv::Mat& raw, cv::Mat* disparity) const;
  // Right-to-left matching of the left-right check into right_disparity_ (and *stats); on an
  // exception the message goes to right_error_. Runs on task_ with parallel_left_right.
  void matchRightToLeft(const cv::Mat& left_grey, const cv::Mat& right_grey,
                        DisparityStepStats* stats);
  static void matchRightToLeftTask(void* self);
  static void matchStripeTask(void* self);
  /// The one-volume matcher applies (BM, left-right check on, settings it reproduces exactly).
  bool useOneVolumeMatcher() const;
  /// The left-right check runs on a right-to-left match of its own (not LeftRightMode::kOpenCV).
  bool secondMatch() const {
    return config_.enable_left_right && config_.left_right_mode != LeftRightMode::kOpenCV;
  }
  bool halfResolutionRight() const {
    return config_.enable_left_right && config_.left_right_mode == LeftRightMode::kHalfResolution;
  }
  /// The right-to-left matcher's settings for LeftRightMode::kHalfResolution.
  static MatcherKey halfKeyOf(const MatcherKey& key);
  BlockMatcherParams blockMatcherParams() const;  // the one-volume matcher's, from the config
  void markRemoved(const cv::Mat& disparity, DisparityRemoval reason);
  /// Step 6: fills *disparity from the coarse level (coarse_fill_levels >= 1); returns the
  /// pixels filled, or -1 with *error set when the coarse pipeline failed.
  int coarseFill(const cv::Mat& left_grey, const cv::Mat& right_grey, cv::Mat* disparity,
                 std::string* error);
  /// The coarse level's configuration (coarse_fill_levels >= 1).
  static DisparityPipelineConfig coarseConfigOf(const DisparityPipelineConfig& config);
  void renderDebugImage(const cv::Mat& disparity);

  DisparityPipelineConfig config_;
  double focal_baseline_ = 0.0;  ///< setFocalBaseline()
  MatcherKey key_;
  MatcherKey right_key_;  ///< the right-to-left matcher's (key_, or its half-resolution one)
  cv::Ptr<cv::StereoMatcher> left_matcher_;
  cv::Ptr<cv::StereoMatcher> right_matcher_;
  cv::Ptr<cv::StereoMatcher> plain_matcher_;  ///< debug: left matcher without uniqueness test
  /// debug, LeftRightMode::kOpenCV: the left matcher without its left-right check
  cv::Ptr<cv::StereoMatcher> unchecked_matcher_;
  int matcher_builds_ = 0;

  // Buffers reused between frames.
  cv::Mat left_grey_, right_grey_;
  cv::Mat raw_;                             ///< CV_16S matcher output (1/16 px)
  cv::Mat mirrored_left_, mirrored_right_;  ///< mirrored, padded pair for right-to-left
  cv::Mat raw_mirrored_, raw_right_;
  cv::Mat half_left_, half_right_, half_right_disparity_;  ///< LeftRightMode::kHalfResolution
  cv::Mat right_disparity_;
  bool right_ran_ = false;  ///< right_disparity_ belongs to the last compute()
  cv::Mat empty_;
  cv::Mat plain_disparity_, unchecked_disparity_;
  cv::Mat removal_, debug_image_;
  DisparityFilterWorkspace workspace_;
  LeftRightBlockMatcher block_matcher_;  ///< left and right disparities from one cost volume

  /// The coarse level of coarse_fill_levels, created at its first use; copies start without one.
  struct CoarseLevel {
    CoarseLevel();
    CoarseLevel(const CoarseLevel&);
    CoarseLevel& operator=(const CoarseLevel&);
    ~CoarseLevel();
    std::unique_ptr<DisparityPipeline> pipeline;
    cv::Mat left, right, disparity;
    cv::Mat nearest;       ///< largest full-resolution disparity within block_size px
    cv::Mat reach_kernel;  ///< the (2 block_size + 1)^2 rectangle of that dilation
  };
  CoarseLevel coarse_;
  cv::Mat coarse_mask_;  ///< coarseMask()

  // parallel_left_right: the helper thread and the arguments of its task.
  detail::TaskThread task_;
  const cv::Mat* task_left_ = nullptr;
  const cv::Mat* task_right_ = nullptr;
  DisparityStepStats task_stats_;
  bool right_failed_ = false;
  std::string right_error_;
};

}  // namespace stereo_safety_map
