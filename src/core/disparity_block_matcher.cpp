#include "stereo_safety_map/core/disparity_block_matcher.h"

#include <immintrin.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>

namespace stereo_safety_map {

namespace {

constexpr std::int16_t kInfinite = 32767;

// The geometry of one compute(): left-image columns X, disparities k = k_max - d (d: OpenCV's
// internal index, so that the right pixel X - k = X - k_max + d grows with d).
struct Layout {
  int w = 0, h = 0, nd = 0, r2 = 0, k_min = 0, k_max = 0, cap = 0, ratio = 0;
  int pad = 0;     // the mirrored matcher's padding: min_disparity + num_disparities + block / 2
  int margin = 0;  // columns before X = 0 in the pre-filtered rows (reads at X - k_max - r2)
  int stride = 0;  // of the pre-filtered rows
  int xv0 = 0, xv1 = 0;            // columns with a column sum
  int x_first = 0, x_last = 0;     // window centres swept
  int left_min = 0, left_max = 0;  // valid left pixels (StereoBM's ROI)
  int state_offset = 0, state_len = 0;
  std::int16_t filtered = 0;
};

Layout makeLayout(const cv::Size& size, const BlockMatcherParams& p) {
  Layout l;
  l.w = size.width;
  l.h = size.height;
  l.nd = p.num_disparities;
  l.r2 = p.block_size / 2;
  l.k_min = p.min_disparity;
  l.k_max = p.min_disparity + p.num_disparities - 1;
  l.cap = p.pre_filter_cap;
  l.ratio = p.uniqueness_ratio;
  l.pad = p.min_disparity + p.num_disparities + l.r2;
  l.margin = (l.k_max + l.r2 + 16 + 31) & ~31;
  l.stride = l.margin + l.w + l.pad + 32;
  l.xv0 = l.k_min;
  l.xv1 = l.w - 1 + l.k_max + l.r2;
  l.x_first = l.r2 + l.k_min;
  l.x_last = l.w - 1 + l.k_max;
  l.left_min = l.k_max + l.r2;
  l.left_max = l.w - 1 - l.r2;
  // Right pixels touched by the sweep: x_first - k_max .. x_last - k_min.
  l.state_offset = l.k_max - l.x_first;
  l.state_len = (l.x_last - l.k_min) + l.state_offset + 1 + 16;
  l.filtered = static_cast<std::int16_t>((p.min_disparity - 1) * 16);
  return l;
}

// StereoBM's PREFILTER_XSOBEL (clipped x-derivative, offset by cap) of one row, on the image as
// the mirrored matcher sees it: extended to the right by `pad` copies of the last column, its
// first and last columns the border value. Column w - 1 therefore has the one-sided derivative
// here; StereoBM on the unpadded pair sees the border value there (compute() corrects for it).
void prefilterRow(const cv::Mat& img, int y, const Layout& l, std::uint8_t* out) {
  const int h = l.h, w = l.w, cap = l.cap;
  std::memset(out, cap, static_cast<std::size_t>(l.stride));
  std::uint8_t* row = out + l.margin;
  if (h % 2 == 1 && y == h - 1) return;  // StereoBM leaves an odd last row at the border value
  const std::uint8_t* a = img.ptr<std::uint8_t>(y > 0 ? y - 1 : 1);
  const std::uint8_t* b = img.ptr<std::uint8_t>(y);
  const std::uint8_t* c = img.ptr<std::uint8_t>(y < h - 1 ? y + 1 : y - 1);
  for (int x = 1; x < w - 1; ++x) {
    const int v = (a[x + 1] - a[x - 1]) + 2 * (b[x + 1] - b[x - 1]) + (c[x + 1] - c[x - 1]);
    row[x] = static_cast<std::uint8_t>(std::min(std::max(v, -cap), cap) + cap);
  }
  const int x = w - 1;
  const int v = (a[x] - a[x - 1]) + 2 * (b[x] - b[x - 1]) + (c[x] - c[x - 1]);
  row[x] = static_cast<std::uint8_t>(std::min(std::max(v, -cap), cap) + cap);
}

// StereoBM's disparity in 1/16 px from the winner's index and its neighbours' costs.
inline std::int16_t subpixel(const Layout& l, int d, int cost, int p, int n) {
  if (d > 0 && d < l.nd - 1) {
    const int den = p + n - 2 * cost + std::abs(p - n);
    return static_cast<std::int16_t>(
        ((l.k_max - d) * 256 + (den != 0 ? (p - n) * 256 / den : 0) + 15) >> 4);
  }
  return static_cast<std::int16_t>((l.k_max - d) * 16);
}

__attribute__((target("avx2"))) inline __m256i absDiffRow(const std::uint8_t* r, int lval) {
  const __m256i rv = _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(r)));
  return _mm256_abs_epi16(_mm256_sub_epi16(rv, _mm256_set1_epi16(static_cast<short>(lval))));
}

// Horizontal minimum of 16 int16 lanes.
__attribute__((target("avx2"))) inline int hmin16(__m256i v) {
  __m128i m = _mm_min_epi16(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  m = _mm_min_epi16(m, _mm_shuffle_epi32(m, 0x4E));
  m = _mm_min_epi16(m, _mm_shuffle_epi32(m, 0xB1));
  m = _mm_min_epi16(m, _mm_shufflelo_epi16(m, 0xB1));
  return static_cast<std::int16_t>(_mm_cvtsi128_si32(m));
}

// Rows [y_begin, y_end) of both outputs (valid rows only; the caller fills the others).
__attribute__((target("avx2"))) void matchRows(const Layout& l, const std::uint8_t* lf,
                                               const std::uint8_t* rf, int y_begin, int y_end,
                                               LeftRightBlockMatcher::Stripe* st, cv::Mat* raw_left,
                                               cv::Mat* raw_right) {
  const int nd = l.nd, nv = nd / 16, r2 = l.r2;
  std::int16_t* vs = st->column_sums.data();
  std::int16_t* cost = st->costs.data();
  std::int16_t* m1 = st->right_state.data();  // right winner's cost
  std::int16_t* s2 = m1 + l.state_len;        // best cost away from the winner and its neighbours
  std::int16_t* pm = s2 + l.state_len;        // best cost seen, the last one excepted
  std::int16_t* cl = pm + l.state_len;        // last cost seen
  std::int16_t* pp = cl + l.state_len;        // cost at the winner's index + 1
  std::int16_t* nn = pp + l.state_len;        // cost at the winner's index - 1
  std::int16_t* d1 = nn + l.state_len;        // winner's index
  const __m256i lane = _mm256_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m256i ones = _mm256_set1_epi16(1);
  auto lrow = [&](int y) { return lf + static_cast<std::size_t>(y) * l.stride + l.margin; };
  auto rrow = [&](int y) { return rf + static_cast<std::size_t>(y) * l.stride + l.margin; };

  for (int y = y_begin; y < y_end; ++y) {
    // Column sums over the window's rows: from scratch at the stripe's first row, then slid.
    if (y == y_begin) {
      std::memset(vs, 0, st->column_sums.size() * sizeof(std::int16_t));
      for (int yy = y - r2; yy <= y + r2; ++yy) {
        const std::uint8_t* a = lrow(yy);
        const std::uint8_t* b = rrow(yy);
        for (int x = l.xv0; x <= l.xv1; ++x) {
          std::int16_t* v = vs + static_cast<std::size_t>(x - l.xv0) * nd;
          const int lv = a[x];
          const std::uint8_t* rp = b + x - l.k_max;
          for (int j = 0; j < nv; ++j) {
            __m256i s = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(v + 16 * j));
            s = _mm256_add_epi16(s, absDiffRow(rp + 16 * j, lv));
            _mm256_storeu_si256(reinterpret_cast<__m256i*>(v + 16 * j), s);
          }
        }
      }
    } else {
      const std::uint8_t* a_in = lrow(y + r2);
      const std::uint8_t* b_in = rrow(y + r2);
      const std::uint8_t* a_out = lrow(y - r2 - 1);
      const std::uint8_t* b_out = rrow(y - r2 - 1);
      for (int x = l.xv0; x <= l.xv1; ++x) {
        std::int16_t* v = vs + static_cast<std::size_t>(x - l.xv0) * nd;
        const int lv_in = a_in[x], lv_out = a_out[x];
        const std::uint8_t* rp_in = b_in + x - l.k_max;
        const std::uint8_t* rp_out = b_out + x - l.k_max;
        for (int j = 0; j < nv; ++j) {
          __m256i s = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(v + 16 * j));
          s = _mm256_add_epi16(s, absDiffRow(rp_in + 16 * j, lv_in));
          s = _mm256_sub_epi16(s, absDiffRow(rp_out + 16 * j, lv_out));
          _mm256_storeu_si256(reinterpret_cast<__m256i*>(v + 16 * j), s);
        }
      }
    }

    // Right-to-left winners start afresh on every row.
    std::fill(m1, m1 + l.state_len, kInfinite);
    std::fill(s2, s2 + l.state_len, kInfinite);
    std::fill(pm, pm + l.state_len, kInfinite);
    std::fill(cl, cl + l.state_len, kInfinite);
    std::fill(pp, pp + 3 * l.state_len, std::int16_t{0});  // pp, nn, d1

    std::int16_t* out_left = raw_left->ptr<std::int16_t>(y);
    // The window's SAD at x_first, then slid along the row.
    std::memset(cost, 0, static_cast<std::size_t>(nd) * sizeof(std::int16_t));
    for (int x = l.x_first - r2; x <= l.x_first + r2; ++x) {
      const std::int16_t* v = vs + static_cast<std::size_t>(x - l.xv0) * nd;
      for (int d = 0; d < nd; ++d)
        cost[d] = static_cast<std::int16_t>(cost[d] + v[d]);
    }
    for (int x = l.x_first; x <= l.x_last; ++x) {
      if (x > l.x_first) {
        const std::int16_t* v_in = vs + static_cast<std::size_t>(x + r2 - l.xv0) * nd;
        const std::int16_t* v_out = vs + static_cast<std::size_t>(x - r2 - 1 - l.xv0) * nd;
        for (int j = 0; j < nv; ++j) {
          __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cost + 16 * j));
          c = _mm256_add_epi16(c,
                               _mm256_loadu_si256(reinterpret_cast<const __m256i*>(v_in + 16 * j)));
          c = _mm256_sub_epi16(
              c, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(v_out + 16 * j)));
          _mm256_storeu_si256(reinterpret_cast<__m256i*>(cost + 16 * j), c);
        }
      }

      // Left pixel x: the winner over its own costs (StereoBM's rules).
      if (x >= l.left_min && x <= l.left_max) {
        const std::int16_t* c = cost;
        if (x == l.w - 1 - r2) {
          // StereoBM sees the border value in column w - 1 of the unpadded pair, where the cost
          // volume holds the padded pair's one-sided derivative: correct that column's terms.
          std::int16_t* fixed = cost + nd;
          std::copy(cost, cost + nd, fixed);
          for (int yy = y - r2; yy <= y + r2; ++yy) {
            const std::uint8_t* a = lrow(yy);
            const std::uint8_t* b = rrow(yy);
            const int lv = a[l.w - 1];
            for (int d = 0; d < nd; ++d) {
              const int xr = l.w - 1 - (l.k_max - d);
              const int rv_padded = b[xr];
              const int rv_plain = xr == l.w - 1 ? l.cap : rv_padded;
              fixed[d] = static_cast<std::int16_t>(fixed[d] + std::abs(l.cap - rv_plain) -
                                                   std::abs(lv - rv_padded));
            }
          }
          c = fixed;
        }
        __m256i minv = _mm256_set1_epi16(kInfinite), idx = _mm256_setzero_si256();
        for (int j = 0; j < nv; ++j) {
          const __m256i cv = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c + 16 * j));
          const __m256i better = _mm256_cmpgt_epi16(minv, cv);
          minv = _mm256_min_epi16(minv, cv);
          idx = _mm256_blendv_epi8(idx, _mm256_add_epi16(lane, _mm256_set1_epi16(16 * j)), better);
        }
        const int best = hmin16(minv);
        const __m256i at_best = _mm256_cmpeq_epi16(minv, _mm256_set1_epi16(best));
        const int d = hmin16(_mm256_blendv_epi8(_mm256_set1_epi16(kInfinite), idx, at_best));
        bool unique = true;
        if (l.ratio > 0) {
          const int thresh = best + best * l.ratio / 100;
          const __m256i t1 = _mm256_set1_epi16(static_cast<short>(thresh + 1));
          const __m256i lo = _mm256_set1_epi16(static_cast<short>(d - 1));
          const __m256i hi = _mm256_set1_epi16(static_cast<short>(d + 1));
          for (int j = 0; j < nv && unique; ++j) {
            const __m256i cv = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c + 16 * j));
            const __m256i dv = _mm256_add_epi16(lane, _mm256_set1_epi16(16 * j));
            const __m256i far =
                _mm256_or_si256(_mm256_cmpgt_epi16(lo, dv), _mm256_cmpgt_epi16(dv, hi));
            const __m256i low = _mm256_cmpgt_epi16(t1, cv);
            unique = _mm256_movemask_epi8(_mm256_and_si256(far, low)) == 0;
          }
        }
        out_left[x] = unique ? subpixel(l, d, best, d + 1 < nd ? c[d + 1] : 0, d > 0 ? c[d - 1] : 0)
                             : l.filtered;
      }

      // Right pixels x - k_max + d: this is their visit at index d (visited in decreasing d).
      const int base = x - l.k_max + l.state_offset;
      for (int j = 0; j < nv; ++j) {
        const int i = base + 16 * j;
        const __m256i dv = _mm256_add_epi16(lane, _mm256_set1_epi16(16 * j));
        const __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cost + 16 * j));
        __m256i vm1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(m1 + i));
        __m256i vs2 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(s2 + i));
        __m256i vpm = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pm + i));
        const __m256i vcl = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cl + i));
        __m256i vpp = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pp + i));
        __m256i vnn = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(nn + i));
        __m256i vd1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(d1 + i));
        // The winner so far was set at the previous visit (index d + 1): c is its neighbour.
        const __m256i last_won = _mm256_cmpeq_epi16(vd1, _mm256_add_epi16(dv, ones));
        const __m256i not_new = _mm256_cmpgt_epi16(c, vm1);  // ties go to the smaller index
        const __m256i s_keep = _mm256_blendv_epi8(_mm256_min_epi16(vs2, c), vs2, last_won);
        vs2 = _mm256_blendv_epi8(vpm, s_keep, not_new);
        vpp = _mm256_blendv_epi8(vcl, vpp, not_new);
        vnn = _mm256_blendv_epi8(vnn, c, last_won);
        vm1 = _mm256_min_epi16(vm1, c);
        vd1 = _mm256_blendv_epi8(dv, vd1, not_new);
        vpm = _mm256_min_epi16(vpm, vcl);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(m1 + i), vm1);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(s2 + i), vs2);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(pm + i), vpm);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(cl + i), c);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(pp + i), vpp);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(nn + i), vnn);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(d1 + i), vd1);
      }
    }

    // Right pixels r2 .. w - 1 have seen every index: their winners.
    std::int16_t* out_right = raw_right->ptr<std::int16_t>(y);
    for (int xr = l.r2; xr < l.w; ++xr) {
      const int i = xr + l.state_offset;
      const int best = m1[i];
      if (l.ratio > 0 && s2[i] <= best + best * l.ratio / 100) {
        out_right[xr] = l.filtered;
      } else {
        out_right[xr] = subpixel(l, d1[i], best, pp[i], nn[i]);
      }
    }
  }
}

bool cpuHasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

}  // namespace

bool LeftRightBlockMatcher::supports(const BlockMatcherParams& p) {
  return cpuHasAvx2() && p.num_disparities >= 16 && p.num_disparities % 16 == 0 &&
         p.num_disparities <= 256 && p.min_disparity == 0 && p.block_size >= 5 &&
         p.block_size % 2 == 1 && p.pre_filter_cap >= 1 && p.pre_filter_cap <= 63 &&
         p.uniqueness_ratio >= 0 && p.uniqueness_ratio <= 100 &&
         // The window's SAD, and min + min * ratio / 100, must fit int16.
         static_cast<long>(p.block_size) * p.block_size * 2 * p.pre_filter_cap * 2 < 32767;
}

void LeftRightBlockMatcher::compute(const cv::Mat& left, const cv::Mat& right,
                                    const BlockMatcherParams& params, int stripes,
                                    cv::Mat* raw_left, cv::Mat* raw_right) {
  const int n = prepare(left, right, params, stripes, raw_left, raw_right);
  cv::parallel_for_(
      cv::Range(0, n),
      [this](const cv::Range& r) {
        for (int s = r.start; s < r.end; ++s)
          matchStripe(s);
      },
      n);
}

int LeftRightBlockMatcher::prepare(const cv::Mat& left, const cv::Mat& right,
                                   const BlockMatcherParams& params, int stripes, cv::Mat* raw_left,
                                   cv::Mat* raw_right) {
  CV_Assert(left.type() == CV_8UC1 && right.type() == CV_8UC1 && left.size() == right.size());
  CV_Assert(supports(params));
  const Layout l = makeLayout(left.size(), params);
  CV_Assert(l.w > l.k_max + 2 * l.r2 + 1 && l.h > 2 * l.r2);
  raw_left->create(left.size(), CV_16SC1);
  raw_right->create(left.size(), CV_16SC1);
  params_ = params;
  raw_left_ = raw_left;
  raw_right_ = raw_right;

  const std::size_t image_bytes = static_cast<std::size_t>(l.h) * l.stride + 64;
  left_filtered_.resize(image_bytes);
  right_filtered_.resize(image_bytes);
  stripes = std::max(1, std::min(stripes, l.h - 2 * l.r2));
  for (int y = 0; y < l.h; ++y) {
    prefilterRow(left, y, l, left_filtered_.data() + static_cast<std::size_t>(y) * l.stride);
    prefilterRow(right, y, l, right_filtered_.data() + static_cast<std::size_t>(y) * l.stride);
  }

  // Rows outside the valid band, and the columns outside each valid range.
  const int y0 = l.r2, y1 = l.h - l.r2;  // valid rows [y0, y1)
  for (int y = 0; y < l.h; ++y) {
    std::int16_t* a = raw_left->ptr<std::int16_t>(y);
    std::int16_t* b = raw_right->ptr<std::int16_t>(y);
    if (y < y0 || y >= y1) {
      std::fill(a, a + l.w, l.filtered);
      std::fill(b, b + l.w, l.filtered);
    } else {
      std::fill(a, a + std::min(l.left_min, l.w), l.filtered);
      if (l.left_max + 1 < l.w) std::fill(a + l.left_max + 1, a + l.w, l.filtered);
      std::fill(b, b + l.r2, l.filtered);
    }
  }
  if (static_cast<int>(stripes_.size()) < stripes) {
    stripes_.resize(static_cast<std::size_t>(stripes));
  }
  // Sized here so that matchStripe() allocates nothing (and cannot throw on a helper thread).
  const int ncols = l.xv1 - l.xv0 + 1;
  for (int s = 0; s < stripes; ++s) {
    Stripe& st = stripes_[static_cast<std::size_t>(s)];
    st.column_sums.resize(static_cast<std::size_t>(ncols) * l.nd + 16);
    st.costs.resize(2 * static_cast<std::size_t>(l.nd) + 16);  // costs, corrected costs
    st.right_state.resize(static_cast<std::size_t>(l.state_len) * 7);
  }
  stripe_count_ = stripes;
  return stripes;
}

void LeftRightBlockMatcher::matchStripe(int stripe) {
  const Layout l = makeLayout(raw_left_->size(), params_);
  const int y0 = l.r2, rows = l.h - 2 * l.r2;
  const int begin = y0 + rows * stripe / stripe_count_;
  const int end = y0 + rows * (stripe + 1) / stripe_count_;
  if (begin < end) {
    matchRows(l, left_filtered_.data(), right_filtered_.data(), begin, end, &stripes_[stripe],
              raw_left_, raw_right_);
  }
}

}  // namespace stereo_safety_map
