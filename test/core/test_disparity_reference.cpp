// Equivalence guard of the disparity stage (issue 18): DisparityPipeline::compute(), however it is
// optimised, must give bit for bit what the straightforward pipeline below gives. The reference
// is the pipeline as first written: a second full matcher on the mirrored pair for the left-right
// check (002 Sec. 4.1), the LoG texture test from the left image (002 Sec. 2.2), neighbour
// consistency with a plain window loop (000 Sec. III), spike removal by flood fill (002 Sec. 4.2),
// one filter after the other. Frames: the five benchmark datasets rendered at 320x240 (and one at
// 640x480), plus random-dot layers with occlusions; configurations: BM and SGBM, each filter on
// and off, non-default parameters.
#include "layered_stereo_pair.h"
#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/dataset/renderer.h"
#include "stereo_safety_map/dataset/scene_loader.h"
#include "stereo_safety_map/dataset/trajectory.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace {

namespace ds = dataset;

// ------------------------------------------------------------------------------------------------
// Reference pipeline: simple, slow, obviously the algorithm.

// The matcher is OpenCV's, set up as the pipeline sets it up (DisparityPipeline::matcherFor).

cv::Mat toPixels(const cv::Mat& raw) {
  cv::Mat d(raw.size(), CV_32FC1);
  for (int y = 0; y < raw.rows; ++y) {
    for (int x = 0; x < raw.cols; ++x) {
      const float v = static_cast<float>(raw.at<short>(y, x)) * (1.0f / 16.0f);
      d.at<float>(y, x) = v > 0.0f ? v : 0.0f;
    }
  }
  return d;
}

bool valid(float d) {
  return d > 0.0f && std::isfinite(d);
}

void referenceTexture(const cv::Mat& left, const TextureValidationConfig& c, cv::Mat* d) {
  cv::Mat f, blurred, log, energy;
  left.convertTo(f, CV_32F);
  cv::GaussianBlur(f, blurred, cv::Size(), c.log_sigma, c.log_sigma, cv::BORDER_REPLICATE);
  cv::Laplacian(blurred, log, CV_32F, 1, 1.0, 0.0, cv::BORDER_REPLICATE);
  log = cv::abs(log);
  cv::boxFilter(log, energy, CV_32F, cv::Size(c.window_size, c.window_size), cv::Point(-1, -1),
                true, cv::BORDER_REPLICATE);
  for (int y = 0; y < d->rows; ++y) {
    for (int x = 0; x < d->cols; ++x) {
      if (valid(d->at<float>(y, x)) && energy.at<float>(y, x) < static_cast<float>(c.min_energy))
        d->at<float>(y, x) = 0.0f;
    }
  }
}

cv::Mat referenceRightDisparity(const cv::Mat& left, const cv::Mat& right,
                                const DisparityPipelineConfig& c) {
  const int pad = c.min_disparity + c.num_disparities + c.block_size / 2;
  cv::Mat ml, mr, raw;
  cv::Mat fl, fr;
  cv::flip(right, fl, 1);
  cv::flip(left, fr, 1);
  cv::copyMakeBorder(fl, ml, 0, 0, pad, 0, cv::BORDER_REPLICATE);
  cv::copyMakeBorder(fr, mr, 0, 0, pad, 0, cv::BORDER_REPLICATE);
  DisparityPipeline::matcherFor(c)->compute(ml, mr, raw);
  cv::Mat raw_right;
  cv::flip(raw.colRange(pad, pad + left.cols), raw_right, 1);
  return toPixels(raw_right);
}

// left_right_mode half: the same right-to-left match on the pair shrunk 2x by area averaging, with
// half the disparities and half the window; each half-size disparity doubled for the 2 x 2 pixels
// it covers.
cv::Mat referenceHalfRightDisparity(const cv::Mat& left, const cv::Mat& right,
                                    const DisparityPipelineConfig& c) {
  DisparityPipelineConfig h = c;
  h.left_right_mode = LeftRightMode::kFull;
  h.min_disparity = c.min_disparity / 2;
  h.num_disparities = std::max(16, (c.num_disparities / 2 + 15) / 16 * 16);
  h.block_size =
      std::max(c.matcher == StereoMatcherType::kBlockMatching ? 5 : 1, (c.block_size / 2) | 1);
  h.speckle_window_size = c.speckle_window_size / 4;
  EXPECT_EQ(c.sgbm_p1, 0);  // the customary penalties of the half window
  EXPECT_EQ(c.sgbm_p2, 0);
  const cv::Size half_size(left.cols / 2, left.rows / 2);
  cv::Mat hl, hr;
  cv::resize(left, hl, half_size, 0.0, 0.0, cv::INTER_AREA);
  cv::resize(right, hr, half_size, 0.0, 0.0, cv::INTER_AREA);
  const cv::Mat half = referenceRightDisparity(hl, hr, h);
  cv::Mat out(left.size(), CV_32FC1);
  for (int y = 0; y < out.rows; ++y) {
    for (int x = 0; x < out.cols; ++x) {
      out.at<float>(y, x) =
          2.0f * half.at<float>(std::min(y / 2, half.rows - 1), std::min(x / 2, half.cols - 1));
    }
  }
  return out;
}

void referenceLeftRight(const cv::Mat& right_d, const LeftRightCheckConfig& c, cv::Mat* d) {
  for (int y = 0; y < d->rows; ++y) {
    for (int x = 0; x < d->cols; ++x) {
      const float v = d->at<float>(y, x);
      if (!valid(v)) continue;
      const int xr = static_cast<int>(std::floor(static_cast<float>(x) - v + 0.5f));
      bool reject = true;
      if (xr >= 0) {
        const float r = right_d.at<float>(y, xr);
        reject = valid(r) ? std::fabs(v - r) > static_cast<float>(c.max_difference)
                          : c.reject_if_right_invalid;
      }
      if (reject) d->at<float>(y, x) = 0.0f;
    }
  }
}

void referenceNeighbours(const NeighbourConsistencyConfig& c, cv::Mat* d) {
  const cv::Mat in = d->clone();
  const int r = c.window_radius;
  for (int y = 0; y < in.rows; ++y) {
    for (int x = 0; x < in.cols; ++x) {
      const float v = in.at<float>(y, x);
      if (!valid(v)) continue;
      int n = 0, agree = 0;
      for (int dy = -r; dy <= r; ++dy) {
        for (int dx = -r; dx <= r; ++dx) {
          const int yy = y + dy, xx = x + dx;
          if ((dy == 0 && dx == 0) || yy < 0 || xx < 0 || yy >= in.rows || xx >= in.cols) continue;
          const float w = in.at<float>(yy, xx);
          if (!valid(w)) continue;
          ++n;
          agree += std::fabs(w - v) <= static_cast<float>(c.max_difference);
        }
      }
      const bool reject =
          n == 0 ? c.remove_isolated
                 : static_cast<float>(agree) <
                       static_cast<float>(c.min_agreeing_fraction) * static_cast<float>(n) - 1e-3f;
      if (reject) d->at<float>(y, x) = 0.0f;
    }
  }
}

void referenceSpikes(const SpikeRemovalConfig& c, cv::Mat* d) {
  cv::Mat label(d->size(), CV_32SC1, cv::Scalar(-1));
  int next = 0;
  const float tol = static_cast<float>(c.max_difference);
  for (int y = 0; y < d->rows; ++y) {
    for (int x = 0; x < d->cols; ++x) {
      if (!valid(d->at<float>(y, x)) || label.at<int>(y, x) >= 0) continue;
      std::vector<cv::Point> region{{x, y}};
      label.at<int>(y, x) = next;
      for (std::size_t head = 0; head < region.size(); ++head) {
        const cv::Point p = region[head];
        const float dp = d->at<float>(p);
        for (const cv::Point o :
             {cv::Point(-1, 0), cv::Point(1, 0), cv::Point(0, -1), cv::Point(0, 1)}) {
          const cv::Point q = p + o;
          if (q.x < 0 || q.y < 0 || q.x >= d->cols || q.y >= d->rows) continue;
          const float dq = d->at<float>(q);
          if (valid(dq) && label.at<int>(q) < 0 && std::fabs(dq - dp) <= tol) {
            label.at<int>(q) = next;
            region.push_back(q);
          }
        }
      }
      ++next;
      if (static_cast<int>(region.size()) < c.min_region_size) {
        for (const cv::Point& p : region)
          d->at<float>(p) = 0.0f;
      }
    }
  }
}

// The matcher without OpenCV's own left-right check (disp12MaxDiff -1), as left_right_mode full
// sets it up; left_right_mode opencv: the same with OpenCV's check, disp12MaxDiff =
// floor(max_difference), and no check of ours.
cv::Ptr<cv::StereoMatcher> referenceMatcher(const DisparityPipelineConfig& c) {
  DisparityPipelineConfig full = c;
  full.left_right_mode = LeftRightMode::kFull;
  cv::Ptr<cv::StereoMatcher> m = DisparityPipeline::matcherFor(full);
  EXPECT_EQ(m->getDisp12MaxDiff(), -1);
  if (c.enable_left_right && c.left_right_mode == LeftRightMode::kOpenCV) {
    m->setDisp12MaxDiff(static_cast<int>(std::floor(c.left_right.max_difference)));
  }
  return m;
}

cv::Mat referencePipeline(const cv::Mat& left, const cv::Mat& right,
                          const DisparityPipelineConfig& c) {
  cv::Mat raw;
  referenceMatcher(c)->compute(left, right, raw);
  cv::Mat d = toPixels(raw);
  if (c.enable_texture) referenceTexture(left, c.texture, &d);
  if (c.enable_left_right && c.left_right_mode == LeftRightMode::kFull) {
    referenceLeftRight(referenceRightDisparity(left, right, c), c.left_right, &d);
  }
  if (c.enable_left_right && c.left_right_mode == LeftRightMode::kHalfResolution) {
    referenceLeftRight(referenceHalfRightDisparity(left, right, c), c.left_right, &d);
  }
  if (c.enable_neighbour_consistency) referenceNeighbours(c.neighbour_consistency, &d);
  if (c.enable_spike_removal) referenceSpikes(c.spike_removal, &d);
  return d;
}

// ------------------------------------------------------------------------------------------------
// Frames.

struct Pair {
  std::string name;
  cv::Mat left, right;
};

// A few moving frames of each benchmark dataset, rendered in-process.
std::vector<Pair> datasetFrames(int width, int height, const std::vector<std::string>& files,
                                int frames_per_scene) {
  std::vector<Pair> out;
  for (const std::string& file : files) {
    ds::SceneFile sf;
    const std::string err = ds::loadSceneFromFile("scenes/" + file, "", &sf);
    EXPECT_TRUE(err.empty()) << file << ": " << err;
    if (!err.empty()) continue;
    ds::StereoHeadConfig head = sf.camera.scaledTo(width, height);
    head.threads = 2;
    ds::StereoRenderer renderer(sf.scene, head, sf.seed);
    const std::vector<ds::RobotPose> poses = ds::sampleTrajectory(sf.trajectory);
    std::vector<std::size_t> moving;
    for (std::size_t i = 0; i < poses.size(); ++i)
      if (!poses[i].stationary) moving.push_back(i);
    for (int k = 0; k < frames_per_scene && !moving.empty(); ++k) {
      const std::size_t i = moving[(moving.size() - 1) * (2 * k + 1) / (2 * frames_per_scene)];
      const ds::RobotPose& p = poses[i];
      Pair pair;
      pair.name = file + " frame " + std::to_string(i);
      renderer.render(
          ds::basePose(p.x, p.y, sf.trajectory.base_z, p.yaw) * head.baseToLeftOptical(), i,
          &pair.left, &pair.right);
      out.push_back(pair);
    }
  }
  return out;
}

// Random-dot fronto-parallel boxes over a background, with occlusions (as in
// test_disparity_pipeline.cpp): the left-right check and spike removal have work to do.
Pair randomDotFrame(int index) {
  const int rows = 240, cols = 320, tex_cols = cols + 96;
  cv::RNG rng(1000 + index);
  auto dots = [&]() {
    cv::Mat t(rows, tex_cols, CV_8UC1);
    rng.fill(t, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(t, t, cv::Size(), 1.0);
    return t;
  };
  std::vector<test::StereoLayer> layers{{cv::Rect(0, 0, tex_cols, rows), 6 + index, dots()}};
  layers.push_back({cv::Rect(100 + 7 * index, 40, 60 + 5 * index, 120), 28 + 3 * index, dots()});
  layers.push_back({cv::Rect(220, 150 - 9 * index, 12, 60), 45, dots()});  // thin pole
  // A flat (textureless) patch for the texture test.
  layers.push_back({cv::Rect(30, 170, 80, 50), 12, cv::Mat(rows, tex_cols, CV_8UC1, 128)});
  Pair p;
  p.name = "random dots " + std::to_string(index);
  test::renderLayers(layers, rows, cols, &p.left, &p.right);
  return p;
}

// ------------------------------------------------------------------------------------------------
// Configurations.

struct NamedConfig {
  std::string name;
  DisparityPipelineConfig config;
};

std::vector<NamedConfig> configurations(StereoMatcherType matcher) {
  std::vector<NamedConfig> out;
  DisparityPipelineConfig base;
  base.matcher = matcher;
  out.push_back({"defaults", base});
  DisparityPipelineConfig c = base;
  c.enable_texture = c.enable_left_right = c.enable_neighbour_consistency = c.enable_spike_removal =
      false;
  out.push_back({"no filters", c});
  // Each filter alone, and all but it.
  const char* names[4] = {"texture", "left_right", "neighbours", "spikes"};
  for (int k = 0; k < 4; ++k) {
    for (const bool alone : {true, false}) {
      c = base;
      bool* flags[4] = {&c.enable_texture, &c.enable_left_right, &c.enable_neighbour_consistency,
                        &c.enable_spike_removal};
      for (int j = 0; j < 4; ++j)
        *flags[j] = alone ? j == k : j != k;
      out.push_back({std::string(alone ? "only " : "all but ") + names[k], c});
    }
  }
  c = base;
  c.enable_uniqueness = false;
  out.push_back({"no uniqueness", c});
  c = base;
  c.left_right.max_difference = 0.5;
  c.left_right.reject_if_right_invalid = false;
  c.neighbour_consistency.window_radius = 2;
  c.neighbour_consistency.max_difference = 2.0;
  c.neighbour_consistency.min_agreeing_fraction = 0.5;
  c.neighbour_consistency.remove_isolated = false;
  c.spike_removal.max_difference = 0.5;
  c.spike_removal.min_region_size = 200;
  c.texture.log_sigma = 1.5;
  c.texture.min_energy = 2.5;
  out.push_back({"other filter parameters", c});
  c = base;
  c.min_disparity = 3;
  c.num_disparities = 32;
  c.block_size = 7;
  c.texture.window_size = 7;
  c.left_right.max_difference = 0.0;
  c.spike_removal.min_region_size = 1;
  c.neighbour_consistency.min_agreeing_fraction = 1.0;
  c.texture.min_energy = 0.0;
  out.push_back({"other matcher, edge parameters", c});
  c = base;
  c.speckle_window_size = 40;
  c.speckle_range = 2;
  c.pre_filter_cap = 63;
  c.block_size = 11;
  c.texture.window_size = 11;
  if (matcher == StereoMatcherType::kBlockMatching) c.bm_texture_threshold = 10;
  if (matcher == StereoMatcherType::kSemiGlobal) c.sgbm_three_way = true;
  out.push_back({"OpenCV's own filters on", c});
  // OpenCV's left-right check inside the matcher instead of a second match (issue 18).
  c = base;
  c.left_right_mode = LeftRightMode::kOpenCV;
  out.push_back({"left_right_mode opencv", c});
  c.left_right.max_difference = 2.5;  // disp12MaxDiff 2
  c.enable_texture = false;
  out.push_back({"left_right_mode opencv, max_difference 2.5, no texture", c});
  c = base;
  c.left_right_mode = LeftRightMode::kOpenCV;
  c.enable_left_right = false;  // the mode alone does nothing
  out.push_back({"left_right_mode opencv, check off", c});
  // The right-to-left match at half resolution (issue 18).
  c = base;
  c.left_right_mode = LeftRightMode::kHalfResolution;
  out.push_back({"left_right_mode half", c});
  c.min_disparity = 3;
  c.num_disparities = 32;
  c.block_size = 7;
  c.texture.window_size = 7;
  c.left_right.max_difference = 0.5;
  c.left_right.reject_if_right_invalid = false;
  out.push_back({"left_right_mode half, other matcher and check parameters", c});
  return out;
}

void expectSame(const cv::Mat& expected, const cv::Mat& actual, const std::string& what) {
  ASSERT_EQ(actual.type(), CV_32FC1) << what;
  ASSERT_EQ(actual.size(), expected.size()) << what;
  int differing = 0;
  cv::Point first(-1, -1);
  for (int y = 0; y < expected.rows; ++y) {
    const float* e = expected.ptr<float>(y);
    const float* a = actual.ptr<float>(y);
    for (int x = 0; x < expected.cols; ++x) {
      if (std::memcmp(&e[x], &a[x], sizeof(float)) != 0) {
        if (differing++ == 0) first = cv::Point(x, y);
      }
    }
  }
  EXPECT_EQ(differing, 0) << what << ": first at (" << first.x << ", " << first.y << "), expected "
                          << (first.x >= 0 ? expected.at<float>(first) : 0.0f) << ", got "
                          << (first.x >= 0 ? actual.at<float>(first) : 0.0f);
}

void checkFrames(const std::vector<Pair>& frames, StereoMatcherType matcher) {
  for (const NamedConfig& nc : configurations(matcher)) {
    ASSERT_TRUE(nc.config.validate().empty()) << nc.name << ": " << nc.config.validate();
    // One pipeline per configuration, reused over the frames (buffers carried across frames),
    // and one reconfigured from the previous configuration (matcher cache, stale buffers).
    DisparityPipeline pipeline(nc.config);
    for (const Pair& f : frames) {
      const cv::Mat expected = referencePipeline(f.left, f.right, nc.config);
      cv::Mat actual;
      DisparityStats stats;
      std::string error;
      ASSERT_TRUE(pipeline.compute(f.left, f.right, &actual, &stats, &error)) << error;
      expectSame(expected, actual, nc.name + ", " + f.name);
      EXPECT_EQ(stats.valid, cv::countNonZero(expected)) << nc.name << ", " << f.name;
      if (nc.config.enable_texture || nc.config.enable_left_right) {
        // Something is left to check on these frames.
        EXPECT_GT(stats.valid, 0) << nc.name << ", " << f.name;
      }
    }
  }
}

TEST(DisparityReference, DatasetFramesBlockMatching) {
  const std::vector<Pair> frames = datasetFrames(
      320, 240,
      {"dataset1_rail_dropoff_ramp.yaml", "dataset2_ramps_dropoffs.yaml", "dataset3_two_ramps.yaml",
       "dataset4_low_steps.yaml", "dataset5_curb_sidewalk.yaml"},
      2);
  ASSERT_EQ(frames.size(), 10u);
  checkFrames(frames, StereoMatcherType::kBlockMatching);
}

TEST(DisparityReference, DatasetFramesSemiGlobal) {
  const std::vector<Pair> frames = datasetFrames(
      320, 240, {"dataset1_rail_dropoff_ramp.yaml", "dataset5_curb_sidewalk.yaml"}, 1);
  ASSERT_EQ(frames.size(), 2u);
  checkFrames(frames, StereoMatcherType::kSemiGlobal);
}

TEST(DisparityReference, FullSizeFrames) {
  std::vector<Pair> frames =
      datasetFrames(640, 480, {"dataset1_rail_dropoff_ramp.yaml", "dataset4_low_steps.yaml"}, 1);
  ASSERT_EQ(frames.size(), 2u);
  for (const StereoMatcherType m :
       {StereoMatcherType::kBlockMatching, StereoMatcherType::kSemiGlobal}) {
    DisparityPipelineConfig c;
    c.matcher = m;
    for (const bool parallel : {false, true}) {
      c.parallel_left_right = parallel;
      // left_right_mode half at full size, on the helper thread or not (issue 18).
      c.left_right_mode = LeftRightMode::kHalfResolution;
      DisparityPipeline half(c);
      for (const Pair& f : frames) {
        cv::Mat actual;
        std::string error;
        ASSERT_TRUE(half.compute(f.left, f.right, &actual, nullptr, &error)) << error;
        expectSame(referencePipeline(f.left, f.right, c), actual, f.name + ", half");
      }
      c.left_right_mode = LeftRightMode::kFull;
      DisparityPipeline pipeline(c);
      for (const Pair& f : frames) {
        cv::Mat actual;
        std::string error;
        ASSERT_TRUE(pipeline.compute(f.left, f.right, &actual, nullptr, &error)) << error;
        expectSame(referencePipeline(f.left, f.right, c), actual, f.name);
      }
    }
  }
}

TEST(DisparityReference, RandomDotFrames) {
  std::vector<Pair> frames;
  for (int i = 0; i < 4; ++i)
    frames.push_back(randomDotFrame(i));
  checkFrames(frames, StereoMatcherType::kBlockMatching);
  checkFrames(frames, StereoMatcherType::kSemiGlobal);
}

TEST(DisparityReference, ReconfiguredPipelineMatchesAFreshOne) {
  // One pipeline walked through every configuration: nothing of the previous one may leak.
  std::vector<Pair> frames{randomDotFrame(1)};
  DisparityPipeline pipeline;
  for (const StereoMatcherType m :
       {StereoMatcherType::kBlockMatching, StereoMatcherType::kSemiGlobal}) {
    for (const NamedConfig& nc : configurations(m)) {
      pipeline.setConfig(nc.config);
      cv::Mat actual;
      std::string error;
      ASSERT_TRUE(pipeline.compute(frames[0].left, frames[0].right, &actual, nullptr, &error));
      expectSame(referencePipeline(frames[0].left, frames[0].right, nc.config), actual, nc.name);
    }
  }
}

}  // namespace
}  // namespace stereo_safety_map
