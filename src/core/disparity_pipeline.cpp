#include "stereo_safety_map/core/disparity_pipeline.h"

#include <opencv2/imgproc.hpp>

#include <emmintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <sstream>

namespace stereo_safety_map {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::string prefixed(const char* prefix, const std::string& message) {
  return message.empty() ? message : std::string(prefix) + message;
}

std::string describe(const cv::Mat& m) {
  std::ostringstream s;
  s << m.cols << "x" << m.rows << " " << cv::typeToString(m.type());
  return s.str();
}

// Fills the `pad` leftmost columns of `m` with a copy of column `pad` (replicated border).
template <typename T>
void replicateLeftColumns(int pad, cv::Mat* m) {
  for (int y = 0; y < m->rows; ++y) {
    T* row = m->ptr<T>(y);
    std::fill(row, row + pad, row[pad]);
  }
}

// The matcher's CV_16S output (1/16 px) as CV_32F pixels, everything <= 0 as 0, in one pass;
// returns the number of valid pixels. Bit for bit raw.convertTo(CV_32F, 1 / 16) followed by
// threshold(THRESH_TOZERO) and countNonZero (value / 16 is exact in float).
int convertRaw(const cv::Mat& raw, cv::Mat* disparity) {
  CV_Assert(raw.type() == CV_16SC1);
  disparity->create(raw.size(), CV_32FC1);
  const float scale = 1.0f / cv::StereoMatcher::DISP_SCALE;
  const __m128i zero = _mm_setzero_si128();
  const __m128 scale4 = _mm_set1_ps(scale);
  int valid = 0;
  for (int y = 0; y < raw.rows; ++y) {
    const std::int16_t* r = raw.ptr<std::int16_t>(y);
    float* d = disparity->ptr<float>(y);
    int x = 0;
    __m128i count = zero;  // per lane, at most cols / 8 per row
    for (; x + 8 <= raw.cols && x < 8 * 32767; x += 8) {
      const __m128i v =
          _mm_max_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(r + x)), zero);
      _mm_storeu_ps(d + x, _mm_mul_ps(_mm_cvtepi32_ps(_mm_unpacklo_epi16(v, zero)), scale4));
      _mm_storeu_ps(d + x + 4, _mm_mul_ps(_mm_cvtepi32_ps(_mm_unpackhi_epi16(v, zero)), scale4));
      count = _mm_sub_epi16(count, _mm_cmpgt_epi16(v, zero));
    }
    alignas(16) std::int32_t sums[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(sums), _mm_madd_epi16(count, _mm_set1_epi16(1)));
    valid += sums[0] + sums[1] + sums[2] + sums[3];
    for (; x < raw.cols; ++x) {
      const int v = std::max<int>(r[x], 0);
      d[x] = static_cast<float>(v) * scale;
      valid += v > 0 ? 1 : 0;
    }
  }
  return valid;
}

}  // namespace

const char* disparityStepName(DisparityStep step) {
  switch (step) {
    case DisparityStep::kPreprocess:
      return "preprocess";
    case DisparityStep::kMatching:
      return "matching";
    case DisparityStep::kUniqueness:
      return "uniqueness";
    case DisparityStep::kTexture:
      return "texture";
    case DisparityStep::kRightMatching:
      return "right_matching";
    case DisparityStep::kLeftRight:
      return "left_right";
    case DisparityStep::kNeighbourConsistency:
      return "neighbour_consistency";
    case DisparityStep::kSpikeRemoval:
      return "spike_removal";
    case DisparityStep::kCoarseFill:
      return "coarse_fill";
  }
  return "unknown";
}

cv::Vec3b disparityRemovalColour(DisparityRemoval reason) {
  switch (reason) {
    case DisparityRemoval::kValid:
      return cv::Vec3b(255, 255, 255);
    case DisparityRemoval::kMatcher:
      return cv::Vec3b(0, 0, 0);
    case DisparityRemoval::kUniqueness:
      return cv::Vec3b(0, 200, 0);
    case DisparityRemoval::kTexture:
      return cv::Vec3b(255, 0, 0);
    case DisparityRemoval::kLeftRight:
      return cv::Vec3b(0, 0, 255);
    case DisparityRemoval::kNeighbour:
      return cv::Vec3b(0, 255, 255);
    case DisparityRemoval::kSpike:
      return cv::Vec3b(255, 0, 255);
  }
  return cv::Vec3b(0, 0, 0);
}

std::string DisparityPipelineConfig::validate() const {
  std::ostringstream s;
  if (min_disparity < 0 || min_disparity > 256) {
    s << "min_disparity = " << min_disparity << " must be in [0, 256]";
  } else if (num_disparities < 16 || num_disparities > 256 || num_disparities % 16 != 0) {
    s << "num_disparities = " << num_disparities << " must be a multiple of 16 in [16, 256]";
  } else if (block_size % 2 == 0 || block_size > 255 ||
             block_size < (matcher == StereoMatcherType::kBlockMatching ? 5 : 1)) {
    s << "block_size = " << block_size << " must be odd and in "
      << (matcher == StereoMatcherType::kBlockMatching ? "[5, 255] for block matching"
                                                       : "[1, 255] for SGBM");
  } else if (pre_filter_cap < 1 || pre_filter_cap > 63) {
    s << "pre_filter_cap = " << pre_filter_cap << " must be in [1, 63]";
  } else if (bm_texture_threshold < 0) {
    s << "bm_texture_threshold = " << bm_texture_threshold << " must be >= 0";
  } else if (speckle_window_size < 0) {
    s << "speckle_window_size = " << speckle_window_size << " must be >= 0";
  } else if (speckle_range < 0 || speckle_range > 64) {
    s << "speckle_range = " << speckle_range << " must be in [0, 64]";
  } else if (sgbm_p1 < 0 || sgbm_p2 < 0) {
    s << "sgbm_p1 = " << sgbm_p1 << " and sgbm_p2 = " << sgbm_p2 << " must be >= 0";
  } else if (sgbm_p1 > 0 && sgbm_p2 > 0 && sgbm_p2 <= sgbm_p1) {
    s << "sgbm_p2 = " << sgbm_p2 << " must be > sgbm_p1 = " << sgbm_p1;
  } else if (coarse_fill_levels < 0 || coarse_fill_levels > 3) {
    s << "coarse_fill_levels = " << coarse_fill_levels << " must be in [0, 3]";
  } else if (!(coarse_fill_max_depth >= 0.0 && coarse_fill_max_depth <= 100.0)) {
    s << "coarse_fill_max_depth = " << coarse_fill_max_depth << " must be in [0, 100] m";
  }
  if (!s.str().empty()) return s.str();

  if (enable_uniqueness) {
    const std::string e = prefixed("uniqueness.", uniqueness.validate());
    if (!e.empty()) return e;
    if (uniqueness.max_normalized_cost > 0.0) {
      return "uniqueness.max_normalized_cost must be 0 in the pipeline: OpenCV's matchers expose "
             "no cost volume (use uniqueness.uniqueness_ratio)";
    }
  }
  if (enable_texture) {
    const std::string e = prefixed("texture.", texture.validate());
    if (!e.empty()) return e;
  }
  if (enable_left_right) {
    const std::string e = prefixed("left_right.", left_right.validate());
    if (!e.empty()) return e;
  }
  if (enable_neighbour_consistency) {
    const std::string e = prefixed("neighbour_consistency.", neighbour_consistency.validate());
    if (!e.empty()) return e;
  }
  if (enable_spike_removal) {
    const std::string e = prefixed("spike_removal.", spike_removal.validate());
    if (!e.empty()) return e;
  }
  return {};
}

// ------------------------------------------------------------------------------------------------
namespace detail {

TaskThread::~TaskThread() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void TaskThread::start(void (*fn)(void*), void* arg) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    fn_ = fn;
    arg_ = arg;
    busy_ = true;
  }
  if (!thread_.joinable()) thread_ = std::thread(&TaskThread::loop, this);
  cv_.notify_all();
}

void TaskThread::wait() {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [this] { return !busy_; });
}

void TaskThread::loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    cv_.wait(lock, [this] { return stop_ || (busy_ && fn_ != nullptr); });
    if (stop_) return;
    void (*fn)(void*) = fn_;
    void* arg = arg_;
    fn_ = nullptr;
    lock.unlock();
    fn(arg);  // must not throw
    lock.lock();
    busy_ = false;
    cv_.notify_all();
  }
}

}  // namespace detail

// ------------------------------------------------------------------------------------------------
bool DisparityPipeline::MatcherKey::operator==(const MatcherKey& o) const {
  return type == o.type && min_disparity == o.min_disparity &&
         num_disparities == o.num_disparities && block_size == o.block_size &&
         pre_filter_cap == o.pre_filter_cap && texture_threshold == o.texture_threshold &&
         uniqueness_ratio == o.uniqueness_ratio && speckle_window_size == o.speckle_window_size &&
         speckle_range == o.speckle_range && p1 == o.p1 && p2 == o.p2 &&
         disp12_max_diff == o.disp12_max_diff && three_way == o.three_way;
}

DisparityPipeline::MatcherKey DisparityPipeline::keyOf(const DisparityPipelineConfig& c) {
  MatcherKey k;
  k.type = c.matcher;
  k.min_disparity = c.min_disparity;
  k.num_disparities = c.num_disparities;
  k.block_size = c.block_size;
  k.pre_filter_cap = c.pre_filter_cap;
  k.texture_threshold = c.bm_texture_threshold;
  k.uniqueness_ratio = c.enable_uniqueness ? c.uniqueness.uniqueness_ratio : 0;
  k.speckle_window_size = c.speckle_window_size;
  k.speckle_range = c.speckle_range;
  // OpenCV's customary SGBM penalties for one channel.
  const int area = c.block_size * c.block_size;
  k.p1 = c.sgbm_p1 > 0 ? c.sgbm_p1 : 8 * area;
  // In 64 bits: p1 + 1 overflows an int for p1 = INT_MAX (fuzzing found it).
  k.p2 = c.sgbm_p2 > 0 ? c.sgbm_p2
                       : static_cast<int>(std::min<long long>(
                             std::numeric_limits<int>::max(),
                             std::max<long long>(32LL * area, static_cast<long long>(k.p1) + 1)));
  k.three_way = c.sgbm_three_way;
  // OpenCV compares integer disparities (its disp2 is integer): floor, so that the tolerance is
  // never looser than left_right.max_difference.
  k.disp12_max_diff = c.enable_left_right && c.left_right_mode == LeftRightMode::kOpenCV
                          ? static_cast<int>(std::floor(c.left_right.max_difference))
                          : -1;
  return k;
}

cv::Ptr<cv::StereoMatcher> DisparityPipeline::createMatcher(const MatcherKey& k,
                                                            int uniqueness_ratio,
                                                            int disp12_max_diff) {
  // disp12MaxDiff = -1 (left_right_mode full, the default): the left-right check is our own, on
  // a full right-to-left match. OpenCV's own (left_right_mode opencv: the left match's winners
  // competing for a right pixel) costs almost nothing but is not equivalent: measured on the
  // five datasets (issue 18, docs/performance.md) with BM it keeps 7 - 40 % more pixels per
  // frame and the map's FP rate rises from 7.3 to 9.3 % (decr 1), FN from 1.9 to 2.6 % (decr 3).
  // StereoBM turns its check off for -1; StereoSGBM (OpenCV 4.6) takes any value <= 0 as 1, so
  // its check always runs, in every mode, before ours (and in the "StereoSGBM alone" peer).
  if (k.type == StereoMatcherType::kSemiGlobal) {
    return cv::StereoSGBM::create(
        k.min_disparity, k.num_disparities, k.block_size, k.p1, k.p2, disp12_max_diff,
        k.pre_filter_cap, uniqueness_ratio, k.speckle_window_size, k.speckle_range,
        k.three_way ? cv::StereoSGBM::MODE_SGBM_3WAY : cv::StereoSGBM::MODE_SGBM);
  }
  cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(k.num_disparities, k.block_size);
  bm->setMinDisparity(k.min_disparity);
  bm->setPreFilterType(cv::StereoBM::PREFILTER_XSOBEL);
  bm->setPreFilterCap(k.pre_filter_cap);
  bm->setTextureThreshold(k.texture_threshold);
  // 002's "quality of match" test (Sec. 2.2) as OpenCV implements it on the SAD costs.
  bm->setUniquenessRatio(uniqueness_ratio);
  bm->setSpeckleWindowSize(k.speckle_window_size);
  bm->setSpeckleRange(k.speckle_range);
  bm->setDisp12MaxDiff(disp12_max_diff);
  return bm;
}

// Half the image in each direction: half the disparities (at least 16), half the window (odd, at
// least StereoBM's 5), OpenCV's customary penalties for that window (or the set ones scaled by
// the window area), the speckle window a quarter.
DisparityPipeline::MatcherKey DisparityPipeline::halfKeyOf(const MatcherKey& key) {
  MatcherKey k = key;
  k.min_disparity = key.min_disparity / 2;
  k.num_disparities = std::max(16, (key.num_disparities / 2 + 15) / 16 * 16);
  k.block_size =
      std::max(key.type == StereoMatcherType::kBlockMatching ? 5 : 1, (key.block_size / 2) | 1);
  const double area_ratio = static_cast<double>(k.block_size * k.block_size) /
                            static_cast<double>(key.block_size * key.block_size);
  k.p1 = std::max(1, static_cast<int>(std::lround(key.p1 * area_ratio)));
  k.p2 = std::max(k.p1 + 1, static_cast<int>(std::lround(key.p2 * area_ratio)));
  k.speckle_window_size = key.speckle_window_size / 4;
  k.disp12_max_diff = -1;
  return k;
}

cv::Ptr<cv::StereoMatcher> DisparityPipeline::matcherFor(const DisparityPipelineConfig& config) {
  const MatcherKey key = keyOf(config);
  return createMatcher(key, key.uniqueness_ratio, key.disp12_max_diff);
}

void DisparityPipeline::ensureMatchers() {
  const MatcherKey key = keyOf(config_);
  const MatcherKey right_key = halfResolutionRight() ? halfKeyOf(key) : key;
  if (left_matcher_ && key == key_ && right_key == right_key_) return;
  left_matcher_ = createMatcher(key, key.uniqueness_ratio, key.disp12_max_diff);
  right_matcher_ = createMatcher(right_key, right_key.uniqueness_ratio, -1);
  right_key_ = right_key;
  plain_matcher_.reset();
  unchecked_matcher_.reset();
  key_ = key;
  ++matcher_builds_;
}

bool DisparityPipeline::toGrey(const cv::Mat& in, cv::Mat* buffer, const cv::Mat** grey,
                               const char* which, std::string* error) const {
  switch (in.channels()) {
    case 1:
      *grey = &in;
      return true;
    case 3:
      cv::cvtColor(in, *buffer, cv::COLOR_BGR2GRAY);
      *grey = buffer;
      return true;
    case 4:
      cv::cvtColor(in, *buffer, cv::COLOR_BGRA2GRAY);
      *grey = buffer;
      return true;
    default:
      if (error != nullptr) {
        *error = std::string(which) + " image has unsupported type " + describe(in) +
                 " (expected CV_8UC1, CV_8UC3 or CV_8UC4)";
      }
      return false;
  }
}

// OpenCV matchers return fixed point disparities (1/16 px); anything <= 0 (incl. their
// "no match" value (min_disparity - 1) * 16) becomes kInvalidDisparity.
void DisparityPipeline::convertMatcherOutput(const cv::Mat& raw, cv::Mat* disparity) const {
  convertRaw(raw, disparity);
}

// Right-to-left disparities from the mirrored pair. Mirroring turns "right pixel x_r matches left
// pixel x_r + d" into an ordinary left-to-right search. The pair is padded on the side where the
// matcher leaves no result (the first min_disparity + num_disparities + block_size / 2 columns),
// so that every right pixel gets a disparity; candidates falling into the padding lie outside
// the left image. Touches only the right-to-left buffers, so that it can run beside the
// left-to-right matching and the texture test (parallel_left_right).
void DisparityPipeline::matchRightToLeft(const cv::Mat& full_left, const cv::Mat& full_right,
                                         DisparityStepStats* stats) {
  const Clock::time_point t = Clock::now();
  const bool half = halfResolutionRight();
  if (half) {
    const cv::Size half_size(full_left.cols / 2, full_left.rows / 2);
    cv::resize(full_left, half_left_, half_size, 0.0, 0.0, cv::INTER_AREA);
    cv::resize(full_right, half_right_, half_size, 0.0, 0.0, cv::INTER_AREA);
  }
  const cv::Mat& left_grey = half ? half_left_ : full_left;
  const cv::Mat& right_grey = half ? half_right_ : full_right;
  const cv::Size size = left_grey.size();
  const int pad = right_key_.min_disparity + right_key_.num_disparities + right_key_.block_size / 2;
  const int w = size.width;
  mirrored_left_.create(size.height, w + pad, CV_8UC1);
  mirrored_right_.create(size.height, w + pad, CV_8UC1);
  cv::Mat roi_left = mirrored_left_.colRange(pad, pad + w);
  cv::Mat roi_right = mirrored_right_.colRange(pad, pad + w);
  cv::flip(right_grey, roi_left, 1);
  cv::flip(left_grey, roi_right, 1);
  replicateLeftColumns<std::uint8_t>(pad, &mirrored_left_);
  replicateLeftColumns<std::uint8_t>(pad, &mirrored_right_);
  right_matcher_->compute(mirrored_left_, mirrored_right_, raw_mirrored_);
  cv::flip(raw_mirrored_.colRange(pad, pad + w), raw_right_, 1);
  if (half) {
    // Each half-resolution right pixel's disparity, doubled, for the 2 x 2 full-resolution
    // pixels it covers; an odd last row / column repeats the one before.
    convertMatcherOutput(raw_right_, &half_right_disparity_);
    right_disparity_.create(full_left.size(), CV_32FC1);
    for (int y = 0; y < full_left.rows; ++y) {
      const float* h = half_right_disparity_.ptr<float>(std::min(y / 2, size.height - 1));
      float* d = right_disparity_.ptr<float>(y);
      for (int x = 0; x < full_left.cols; ++x)
        d[x] = 2.0f * h[std::min(x / 2, w - 1)];
    }
  } else {
    convertMatcherOutput(raw_right_, &right_disparity_);
  }
  right_ran_ = true;
  stats->ran = true;
  stats->valid_before = 0;
  stats->valid_after = cv::countNonZero(right_disparity_);
  stats->ms = msSince(t);
}

void DisparityPipeline::matchRightToLeftTask(void* self) {
  auto* p = static_cast<DisparityPipeline*>(self);
  try {
    p->matchRightToLeft(*p->task_left_, *p->task_right_, &p->task_stats_);
  } catch (const cv::Exception& e) {
    p->right_failed_ = true;
    p->right_error_ = std::string("OpenCV error: ") + e.what();
  } catch (const std::exception& e) {
    p->right_failed_ = true;
    p->right_error_ = std::string("error: ") + e.what();
  } catch (...) {
    p->right_failed_ = true;
    p->right_error_ = "unknown error in the right-to-left matcher";
  }
}

void DisparityPipeline::matchStripeTask(void* self) {
  static_cast<DisparityPipeline*>(self)->block_matcher_.matchStripe(1);  // does not throw
}

bool DisparityPipeline::useOneVolumeMatcher() const {
  if (config_.matcher != StereoMatcherType::kBlockMatching || !secondMatch() ||
      config_.left_right_mode != LeftRightMode::kFull || config_.bm_texture_threshold != 0 ||
      config_.speckle_window_size != 0) {
    return false;
  }
  return LeftRightBlockMatcher::supports(blockMatcherParams());
}

BlockMatcherParams DisparityPipeline::blockMatcherParams() const {
  BlockMatcherParams p;
  p.min_disparity = config_.min_disparity;
  p.num_disparities = config_.num_disparities;
  p.block_size = config_.block_size;
  p.pre_filter_cap = config_.pre_filter_cap;
  p.uniqueness_ratio = key_.uniqueness_ratio;
  return p;
}

DisparityPipeline::CoarseLevel::CoarseLevel() = default;
DisparityPipeline::CoarseLevel::CoarseLevel(const CoarseLevel&) {}
DisparityPipeline::CoarseLevel& DisparityPipeline::CoarseLevel::operator=(const CoarseLevel&) {
  return *this;
}
DisparityPipeline::CoarseLevel::~CoarseLevel() = default;

DisparityPipelineConfig DisparityPipeline::coarseConfigOf(const DisparityPipelineConfig& config) {
  DisparityPipelineConfig c = config;
  c.coarse_fill_levels = std::max(0, config.coarse_fill_levels - 1);
  c.min_disparity = config.min_disparity / 2;
  // The same depth range at half the image width; OpenCV wants a multiple of 16.
  c.num_disparities = std::max(16, (config.num_disparities / 2 + 15) / 16 * 16);
  // spike_removal.min_region_size is kept in coarse pixels: a surface must cover 4x the area
  // to be kept, since a coarse mismatch is twice as large and blobs of them are what the
  // coarse level gets wrong on a pale floor (dev split, docs/evaluation.md).
  c.debug = false;
  c.parallel_left_right = false;  // one helper thread per pipeline: the fine level's
  if (c.left_right_mode == LeftRightMode::kHalfResolution) c.left_right_mode = LeftRightMode::kFull;
  return c;
}

int DisparityPipeline::coarseFill(const cv::Mat& left_grey, const cv::Mat& right_grey,
                                  cv::Mat* disparity, std::string* error) {
  const DisparityPipelineConfig cc = coarseConfigOf(config_);
  const cv::Size half(left_grey.cols / 2, left_grey.rows / 2);
  if (half.width <= cc.min_disparity + cc.num_disparities + cc.block_size ||
      half.height <= cc.block_size) {
    return 0;  // too small to match at the coarse level: nothing to fill (documented)
  }
  if (!coarse_.pipeline) coarse_.pipeline = std::make_unique<DisparityPipeline>();
  coarse_.pipeline->setConfig(cc);
  coarse_.pipeline->setFocalBaseline(0.5 * focal_baseline_);  // its disparities are halved
  cv::resize(left_grey, coarse_.left, half, 0.0, 0.0, cv::INTER_AREA);
  cv::resize(right_grey, coarse_.right, half, 0.0, 0.0, cv::INTER_AREA);
  std::string coarse_error;
  if (!coarse_.pipeline->compute(coarse_.left, coarse_.right, &coarse_.disparity, nullptr,
                                 &coarse_error)) {
    if (error != nullptr) *error = "coarse fill level: " + coarse_error;
    return -1;
  }
  // A valid full-resolution reading further than this from the coarse one vetoes its block: the
  // left-right check's tolerance plus one pixel for the coarse level's resolution.
  const float veto = static_cast<float>(config_.left_right.max_difference) + 1.0f;
  // Nothing is filled behind a nearer full-resolution reading within the coarse window's reach
  // (block_size full-resolution pixels each way): block matching fattens the surface that
  // dominates a window, so at the thin edge of a table top or a step the coarse level gives
  // the floor behind it, and the rays of those points would carve the nearer surface's voxels
  // free. coarse_.nearest holds the largest valid full-resolution disparity around each pixel.
  const int reach = config_.block_size;
  // DisparityPipelineConfig::coarse_fill_max_depth as a disparity of this level.
  const float min_fill = focal_baseline_ > 0.0 && config_.coarse_fill_max_depth > 0.0
                             ? static_cast<float>(focal_baseline_ / config_.coarse_fill_max_depth)
                             : 0.0f;
  if (coarse_.reach_kernel.rows != 2 * reach + 1) {  // built once per block size
    coarse_.reach_kernel =
        cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * reach + 1, 2 * reach + 1));
  }
  cv::dilate(*disparity, coarse_.nearest, coarse_.reach_kernel);
  int filled = 0;
  for (int cy = 0; cy < half.height; ++cy) {
    const float* c = coarse_.disparity.ptr<float>(cy);
    float* rows[2] = {disparity->ptr<float>(2 * cy), disparity->ptr<float>(2 * cy + 1)};
    for (int cx = 0; cx < half.width; ++cx) {
      if (!(c[cx] > 0.0f)) continue;
      const float v = 2.0f * c[cx];
      if (v < min_fill) continue;  // DisparityPipelineConfig::coarse_fill_max_depth
      bool vetoed = false;
      int invalid = 0;
      for (float* r : rows) {
        for (int x = 2 * cx; x < 2 * cx + 2; ++x) {
          if (r[x] > 0.0f) {
            vetoed = vetoed || std::fabs(r[x] - v) > veto;
          } else {
            ++invalid;
          }
        }
      }
      for (int y = 2 * cy; y < 2 * cy + 2 && !vetoed; ++y) {
        const float* n = coarse_.nearest.ptr<float>(y);
        vetoed = n[2 * cx] > v + veto || n[2 * cx + 1] > v + veto;
      }
      if (vetoed || invalid == 0) continue;
      std::uint8_t* masks[2] = {coarse_mask_.ptr<std::uint8_t>(2 * cy),
                                coarse_mask_.ptr<std::uint8_t>(2 * cy + 1)};
      for (int k = 0; k < 2; ++k) {
        for (int x = 2 * cx; x < 2 * cx + 2; ++x) {
          if (!(rows[k][x] > 0.0f)) {
            rows[k][x] = v;
            masks[k][x] = 255;
          }
        }
      }
      filled += invalid;
    }
  }
  return filled;
}

void DisparityPipeline::markRemoved(const cv::Mat& disparity, DisparityRemoval reason) {
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    std::uint8_t* r = removal_.ptr<std::uint8_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (r[x] == static_cast<std::uint8_t>(DisparityRemoval::kValid) && !(d[x] > 0.0f)) {
        r[x] = static_cast<std::uint8_t>(reason);
      }
    }
  }
}

void DisparityPipeline::renderDebugImage(const cv::Mat& disparity) {
  debug_image_.create(disparity.size(), CV_8UC3);
  std::array<cv::Vec3b, 7> colours;
  for (int i = 0; i < 7; ++i)
    colours[i] = disparityRemovalColour(static_cast<DisparityRemoval>(i));
  const float lo = static_cast<float>(config_.min_disparity);
  const float scale = 191.0f / static_cast<float>(config_.num_disparities);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    const std::uint8_t* r = removal_.ptr<std::uint8_t>(y);
    cv::Vec3b* out = debug_image_.ptr<cv::Vec3b>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      if (r[x] == static_cast<std::uint8_t>(DisparityRemoval::kValid)) {
        // Grey from 64 (farthest) to 255 (nearest), never black so it cannot read as kMatcher.
        const float v = std::min(255.0f, std::max(64.0f, 64.0f + (d[x] - lo) * scale));
        const auto g = static_cast<std::uint8_t>(v);
        out[x] = cv::Vec3b(g, g, g);
      } else {
        out[x] = colours[std::min<int>(r[x], 6)];
      }
    }
  }
}

// ------------------------------------------------------------------------------------------------
bool DisparityPipeline::compute(const cv::Mat& left, const cv::Mat& right, cv::Mat* disparity_out,
                                DisparityStats* stats, std::string* error) {
  const Clock::time_point start = Clock::now();
  DisparityStats local_stats;
  DisparityStats& st = stats != nullptr ? *stats : local_stats;
  st = DisparityStats();
  auto fail = [this, error](const std::string& message) {
    if (error != nullptr) *error = message;
    coarse_mask_.release();
    return false;
  };

  // --- input checks: nothing below may throw on user input.
  if (disparity_out == nullptr) return fail("disparity_out is null");
  if (disparity_out == &left || disparity_out == &right) {
    return fail("disparity_out must not be one of the input images");
  }
  const std::string config_error = config_.validate();
  if (!config_error.empty()) return fail("invalid config: " + config_error);
  if (left.empty() || right.empty()) {
    return fail(std::string(left.empty() ? "left" : "right") + " image is empty");
  }
  if (left.dims != 2 || right.dims != 2) return fail("images must be two-dimensional");
  if (left.size() != right.size()) {
    return fail("left (" + describe(left) + ") and right (" + describe(right) +
                ") images differ in size");
  }
  for (const cv::Mat* m : {&left, &right}) {
    if (m->depth() != CV_8U || (m->channels() != 1 && m->channels() != 3 && m->channels() != 4)) {
      return fail(std::string(m == &left ? "left" : "right") + " image has unsupported type " +
                  describe(*m) + " (expected CV_8UC1, CV_8UC3 or CV_8UC4)");
    }
  }
  const int min_width = config_.min_disparity + config_.num_disparities + config_.block_size;
  if (left.cols <= min_width || left.rows <= config_.block_size) {
    std::ostringstream s;
    s << "images " << left.cols << "x" << left.rows << " too small: need width > min_disparity "
      << "+ num_disparities + block_size = " << min_width
      << " and height > block_size = " << config_.block_size;
    return fail(s.str());
  }
  if (halfResolutionRight()) {
    const MatcherKey h = halfKeyOf(keyOf(config_));
    const int half_width = h.min_disparity + h.num_disparities + h.block_size;
    if (left.cols / 2 <= half_width || left.rows / 2 <= h.block_size) {
      std::ostringstream s;
      s << "images " << left.cols << "x" << left.rows << " too small for left_right_mode half: "
        << "the half-size pair needs width > " << half_width << " and height > " << h.block_size;
      return fail(s.str());
    }
  }

  try {
    const cv::Size size = left.size();
    st.pixels = size.area();
    DisparityStepStats& pre = st.step(DisparityStep::kPreprocess);
    ensureMatchers();
    const cv::Mat* left_grey = nullptr;
    const cv::Mat* right_grey = nullptr;
    if (!toGrey(left, &left_grey_, &left_grey, "left", error) ||
        !toGrey(right, &right_grey_, &right_grey, "right", error)) {
      coarse_mask_.release();  // coarseMask(): empty after a failure
      return false;
    }
    pre.ran = true;
    pre.valid_before = pre.valid_after = 0;
    pre.ms = msSince(start);

    // --- 3 (started early). The right-to-left matcher of the left-right check, on the helper
    // thread while this one runs steps 1 and 2. Every path out of this block waits for it: it
    // reads the grey images and writes the right-to-left buffers.
    right_ran_ = false;  // the buffer itself is kept: no allocation per frame
    const bool one_volume = useOneVolumeMatcher();
    const bool second_match = secondMatch();
    const bool parallel = second_match && config_.parallel_left_right && !one_volume;
    struct Join {
      detail::TaskThread* task;
      ~Join() {
        if (task != nullptr) task->wait();
      }
    } join{nullptr};
    if (parallel) {
      task_left_ = left_grey;
      task_right_ = right_grey;
      task_stats_ = DisparityStepStats();
      right_failed_ = false;
      task_.start(&DisparityPipeline::matchRightToLeftTask, this);
      join.task = &task_;
    }

    // --- 1. matching; the uniqueness test (002, Sec. 2.2) runs inside the matcher.
    cv::Mat& disparity = *disparity_out;
    Clock::time_point t = Clock::now();
    if (one_volume) {
      // Both directions from one SAD volume (disparity_block_matcher.h): StereoBM's left output
      // and the mirrored matcher's right output, bit for bit. Rows in stripes: OpenCV's threads,
      // or with parallel_left_right the lower half on the pipeline's helper thread.
      const BlockMatcherParams p = blockMatcherParams();
      if (config_.parallel_left_right) {
        if (block_matcher_.prepare(*left_grey, *right_grey, p, 2, &raw_, &raw_right_) == 2) {
          task_.start(&DisparityPipeline::matchStripeTask, this);
          join.task = &task_;
          block_matcher_.matchStripe(0);
          task_.wait();
          join.task = nullptr;
        } else {
          block_matcher_.matchStripe(0);
        }
      } else {
        block_matcher_.compute(*left_grey, *right_grey, p, cv::getNumThreads(), &raw_, &raw_right_);
      }
    } else {
      left_matcher_->compute(*left_grey, *right_grey, raw_);
    }
    int valid = convertRaw(raw_, &disparity);
    DisparityStepStats& match = st.step(DisparityStep::kMatching);
    match.ran = true;
    match.valid_before = st.pixels;
    match.valid_after = valid;
    match.ms = msSince(t);

    // left_right_mode opencv: the check ran inside the matcher, its removals are not counted
    // apart (debug mode: attributed to kLeftRight below).
    const bool check_in_matcher = key_.disp12_max_diff >= 0;
    if (config_.debug) {
      removal_.create(size, CV_8UC1);
      const bool attribute_uniqueness =
          config_.enable_uniqueness && config_.uniqueness.uniqueness_ratio > 0;
      if (attribute_uniqueness) {
        // Same matcher without the test: what it would have accepted, the test removed.
        t = Clock::now();
        // With OpenCV's check in the matcher, without that check either (attributed below).
        if (!plain_matcher_) {
          plain_matcher_ = createMatcher(key_, 0, check_in_matcher ? key_.num_disparities + 1 : -1);
        }
        plain_matcher_->compute(*left_grey, *right_grey, raw_);
        convertMatcherOutput(raw_, &plain_disparity_);
        DisparityStepStats& uniq = st.step(DisparityStep::kUniqueness);
        uniq.ran = true;
        uniq.valid_before = cv::countNonZero(plain_disparity_);
        uniq.valid_after = valid;
        uniq.ms = msSince(t);
      }
      if (check_in_matcher) {
        // Same matcher without OpenCV's left-right check: what that check removed. A tolerance
        // above any disparity difference turns it off (StereoSGBM takes -1 and 0 as 1).
        if (!unchecked_matcher_) {
          unchecked_matcher_ = createMatcher(key_, key_.uniqueness_ratio, key_.num_disparities + 1);
        }
        unchecked_matcher_->compute(*left_grey, *right_grey, raw_);
        const int valid_unchecked = convertRaw(raw_, &unchecked_disparity_);
        if (attribute_uniqueness) st.step(DisparityStep::kUniqueness).valid_after = valid_unchecked;
      }
      const cv::Mat& reference = attribute_uniqueness ? plain_disparity_
                                 : check_in_matcher   ? unchecked_disparity_
                                                      : disparity;
      const cv::Mat& unchecked = check_in_matcher ? unchecked_disparity_ : disparity;
      for (int y = 0; y < size.height; ++y) {
        const float* before = reference.ptr<float>(y);
        const float* middle = unchecked.ptr<float>(y);
        const float* after = disparity.ptr<float>(y);
        std::uint8_t* r = removal_.ptr<std::uint8_t>(y);
        for (int x = 0; x < size.width; ++x) {
          // Valid first: StereoSGBM's 3x3 median runs after its tests, so a pixel may be valid
          // in the output and not in a matcher run without a test.
          r[x] = static_cast<std::uint8_t>(after[x] > 0.0f       ? DisparityRemoval::kValid
                                           : !(before[x] > 0.0f) ? DisparityRemoval::kMatcher
                                           : !(middle[x] > 0.0f) ? DisparityRemoval::kUniqueness
                                                                 : DisparityRemoval::kLeftRight);
        }
      }
    }

    // Runs one post-filter step with its bookkeeping.
    auto run_step = [&](DisparityStep step, DisparityRemoval reason, auto&& filter) {
      DisparityStepStats& s = st.step(step);
      const Clock::time_point t0 = Clock::now();
      const int removed = filter();
      s.ran = true;
      s.ms = msSince(t0);
      s.valid_before = valid;
      if (removed > 0) valid -= removed;
      s.valid_after = valid;
      if (config_.debug && removed > 0) markRemoved(disparity, reason);
      return removed >= 0;
    };

    // --- 2. texture validation (002, Sec. 2.2).
    if (config_.enable_texture &&
        !run_step(DisparityStep::kTexture, DisparityRemoval::kTexture, [&] {
          return filterLowTexture(*left_grey, config_.texture, &disparity, &workspace_);
        })) {
      return fail("texture validation rejected its input");
    }

    // --- 3. left-right consistency (002 Sec. 4.1, ref. [7]) against the right-to-left match.
    if (check_in_matcher) {
      // Done inside the matcher (step 1): its removals are in kMatching's count (debug mode
      // marks them kLeftRight in the removal image).
      DisparityStepStats& lr = st.step(DisparityStep::kLeftRight);
      lr.ran = true;
      lr.valid_before = lr.valid_after = valid;
    } else if (second_match) {
      DisparityStepStats& rm = st.step(DisparityStep::kRightMatching);
      if (one_volume) {
        const Clock::time_point t0 = Clock::now();
        rm.valid_after = convertRaw(raw_right_, &right_disparity_);
        right_ran_ = true;
        rm.ran = true;
        rm.valid_before = 0;
        rm.ms = msSince(t0);
      } else if (parallel) {
        task_.wait();
        join.task = nullptr;
        if (right_failed_) return fail(right_error_);
        rm = task_stats_;
      } else {
        matchRightToLeft(*left_grey, *right_grey, &rm);
      }

      if (!run_step(DisparityStep::kLeftRight, DisparityRemoval::kLeftRight, [&] {
            return filterLeftRightInconsistent(right_disparity_, config_.left_right, &disparity);
          })) {
        return fail("left-right check rejected its input");
      }
    }

    // --- 4. readings unlike their neighbours (000, Sec. III).
    if (config_.enable_neighbour_consistency &&
        !run_step(DisparityStep::kNeighbourConsistency, DisparityRemoval::kNeighbour, [&] {
          return filterInconsistentNeighbours(config_.neighbour_consistency, &disparity,
                                              &workspace_);
        })) {
      return fail("neighbour consistency filter rejected its input");
    }

    // --- 5. spike removal by disparity-surface segmentation (002, Sec. 4.2).
    if (config_.enable_spike_removal &&
        !run_step(DisparityStep::kSpikeRemoval, DisparityRemoval::kSpike,
                  [&] { return filterSpikes(config_.spike_removal, &disparity, &workspace_); })) {
      return fail("spike removal rejected its input");
    }

    // --- 6. coarse fill (multi-scale, 000 Sec. III; the rule is ours).
    if (config_.coarse_fill_levels <= 0) coarse_mask_.release();  // coarseMask(): empty
    if (config_.coarse_fill_levels > 0) {
      coarse_mask_.create(size, CV_8UC1);  // allocates only when the size changes
      coarse_mask_.setTo(0);
      DisparityStepStats& cf = st.step(DisparityStep::kCoarseFill);
      const Clock::time_point t0 = Clock::now();
      std::string coarse_error;
      const int filled = coarseFill(*left_grey, *right_grey, &disparity, &coarse_error);
      if (filled < 0) return fail(coarse_error);
      cf.ran = true;
      cf.ms = msSince(t0);
      cf.valid_before = valid;
      valid += filled;
      cf.valid_after = valid;
      if (config_.debug && filled > 0) {
        for (int y = 0; y < size.height; ++y) {
          const float* d = disparity.ptr<float>(y);
          std::uint8_t* r = removal_.ptr<std::uint8_t>(y);
          for (int x = 0; x < size.width; ++x) {
            if (d[x] > 0.0f) r[x] = static_cast<std::uint8_t>(DisparityRemoval::kValid);
          }
        }
      }
    }

    st.valid = valid;
    if (config_.debug) {
      renderDebugImage(disparity);
    } else {
      removal_.release();
      debug_image_.release();
    }
    st.total_ms = msSince(start);
    return true;
  } catch (const cv::Exception& e) {
    return fail(std::string("OpenCV error: ") + e.what());
  } catch (const std::exception& e) {
    return fail(std::string("error: ") + e.what());
  }
}

}  // namespace stereo_safety_map
