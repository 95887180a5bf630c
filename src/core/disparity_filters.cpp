#include "stereo_safety_map/core/disparity_filters.h"

#include <opencv2/imgproc.hpp>

#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

namespace stereo_safety_map {

namespace {

bool isFloatImage(const cv::Mat* m) {
  return m != nullptr && !m->empty() && m->type() == CV_32FC1 && m->dims == 2;
}

template <typename T>
std::string rangeError(const char* name, T value, const char* range) {
  std::ostringstream s;
  s << name << " = " << value << " must be in " << range;
  return s.str();
}

// Copies `src` into the interior of `dst` with every invalid pixel as exactly 0, surrounded by
// `border` zero rows / columns (plus `extra_right` more zero columns), so that neighbour look-ups
// need no bounds checks.
void copyWithInvalidBorder(const cv::Mat& src, int border, int extra_right, cv::Mat* dst) {
  dst->create(src.rows + 2 * border, src.cols + 2 * border + extra_right, CV_32FC1);
  const std::size_t row_bytes = static_cast<std::size_t>(dst->cols) * sizeof(float);
  for (int y = 0; y < border; ++y) {
    std::memset(dst->ptr<float>(y), 0, row_bytes);
    std::memset(dst->ptr<float>(dst->rows - 1 - y), 0, row_bytes);
  }
  for (int y = 0; y < src.rows; ++y) {
    const float* in = src.ptr<float>(y);
    float* out = dst->ptr<float>(y + border);
    std::fill(out, out + border, 0.0f);
    std::fill(out + border + src.cols, out + dst->cols, 0.0f);
    out += border;
    for (int x = 0; x < src.cols; ++x)
      out[x] = isValidDisparity(in[x]) ? in[x] : 0.0f;
  }
}

// Adds, per column, whether one neighbour is valid and whether it agrees with the centre.
// Distinct buffers (__restrict) and a length that is a multiple of 8 let -O2 vectorise it.
void accumulateAgreement(const float* __restrict neighbour, const float* __restrict centre,
                         float tolerance, int n, float* __restrict valid, float* __restrict agree) {
  for (int x = 0; x < n; ++x) {
    const float v = neighbour[x];
    const float ok = v > 0.0f ? 1.0f : 0.0f;
    valid[x] += ok;
    agree[x] += std::fabs(v - centre[x]) <= tolerance ? ok : 0.0f;
  }
}

}  // namespace

int sanitizeDisparity(cv::Mat* disparity) {
  if (!isFloatImage(disparity)) return -1;
  int rewritten = 0;
  for (int y = 0; y < disparity->rows; ++y) {
    float* row = disparity->ptr<float>(y);
    for (int x = 0; x < disparity->cols; ++x) {
      const float d = row[x];
      if (!isValidDisparity(d) && d != kInvalidDisparity) {
        row[x] = kInvalidDisparity;
        ++rewritten;
      }
    }
  }
  return rewritten;
}

int countValidDisparities(const cv::Mat& disparity) {
  if (!isFloatImage(&disparity)) return -1;
  int valid = 0;
  for (int y = 0; y < disparity.rows; ++y) {
    const float* row = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x)
      valid += isValidDisparity(row[x]) ? 1 : 0;
  }
  return valid;
}

// ------------------------------------------------------------------------------------------------
std::string TextureValidationConfig::validate() const {
  if (!(log_sigma > 0.0 && log_sigma <= 10.0)) return rangeError("log_sigma", log_sigma, "(0, 10]");
  if (window_size < 1 || window_size > 255 || window_size % 2 == 0) {
    return rangeError("window_size", window_size, "odd values of [1, 255]");
  }
  if (!(min_energy >= 0.0 && std::isfinite(min_energy))) {
    return rangeError("min_energy", min_energy, "[0, inf)");
  }
  return {};
}

namespace {

// OpenCV's own ksize for a float GaussianBlur with ksize (0, 0).
int gaussianTaps(double sigma) {
  return cvRound(sigma * 4 * 2 + 1) | 1;
}

bool cpuHasAvx2Fma() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}

// |Laplacian| (ksize 1, borders replicated) of row y of the w x h image `blurred` into a[0, w),
// with rw replicated columns on each side: textureEnergyOwn()'s third step.
__attribute__((target("avx2,fma"))) void absLaplacianRow(const float* blurred, int w, int h, int y,
                                                         int rw, float* a) {
  const __m256 minus4 = _mm256_set1_ps(-4.0f);
  const __m256 sign = _mm256_set1_ps(-0.0f);
  auto clampRow = [h](int yy) { return std::min(std::max(yy, 0), h - 1); };
  const float* up = blurred + static_cast<std::size_t>(clampRow(y - 1)) * w;
  const float* c = blurred + static_cast<std::size_t>(y) * w;
  const float* down = blurred + static_cast<std::size_t>(clampRow(y + 1)) * w;
  auto laplacian = [&](int x) {
    float s = up[x] + c[x > 0 ? x - 1 : 0];
    s = s + -4.0f * c[x];
    s = s + c[x < w - 1 ? x + 1 : w - 1];
    s = s + down[x];
    return std::fabs(s);
  };
  a[0] = laplacian(0);
  int x = 1;
  for (; x + 8 <= w - 1; x += 8) {
    __m256 s = _mm256_add_ps(_mm256_loadu_ps(up + x), _mm256_loadu_ps(c + x - 1));
    s = _mm256_fmadd_ps(_mm256_loadu_ps(c + x), minus4, s);  // exact product: same as add
    s = _mm256_add_ps(s, _mm256_loadu_ps(c + x + 1));
    s = _mm256_add_ps(s, _mm256_loadu_ps(down + x));
    _mm256_storeu_ps(a + x, _mm256_andnot_ps(sign, s));
  }
  for (; x < w; ++x)
    a[x] = laplacian(x);
  for (int k = 1; k <= rw; ++k) {
    a[-k] = a[0];
    a[w - 1 + k] = a[w - 1];
  }
}

// One row of textureEnergyOwn()'s box filter down the columns: s0 = column + in, the output
// (float)(s0 * scale), column = s0 - out (OpenCV's running column sums in double).
__attribute__((target("avx2,fma"))) void boxColumnRow(const double* in, const double* out,
                                                      double scale, int w, double* column,
                                                      float* o) {
  const __m256d scale4 = _mm256_set1_pd(scale);
  int x = 0;
  for (; x + 4 <= w; x += 4) {
    const __m256d s0 = _mm256_add_pd(_mm256_loadu_pd(column + x), _mm256_loadu_pd(in + x));
    _mm_storeu_ps(o + x, _mm256_cvtpd_ps(_mm256_mul_pd(s0, scale4)));
    _mm256_storeu_pd(column + x, _mm256_sub_pd(s0, _mm256_loadu_pd(out + x)));
  }
  for (; x < w; ++x) {
    const double s0 = column[x] + in[x];
    o[x] = static_cast<float>(s0 * scale);
    column[x] = s0 - out[x];
  }
}

// The texture energy as OpenCV 4.6 computes it on a CPU with AVX2 (its filter code is dispatched
// there and uses FMA), step for step, so that every float is the same:
//  - GaussianBlur (ksize >= 7: RowFilter, then SymmColumnFilter): along the row
//    s = fma(x[i + k], kx[k], s) for k = 0..ksize-1 from s = 0; down the column
//    s = c * ky[r], then s = fma(below_k + above_k, ky[r + k], s) for k = 1..r;
//  - Laplacian, ksize 1 (Filter2D over the kernel's non-zero taps in row order):
//    ((((up + left) + (-4) * centre) + right) + down), then |.|;
//  - normalised boxFilter: running sums in double, along the row (first window summed left to
//    right, then s += (in - out)), then down the columns (sum of the first ksize - 1 rows, then
//    s0 = sum + in, out = (float)(s0 * (1 / ksize^2)), sum = s0 - out);
// every border replicated. test_disparity_filters compares it with OpenCV's calls.
__attribute__((target("avx2,fma"))) void textureEnergyOwn(const cv::Mat& left,
                                                          const TextureValidationConfig& config,
                                                          DisparityFilterWorkspace* ws,
                                                          cv::Mat* energy) {
  const int w = left.cols, h = left.rows;
  const int taps = gaussianTaps(config.log_sigma), r = taps / 2;
  if (ws->texture_kernel.size() != static_cast<std::size_t>(taps) ||
      ws->texture_kernel_sigma != config.log_sigma) {
    const cv::Mat kernel = cv::getGaussianKernel(taps, config.log_sigma, CV_32F);
    ws->texture_kernel.assign(kernel.ptr<float>(), kernel.ptr<float>() + taps);
    ws->texture_kernel_sigma = config.log_sigma;
  }
  const float* kx = ws->texture_kernel.data();
  const std::size_t area = static_cast<std::size_t>(w) * h;
  ws->texture_rows.resize(area);
  ws->texture_blurred.resize(area);
  const int rw = config.window_size / 2;
  const int padded = w + 2 * std::max(r, rw) + 8;
  ws->texture_row.resize(static_cast<std::size_t>(padded));
  ws->texture_column.assign(static_cast<std::size_t>(w), 0.0);

  // Gaussian along the rows.
  float* e = ws->texture_row.data();
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* s = left.ptr<std::uint8_t>(y);
    for (int x = 0; x < r; ++x) {
      e[x] = s[0];
      e[r + w + x] = s[w - 1];
    }
    for (int x = 0; x < w; ++x)
      e[r + x] = s[x];
    float* o = ws->texture_rows.data() + static_cast<std::size_t>(y) * w;
    int x = 0;
    for (; x + 8 <= w; x += 8) {
      __m256 acc = _mm256_setzero_ps();
      for (int k = 0; k < taps; ++k)
        acc = _mm256_fmadd_ps(_mm256_loadu_ps(e + x + k), _mm256_set1_ps(kx[k]), acc);
      _mm256_storeu_ps(o + x, acc);
    }
    for (; x < w; ++x) {
      float acc = 0.0f;
      for (int k = 0; k < taps; ++k)
        acc = std::fma(e[x + k], kx[k], acc);
      o[x] = acc;
    }
  }

  // Gaussian down the columns (symmetric kernel: the two rows at +-k added first).
  auto clampRow = [h](int y) { return std::min(std::max(y, 0), h - 1); };
  for (int y = 0; y < h; ++y) {
    const float* rows = ws->texture_rows.data();
    const float* c = rows + static_cast<std::size_t>(y) * w;
    float* o = ws->texture_blurred.data() + static_cast<std::size_t>(y) * w;
    int x = 0;
    for (; x + 8 <= w; x += 8) {
      __m256 acc = _mm256_mul_ps(_mm256_loadu_ps(c + x), _mm256_set1_ps(kx[r]));
      for (int k = 1; k <= r; ++k) {
        const float* below = rows + static_cast<std::size_t>(clampRow(y + k)) * w;
        const float* above = rows + static_cast<std::size_t>(clampRow(y - k)) * w;
        acc = _mm256_fmadd_ps(_mm256_add_ps(_mm256_loadu_ps(below + x), _mm256_loadu_ps(above + x)),
                              _mm256_set1_ps(kx[r + k]), acc);
      }
      _mm256_storeu_ps(o + x, acc);
    }
    for (; x < w; ++x) {
      float acc = c[x] * kx[r];
      for (int k = 1; k <= r; ++k) {
        const float below = rows[static_cast<std::size_t>(clampRow(y + k)) * w + x];
        const float above = rows[static_cast<std::size_t>(clampRow(y - k)) * w + x];
        acc = std::fma(below + above, kx[r + k], acc);
      }
      o[x] = acc;
    }
  }

  // |Laplacian| of each row, then its window sums along the row. The running sum of a row is one
  // chain of dependent double additions; four rows at a time run four chains side by side
  // (issue 18), each with its row's operations in the same order.
  const std::size_t lane = static_cast<std::size_t>(padded);
  ws->texture_log.resize(4 * lane);
  auto firstSum = [&](const float* a) {
    double s = 0.0;
    for (int k = -rw; k <= rw; ++k)
      s += static_cast<double>(a[k]);
    return s;
  };
  // The window sums of a row go into a ring of `ring` rows, and each energy row is written as
  // soon as the rows of its window are in it (issue 18: a full-image double buffer went through
  // memory twice). The ring holds what the consumer still needs: rows y - rw .. y + rw of the
  // next output row y, and at most the four rows produced ahead of it.
  const int ring = 2 * rw + 8;
  ws->texture_sums.resize(static_cast<std::size_t>(ring) * w);
  auto sumsRow = [&](int row) {
    return ws->texture_sums.data() + static_cast<std::size_t>(row % ring) * w;
  };
  energy->create(h, w, CV_32FC1);
  const double scale = 1.0 / (static_cast<double>(config.window_size) * config.window_size);
  double* column = ws->texture_column.data();
  int produced = 0, next_out = 0;
  // Window sums down the columns, scaled to the mean, for every row whose window is complete.
  auto consume = [&]() {
    while (next_out < h && clampRow(next_out + rw) < produced) {
      if (next_out == 0) {
        for (int k = -rw; k < rw; ++k) {
          const double* in = sumsRow(clampRow(k));
          for (int x = 0; x < w; ++x)
            column[x] += in[x];
        }
      }
      boxColumnRow(sumsRow(clampRow(next_out + rw)), sumsRow(clampRow(next_out - rw)), scale, w,
                   column, energy->ptr<float>(next_out));
      ++next_out;
    }
  };
  int y = 0;
  for (; y + 4 <= h; y += 4) {
    float* a[4];
    double* sums[4];
    double s[4];
    for (int j = 0; j < 4; ++j) {
      a[j] = ws->texture_log.data() + j * lane + rw;
      absLaplacianRow(ws->texture_blurred.data(), w, h, y + j, rw, a[j]);
      sums[j] = sumsRow(y + j);
      s[j] = firstSum(a[j]);
      sums[j][0] = s[j];
    }
    for (int xx = 1; xx < w; ++xx) {
      for (int j = 0; j < 4; ++j) {
        s[j] += static_cast<double>(a[j][xx + rw]) - static_cast<double>(a[j][xx - rw - 1]);
        sums[j][xx] = s[j];
      }
    }
    produced = y + 4;
    consume();
  }
  for (; y < h; ++y) {
    float* a = ws->texture_log.data() + rw;
    absLaplacianRow(ws->texture_blurred.data(), w, h, y, rw, a);
    double* sums = sumsRow(y);
    double s = firstSum(a);
    sums[0] = s;
    for (int xx = 1; xx < w; ++xx) {
      s += static_cast<double>(a[xx + rw]) - static_cast<double>(a[xx - rw - 1]);
      sums[xx] = s;
    }
    produced = y + 1;
    consume();
  }
}

}  // namespace

bool textureEnergy(const cv::Mat& left, const TextureValidationConfig& config, cv::Mat* energy,
                   DisparityFilterWorkspace* workspace, bool opencv_only) {
  if (energy == nullptr || left.empty() || left.type() != CV_8UC1 || left.dims != 2 ||
      !config.validate().empty()) {
    return false;
  }
  DisparityFilterWorkspace local;
  DisparityFilterWorkspace& ws = workspace != nullptr ? *workspace : local;
  // Texture energy of the matching window: mean |LoG| of the left image (002, Sec. 2.2).
  // OpenCV's Gaussian shrinks to one tap along a one-pixel dimension: left to its own calls.
  if (!opencv_only && cpuHasAvx2Fma() && gaussianTaps(config.log_sigma) >= 7 && left.rows > 1 &&
      left.cols > 1) {
    textureEnergyOwn(left, config, &ws, energy);
    return true;
  }
  left.convertTo(ws.grey_f, CV_32F);
  cv::GaussianBlur(ws.grey_f, ws.blurred, cv::Size(), config.log_sigma, config.log_sigma,
                   cv::BORDER_REPLICATE);
  cv::Laplacian(ws.blurred, ws.log, CV_32F, 1, 1.0, 0.0, cv::BORDER_REPLICATE);
  cv::absdiff(ws.log, cv::Scalar::all(0.0), ws.log);
  cv::boxFilter(ws.log, *energy, CV_32F, cv::Size(config.window_size, config.window_size),
                cv::Point(-1, -1), true, cv::BORDER_REPLICATE);
  return true;
}

namespace {

// filterLowTexture()'s test on one row, 8 pixels at a time: a valid disparity whose energy is
// below min_energy becomes 0. Returns how many; *done: columns covered.
__attribute__((target("avx2"))) int lowTextureRowAvx2(const float* energy, float min_energy,
                                                      int cols, float* d, int* done) {
  const __m256 zero = _mm256_setzero_ps();
  const __m256 largest = _mm256_set1_ps(std::numeric_limits<float>::max());
  const __m256 threshold = _mm256_set1_ps(min_energy);
  int removed = 0, x = 0;
  for (; x + 8 <= cols; x += 8) {
    const __m256 v = _mm256_loadu_ps(d + x);
    const __m256 valid =
        _mm256_and_ps(_mm256_cmp_ps(v, zero, _CMP_GT_OQ), _mm256_cmp_ps(v, largest, _CMP_LE_OQ));
    const __m256 reject =
        _mm256_and_ps(valid, _mm256_cmp_ps(_mm256_loadu_ps(energy + x), threshold, _CMP_LT_OQ));
    const int mask = _mm256_movemask_ps(reject);
    if (mask != 0) {
      _mm256_storeu_ps(d + x, _mm256_blendv_ps(v, zero, reject));
      removed += __builtin_popcount(static_cast<unsigned>(mask));
    }
  }
  *done = x;
  return removed;
}

}  // namespace

int filterLowTexture(const cv::Mat& left, const TextureValidationConfig& config, cv::Mat* disparity,
                     DisparityFilterWorkspace* workspace) {
  if (!isFloatImage(disparity) || left.empty() || left.type() != CV_8UC1 ||
      left.size() != disparity->size() || !config.validate().empty()) {
    return -1;
  }
  DisparityFilterWorkspace local;
  DisparityFilterWorkspace& ws = workspace != nullptr ? *workspace : local;
  textureEnergy(left, config, &ws.energy, &ws);

  const float min_energy = static_cast<float>(config.min_energy);
  const bool avx2 = cpuHasAvx2Fma();
  int removed = 0;
  for (int y = 0; y < disparity->rows; ++y) {
    float* d = disparity->ptr<float>(y);
    const float* e = ws.energy.ptr<float>(y);
    int x = 0;
    if (avx2) removed += lowTextureRowAvx2(e, min_energy, disparity->cols, d, &x);
    for (; x < disparity->cols; ++x) {
      if (isValidDisparity(d[x]) && e[x] < min_energy) {
        d[x] = kInvalidDisparity;
        ++removed;
      }
    }
  }
  return removed;
}

// ------------------------------------------------------------------------------------------------
std::string MatchUniquenessConfig::validate() const {
  if (uniqueness_ratio < 0 || uniqueness_ratio > 100) {
    return rangeError("uniqueness_ratio", uniqueness_ratio, "[0, 100]");
  }
  if (!(max_normalized_cost >= 0.0 && max_normalized_cost <= 1.0)) {
    return rangeError("max_normalized_cost", max_normalized_cost, "[0, 1]");
  }
  return {};
}

int filterNonUniqueMatches(const cv::Mat& cost_volume, int min_disparity,
                           const MatchUniquenessConfig& config, cv::Mat* disparity) {
  if (!isFloatImage(disparity) || cost_volume.dims != 3 || cost_volume.type() != CV_32FC1 ||
      cost_volume.size[0] != disparity->rows || cost_volume.size[1] != disparity->cols ||
      cost_volume.size[2] < 1 || !config.validate().empty()) {
    return -1;
  }
  const int num_disp = cost_volume.size[2];
  const bool ratio_test = config.uniqueness_ratio > 0;
  const float ratio = 1.0f + static_cast<float>(config.uniqueness_ratio) / 100.0f;
  const bool normalized_test = config.max_normalized_cost > 0.0;
  const double max_normalized = config.max_normalized_cost;

  int removed = 0;
  for (int y = 0; y < disparity->rows; ++y) {
    float* drow = disparity->ptr<float>(y);
    for (int x = 0; x < disparity->cols; ++x) {
      const float d = drow[x];
      if (!isValidDisparity(d)) continue;
      // In double: a huge disparity must not overflow on its way to an index (fuzzing found it).
      const double kd = std::round(static_cast<double>(d)) - min_disparity;
      bool reject = !(kd >= 0.0 && kd < num_disp);
      const long k1 = reject ? 0 : static_cast<long>(kd);
      if (!reject) {
        const float* cost = cost_volume.ptr<float>(y, x);
        const float best = cost[k1];
        reject = !std::isfinite(best);
        if (!reject && ratio_test) {
          // The runner-up must lose by uniqueness_ratio %, its sub-pixel neighbours excepted
          // (same rule as OpenCV's uniquenessRatio) (002, Sec. 2.2).
          const float threshold = best * ratio;
          for (int k = 0; k < num_disp && !reject; ++k) {
            if ((k < k1 - 1 || k > k1 + 1) && cost[k] <= threshold) reject = true;
          }
        }
        if (!reject && normalized_test) {
          // Best score over the sum of all scores must be below the threshold (002, Sec. 2.2);
          // an all-zero cost row is as ambiguous as it gets.
          double sum = 0.0;
          for (int k = 0; k < num_disp; ++k)
            sum += cost[k];
          reject = !(sum > 0.0) || static_cast<double>(best) / sum >= max_normalized;
        }
      }
      if (reject) {
        drow[x] = kInvalidDisparity;
        ++removed;
      }
    }
  }
  return removed;
}

// ------------------------------------------------------------------------------------------------
std::string LeftRightCheckConfig::validate() const {
  if (!(max_difference >= 0.0 && std::isfinite(max_difference))) {
    return rangeError("max_difference", max_difference, "[0, inf)");
  }
  return {};
}

namespace {

// The left-right check of one row, 8 pixels at a time (AVX2 gather of the right disparities), the
// same float operations as the scalar loop below: x - d + 0.5 floored, |d - d_R| > tolerance.
// Returns the pixels it invalidated; *done: how many columns it covered.
__attribute__((target("avx2"))) int leftRightRowAvx2(float* left_row, const float* right_row,
                                                     int cols, float tolerance,
                                                     bool reject_if_right_invalid, int* done) {
  const __m256 zero = _mm256_setzero_ps();
  const __m256 largest = _mm256_set1_ps(std::numeric_limits<float>::max());
  const __m256 half = _mm256_set1_ps(0.5f);
  const __m256 tol = _mm256_set1_ps(tolerance);
  const __m256 sign = _mm256_set1_ps(-0.0f);
  const __m256 right_invalid =
      _mm256_castsi256_ps(_mm256_set1_epi32(reject_if_right_invalid ? -1 : 0));
  __m256 xv = _mm256_setr_ps(0.0f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 7.0f);
  const __m256 eight = _mm256_set1_ps(8.0f);
  int removed = 0, x = 0;
  for (; x + 8 <= cols; x += 8, xv = _mm256_add_ps(xv, eight)) {
    const __m256 d = _mm256_loadu_ps(left_row + x);
    const __m256 valid =
        _mm256_and_ps(_mm256_cmp_ps(d, zero, _CMP_GT_OQ), _mm256_cmp_ps(d, largest, _CMP_LE_OQ));
    if (_mm256_movemask_ps(valid) == 0) continue;
    const __m256 xf = _mm256_floor_ps(_mm256_add_ps(_mm256_sub_ps(xv, d), half));
    const __m256 inside = _mm256_and_ps(valid, _mm256_cmp_ps(xf, zero, _CMP_GE_OQ));
    // Lanes outside (or invalid) read column 0, and their result is not used.
    const __m256i xr = _mm256_cvttps_epi32(_mm256_and_ps(xf, inside));
    const __m256 dr = _mm256_i32gather_ps(right_row, xr, 4);
    const __m256 right_valid =
        _mm256_and_ps(_mm256_cmp_ps(dr, zero, _CMP_GT_OQ), _mm256_cmp_ps(dr, largest, _CMP_LE_OQ));
    const __m256 differs =
        _mm256_cmp_ps(_mm256_andnot_ps(sign, _mm256_sub_ps(d, dr)), tol, _CMP_GT_OQ);
    const __m256 reject_inside = _mm256_blendv_ps(right_invalid, differs, right_valid);
    const __m256 keep = _mm256_andnot_ps(reject_inside, inside);
    const __m256 reject = _mm256_andnot_ps(keep, valid);
    const int mask = _mm256_movemask_ps(reject);
    if (mask != 0) {
      _mm256_storeu_ps(left_row + x, _mm256_blendv_ps(d, zero, reject));
      removed += __builtin_popcount(static_cast<unsigned>(mask));
    }
  }
  *done = x;
  return removed;
}

bool cpuHasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

}  // namespace

int filterLeftRightInconsistent(const cv::Mat& right_disparity, const LeftRightCheckConfig& config,
                                cv::Mat* disparity) {
  if (!isFloatImage(disparity) || !isFloatImage(&right_disparity) ||
      right_disparity.size() != disparity->size() || !config.validate().empty()) {
    return -1;
  }
  const float tolerance = static_cast<float>(config.max_difference);
  const int cols = disparity->cols;
  int removed = 0;
  const bool avx2 = cpuHasAvx2();
  for (int y = 0; y < disparity->rows; ++y) {
    float* left_row = disparity->ptr<float>(y);
    const float* right_row = right_disparity.ptr<float>(y);
    int x = 0;
    if (avx2) {
      removed += leftRightRowAvx2(left_row, right_row, cols, tolerance,
                                  config.reject_if_right_invalid, &x);
    }
    for (; x < cols; ++x) {
      const float d = left_row[x];
      if (!isValidDisparity(d)) continue;
      // d is finite and > 0, so x - d + 0.5 <= x + 0.5 fits an int once it is >= 0 (a huge d
      // does not: fuzzing found it).
      const float xf = std::floor(static_cast<float>(x) - d + 0.5f);
      const int xr = xf >= 0.0f ? static_cast<int>(xf) : -1;
      bool reject;
      if (xr < 0) {
        reject = true;  // the match lies outside the right image: nothing can confirm it
      } else {
        const float dr = right_row[xr];
        reject =
            isValidDisparity(dr) ? std::fabs(d - dr) > tolerance : config.reject_if_right_invalid;
      }
      if (reject) {
        left_row[x] = kInvalidDisparity;
        ++removed;
      }
    }
  }
  return removed;
}

// ------------------------------------------------------------------------------------------------
std::string SpikeRemovalConfig::validate() const {
  if (!(max_difference > 0.0 && std::isfinite(max_difference))) {
    return rangeError("max_difference", max_difference, "(0, inf)");
  }
  if (min_region_size < 1) return rangeError("min_region_size", min_region_size, "[1, inf)");
  return {};
}

namespace {

// The first x in [x, end) with row[x] > 0, or end: 8 floats per step (AVX2).
__attribute__((target("avx2"))) int nextPositive(const float* row, int x, int end) {
  const __m256 zero = _mm256_setzero_ps();
  for (; x + 8 <= end; x += 8) {
    const int mask = _mm256_movemask_ps(_mm256_cmp_ps(_mm256_loadu_ps(row + x), zero, _CMP_GT_OQ));
    if (mask != 0) return x + __builtin_ctz(static_cast<unsigned>(mask));
  }
  for (; x < end; ++x)
    if (row[x] > 0.0f) return x;
  return end;
}

}  // namespace

int filterSpikes(const SpikeRemovalConfig& config, cv::Mat* disparity,
                 DisparityFilterWorkspace* workspace) {
  if (!isFloatImage(disparity) || !config.validate().empty()) return -1;
  DisparityFilterWorkspace local;
  DisparityFilterWorkspace& ws = workspace != nullptr ? *workspace : local;

  // One-pixel invalid border: the flood fill below needs no bounds checks. A pixel is labelled
  // by negating its value (valid values are > 0, invalid ones are 0), so no label image is needed.
  copyWithInvalidBorder(*disparity, 1, 0, &ws.surface);
  const int stride = ws.surface.cols;
  float* surface = ws.surface.ptr<float>(0);
  const std::size_t capacity = static_cast<std::size_t>(disparity->rows) * disparity->cols;
  if (ws.region.capacity() < capacity) ws.region.reserve(capacity);

  const float tolerance = static_cast<float>(config.max_difference);
  const std::size_t min_size = static_cast<std::size_t>(config.min_region_size);
  const int offsets[4] = {-1, 1, -stride, stride};  // 4-neighbourhood N(i) (002, Sec. 4.2)
  int removed = 0;
  const bool avx2 = cpuHasAvx2();
  for (int y = 1; y <= disparity->rows; ++y) {
    for (int x = 1; x <= disparity->cols; ++x) {
      // Most pixels are invalid or labelled: skip 8 of them at a time (issue 18).
      if (avx2) x = nextPositive(surface + y * stride, x, disparity->cols + 1);
      if (x > disparity->cols) break;
      const int seed = y * stride + x;
      if (!(surface[seed] > 0.0f)) continue;  // invalid or already labelled
      // Breadth-first flood fill of one continuous-disparity surface: j joins i's surface when
      // |d_j - d_i| <= 1 (002, Sec. 4.2). The queue keeps every pixel it saw, so at the end it
      // is the surface's pixel list.
      ws.region.clear();
      ws.region.push_back(seed);
      surface[seed] = -surface[seed];
      for (std::size_t head = 0; head < ws.region.size(); ++head) {
        const int i = ws.region[head];
        const float di = -surface[i];
        for (int k = 0; k < 4; ++k) {
          const int j = i + offsets[k];
          const float dj = surface[j];
          if (dj > 0.0f && std::fabs(dj - di) <= tolerance) {
            surface[j] = -dj;
            ws.region.push_back(j);
          }
        }
      }
      // Surfaces too small to be real are mismatches (002, Sec. 4.2).
      if (ws.region.size() < min_size) {
        for (const int q : ws.region) {
          disparity->ptr<float>(q / stride - 1)[q % stride - 1] = kInvalidDisparity;
        }
        removed += static_cast<int>(ws.region.size());
      }
    }
  }
  return removed;
}

// ------------------------------------------------------------------------------------------------
std::string NeighbourConsistencyConfig::validate() const {
  if (window_radius < 1 || window_radius > 5) {
    return rangeError("window_radius", window_radius, "[1, 5]");
  }
  if (!(max_difference >= 0.0 && std::isfinite(max_difference))) {
    return rangeError("max_difference", max_difference, "[0, inf)");
  }
  if (!(min_agreeing_fraction > 0.0 && min_agreeing_fraction <= 1.0)) {
    return rangeError("min_agreeing_fraction", min_agreeing_fraction, "(0, 1]");
  }
  return {};
}

namespace {

// One pixel of filterInconsistentNeighbours() from the padded copy: true when it is rejected.
bool neighbourReject(const cv::Mat& padded, int y, int x, int r, float tolerance, float fraction,
                     bool isolated) {
  const float c = padded.ptr<float>(y + r)[x + r];
  float n = 0.0f, agree = 0.0f;
  for (int dy = -r; dy <= r; ++dy) {
    const float* row = padded.ptr<float>(y + r + dy) + r + x;
    for (int dx = -r; dx <= r; ++dx) {
      if (dy == 0 && dx == 0) continue;
      const float v = row[dx];
      const float ok = v > 0.0f ? 1.0f : 0.0f;
      n += ok;
      agree += std::fabs(v - c) <= tolerance ? ok : 0.0f;
    }
  }
  return n == 0.0f ? isolated : agree < fraction * n - 1e-3f;
}

// filterInconsistentNeighbours() on one row, 8 centres at a time with every window offset in
// registers (issue 18), skipping blocks without a valid centre; the same float operations as
// the scalar rule (no FMA: this function is compiled for AVX2 alone), so the same result.
// Writes 0 into the rejected pixels of `out`, returns how many; *done: columns covered.
__attribute__((target("avx2"))) int neighbourRowAvx2(const cv::Mat& padded, int y, int r, int cols,
                                                     float tolerance, float fraction, bool isolated,
                                                     float* out, int* done) {
  const __m256 zero = _mm256_setzero_ps();
  const __m256 one = _mm256_set1_ps(1.0f);
  const __m256 sign = _mm256_set1_ps(-0.0f);
  const __m256 tol = _mm256_set1_ps(tolerance);
  const __m256 frac = _mm256_set1_ps(fraction);
  const __m256 margin = _mm256_set1_ps(1e-3f);
  const __m256 iso = _mm256_castsi256_ps(_mm256_set1_epi32(isolated ? -1 : 0));
  const float* centre = padded.ptr<float>(y + r) + r;
  const std::size_t step = padded.step1();
  int removed = 0, x = 0;
  for (; x + 8 <= cols; x += 8) {
    const __m256 c = _mm256_loadu_ps(centre + x);
    const __m256 c_valid = _mm256_cmp_ps(c, zero, _CMP_GT_OQ);
    if (_mm256_movemask_ps(c_valid) == 0) continue;
    __m256 n = zero, agree = zero;
    const float* base =
        centre + x - static_cast<std::ptrdiff_t>(r) * static_cast<std::ptrdiff_t>(step);
    for (int dy = -r; dy <= r; ++dy, base += step) {
      for (int dx = -r; dx <= r; ++dx) {
        if (dy == 0 && dx == 0) continue;
        const __m256 v = _mm256_loadu_ps(base + dx);
        const __m256 ok = _mm256_and_ps(_mm256_cmp_ps(v, zero, _CMP_GT_OQ), one);
        n = _mm256_add_ps(n, ok);
        const __m256 near =
            _mm256_cmp_ps(_mm256_andnot_ps(sign, _mm256_sub_ps(v, c)), tol, _CMP_LE_OQ);
        agree = _mm256_add_ps(agree, _mm256_and_ps(near, ok));
      }
    }
    const __m256 none = _mm256_cmp_ps(n, zero, _CMP_EQ_OQ);
    const __m256 few =
        _mm256_cmp_ps(agree, _mm256_sub_ps(_mm256_mul_ps(frac, n), margin), _CMP_LT_OQ);
    const __m256 reject =
        _mm256_and_ps(c_valid, _mm256_or_ps(_mm256_and_ps(none, iso), _mm256_andnot_ps(none, few)));
    const int mask = _mm256_movemask_ps(reject);
    if (mask != 0) {
      _mm256_storeu_ps(out + x, _mm256_blendv_ps(_mm256_loadu_ps(out + x), zero, reject));
      removed += __builtin_popcount(static_cast<unsigned>(mask));
    }
  }
  *done = x;
  return removed;
}

}  // namespace

int filterInconsistentNeighbours(const NeighbourConsistencyConfig& config, cv::Mat* disparity,
                                 DisparityFilterWorkspace* workspace) {
  if (!isFloatImage(disparity) || !config.validate().empty()) return -1;
  DisparityFilterWorkspace local;
  DisparityFilterWorkspace& ws = workspace != nullptr ? *workspace : local;

  const int r = config.window_radius;
  const int cols = disparity->cols;
  // Rows are processed in whole blocks of 8 (the extra columns are invalid padding), which lets
  // the compiler vectorise the loops below even at -O2.
  const int cols8 = (cols + 7) & ~7;
  // Judged against an untouched copy so that the result does not depend on scan order.
  copyWithInvalidBorder(*disparity, r, cols8 - cols, &ws.padded);
  ws.valid_count.resize(static_cast<std::size_t>(cols8));
  ws.agree_count.resize(static_cast<std::size_t>(cols8));
  float* valid_count = ws.valid_count.data();
  float* agree_count = ws.agree_count.data();

  const float tolerance = static_cast<float>(config.max_difference);
  const float fraction = static_cast<float>(config.min_agreeing_fraction);
  const float isolated = config.remove_isolated ? 1.0f : 0.0f;
  int removed = 0;
  if (cpuHasAvx2()) {
    for (int y = 0; y < disparity->rows; ++y) {
      float* out = disparity->ptr<float>(y);
      int done = 0;
      removed += neighbourRowAvx2(ws.padded, y, r, cols, tolerance, fraction,
                                  config.remove_isolated, out, &done);
      for (int x = done; x < cols; ++x) {
        if (!(ws.padded.ptr<float>(y + r)[x + r] > 0.0f)) continue;
        if (neighbourReject(ws.padded, y, x, r, tolerance, fraction, config.remove_isolated)) {
          out[x] = kInvalidDisparity;
          ++removed;
        }
      }
    }
    return removed;
  }
  for (int y = 0; y < disparity->rows; ++y) {
    const float* centre = ws.padded.ptr<float>(y + r) + r;
    std::fill(valid_count, valid_count + cols8, 0.0f);
    std::fill(agree_count, agree_count + cols8, 0.0f);
    // One window offset at a time over the whole row: branch-free, vectorisable inner loops.
    for (int dy = -r; dy <= r; ++dy) {
      for (int dx = -r; dx <= r; ++dx) {
        if (dy == 0 && dx == 0) continue;
        accumulateAgreement(ws.padded.ptr<float>(y + r + dy) + r + dx, centre, tolerance, cols8,
                            valid_count, agree_count);
      }
    }
    // Keep a reading when at least min_agreeing_fraction of its valid neighbours agree with it
    // (000, Sec. III). Counts are integers: the 1e-3 margin only absorbs rounding of the product.
    float* out = disparity->ptr<float>(y);
    for (int x = 0; x < cols; ++x) {
      if (!(centre[x] > 0.0f)) continue;
      const float n = valid_count[x];
      const bool reject = n == 0.0f ? isolated != 0.0f : agree_count[x] < fraction * n - 1e-3f;
      if (reject) {
        out[x] = kInvalidDisparity;
        ++removed;
      }
    }
  }
  return removed;
}

}  // namespace stereo_safety_map
