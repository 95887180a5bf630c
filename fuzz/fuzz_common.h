// Helpers shared by the libFuzzer targets in fuzz/ (built by scripts/fuzz, not by catkin).
//
// The targets turn the fuzzer's bytes into structured inputs with FuzzedDataProvider. Values are
// drawn so that the interesting cases (NaN, inf, huge, zero, negative, denormal) come up often
// instead of once in 2^32 tries. A broken documented contract is reported through fuzzCheck(),
// which aborts: libFuzzer then saves the input as a crash like any sanitizer report.
#pragma once

#include <fuzzer/FuzzedDataProvider.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>

namespace ssm_fuzz {

/// Aborts with a message when a documented contract does not hold.
#define FUZZ_CHECK(cond)                                                                  \
  do {                                                                                    \
    if (!(cond)) {                                                                        \
      std::fprintf(stderr, "FUZZ_CHECK failed: %s (%s:%d)\n", #cond, __FILE__, __LINE__); \
      std::abort();                                                                       \
    }                                                                                     \
  } while (0)

/// A double that is often special: NaN, +-inf, +-0, huge, tiny, denormal, or any bit pattern;
/// otherwise uniform in [lo, hi].
inline double specialDouble(FuzzedDataProvider& fdp, double lo, double hi) {
  switch (fdp.ConsumeIntegralInRange<int>(0, 15)) {
    case 0:
      return std::numeric_limits<double>::quiet_NaN();
    case 1:
      return std::numeric_limits<double>::infinity();
    case 2:
      return -std::numeric_limits<double>::infinity();
    case 3:
      return fdp.ConsumeBool() ? 0.0 : -0.0;
    case 4:
      return fdp.ConsumeBool() ? 1e30 : -1e30;
    case 5:
      return fdp.ConsumeBool() ? std::numeric_limits<double>::max()
                               : std::numeric_limits<double>::lowest();
    case 6:
      return std::numeric_limits<double>::denorm_min();
    case 7:
      return fdp.ConsumeFloatingPoint<double>();
    default:
      return fdp.ConsumeFloatingPointInRange<double>(lo, hi);
  }
}

inline float specialFloat(FuzzedDataProvider& fdp, float lo, float hi) {
  switch (fdp.ConsumeIntegralInRange<int>(0, 15)) {
    case 0:
      return std::numeric_limits<float>::quiet_NaN();
    case 1:
      return std::numeric_limits<float>::infinity();
    case 2:
      return -std::numeric_limits<float>::infinity();
    case 3:
      return fdp.ConsumeBool() ? 0.0f : -0.0f;
    case 4:
      return fdp.ConsumeBool() ? 1e30f : -1e30f;
    case 5:
      return fdp.ConsumeBool() ? std::numeric_limits<float>::max()
                               : std::numeric_limits<float>::lowest();
    case 6:
      return std::numeric_limits<float>::denorm_min();
    case 7:
      return fdp.ConsumeFloatingPoint<float>();
    default:
      return fdp.ConsumeFloatingPointInRange<float>(lo, hi);
  }
}

/// Mostly a value in [lo, hi]; sometimes a special one (rate: 1 in `one_in`).
inline double mostlyInRange(FuzzedDataProvider& fdp, double lo, double hi, int one_in = 8) {
  if (fdp.ConsumeIntegralInRange<int>(1, one_in) == 1) return specialDouble(fdp, lo, hi);
  return fdp.ConsumeFloatingPointInRange<double>(lo, hi);
}

/// Mostly an int in [lo, hi]; sometimes an extreme one (0, -1, INT_MIN, INT_MAX, any).
inline int mostlyIntInRange(FuzzedDataProvider& fdp, int lo, int hi, int one_in = 8) {
  if (fdp.ConsumeIntegralInRange<int>(1, one_in) == 1) {
    switch (fdp.ConsumeIntegralInRange<int>(0, 4)) {
      case 0:
        return 0;
      case 1:
        return -1;
      case 2:
        return std::numeric_limits<int>::min();
      case 3:
        return std::numeric_limits<int>::max();
      default:
        return fdp.ConsumeIntegral<int>();
    }
  }
  return fdp.ConsumeIntegralInRange<int>(lo, hi);
}

/// Fills a CV_32F matrix (any channel count) with values that are mostly plausible disparities
/// in [0, max_value], with invalid markers (0, negative) and special values mixed in.
inline void fillFloats(FuzzedDataProvider& fdp, float max_value, cv::Mat* m) {
  const int special_one_in = fdp.ConsumeIntegralInRange<int>(2, 64);
  for (int r = 0; r < m->rows; ++r) {
    float* row = m->ptr<float>(r);
    const int n = m->cols * m->channels();
    for (int c = 0; c < n; ++c) {
      if (fdp.remaining_bytes() == 0) {
        row[c] = static_cast<float>((r * 7 + c * 3) % 17);  // deterministic fill when out of data
      } else if (fdp.ConsumeIntegralInRange<int>(1, special_one_in) == 1) {
        row[c] = specialFloat(fdp, -max_value, max_value);
      } else {
        row[c] = static_cast<float>(fdp.ConsumeIntegralInRange<int>(0, 255)) * max_value / 255.0f;
      }
    }
  }
}

/// Fills an 8-bit matrix (any channel count) from the fuzzer's bytes (pattern when out of data).
inline void fillBytes(FuzzedDataProvider& fdp, cv::Mat* m) {
  for (int r = 0; r < m->rows; ++r) {
    std::uint8_t* row = m->ptr<std::uint8_t>(r);
    const int n = m->cols * static_cast<int>(m->elemSize());
    for (int c = 0; c < n; ++c) {
      row[c] = fdp.remaining_bytes() > 0 ? fdp.ConsumeIntegral<std::uint8_t>()
                                         : static_cast<std::uint8_t>((r * 31 + c * 17) & 0xff);
    }
  }
}

/// A view into `storage` of rows x cols of `type` whose row step is larger than needed
/// (non-continuous), or a region of interest of a larger matrix; continuous otherwise.
inline cv::Mat makeStridedMat(FuzzedDataProvider& fdp, int rows, int cols, int type,
                              cv::Mat* storage) {
  switch (fdp.ConsumeIntegralInRange<int>(0, 2)) {
    case 0: {
      storage->create(rows, cols, type);
      return *storage;
    }
    case 1: {
      // Region of interest: padding on every side.
      const int pad_l = fdp.ConsumeIntegralInRange<int>(0, 3);
      const int pad_r = fdp.ConsumeIntegralInRange<int>(0, 3);
      const int pad_t = fdp.ConsumeIntegralInRange<int>(0, 2);
      const int pad_b = fdp.ConsumeIntegralInRange<int>(0, 2);
      storage->create(rows + pad_t + pad_b, cols + pad_l + pad_r, type);
      storage->setTo(cv::Scalar::all(0));
      return (*storage)(cv::Rect(pad_l, pad_t, cols, rows));
    }
    default: {
      // External buffer with a step padded by a multiple of the element size (OpenCV requires
      // it for multi-channel types).
      const std::size_t elem = CV_ELEM_SIZE(type);
      const std::size_t step =
          elem * (static_cast<std::size_t>(cols) +
                  static_cast<std::size_t>(fdp.ConsumeIntegralInRange<int>(0, 5)));
      storage->create(1, static_cast<int>(step * static_cast<std::size_t>(rows)), CV_8UC1);
      storage->setTo(cv::Scalar::all(0));
      return cv::Mat(rows, cols, type, storage->data, step);
    }
  }
}

}  // namespace ssm_fuzz
