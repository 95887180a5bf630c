// Disparity pipeline on synthetic rectified pairs rendered here: fronto-parallel random-dot
// surfaces at known integer disparities, so the true disparity of every pixel is known.
#include "stereo_safety_map/core/disparity_pipeline.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <string>
#include <vector>

namespace stereo_safety_map {
namespace {

constexpr int kRows = 240;
constexpr int kCols = 320;
constexpr int kTextureCols = kCols + 80;  // textures are indexed by left-image column

/// Fronto-parallel textured rectangle; `rect` is in left-image pixels.
struct Layer {
  cv::Rect rect;
  int disparity;
  cv::Mat texture;  ///< kRows x kTextureCols, CV_8UC1
};

cv::Mat randomDots(std::uint64_t seed) {
  cv::Mat t(kRows, kTextureCols, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(t, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(t, t, cv::Size(), 1.0);
  return t;
}

/// Renders the pair with occlusions: each camera sees the nearest (largest disparity) layer.
/// The surface point at left column x appears at right column x - disparity.
struct Scene {
  cv::Mat left, right, truth;  ///< truth: CV_32FC1 disparity of the left image
};

Scene render(const std::vector<Layer>& layers) {
  Scene s;
  s.left.create(kRows, kCols, CV_8UC1);
  s.right.create(kRows, kCols, CV_8UC1);
  s.truth.create(kRows, kCols, CV_32FC1);
  for (int y = 0; y < kRows; ++y) {
    for (int x = 0; x < kCols; ++x) {
      const Layer* in_left = nullptr;
      const Layer* in_right = nullptr;
      for (const Layer& l : layers) {
        if (y < l.rect.y || y >= l.rect.y + l.rect.height) continue;
        const int xs = x + l.disparity;  // surface column seen by right pixel x
        if (x >= l.rect.x && x < l.rect.x + l.rect.width &&
            (in_left == nullptr || l.disparity > in_left->disparity)) {
          in_left = &l;
        }
        if (xs >= l.rect.x && xs < l.rect.x + l.rect.width &&
            (in_right == nullptr || l.disparity > in_right->disparity)) {
          in_right = &l;
        }
      }
      s.left.at<uchar>(y, x) = in_left ? in_left->texture.at<uchar>(y, x) : 0;
      s.truth.at<float>(y, x) = in_left ? static_cast<float>(in_left->disparity) : 0.0f;
      s.right.at<uchar>(y, x) =
          in_right ? in_right->texture.at<uchar>(y, x + in_right->disparity) : 0;
    }
  }
  return s;
}

Layer background(int disparity, std::uint64_t seed) {
  return Layer{cv::Rect(0, 0, kTextureCols, kRows), disparity, randomDots(seed)};
}

struct RoiCounts {
  int valid = 0;
  int wrong = 0;  ///< valid but more than 1 px from the truth
  int total = 0;
};

RoiCounts count(const cv::Mat& d, const cv::Mat& truth, cv::Rect roi) {
  RoiCounts c;
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    for (int x = roi.x; x < roi.x + roi.width; ++x) {
      const float v = d.at<float>(y, x);
      ++c.total;
      if (!isValidDisparity(v)) continue;
      ++c.valid;
      c.wrong += std::fabs(v - truth.at<float>(y, x)) > 1.0f;
    }
  }
  return c;
}

int countReason(const cv::Mat& reasons, cv::Rect roi, DisparityRemoval reason) {
  return cv::countNonZero(reasons(roi) == static_cast<int>(reason));
}

// Matching needs num_disparities + block_size / 2 columns on the left: this is where every
// pixel can be matched.
const cv::Rect kMatchable(64 + 8, 8, kCols - 64 - 16, kRows - 16);

// ------------------------------------------------------------------------------------------------
TEST(DisparityPipelineConfig, DefaultsAreValidAndBadValuesAreNamed) {
  EXPECT_EQ(DisparityPipelineConfig().validate(), "");
  auto expect_error = [](void (*mutate)(DisparityPipelineConfig*), const char* name) {
    DisparityPipelineConfig c;
    mutate(&c);
    const std::string e = c.validate();
    EXPECT_NE(e.find(name), std::string::npos) << "'" << e << "' should name " << name;
  };
  expect_error([](DisparityPipelineConfig* c) { c->num_disparities = 60; }, "num_disparities");
  expect_error([](DisparityPipelineConfig* c) { c->num_disparities = 0; }, "num_disparities");
  expect_error([](DisparityPipelineConfig* c) { c->block_size = 8; }, "block_size");
  expect_error([](DisparityPipelineConfig* c) { c->block_size = 3; }, "block_size");  // BM >= 5
  expect_error([](DisparityPipelineConfig* c) { c->min_disparity = -4; }, "min_disparity");
  expect_error([](DisparityPipelineConfig* c) { c->pre_filter_cap = 64; }, "pre_filter_cap");
  expect_error([](DisparityPipelineConfig* c) { c->speckle_window_size = -1; },
               "speckle_window_size");
  expect_error(
      [](DisparityPipelineConfig* c) {
        c->sgbm_p1 = 100;
        c->sgbm_p2 = 50;
      },
      "sgbm_p2");
  expect_error([](DisparityPipelineConfig* c) { c->uniqueness.uniqueness_ratio = -1; },
               "uniqueness.uniqueness_ratio");
  expect_error([](DisparityPipelineConfig* c) { c->uniqueness.max_normalized_cost = 0.1; },
               "max_normalized_cost");
  expect_error([](DisparityPipelineConfig* c) { c->texture.window_size = 2; },
               "texture.window_size");
  expect_error([](DisparityPipelineConfig* c) { c->left_right.max_difference = -1; },
               "left_right.max_difference");
  expect_error([](DisparityPipelineConfig* c) { c->neighbour_consistency.window_radius = 9; },
               "neighbour_consistency.window_radius");
  expect_error([](DisparityPipelineConfig* c) { c->spike_removal.min_region_size = 0; },
               "spike_removal.min_region_size");

  // SGBM accepts small blocks; a disabled filter's config is not checked.
  DisparityPipelineConfig sgbm;
  sgbm.matcher = StereoMatcherType::kSemiGlobal;
  sgbm.block_size = 3;
  EXPECT_EQ(sgbm.validate(), "");
  DisparityPipelineConfig off;
  off.enable_spike_removal = false;
  off.spike_removal.min_region_size = 0;
  EXPECT_EQ(off.validate(), "");
}

// ------------------------------------------------------------------------------------------------
TEST(DisparityPipeline, TexturedPlaneIsRecoveredAtItsDisparity) {
  const Scene scene = render({background(20, 1)});
  for (const StereoMatcherType type :
       {StereoMatcherType::kBlockMatching, StereoMatcherType::kSemiGlobal}) {
    DisparityPipelineConfig config;
    config.matcher = type;
    DisparityPipeline pipeline(config);
    cv::Mat disparity;
    DisparityStats stats;
    std::string error;
    ASSERT_TRUE(pipeline.compute(scene.left, scene.right, &disparity, &stats, &error)) << error;
    ASSERT_EQ(disparity.type(), CV_32FC1);
    ASSERT_EQ(disparity.size(), scene.left.size());

    const RoiCounts c = count(disparity, scene.truth, kMatchable);
    EXPECT_GE(c.valid, c.total * 99 / 100);
    const RoiCounts all = count(disparity, scene.truth, cv::Rect(0, 0, kCols, kRows));
    EXPECT_EQ(all.wrong, 0);
    double sum = 0.0;
    for (int y = kMatchable.y; y < kMatchable.br().y; ++y) {
      for (int x = kMatchable.x; x < kMatchable.br().x; ++x)
        sum += disparity.at<float>(y, x);
    }
    EXPECT_NEAR(sum / kMatchable.area(), 20.0, 0.1);
    // Convention: every invalid pixel is exactly 0.
    for (int y = 0; y < kRows; ++y) {
      for (int x = 0; x < kCols; ++x) {
        const float v = disparity.at<float>(y, x);
        ASSERT_TRUE(v == kInvalidDisparity || isValidDisparity(v));
      }
    }

    // Stats: every step ran and chains into the next; the output count is the last count.
    EXPECT_EQ(stats.pixels, kRows * kCols);
    EXPECT_EQ(stats.valid, countValidDisparities(disparity));
    const DisparityStep chain[] = {DisparityStep::kMatching, DisparityStep::kTexture,
                                   DisparityStep::kLeftRight, DisparityStep::kNeighbourConsistency,
                                   DisparityStep::kSpikeRemoval};
    int previous = stats.pixels;
    for (const DisparityStep s : chain) {
      const DisparityStepStats& step = stats.step(s);
      EXPECT_TRUE(step.ran) << disparityStepName(s);
      EXPECT_EQ(step.valid_before, previous) << disparityStepName(s);
      EXPECT_LE(step.valid_after, step.valid_before) << disparityStepName(s);
      EXPECT_GE(step.ms, 0.0);
      previous = step.valid_after;
    }
    EXPECT_EQ(previous, stats.valid);
    EXPECT_TRUE(stats.step(DisparityStep::kRightMatching).ran);
    EXPECT_FALSE(stats.step(DisparityStep::kUniqueness).ran);  // measured in debug mode only
    EXPECT_GT(stats.total_ms, 0.0);
  }
}

TEST(DisparityPipeline, RightDisparityCoversTheRightImageBorder) {
  // The mirrored pair is padded so that right pixels near the right border, whose matches lie
  // inside the left image, get a right-to-left disparity (without padding they get none).
  const Scene scene = render({background(10, 2)});
  DisparityPipeline pipeline;
  cv::Mat disparity;
  ASSERT_TRUE(pipeline.compute(scene.left, scene.right, &disparity, nullptr, nullptr));
  const cv::Mat& right = pipeline.rightDisparity();
  ASSERT_EQ(right.size(), scene.left.size());
  const cv::Rect border(kCols - 40, 8, 25, kRows - 16);  // matches at columns < kCols - 5
  int valid = 0, wrong = 0;
  for (int y = border.y; y < border.br().y; ++y) {
    for (int x = border.x; x < border.br().x; ++x) {
      const float v = right.at<float>(y, x);
      valid += isValidDisparity(v);
      wrong += isValidDisparity(v) && std::fabs(v - 10.0f) > 1.0f;
    }
  }
  EXPECT_GE(valid, border.area() * 8 / 10);
  EXPECT_EQ(wrong, 0);
}

TEST(DisparityPipeline, TexturelessRegionIsRemovedByTextureValidation) {
  cv::Mat texture = randomDots(3);
  texture(cv::Rect(120, 60, 100, 100)).setTo(128);  // same surface patch in both views
  const Scene scene = render({Layer{cv::Rect(0, 0, kTextureCols, kRows), 20, texture}});
  const cv::Rect flat(130, 70, 80, 80);  // core of the flat patch, away from texture

  // Only the texture test on: the matcher alone returns a disparity everywhere.
  DisparityPipelineConfig config;
  config.enable_uniqueness = false;
  config.enable_left_right = false;
  config.enable_neighbour_consistency = false;
  config.enable_spike_removal = false;
  config.enable_texture = false;
  DisparityPipeline raw(config);
  cv::Mat disparity;
  std::string error;
  ASSERT_TRUE(raw.compute(scene.left, scene.right, &disparity, nullptr, &error)) << error;
  EXPECT_GT(count(disparity, scene.truth, flat).valid, flat.area() / 2);

  config.enable_texture = true;
  config.debug = true;
  DisparityPipeline textured(config);
  DisparityStats stats;
  ASSERT_TRUE(textured.compute(scene.left, scene.right, &disparity, &stats, &error)) << error;
  EXPECT_EQ(count(disparity, scene.truth, flat).valid, 0);
  EXPECT_EQ(countReason(textured.removalReasons(), flat, DisparityRemoval::kTexture), flat.area());
  EXPECT_GT(stats.step(DisparityStep::kTexture).valid_before,
            stats.step(DisparityStep::kTexture).valid_after);
  const cv::Rect textured_part(kMatchable.x, kMatchable.y, 40, kMatchable.height);
  EXPECT_GE(count(disparity, scene.truth, textured_part).valid, textured_part.area() * 99 / 100);

  // With every filter on the region is gone as well (here mostly by the uniqueness test).
  DisparityPipeline full;
  ASSERT_TRUE(full.compute(scene.left, scene.right, &disparity, nullptr, &error)) << error;
  EXPECT_EQ(count(disparity, scene.truth, flat).valid, 0);
}

TEST(DisparityPipeline, GhostPatchIsRemovedBySpikeRemoval) {
  // A small textured patch floating 30 disparities in front of the background, cut off from
  // every surrounding surface: the kind of coherent error 002 Sec. 4.2 removes.
  const cv::Rect ghost(200, 100, 14, 14);
  const Scene scene = render({background(10, 4), Layer{ghost, 40, randomDots(5)}});
  const cv::Rect core(202, 102, 10, 10);

  DisparityPipelineConfig config;
  config.spike_removal.min_region_size = 200;  // the ghost is a 10 x 10 patch
  config.debug = true;
  config.enable_spike_removal = false;
  DisparityPipeline without(config);
  cv::Mat disparity;
  std::string error;
  ASSERT_TRUE(without.compute(scene.left, scene.right, &disparity, nullptr, &error)) << error;
  const RoiCounts kept = count(disparity, scene.truth, core);
  EXPECT_GE(kept.valid, core.area() * 9 / 10);  // the matcher and other filters keep it
  EXPECT_EQ(kept.wrong, 0);

  config.enable_spike_removal = true;
  DisparityPipeline with(config);
  DisparityStats stats;
  ASSERT_TRUE(with.compute(scene.left, scene.right, &disparity, &stats, &error)) << error;
  EXPECT_EQ(count(disparity, scene.truth, core).valid, 0);
  EXPECT_EQ(countReason(with.removalReasons(), core, DisparityRemoval::kSpike), kept.valid);
  EXPECT_GE(count(disparity, scene.truth, kMatchable).valid, kMatchable.area() * 9 / 10);
  EXPECT_LT(stats.step(DisparityStep::kSpikeRemoval).valid_after,
            stats.step(DisparityStep::kSpikeRemoval).valid_before);
}

TEST(DisparityPipeline, OccludedRegionIsRemovedByLeftRightCheck) {
  // Box at disparity 34 over a background at 10: the 24 background columns left of the box are
  // hidden from the right camera, and the matcher returns wrong disparities there.
  const cv::Rect box(150, 60, 80, 120);
  const Scene scene = render({background(10, 6), Layer{box, 34, randomDots(7)}});
  const cv::Rect occluded(128, 70, 19, 100);  // inside the 24-column band, away from its edges

  DisparityPipelineConfig config;
  config.debug = true;
  config.enable_uniqueness = false;  // which would catch many of them first
  config.enable_neighbour_consistency = false;
  config.enable_spike_removal = false;
  config.enable_left_right = false;
  DisparityPipeline without(config);
  cv::Mat disparity;
  std::string error;
  ASSERT_TRUE(without.compute(scene.left, scene.right, &disparity, nullptr, &error)) << error;
  const RoiCounts before = count(disparity, scene.truth, occluded);
  EXPECT_GE(before.wrong, occluded.area() * 8 / 10);
  const int wrong_before = count(disparity, scene.truth, cv::Rect(0, 0, kCols, kRows)).wrong;

  config.enable_left_right = true;
  DisparityPipeline with(config);
  ASSERT_TRUE(with.compute(scene.left, scene.right, &disparity, nullptr, &error)) << error;
  const RoiCounts after = count(disparity, scene.truth, occluded);
  EXPECT_LE(after.valid, occluded.area() / 50);
  EXPECT_GE(countReason(with.removalReasons(), occluded, DisparityRemoval::kLeftRight),
            before.valid - after.valid);
  const int wrong_after = count(disparity, scene.truth, cv::Rect(0, 0, kCols, kRows)).wrong;
  EXPECT_LT(wrong_after, wrong_before / 5);
  // Visible surfaces stay.
  EXPECT_GE(count(disparity, scene.truth, cv::Rect(160, 70, 60, 100)).valid, 60 * 100 * 95 / 100);
  EXPECT_GE(count(disparity, scene.truth, cv::Rect(240, 70, 60, 100)).valid, 60 * 100 * 95 / 100);

  // The default pipeline leaves nothing wrong in the band either.
  DisparityPipeline full;
  ASSERT_TRUE(full.compute(scene.left, scene.right, &disparity, nullptr, &error)) << error;
  EXPECT_LE(count(disparity, scene.truth, occluded).wrong, occluded.area() / 50);
}

// left_right_mode opencv (issue 18): OpenCV's check inside the left matcher, no second match. It
// only invalidates pixels of the unchecked matcher's output (every value it keeps is that
// output's, bit for bit), removes the occluded band's wrong matches, and debug mode marks exactly
// its removals kLeftRight.
TEST(DisparityPipeline, LeftRightModeOpenCVChecksInsideTheMatcher) {
  const cv::Rect box(150, 60, 80, 120);
  const Scene scene = render({background(10, 6), Layer{box, 34, randomDots(7)}});
  const cv::Rect occluded(128, 70, 19, 100);
  for (const StereoMatcherType matcher :
       {StereoMatcherType::kBlockMatching, StereoMatcherType::kSemiGlobal}) {
    SCOPED_TRACE(matcher == StereoMatcherType::kSemiGlobal ? "sgbm" : "bm");
    DisparityPipelineConfig config;
    config.matcher = matcher;
    config.enable_uniqueness = false;
    config.enable_texture = config.enable_neighbour_consistency = false;
    config.enable_spike_removal = false;
    config.enable_left_right = false;
    // The same matcher without any left-right check: StereoSGBM takes disp12MaxDiff -1 as 1, a
    // tolerance above every disparity difference turns the check off in both matchers.
    cv::Ptr<cv::StereoMatcher> plain = DisparityPipeline::matcherFor(config);
    plain->setDisp12MaxDiff(config.num_disparities + 1);
    cv::Mat raw, unchecked, checked, debug_checked;
    plain->compute(scene.left, scene.right, raw);
    raw.convertTo(unchecked, CV_32F, 1.0 / cv::StereoMatcher::DISP_SCALE);
    unchecked.setTo(0.0f, unchecked < 0.0f);
    std::string error;

    config.enable_left_right = true;
    config.left_right_mode = LeftRightMode::kOpenCV;
    DisparityPipeline with(config);
    DisparityStats stats;
    ASSERT_TRUE(with.compute(scene.left, scene.right, &checked, &stats, &error)) << error;
    EXPECT_FALSE(stats.step(DisparityStep::kRightMatching).ran);  // no second match
    EXPECT_TRUE(stats.step(DisparityStep::kLeftRight).ran);
    EXPECT_TRUE(with.rightDisparity().empty());

    int removed = 0;
    for (int y = 0; y < kRows; ++y) {
      for (int x = 0; x < kCols; ++x) {
        const float c = checked.at<float>(y, x);
        if (isValidDisparity(c)) {
          // StereoSGBM's 3x3 median runs after its check: neighbours of removed pixels move.
          if (matcher == StereoMatcherType::kBlockMatching) {
            ASSERT_EQ(c, unchecked.at<float>(y, x)) << x << ", " << y;
          }
        } else {
          removed += isValidDisparity(unchecked.at<float>(y, x));
        }
      }
    }
    EXPECT_GT(removed, 0);
    const RoiCounts before = count(unchecked, scene.truth, occluded);
    const RoiCounts after = count(checked, scene.truth, occluded);
    EXPECT_GE(before.wrong, occluded.area() / 2);
    EXPECT_LT(after.wrong, before.wrong / 2);

    config.debug = true;
    DisparityPipeline debug(config);
    ASSERT_TRUE(debug.compute(scene.left, scene.right, &debug_checked, nullptr, &error)) << error;
    EXPECT_EQ(cv::norm(checked, debug_checked, cv::NORM_INF), 0.0);
    const cv::Mat& reasons = debug.removalReasons();
    int marked = 0;
    for (int y = 0; y < kRows; ++y) {
      for (int x = 0; x < kCols; ++x) {
        const bool lr = reasons.at<uchar>(y, x) == static_cast<uchar>(DisparityRemoval::kLeftRight);
        marked += lr;
        ASSERT_EQ(lr, isValidDisparity(unchecked.at<float>(y, x)) &&
                          !isValidDisparity(checked.at<float>(y, x)))
            << x << ", " << y;
        ASSERT_EQ(reasons.at<uchar>(y, x) == static_cast<uchar>(DisparityRemoval::kValid),
                  isValidDisparity(checked.at<float>(y, x)));
      }
    }
    EXPECT_EQ(marked, removed);

    // With the uniqueness test as well: every reason is one of the three, valid exactly where
    // the output is.
    config.enable_uniqueness = true;
    DisparityPipeline unique(config);
    ASSERT_TRUE(unique.compute(scene.left, scene.right, &debug_checked, nullptr, &error)) << error;
    int counts[7] = {0, 0, 0, 0, 0, 0, 0};
    for (int y = 0; y < kRows; ++y) {
      for (int x = 0; x < kCols; ++x) {
        const int reason = unique.removalReasons().at<uchar>(y, x);
        ASSERT_LT(reason, 7);
        ++counts[reason];
        ASSERT_EQ(reason == static_cast<int>(DisparityRemoval::kValid),
                  isValidDisparity(debug_checked.at<float>(y, x)));
      }
    }
    EXPECT_GT(counts[static_cast<int>(DisparityRemoval::kUniqueness)], 0);
    EXPECT_GT(counts[static_cast<int>(DisparityRemoval::kLeftRight)], 0);
  }
}

// ------------------------------------------------------------------------------------------------
// parallel_left_right runs the right-to-left matcher on a helper thread: the output, the
// right-to-left disparities, the step counts and the debug reasons must be those of the
// sequential pipeline, frame after frame (buffers reused), for BM and SGBM.
TEST(DisparityPipeline, ParallelLeftRightGivesTheSequentialResultBitForBit) {
  std::vector<Scene> scenes;
  for (int i = 0; i < 4; ++i) {
    const cv::Rect box(120 + 10 * i, 50 + 5 * i, 70 + 8 * i, 110);
    scenes.push_back(
        render({background(8 + i, 20 + i), Layer{box, 30 + 2 * i, randomDots(30 + i)}}));
  }
  for (const StereoMatcherType matcher :
       {StereoMatcherType::kBlockMatching, StereoMatcherType::kSemiGlobal}) {
    for (const bool debug : {false, true}) {
      DisparityPipelineConfig config;
      config.matcher = matcher;
      config.debug = debug;
      DisparityPipeline sequential(config);
      config.parallel_left_right = true;
      DisparityPipeline parallel(config);
      for (int frame = 0; frame < 8; ++frame) {
        const Scene& scene = scenes[frame % scenes.size()];
        cv::Mat d_seq, d_par;
        DisparityStats st_seq, st_par;
        std::string error;
        ASSERT_TRUE(sequential.compute(scene.left, scene.right, &d_seq, &st_seq, &error)) << error;
        ASSERT_TRUE(parallel.compute(scene.left, scene.right, &d_par, &st_par, &error)) << error;
        ASSERT_EQ(cv::checkRange(d_par), true);
        EXPECT_EQ(cv::norm(d_seq, d_par, cv::NORM_INF), 0.0) << "frame " << frame;
        EXPECT_EQ(cv::norm(sequential.rightDisparity(), parallel.rightDisparity(), cv::NORM_INF),
                  0.0);
        EXPECT_GT(st_par.valid, 0);
        EXPECT_EQ(st_seq.valid, st_par.valid);
        for (int k = 0; k < kNumDisparitySteps; ++k) {
          EXPECT_EQ(st_seq.steps[k].ran, st_par.steps[k].ran) << k;
          EXPECT_EQ(st_seq.steps[k].valid_before, st_par.steps[k].valid_before) << k;
          EXPECT_EQ(st_seq.steps[k].valid_after, st_par.steps[k].valid_after) << k;
        }
        if (debug) {
          EXPECT_EQ(cv::norm(sequential.removalReasons(), parallel.removalReasons(), cv::NORM_INF),
                    0.0);
        }
      }
      // Bad input while the option is on: refused with a message, the next frame is served.
      cv::Mat d;
      std::string error;
      EXPECT_FALSE(parallel.compute(scenes[0].left, scenes[0].right.colRange(0, kCols - 8), &d,
                                    nullptr, &error));
      EXPECT_FALSE(error.empty());
      ASSERT_TRUE(parallel.compute(scenes[1].left, scenes[1].right, &d, nullptr, &error)) << error;
      // A copy gets a helper thread of its own and the same result.
      DisparityPipeline copy = parallel;
      cv::Mat d_copy;
      ASSERT_TRUE(copy.compute(scenes[1].left, scenes[1].right, &d_copy, nullptr, &error));
      EXPECT_EQ(cv::norm(d, d_copy, cv::NORM_INF), 0.0);
    }
  }
}

// ------------------------------------------------------------------------------------------------
TEST(DisparityPipeline, ColourInputGivesTheSameResultAsGrey) {
  const Scene scene = render({background(16, 8)});
  DisparityPipeline pipeline;
  cv::Mat grey_result, bgr_result, bgra_result;
  ASSERT_TRUE(pipeline.compute(scene.left, scene.right, &grey_result, nullptr, nullptr));
  cv::Mat left_bgr, right_bgr, left_bgra, right_bgra;
  cv::cvtColor(scene.left, left_bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(scene.right, right_bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(scene.left, left_bgra, cv::COLOR_GRAY2BGRA);
  cv::cvtColor(scene.right, right_bgra, cv::COLOR_GRAY2BGRA);
  std::string error;
  ASSERT_TRUE(pipeline.compute(left_bgr, right_bgr, &bgr_result, nullptr, &error)) << error;
  ASSERT_TRUE(pipeline.compute(left_bgra, right_bgra, &bgra_result, nullptr, &error)) << error;
  EXPECT_EQ(cv::norm(grey_result, bgr_result, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(grey_result, bgra_result, cv::NORM_INF), 0.0);
  // Mixed types are fine too: each image is converted on its own.
  ASSERT_TRUE(pipeline.compute(left_bgr, scene.right, &bgr_result, nullptr, &error)) << error;
  EXPECT_EQ(cv::norm(grey_result, bgr_result, cv::NORM_INF), 0.0);
}

TEST(DisparityPipeline, BadInputIsRejectedWithAMessage) {
  const Scene scene = render({background(16, 9)});
  DisparityPipeline pipeline;
  cv::Mat disparity;
  std::string error;
  auto rejects = [&](const cv::Mat& l, const cv::Mat& r, const char* expected) {
    SCOPED_TRACE(expected);
    error.clear();
    EXPECT_FALSE(pipeline.compute(l, r, &disparity, nullptr, &error));
    EXPECT_NE(error.find(expected), std::string::npos) << "'" << error << "'";
  };
  rejects(cv::Mat(), scene.right, "empty");
  rejects(scene.left, cv::Mat(), "empty");
  rejects(scene.left, scene.right(cv::Rect(0, 0, kCols - 1, kRows)), "size");
  rejects(scene.left, scene.right.rowRange(0, kRows / 2), "size");
  rejects(cv::Mat(kRows, kCols, CV_16UC1, cv::Scalar(5)), scene.right, "unsupported type");
  rejects(scene.left, cv::Mat(kRows, kCols, CV_32FC1, cv::Scalar(5)), "unsupported type");
  rejects(cv::Mat(kRows, kCols, CV_8UC2), cv::Mat(kRows, kCols, CV_8UC2), "unsupported type");
  // Narrower than min_disparity + num_disparities + block_size = 73.
  rejects(scene.left(cv::Rect(0, 0, 73, 40)), scene.right(cv::Rect(0, 0, 73, 40)), "too small");
  rejects(scene.left(cv::Rect(0, 0, 200, 9)), scene.right(cv::Rect(0, 0, 200, 9)), "too small");
  const int dims[3] = {4, 4, 4};
  rejects(cv::Mat(3, dims, CV_8UC1), cv::Mat(3, dims, CV_8UC1), "two-dimensional");

  EXPECT_FALSE(pipeline.compute(scene.left, scene.right, nullptr, nullptr, &error));
  EXPECT_NE(error.find("null"), std::string::npos);
  EXPECT_FALSE(pipeline.compute(scene.left, scene.right, nullptr, nullptr, nullptr));
  cv::Mat alias = scene.left.clone();
  EXPECT_FALSE(pipeline.compute(alias, scene.right, &alias, nullptr, &error));
  EXPECT_EQ(alias.type(), CV_8UC1);

  DisparityPipelineConfig bad;
  bad.num_disparities = 50;
  pipeline.setConfig(bad);
  rejects(scene.left, scene.right, "num_disparities");

  // Still usable after all that.
  pipeline.setConfig(DisparityPipelineConfig());
  ASSERT_TRUE(pipeline.compute(scene.left, scene.right, &disparity, nullptr, &error)) << error;
  EXPECT_GT(countValidDisparities(disparity), kMatchable.area() * 9 / 10);
}

TEST(DisparityPipeline, MatchersAndBuffersAreReusedUntilTheMatcherConfigChanges) {
  const Scene scene = render({background(12, 10)});
  DisparityPipeline pipeline;
  cv::Mat first, second;
  ASSERT_TRUE(pipeline.compute(scene.left, scene.right, &first, nullptr, nullptr));
  const uchar* data = first.data;
  ASSERT_TRUE(pipeline.compute(scene.left, scene.right, &first, nullptr, nullptr));
  EXPECT_EQ(first.data, data);  // output buffer reused
  EXPECT_EQ(pipeline.matcherBuilds(), 1);

  DisparityPipelineConfig config;
  config.spike_removal.min_region_size = 50;  // a filter setting: no rebuild
  pipeline.setConfig(config);
  ASSERT_TRUE(pipeline.compute(scene.left, scene.right, &second, nullptr, nullptr));
  EXPECT_EQ(pipeline.matcherBuilds(), 1);
  EXPECT_EQ(cv::norm(first, second, cv::NORM_INF), 0.0);

  config.num_disparities = 48;  // a matcher setting: rebuilt, still correct
  pipeline.setConfig(config);
  ASSERT_TRUE(pipeline.compute(scene.left, scene.right, &second, nullptr, nullptr));
  EXPECT_EQ(pipeline.matcherBuilds(), 2);
  const cv::Rect matchable(48 + 8, 8, kCols - 48 - 16, kRows - 16);
  const RoiCounts c = count(second, scene.truth, matchable);
  EXPECT_GE(c.valid, c.total * 99 / 100);
  EXPECT_EQ(c.wrong, 0);

  config.enable_uniqueness = false;  // changes the matcher's uniqueness ratio
  pipeline.setConfig(config);
  ASSERT_TRUE(pipeline.compute(scene.left, scene.right, &second, nullptr, nullptr));
  EXPECT_EQ(pipeline.matcherBuilds(), 3);
}

TEST(DisparityPipeline, DebugImageColoursEachRemovalReason) {
  const cv::Rect box(150, 60, 80, 120);
  const Scene scene = render({background(10, 11), Layer{box, 34, randomDots(12)}});
  DisparityPipelineConfig config;
  DisparityPipeline plain(config);
  cv::Mat disparity;
  ASSERT_TRUE(plain.compute(scene.left, scene.right, &disparity, nullptr, nullptr));
  EXPECT_TRUE(plain.debugImage().empty());
  EXPECT_TRUE(plain.removalReasons().empty());

  config.debug = true;
  DisparityPipeline debug(config);
  cv::Mat debug_disparity;
  DisparityStats stats;
  ASSERT_TRUE(debug.compute(scene.left, scene.right, &debug_disparity, &stats, nullptr));
  EXPECT_EQ(cv::norm(disparity, debug_disparity, cv::NORM_INF), 0.0);  // same output
  EXPECT_TRUE(stats.step(DisparityStep::kUniqueness).ran);
  EXPECT_EQ(stats.step(DisparityStep::kUniqueness).valid_after,
            stats.step(DisparityStep::kMatching).valid_after);

  const cv::Mat& reasons = debug.removalReasons();
  const cv::Mat& image = debug.debugImage();
  ASSERT_EQ(reasons.type(), CV_8UC1);
  ASSERT_EQ(image.type(), CV_8UC3);
  ASSERT_EQ(image.size(), scene.left.size());
  int removed_by_filters = 0;
  for (int y = 0; y < kRows; ++y) {
    for (int x = 0; x < kCols; ++x) {
      const auto reason = static_cast<DisparityRemoval>(reasons.at<uchar>(y, x));
      ASSERT_EQ(reason == DisparityRemoval::kValid,
                isValidDisparity(debug_disparity.at<float>(y, x)));
      const cv::Vec3b colour = image.at<cv::Vec3b>(y, x);
      if (reason == DisparityRemoval::kValid) {
        ASSERT_TRUE(colour[0] == colour[1] && colour[1] == colour[2] && colour[0] >= 64);
      } else {
        ASSERT_EQ(colour, disparityRemovalColour(reason));
        removed_by_filters += reason != DisparityRemoval::kMatcher;
      }
    }
  }
  EXPECT_GT(removed_by_filters, 0);
  // The matcher's unmatched left border is black.
  EXPECT_EQ(image.at<cv::Vec3b>(kRows / 2, 10), cv::Vec3b(0, 0, 0));
  // The colours are distinct.
  for (int a = 0; a < 7; ++a) {
    for (int b = a + 1; b < 7; ++b) {
      EXPECT_NE(disparityRemovalColour(static_cast<DisparityRemoval>(a)),
                disparityRemovalColour(static_cast<DisparityRemoval>(b)));
    }
  }
}

// ------------------------------------------------------------------------------------------------
// coarse_fill_levels (multi-scale fill, issue 15 "low texture"): a pale surface with weak, smooth
// texture under sensor noise, as the open-world scenes' polished / concrete floors.

/// Smooth texture: Gaussian noise blurred with `blur` px and scaled to `contrast` grey levels
/// (standard deviation) around 128.
cv::Mat weakTexture(std::uint64_t seed, double blur, double contrast) {
  cv::Mat f(kRows, kTextureCols, CV_32FC1);
  cv::RNG rng(seed);
  rng.fill(f, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(f, f, cv::Size(), blur);
  cv::Scalar mean, sd;
  cv::meanStdDev(f, mean, sd);
  cv::Mat t;
  f.convertTo(t, CV_8UC1, contrast / sd[0], 128.0 - mean[0] * contrast / sd[0]);
  return t;
}

/// Independent sensor noise of `sigma` grey levels on each image.
void addNoise(Scene* s, double sigma, std::uint64_t seed) {
  cv::RNG rng(seed);
  for (cv::Mat* m : {&s->left, &s->right}) {
    cv::Mat n(m->size(), CV_16SC1);
    rng.fill(n, cv::RNG::NORMAL, 0.0, sigma);
    cv::Mat sum;
    cv::add(*m, n, sum, cv::noArray(), CV_16SC1);
    sum.convertTo(*m, CV_8UC1);
  }
}

TEST(DisparityPipelineConfig, CoarseFillLevelsAreChecked) {
  DisparityPipelineConfig c;
  EXPECT_EQ(c.coarse_fill_levels, 0);  // off by default
  c.coarse_fill_levels = 4;
  EXPECT_NE(c.validate().find("coarse_fill_levels"), std::string::npos) << c.validate();
  c.coarse_fill_levels = -1;
  EXPECT_NE(c.validate().find("coarse_fill_levels"), std::string::npos) << c.validate();
  c.coarse_fill_levels = 2;
  EXPECT_EQ(c.validate(), "");
}

TEST(DisparityPipeline, CoarseFillFindsAWeakSmoothTextureUnderNoise) {
  Scene scene = render({Layer{cv::Rect(0, 0, kTextureCols, kRows), 20, weakTexture(7, 3.0, 5.0)}});
  addNoise(&scene, 3.0, 11);

  DisparityPipelineConfig config;
  DisparityPipeline fine(config);
  cv::Mat fine_disparity;
  DisparityStats fine_stats;
  std::string error;
  ASSERT_TRUE(fine.compute(scene.left, scene.right, &fine_disparity, &fine_stats, &error)) << error;
  EXPECT_FALSE(fine_stats.step(DisparityStep::kCoarseFill).ran);

  config.coarse_fill_levels = 1;
  DisparityPipeline multi(config);
  cv::Mat disparity;
  DisparityStats stats;
  ASSERT_TRUE(multi.compute(scene.left, scene.right, &disparity, &stats, &error)) << error;
  const RoiCounts f = count(fine_disparity, scene.truth, kMatchable);
  const RoiCounts m = count(disparity, scene.truth, kMatchable);
  std::printf(
      "weak texture under noise: fine %d valid (%d wrong), coarse fill %d (%d wrong) of %d\n",
      f.valid, f.wrong, m.valid, m.wrong, m.total);
  // The full-resolution readings are kept as they were; the fill adds many, nearly all right.
  for (int y = 0; y < kRows; ++y) {
    for (int x = 0; x < kCols; ++x) {
      const float v = fine_disparity.at<float>(y, x);
      if (isValidDisparity(v)) {
        ASSERT_EQ(disparity.at<float>(y, x), v) << x << "," << y;
      }
    }
  }
  EXPECT_LT(f.valid, m.total / 4);
  EXPECT_GT(m.valid, 2 * f.valid);
  EXPECT_GT(m.valid, m.total / 2);
  EXPECT_LT(m.wrong, m.valid / 20);
  const DisparityStepStats& cf = stats.step(DisparityStep::kCoarseFill);
  EXPECT_TRUE(cf.ran);
  EXPECT_EQ(cf.valid_before, stats.step(DisparityStep::kSpikeRemoval).valid_after);
  EXPECT_EQ(cf.valid_after, stats.valid);
  EXPECT_EQ(stats.valid, countValidDisparities(disparity));
}

// A depth step along the image column: the upper half at disparity 12, the lower at 24, both
// with the weak texture under noise 3.
Scene weakStepScene() {
  Scene scene = render(
      {Layer{cv::Rect(0, 0, kTextureCols, kRows / 2), 12, weakTexture(8, 3.0, 5.0)},
       Layer{cv::Rect(0, kRows / 2, kTextureCols, kRows / 2), 24, weakTexture(9, 3.0, 5.0)}});
  addNoise(&scene, 3.0, 12);
  return scene;
}

TEST(DisparityPipeline, CoarseFillKeepsAStepAJump) {
  // A depth step along the image column: the upper half at disparity 12, the lower at 24, both
  // with the weak texture under noise. The fill must give one of the two, never a slope between.
  const Scene scene = weakStepScene();
  DisparityPipelineConfig config;
  config.coarse_fill_levels = 1;
  DisparityPipeline pipeline(config);
  cv::Mat disparity;
  std::string error;
  ASSERT_TRUE(pipeline.compute(scene.left, scene.right, &disparity, nullptr, &error)) << error;
  int valid = 0, between = 0;
  for (int y = kMatchable.y; y < kMatchable.br().y; ++y) {
    for (int x = kMatchable.x; x < kMatchable.br().x; ++x) {
      const float v = disparity.at<float>(y, x);
      if (!isValidDisparity(v)) continue;
      ++valid;
      between += v > 14.0f && v < 22.0f;
    }
  }
  std::printf("step: %d valid, %d between the two surfaces\n", valid, between);
  EXPECT_GT(valid, kMatchable.area() / 2);
  EXPECT_LE(between, valid / 200);
}

TEST(DisparityPipeline, CoarseFillReachesOnlyAsFarAsItsMinimumDisparity) {
  // The two surfaces of the step above (disparity 12 and 24) with coarse_fill_max_depth 1 m for a
  // camera of f b = 18 px m (the reach at disparity 18): the near surface is filled as before,
  // the far one keeps only its full-resolution readings; without f b the fill reaches both.
  const Scene scene = weakStepScene();
  DisparityPipelineConfig config;
  config.coarse_fill_levels = 1;
  DisparityPipeline fine_pipeline(DisparityPipelineConfig{}), all(config);
  config.coarse_fill_max_depth = 1.0;
  DisparityPipeline near(config), unknown(config);
  near.setFocalBaseline(18.0);
  cv::Mat fine, filled, reach;
  std::string error;
  ASSERT_TRUE(fine_pipeline.compute(scene.left, scene.right, &fine, nullptr, &error)) << error;
  ASSERT_TRUE(all.compute(scene.left, scene.right, &filled, nullptr, &error)) << error;
  ASSERT_TRUE(near.compute(scene.left, scene.right, &reach, nullptr, &error)) << error;
  cv::Mat without_geometry;
  ASSERT_TRUE(unknown.compute(scene.left, scene.right, &without_geometry, nullptr, &error))
      << error;
  EXPECT_EQ(cv::countNonZero(without_geometry != filled), 0);
  int far_fine = 0, far_reach = 0, far_all = 0, near_all = 0, near_reach = 0;
  // Rows within a coarse window of the step are left out: there the window fattens the near
  // surface over the far one, which is the fill's rule at an edge, not its reach.
  const int margin = 2 * config.block_size;
  for (int y = kMatchable.y; y < kMatchable.br().y; ++y) {
    if (std::abs(y - kRows / 2) < margin) continue;
    const bool far_half = y < kRows / 2;
    for (int x = kMatchable.x; x < kMatchable.br().x; ++x) {
      const bool f = isValidDisparity(fine.at<float>(y, x));
      const bool a = isValidDisparity(filled.at<float>(y, x));
      const bool r = isValidDisparity(reach.at<float>(y, x));
      if (far_half) {
        far_fine += f;
        far_all += a;
        far_reach += r;
        // Beyond the reach only full-resolution readings, unchanged.
        if (r) ASSERT_EQ(reach.at<float>(y, x), fine.at<float>(y, x)) << x << "," << y;
      } else {
        near_all += a;
        near_reach += r;
      }
    }
  }
  std::printf("far half: fine %d, filled %d, within reach %d; near half: filled %d, within %d\n",
              far_fine, far_all, far_reach, near_all, near_reach);
  EXPECT_GT(far_all, 2 * far_fine);  // the fill reaches the far surface when unlimited
  EXPECT_EQ(far_reach, far_fine);
  EXPECT_GT(near_reach, near_all * 9 / 10);
  DisparityPipelineConfig bad;
  bad.coarse_fill_max_depth = -1.0;
  EXPECT_NE(bad.validate().find("coarse_fill_max_depth"), std::string::npos);
}

TEST(DisparityPipeline, CoarseFillPutsNothingBehindANearThinEdge) {
  // The edge of a table top: a strip 6 rows high, well textured, at disparity 30 in front of a
  // pale far surface at 12. The coarse window fattens the far surface over the strip's rows; a
  // far reading just above or below the strip would cast a ray through the table top.
  Scene scene = render({Layer{cv::Rect(0, 0, kTextureCols, kRows), 12, weakTexture(10, 3.0, 5.0)},
                        Layer{cv::Rect(0, 117, kTextureCols, 6), 30, randomDots(4)}});
  addNoise(&scene, 3.0, 13);
  DisparityPipelineConfig config;
  DisparityPipeline fine(config);
  cv::Mat fine_disparity, disparity;
  std::string error;
  ASSERT_TRUE(fine.compute(scene.left, scene.right, &fine_disparity, nullptr, &error)) << error;
  config.coarse_fill_levels = 1;
  DisparityPipeline multi(config);
  ASSERT_TRUE(multi.compute(scene.left, scene.right, &disparity, nullptr, &error)) << error;
  int strip = 0, filled = 0;
  for (int y = kMatchable.y; y < kMatchable.br().y; ++y) {
    for (int x = kMatchable.x; x < kMatchable.br().x; ++x) {
      strip += y >= 117 && y < 123 && std::fabs(fine_disparity.at<float>(y, x) - 30.0f) <= 1.0f;
      const float v = disparity.at<float>(y, x);
      if (isValidDisparity(fine_disparity.at<float>(y, x)) || !isValidDisparity(v)) continue;
      ++filled;
      // Every filled reading: no full-resolution reading within block_size px is nearer.
      const cv::Rect around = cv::Rect(x - config.block_size, y - config.block_size,
                                       2 * config.block_size + 1, 2 * config.block_size + 1) &
                              cv::Rect(0, 0, kCols, kRows);
      double nearest = 0.0;
      cv::minMaxLoc(fine_disparity(around), nullptr, &nearest);
      ASSERT_LE(nearest, v + config.left_right.max_difference + 1.0) << x << "," << y;
    }
  }
  EXPECT_GT(strip, kMatchable.width * 3);    // the strip is seen at full resolution
  EXPECT_GT(filled, kMatchable.area() / 2);  // and the far surface filled away from it
}

TEST(DisparityPipeline, CoarseFillIsSkippedWhenTheShrunkPairIsTooSmall) {
  // 48 columns: enough for 16 disparities and a 9-pixel window, not at half size (24 columns).
  cv::Mat left = randomDots(5)(cv::Rect(0, 0, 48, 40)).clone();
  cv::Mat right = left.clone();
  DisparityPipelineConfig config;
  config.num_disparities = 16;
  config.coarse_fill_levels = 2;
  DisparityPipeline pipeline(config);
  cv::Mat disparity;
  DisparityStats stats;
  std::string error;
  ASSERT_TRUE(pipeline.compute(left, right, &disparity, &stats, &error)) << error;
  EXPECT_TRUE(stats.step(DisparityStep::kCoarseFill).ran);
  EXPECT_EQ(stats.step(DisparityStep::kCoarseFill).valid_after,
            stats.step(DisparityStep::kCoarseFill).valid_before);
}

}  // namespace
}  // namespace stereo_safety_map
