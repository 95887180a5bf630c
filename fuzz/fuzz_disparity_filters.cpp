// libFuzzer target: disparity post-filters, the disparity pipeline, the degraded-camera check
// (stereo_input_check.h) and reprojection on random images (sizes, element types, row steps,
// regions of interest), random configurations (valid and not) and random disparity values (NaN,
// inf, negative, huge).
//
// Contracts checked (disparity_filters.h): a filter that returns -1 leaves the image untouched;
// otherwise it only turns valid pixels into exactly 0, as many as it returns, and never rewrites
// an invalid pixel. The pipeline never throws. Reprojection keeps no NaN depth.
#include "fuzz_common.h"

#include "stereo_safety_map/core/disparity_filters.h"
#include "stereo_safety_map/core/disparity_pipeline.h"
#include "stereo_safety_map/core/stereo_camera_model.h"
#include "stereo_safety_map/core/stereo_input_check.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

using namespace stereo_safety_map;
using ssm_fuzz::mostlyInRange;
using ssm_fuzz::mostlyIntInRange;

namespace {

bool sameBits(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  const std::size_t row_bytes = static_cast<std::size_t>(a.cols) * a.elemSize();
  for (int r = 0; r < a.rows; ++r) {
    if (std::memcmp(a.ptr(r), b.ptr(r), row_bytes) != 0) return false;
  }
  return true;
}

// Checks a filter's result against the image before it (see the file comment).
void checkFilterResult(const cv::Mat& before, const cv::Mat& after, int result) {
  if (result < 0) {
    FUZZ_CHECK(result == -1);
    FUZZ_CHECK(sameBits(before, after));
    return;
  }
  FUZZ_CHECK(before.type() == CV_32FC1 && after.type() == CV_32FC1);
  int changed = 0;
  for (int r = 0; r < before.rows; ++r) {
    const float* b = before.ptr<float>(r);
    const float* a = after.ptr<float>(r);
    for (int c = 0; c < before.cols; ++c) {
      if (std::memcmp(&a[c], &b[c], sizeof(float)) == 0) continue;
      FUZZ_CHECK(isValidDisparity(b[c]));     // only valid pixels are rewritten
      FUZZ_CHECK(a[c] == kInvalidDisparity);  // and only into exactly 0
      ++changed;
    }
  }
  FUZZ_CHECK(changed == result);
}

int randomType(FuzzedDataProvider& fdp, bool disparity) {
  static const int kDisparityTypes[] = {CV_32FC1, CV_32FC1, CV_32FC1, CV_32FC1, CV_32FC1,
                                        CV_32FC2, CV_64FC1, CV_16SC1, CV_8UC1};
  static const int kImageTypes[] = {CV_8UC1,  CV_8UC1,  CV_8UC3, CV_8UC4,
                                    CV_16UC1, CV_32FC1, CV_8UC2};
  return disparity ? fdp.PickValueInArray(kDisparityTypes) : fdp.PickValueInArray(kImageTypes);
}

// A disparity-like image of the given size and type: float types get disparity values, the
// others raw bytes.
cv::Mat randomImage(FuzzedDataProvider& fdp, int rows, int cols, int type, float max_value,
                    cv::Mat* storage) {
  if (rows <= 0 || cols <= 0) return cv::Mat();
  cv::Mat m = ssm_fuzz::makeStridedMat(fdp, rows, cols, type, storage);
  if (CV_MAT_DEPTH(type) == CV_32F) {
    ssm_fuzz::fillFloats(fdp, max_value, &m);
  } else {
    ssm_fuzz::fillBytes(fdp, &m);
  }
  return m;
}

void fuzzFilters(FuzzedDataProvider& fdp, DisparityFilterWorkspace* ws) {
  const int rows = fdp.ConsumeIntegralInRange<int>(0, 48);
  const int cols = fdp.ConsumeIntegralInRange<int>(0, 64);
  cv::Mat storage, other_storage;
  cv::Mat disparity = randomImage(fdp, rows, cols, randomType(fdp, true), 80.0f, &storage);
  // Workspaces are reused across calls and across images of different sizes.
  DisparityFilterWorkspace* workspace = fdp.ConsumeBool() ? ws : nullptr;

  const int calls = fdp.ConsumeIntegralInRange<int>(1, 6);
  for (int i = 0; i < calls && fdp.remaining_bytes() > 0; ++i) {
    const cv::Mat before = disparity.clone();
    int result = 0;
    switch (fdp.ConsumeIntegralInRange<int>(0, 6)) {
      case 0: {
        result = sanitizeDisparity(&disparity);
        if (result >= 0) {
          for (int r = 0; r < disparity.rows; ++r) {
            for (int c = 0; c < disparity.cols; ++c) {
              const float b = before.at<float>(r, c), a = disparity.at<float>(r, c);
              FUZZ_CHECK(isValidDisparity(b) ? std::memcmp(&a, &b, sizeof(float)) == 0
                                             : a == kInvalidDisparity);
            }
          }
        } else {
          FUZZ_CHECK(sameBits(before, disparity));
        }
        continue;
      }
      case 1: {
        const int n = countValidDisparities(disparity);
        if (disparity.empty() || disparity.type() != CV_32FC1) {
          FUZZ_CHECK(n == -1);
        } else {
          int expected = 0;
          for (int r = 0; r < disparity.rows; ++r) {
            for (int c = 0; c < disparity.cols; ++c) {
              expected += isValidDisparity(disparity.at<float>(r, c)) ? 1 : 0;
            }
          }
          FUZZ_CHECK(n == expected);
        }
        continue;
      }
      case 2: {
        TextureValidationConfig config;
        config.log_sigma = mostlyInRange(fdp, 0.1, 4.0);
        config.window_size = mostlyIntInRange(fdp, 0, 15);
        config.min_energy = mostlyInRange(fdp, 0.0, 20.0);
        // Left image: usually matching, sometimes of another size or type.
        int lr = rows, lc = cols;
        if (fdp.ConsumeIntegralInRange<int>(0, 7) == 0) {
          lr = fdp.ConsumeIntegralInRange<int>(0, 48);
          lc = fdp.ConsumeIntegralInRange<int>(0, 64);
        }
        const int type =
            fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? randomType(fdp, false) : CV_8UC1;
        const cv::Mat left = randomImage(fdp, lr, lc, type, 255.0f, &other_storage);
        result = filterLowTexture(left, config, &disparity, workspace);
        break;
      }
      case 3: {
        MatchUniquenessConfig config;
        config.uniqueness_ratio = mostlyIntInRange(fdp, 0, 100);
        config.max_normalized_cost = mostlyInRange(fdp, 0.0, 1.0);
        const int min_disparity = mostlyIntInRange(fdp, -8, 32);
        int vr = rows, vc = cols;
        if (fdp.ConsumeIntegralInRange<int>(0, 7) == 0) {
          vr = fdp.ConsumeIntegralInRange<int>(0, 48);
          vc = fdp.ConsumeIntegralInRange<int>(0, 64);
        }
        const int nd = fdp.ConsumeIntegralInRange<int>(0, 24);
        cv::Mat volume;
        if (vr > 0 && vc > 0 && nd > 0) {
          const int sizes[3] = {vr, vc, nd};
          volume.create(3, sizes, CV_32FC1);
          const std::size_t n = static_cast<std::size_t>(vr) * vc * nd;
          float* v = volume.ptr<float>();
          for (std::size_t k = 0; k < n; ++k) {
            v[k] = fdp.remaining_bytes() > 0
                       ? (fdp.ConsumeIntegralInRange<int>(0, 31) == 0
                              ? ssm_fuzz::specialFloat(fdp, -10.0f, 1000.0f)
                              : static_cast<float>(fdp.ConsumeIntegral<std::uint8_t>()))
                       : static_cast<float>(k % 13);
          }
        } else if (fdp.ConsumeBool()) {
          volume = cv::Mat(vr > 0 ? vr : 1, vc > 0 ? vc : 1, CV_32FC1, cv::Scalar(1.0f));
        }
        result = filterNonUniqueMatches(volume, min_disparity, config, &disparity);
        break;
      }
      case 4: {
        LeftRightCheckConfig config;
        config.max_difference = mostlyInRange(fdp, 0.0, 3.0);
        config.reject_if_right_invalid = fdp.ConsumeBool();
        int rr = rows, rc = cols;
        if (fdp.ConsumeIntegralInRange<int>(0, 7) == 0) {
          rr = fdp.ConsumeIntegralInRange<int>(0, 48);
          rc = fdp.ConsumeIntegralInRange<int>(0, 64);
        }
        const int type =
            fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? randomType(fdp, true) : CV_32FC1;
        const cv::Mat right = randomImage(fdp, rr, rc, type, 80.0f, &other_storage);
        result = filterLeftRightInconsistent(right, config, &disparity);
        break;
      }
      case 5: {
        SpikeRemovalConfig config;
        config.max_difference = mostlyInRange(fdp, 0.01, 3.0);
        config.min_region_size = mostlyIntInRange(fdp, 1, 40);
        result = filterSpikes(config, &disparity, workspace);
        break;
      }
      default: {
        NeighbourConsistencyConfig config;
        config.window_radius = mostlyIntInRange(fdp, 1, 5);
        config.max_difference = mostlyInRange(fdp, 0.0, 3.0);
        config.min_agreeing_fraction = mostlyInRange(fdp, 0.01, 1.0);
        config.remove_isolated = fdp.ConsumeBool();
        result = filterInconsistentNeighbours(config, &disparity, workspace);
        break;
      }
    }
    checkFilterResult(before, disparity, result);
  }

  // Reprojection of whatever is left, with a random (possibly invalid) camera model.
  StereoCameraModel model;
  model.fx = mostlyInRange(fdp, 10.0, 1000.0);
  model.fy = mostlyInRange(fdp, 10.0, 1000.0);
  model.cx = mostlyInRange(fdp, -10.0, 80.0);
  model.cy = mostlyInRange(fdp, -10.0, 60.0);
  model.cx_right = fdp.ConsumeBool() ? model.cx : mostlyInRange(fdp, -10.0, 80.0);
  model.baseline = mostlyInRange(fdp, 0.01, 0.5);
  model.width = fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? mostlyIntInRange(fdp, 0, 80) : cols;
  model.height = fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? mostlyIntInRange(fdp, 0, 60) : rows;
  const double min_depth = mostlyInRange(fdp, 0.0, 2.0);
  const double max_depth = mostlyInRange(fdp, 2.0, 50.0);
  const int step = mostlyIntInRange(fdp, 1, 4);
  std::vector<Eigen::Vector3f> points;
  reprojectDisparity(disparity, model, min_depth, max_depth, step, &points);
  for (const Eigen::Vector3f& p : points)
    FUZZ_CHECK(!std::isnan(p.z()));
  cv::Mat xyz;
  reprojectDisparityOrganized(disparity, model, max_depth, &xyz);
}

void fuzzPipeline(FuzzedDataProvider& fdp, DisparityPipeline* pipeline) {
  DisparityPipelineConfig config;
  config.matcher =
      fdp.ConsumeBool() ? StereoMatcherType::kBlockMatching : StereoMatcherType::kSemiGlobal;
  config.min_disparity = mostlyIntInRange(fdp, 0, 16, 16);
  // Multiples of 16 / odd values, and now and then an extreme int as it is (no overflow here).
  const int nd = mostlyIntInRange(fdp, 1, 2, 16);
  config.num_disparities = (nd > -1000 && nd < 1000) ? 16 * nd : nd;
  const int bs = mostlyIntInRange(fdp, 0, 7, 16);
  config.block_size = (bs > -1000 && bs < 1000) ? 2 * bs + 1 : bs;
  config.pre_filter_cap = mostlyIntInRange(fdp, 1, 63, 16);
  config.bm_texture_threshold = mostlyIntInRange(fdp, 0, 20, 16);
  config.speckle_window_size = mostlyIntInRange(fdp, 0, 50, 16);
  config.speckle_range = mostlyIntInRange(fdp, 0, 4, 16);
  config.sgbm_p1 = mostlyIntInRange(fdp, 0, 200, 16);
  config.sgbm_p2 = mostlyIntInRange(fdp, 0, 800, 16);
  config.sgbm_three_way = fdp.ConsumeBool();
  config.enable_uniqueness = fdp.ConsumeBool();
  config.uniqueness.uniqueness_ratio = mostlyIntInRange(fdp, 0, 30, 16);
  config.enable_texture = fdp.ConsumeBool();
  config.texture.window_size = config.block_size;
  config.texture.min_energy = mostlyInRange(fdp, 0.0, 5.0, 16);
  config.enable_left_right = fdp.ConsumeBool();
  config.enable_neighbour_consistency = fdp.ConsumeBool();
  config.enable_spike_removal = fdp.ConsumeBool();
  config.spike_removal.min_region_size = mostlyIntInRange(fdp, 1, 50, 16);
  config.debug = fdp.ConsumeBool();
  pipeline->setConfig(config);

  const int rows = fdp.ConsumeIntegralInRange<int>(0, 40);
  const int cols = fdp.ConsumeIntegralInRange<int>(0, 112);
  const int left_type = randomType(fdp, false);
  const int right_type =
      fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? randomType(fdp, false) : left_type;
  int right_rows = rows, right_cols = cols;
  if (fdp.ConsumeIntegralInRange<int>(0, 7) == 0) {
    right_rows = fdp.ConsumeIntegralInRange<int>(0, 40);
    right_cols = fdp.ConsumeIntegralInRange<int>(0, 112);
  }
  cv::Mat ls, rs;
  const cv::Mat left = randomImage(fdp, rows, cols, left_type, 255.0f, &ls);
  cv::Mat right;
  if (fdp.ConsumeBool() && right_type == left_type && right_rows == rows && right_cols == cols &&
      !left.empty()) {
    // A shifted copy of the left image, so that the matcher finds real matches.
    right = cv::Mat::zeros(rows, cols, left_type);
    const int shift = fdp.ConsumeIntegralInRange<int>(0, 20);
    if (shift < cols) left.colRange(shift, cols).copyTo(right.colRange(0, cols - shift));
  } else {
    right = randomImage(fdp, right_rows, right_cols, right_type, 255.0f, &rs);
  }
  cv::Mat disparity;
  DisparityStats stats;
  std::string error;
  const bool ok = pipeline->compute(left, right, &disparity, fdp.ConsumeBool() ? &stats : nullptr,
                                    fdp.ConsumeBool() ? &error : nullptr);
  if (ok) {
    FUZZ_CHECK(disparity.type() == CV_32FC1 && disparity.rows == rows && disparity.cols == cols);
    for (int r = 0; r < disparity.rows; ++r) {
      for (int c = 0; c < disparity.cols; ++c) {
        const float d = disparity.at<float>(r, c);
        FUZZ_CHECK(isValidDisparity(d) || d == kInvalidDisparity);
      }
    }
  }
}

// The degraded-camera check (stereo_input_check.h) on random pairs of any type and size, views
// and copies: never throws; refuses mismatched or non-8-bit-grey pairs as kBadImage and only
// them; a pair checked twice in a row is never accepted the second time while frozen images
// are rejected.
void fuzzInputCheck(FuzzedDataProvider& fdp) {
  StereoInputCheckConfig config;
  config.min_contrast = fdp.ConsumeIntegralInRange<int>(0, 7) == 0
                            ? ssm_fuzz::specialDouble(fdp, 0.0, 10.0)
                            : fdp.ConsumeFloatingPointInRange<double>(0.0, 10.0);
  config.reject_frozen = fdp.ConsumeBool();
  if (!config.validate().empty()) {
    bool threw = false;
    try {
      StereoInputCheck refused(config);
    } catch (const std::invalid_argument&) {
      threw = true;
    }
    FUZZ_CHECK(threw);
    return;
  }
  StereoInputCheck check(config);
  const int pairs = fdp.ConsumeIntegralInRange<int>(1, 4);
  for (int i = 0; i < pairs && fdp.remaining_bytes() > 0; ++i) {
    const int rows = fdp.ConsumeIntegralInRange<int>(0, 24);
    const int cols = fdp.ConsumeIntegralInRange<int>(0, 32);
    const int lt = fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? randomType(fdp, false) : CV_8UC1;
    const int rt = fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? randomType(fdp, false) : CV_8UC1;
    const int rrows = fdp.ConsumeIntegralInRange<int>(0, 7) == 0 ? rows + 1 : rows;
    cv::Mat ls, rs;
    const cv::Mat left =
        rows > 0 && cols > 0 ? randomImage(fdp, rows, cols, lt, 64.0f, &ls) : cv::Mat();
    const cv::Mat right =
        rrows > 0 && cols > 0 ? randomImage(fdp, rrows, cols, rt, 64.0f, &rs) : cv::Mat();
    std::string detail;
    const StereoInputProblem p = check.check(left, right, &detail);
    const bool usable = !left.empty() && !right.empty() && left.type() == CV_8UC1 &&
                        right.type() == CV_8UC1 && left.size() == right.size();
    FUZZ_CHECK((p == StereoInputProblem::kBadImage) == !usable);
    FUZZ_CHECK((p == StereoInputProblem::kNone) == detail.empty());
    if (usable && config.reject_frozen) {
      FUZZ_CHECK(check.check(left.clone(), right.clone()) != StereoInputProblem::kNone);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  cv::setNumThreads(0);  // deterministic, and no thread pool for ASan to track
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Fresh state per input so that every crash reproduces from its input alone; within one input
  // the workspace and the pipeline (with its matcher cache) are reused across calls.
  DisparityFilterWorkspace workspace;
  DisparityPipeline pipeline;
  FuzzedDataProvider fdp(data, size);
  const int mode = fdp.ConsumeIntegralInRange<int>(0, 7);
  if (mode == 0) {
    fuzzInputCheck(fdp);
  } else if (mode <= 2) {
    const int frames = fdp.ConsumeIntegralInRange<int>(1, 2);
    for (int i = 0; i < frames; ++i)
      fuzzPipeline(fdp, &pipeline);
  } else {
    const int images = fdp.ConsumeIntegralInRange<int>(1, 2);
    for (int i = 0; i < images; ++i)
      fuzzFilters(fdp, &workspace);
  }
  return 0;
}
