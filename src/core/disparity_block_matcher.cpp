#include "stereo_safety_map/core/disparity_block_matcher.h"

#include <immintrin.h>

#include <algorithm>
#include <atomic>
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
  int cost_stride = 0;             // of the per-disparity cost rows (columns 0 .. x_last + 16)
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
  l.cost_stride = ((l.x_last + 16) | 15) + 1;
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

// 16 x 16 transpose of int16: row i of src (16 values from src + i * src_stride) becomes column i
// of dst (dst + j * dst_stride holds element j of every source row).
__attribute__((target("avx2"))) inline void transpose16x16(const std::int16_t* src,
                                                           std::size_t src_stride,
                                                           std::int16_t* dst,
                                                           std::size_t dst_stride) {
  __m256i v[16], w[16];
  for (int half = 0; half < 2; ++half) {
    // An 8 x 8 transpose in each 128-bit lane of rows 8 * half .. 8 * half + 7.
    __m256i r[8], t[8], u[8];
    for (int i = 0; i < 8; ++i) {
      r[i] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(
          src + static_cast<std::size_t>(8 * half + i) * src_stride));
    }
    for (int i = 0; i < 4; ++i) {
      t[2 * i] = _mm256_unpacklo_epi16(r[2 * i], r[2 * i + 1]);
      t[2 * i + 1] = _mm256_unpackhi_epi16(r[2 * i], r[2 * i + 1]);
    }
    u[0] = _mm256_unpacklo_epi32(t[0], t[2]);
    u[1] = _mm256_unpackhi_epi32(t[0], t[2]);
    u[2] = _mm256_unpacklo_epi32(t[1], t[3]);
    u[3] = _mm256_unpackhi_epi32(t[1], t[3]);
    u[4] = _mm256_unpacklo_epi32(t[4], t[6]);
    u[5] = _mm256_unpackhi_epi32(t[4], t[6]);
    u[6] = _mm256_unpacklo_epi32(t[5], t[7]);
    u[7] = _mm256_unpackhi_epi32(t[5], t[7]);
    __m256i* o = half == 0 ? v : w;
    for (int k = 0; k < 4; ++k) {
      o[2 * k] = _mm256_unpacklo_epi64(u[k], u[k + 4]);
      o[2 * k + 1] = _mm256_unpackhi_epi64(u[k], u[k + 4]);
    }
  }
  // v[k]: column k (low lane) and k + 8 (high lane) of rows 0..7; w[k] the same of rows 8..15.
  for (int k = 0; k < 8; ++k) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst + static_cast<std::size_t>(k) * dst_stride),
                        _mm256_permute2x128_si256(v[k], w[k], 0x20));
    _mm256_storeu_si256(
        reinterpret_cast<__m256i*>(dst + static_cast<std::size_t>(k + 8) * dst_stride),
        _mm256_permute2x128_si256(v[k], w[k], 0x31));
  }
}

// Packs two vectors of 8 int32 (values that fit int16) into 16 int16 in lane order.
__attribute__((target("avx2"))) inline __m256i pack16(__m256i lo, __m256i hi) {
  return _mm256_permute4x64_epi64(_mm256_packs_epi32(lo, hi), 0xD8);
}

// best + best * ratio / 100 (C's integer division) of 8 costs. In float it is exact: best * ratio
// < 2^24 and a non-integer quotient is >= 0.01 from the next integer.
__attribute__((target("avx2"))) inline __m256i uniquenessThreshold8(__m128i best16, int ratio) {
  const __m256i b = _mm256_cvtepi16_epi32(best16);
  const __m256 f =
      _mm256_div_ps(_mm256_mul_ps(_mm256_cvtepi32_ps(b), _mm256_set1_ps(static_cast<float>(ratio))),
                    _mm256_set1_ps(100.0f));
  return _mm256_add_epi32(b, _mm256_cvttps_epi32(f));
}

// subpixel() of 8 pixels: winner index d, its cost c, the costs p at d + 1 and n at d - 1. The
// quotient (p - n) * 256 / den is truncated like C's integer division; in float it is exact
// (|quotient| <= 128, den < 2^15, numerator < 2^24: a non-integer quotient is >= 2^-15 from an
// integer, far more than the float's rounding error).
__attribute__((target("avx2"))) inline __m256i subpixel8(const Layout& l, __m128i p16, __m128i n16,
                                                         __m128i c16, __m128i d16) {
  const __m256i pv = _mm256_cvtepi16_epi32(p16), nv = _mm256_cvtepi16_epi32(n16);
  const __m256i cv = _mm256_cvtepi16_epi32(c16), dd = _mm256_cvtepi16_epi32(d16);
  const __m256i zero = _mm256_setzero_si256();
  const __m256i diff = _mm256_sub_epi32(pv, nv);
  const __m256i den = _mm256_sub_epi32(
      _mm256_add_epi32(_mm256_add_epi32(pv, nv), _mm256_abs_epi32(diff)), _mm256_slli_epi32(cv, 1));
  const __m256i den_zero = _mm256_cmpeq_epi32(den, zero);
  const __m256 quot =
      _mm256_div_ps(_mm256_cvtepi32_ps(_mm256_slli_epi32(diff, 8)),
                    _mm256_cvtepi32_ps(_mm256_blendv_epi8(den, _mm256_set1_epi32(1), den_zero)));
  const __m256i qi = _mm256_blendv_epi8(_mm256_cvttps_epi32(quot), zero, den_zero);
  const __m256i k = _mm256_sub_epi32(_mm256_set1_epi32(l.k_max), dd);
  const __m256i inner = _mm256_srai_epi32(
      _mm256_add_epi32(_mm256_add_epi32(_mm256_slli_epi32(k, 8), qi), _mm256_set1_epi32(15)), 4);
  const __m256i edge = _mm256_or_si256(_mm256_cmpeq_epi32(dd, zero),
                                       _mm256_cmpeq_epi32(dd, _mm256_set1_epi32(l.nd - 1)));
  return _mm256_blendv_epi8(inner, _mm256_slli_epi32(k, 4), edge);
}

// The end of winners16(): uniqueness test and sub-pixel step of the 16 winners (index d1, cost
// m1, neighbours' costs pp at d1 + 1 and nn at d1 - 1, best cost away from them s2).
__attribute__((target("avx2"))) inline void finishWinners16(const Layout& l, __m256i m1, __m256i s2,
                                                            __m256i pp, __m256i nn, __m256i d1,
                                                            std::int16_t* out) {
  const __m256i ones = _mm256_set1_epi16(1);
  // Uniqueness: rejected when s2 <= best + best * ratio / 100.
  __m256i reject = _mm256_setzero_si256();
  if (l.ratio > 0) {
    const __m256i thresh = pack16(uniquenessThreshold8(_mm256_castsi256_si128(m1), l.ratio),
                                  uniquenessThreshold8(_mm256_extracti128_si256(m1, 1), l.ratio));
    reject = _mm256_cmpgt_epi16(_mm256_add_epi16(thresh, ones), s2);
  }

  const __m256i value =
      pack16(subpixel8(l, _mm256_castsi256_si128(pp), _mm256_castsi256_si128(nn),
                       _mm256_castsi256_si128(m1), _mm256_castsi256_si128(d1)),
             subpixel8(l, _mm256_extracti128_si256(pp, 1), _mm256_extracti128_si256(nn, 1),
                       _mm256_extracti128_si256(m1, 1), _mm256_extracti128_si256(d1, 1)));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(out),
                      _mm256_blendv_epi8(value, _mm256_set1_epi16(l.filtered), reject));
}

// StereoBM's winner of 16 pixels at once, each reading its cost at index d from p + d * step (the
// left pixels x0..x0 + 15: step = the cost rows' stride; the right pixels xr0..xr0 + 15, whose
// index d lies at left column xr + k_max - d: one column less per index). Indices are visited
// from nd - 1 down to 0, the state in registers: winner (ties to the smaller index), its cost,
// its neighbours' costs and the best cost away from it and its neighbours (uniqueness). Writes
// the 16 disparities in 1/16 px (subpixel()'s rule) or l.filtered.
// No vpblendvb (2-3 uops on recent Intel cores): the selects are and / andnot / or, and the two
// updates with an order to exploit use the unsigned minimum (costs and indices are < 2^15, so a
// lane OR-ed with an all-ones mask is 65535 and never wins). 1.3x faster than the blend version
// on the benchmark machine (issue 18), the same integers.
__attribute__((target("avx2"))) inline __m256i select16(__m256i mask, __m256i a, __m256i b) {
  return _mm256_or_si256(_mm256_and_si256(mask, a), _mm256_andnot_si256(mask, b));  // mask ? a : b
}

__attribute__((target("avx2"))) inline void winners16(const Layout& l, const std::int16_t* p,
                                                      std::ptrdiff_t step, std::int16_t* out) {
  const int nd = l.nd;
  const __m256i ones = _mm256_set1_epi16(1);
  const __m256i all = _mm256_set1_epi16(-1);
  __m256i m1 = _mm256_set1_epi16(kInfinite), s2 = m1, pm = m1, cl = m1;
  __m256i pp = _mm256_setzero_si256(), nn = pp;
  // d1 starts at 65535 (unsigned): the first index always wins (every cost < kInfinite), and a
  // new winner's index is below every earlier one, so d1 = min_u(d1, dv | not_new).
  __m256i d1 = all;
  __m256i kept_before = all;  // not_new of the previous visit: its winner did not change
  __m256i dv = _mm256_set1_epi16(static_cast<short>(nd - 1));
  const std::int16_t* q = p + static_cast<std::ptrdiff_t>(nd - 1) * step;
  for (int d = nd - 1; d >= 0; --d, q -= step) {
    const __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q));
    const __m256i not_new = _mm256_cmpgt_epi16(c, m1);  // ties go to the smaller index
    // Where the previous visit made the winner, c is its neighbour and stays out of s2.
    const __m256i s_keep =
        _mm256_min_epu16(s2, _mm256_or_si256(c, _mm256_andnot_si256(kept_before, all)));
    s2 = select16(not_new, s_keep, pm);
    pp = select16(not_new, pp, cl);
    nn = select16(kept_before, nn, c);
    m1 = _mm256_min_epi16(m1, c);
    d1 = _mm256_min_epu16(d1, _mm256_or_si256(dv, not_new));
    pm = _mm256_min_epi16(pm, cl);
    cl = c;
    kept_before = not_new;
    dv = _mm256_sub_epi16(dv, ones);
  }

  finishWinners16(l, m1, s2, pp, nn, d1, out);
}

// winners16() with AVX-512BW / VL mask registers (issue 18): each select is one masked move,
// where AVX2 needs three instructions; the same state, visits and integers. About 1.35x faster
// than the AVX2 kernel on the benchmark machine (a Xeon with AVX-512).
__attribute__((target("avx2,avx512f,avx512bw,avx512vl"))) inline void winners16Avx512(
    const Layout& l, const std::int16_t* p, std::ptrdiff_t step, std::int16_t* out) {
  const int nd = l.nd;
  const __m256i ones = _mm256_set1_epi16(1);
  __m256i m1 = _mm256_set1_epi16(kInfinite), s2 = m1, pm = m1, cl = m1;
  __m256i pp = _mm256_setzero_si256(), nn = pp, d1 = pp;
  __mmask16 kept_before = 0xFFFF;  // the previous visit did not change the winner
  __m256i dv = _mm256_set1_epi16(static_cast<short>(nd - 1));
  const std::int16_t* q = p + static_cast<std::ptrdiff_t>(nd - 1) * step;
  for (int d = nd - 1; d >= 0; --d, q -= step) {
    const __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q));
    const __mmask16 is_new = _mm256_cmple_epi16_mask(c, m1);  // ties go to the smaller index
    const __m256i s_keep = _mm256_mask_min_epi16(s2, kept_before, s2, c);
    s2 = _mm256_mask_mov_epi16(s_keep, is_new, pm);
    pp = _mm256_mask_mov_epi16(pp, is_new, cl);
    nn = _mm256_mask_mov_epi16(nn, static_cast<__mmask16>(~kept_before), c);
    m1 = _mm256_min_epi16(m1, c);
    d1 = _mm256_mask_mov_epi16(d1, is_new, dv);
    pm = _mm256_min_epi16(pm, cl);
    cl = c;
    kept_before = static_cast<__mmask16>(~is_new);
    dv = _mm256_sub_epi16(dv, ones);
  }
  finishWinners16(l, m1, s2, pp, nn, d1, out);
}

// The left winners (StereoBM's ROI) and the right winners (pixels r2 .. w - 1; right pixel xr at
// index d is left column xr + k_max - d) of one row, 16 pixels at a time; a last partial block
// goes through a scratch row.
#define SSM_WINNERS_ROW(KERNEL)                                             \
  alignas(32) std::int16_t scratch[16];                                     \
  for (int x0 = l.left_min; x0 <= l.left_max; x0 += 16) {                   \
    const int n = std::min(16, l.left_max + 1 - x0);                        \
    std::int16_t* o = n == 16 ? out_left + x0 : scratch;                    \
    KERNEL(l, rows + x0, static_cast<std::ptrdiff_t>(cs), o);               \
    if (n < 16) std::copy(scratch, scratch + n, out_left + x0);             \
  }                                                                         \
  for (int x0 = l.r2; x0 < l.w; x0 += 16) {                                 \
    const int n = std::min(16, l.w - x0);                                   \
    std::int16_t* o = n == 16 ? out_right + x0 : scratch;                   \
    KERNEL(l, rows + x0 + l.k_max, static_cast<std::ptrdiff_t>(cs) - 1, o); \
    if (n < 16) std::copy(scratch, scratch + n, out_right + x0);            \
  }

__attribute__((target("avx2"))) void winnersRowAvx2(const Layout& l, const std::int16_t* rows,
                                                    std::size_t cs, std::int16_t* out_left,
                                                    std::int16_t* out_right) {
  SSM_WINNERS_ROW(winners16)
}

__attribute__((target("avx2,avx512f,avx512bw,avx512vl"))) void winnersRowAvx512(
    const Layout& l, const std::int16_t* rows, std::size_t cs, std::int16_t* out_left,
    std::int16_t* out_right) {
  SSM_WINNERS_ROW(winners16Avx512)
}
#undef SSM_WINNERS_ROW

bool cpuHasAvx512bwVl() {
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512vl");
  return has;
}
// LeftRightBlockMatcher::allowAvx512(); atomic, since the stripes read it on their threads.
std::atomic<bool> avx512_allowed{true};

// One pixel's winner over its own costs c[0..nd) (StereoBM's rules), for the one left pixel whose
// costs compute() corrects.
std::int16_t winner(const Layout& l, const std::int16_t* c) {
  int d = 0;
  for (int k = 1; k < l.nd; ++k)
    if (c[k] < c[d]) d = k;
  const int best = c[d];
  if (l.ratio > 0) {
    const int thresh = best + best * l.ratio / 100;
    for (int k = 0; k < l.nd; ++k)
      if ((k < d - 1 || k > d + 1) && c[k] <= thresh) return l.filtered;
  }
  return subpixel(l, d, best, d + 1 < l.nd ? c[d + 1] : 0, d > 0 ? c[d - 1] : 0);
}

// Rows [y_begin, y_end) of both outputs (valid rows only; the caller fills the others).
// Per row: the column sums slide down one row, the window's SAD slides along the row (all
// disparities of one column at once) into 16-column tiles, which are transposed into one cost row
// per disparity; the left and the right winners are then read from those rows, 16 pixels at a
// time (winners16).
__attribute__((target("avx2"))) void matchRows(const Layout& l, const std::uint8_t* lf,
                                               const std::uint8_t* rf, int y_begin, int y_end,
                                               LeftRightBlockMatcher::Stripe* st, cv::Mat* raw_left,
                                               cv::Mat* raw_right) {
  const bool use_avx512 = LeftRightBlockMatcher::usesAvx512();
  const int nd = l.nd, nv = nd / 16, r2 = l.r2;
  std::int16_t* vs = st->column_sums.data();
  std::int16_t* tile = st->costs.data();      // 16 columns x nd costs
  std::int16_t* fixed = tile + 16 * nd;       // the corrected costs of column w - 1 - r2
  std::int16_t* rows = st->cost_rows.data();  // nd rows of cost_stride columns
  const std::size_t cs = static_cast<std::size_t>(l.cost_stride);
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

    // The window's SAD at x_first, then slid along the row; every column's costs go to the tile
    // of its 16 columns, and a full tile (or the last) into the cost rows.
    std::int16_t* prev = tile + static_cast<std::size_t>((l.x_first + 15) & 15) * nd;
    std::memset(prev, 0, static_cast<std::size_t>(nd) * sizeof(std::int16_t));
    for (int x = l.x_first - r2; x < l.x_first + r2; ++x) {
      const std::int16_t* v = vs + static_cast<std::size_t>(x - l.xv0) * nd;
      for (int d = 0; d < nd; ++d)
        prev[d] = static_cast<std::int16_t>(prev[d] + v[d]);
    }
    bool fix_pending = false;
    for (int x = l.x_first; x <= l.x_last; ++x) {
      std::int16_t* cost = tile + static_cast<std::size_t>(x & 15) * nd;
      const std::int16_t* v_in = vs + static_cast<std::size_t>(x + r2 - l.xv0) * nd;
      if (x > l.x_first) {
        const std::int16_t* v_out = vs + static_cast<std::size_t>(x - r2 - 1 - l.xv0) * nd;
        for (int j = 0; j < nv; ++j) {
          __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(prev + 16 * j));
          c = _mm256_add_epi16(c,
                               _mm256_loadu_si256(reinterpret_cast<const __m256i*>(v_in + 16 * j)));
          c = _mm256_sub_epi16(
              c, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(v_out + 16 * j)));
          _mm256_storeu_si256(reinterpret_cast<__m256i*>(cost + 16 * j), c);
        }
      } else {
        for (int j = 0; j < nv; ++j) {
          __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(prev + 16 * j));
          c = _mm256_add_epi16(c,
                               _mm256_loadu_si256(reinterpret_cast<const __m256i*>(v_in + 16 * j)));
          _mm256_storeu_si256(reinterpret_cast<__m256i*>(cost + 16 * j), c);
        }
      }
      prev = cost;

      if (x == l.w - 1 - r2 && x >= l.left_min) {
        // StereoBM sees the border value in column w - 1 of the unpadded pair, where the cost
        // volume holds the padded pair's one-sided derivative: that left pixel's costs corrected.
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
        fix_pending = true;
      }

      if ((x & 15) == 15 || x == l.x_last) {
        const int base = x & ~15;
        for (int j = 0; j < nv; ++j)
          transpose16x16(tile + 16 * j, static_cast<std::size_t>(nd), rows + 16 * j * cs + base,
                         cs);
      }
    }

    // Winners, 16 pixels at a time; the left pixel whose costs were corrected afterwards.
    std::int16_t* out_left = raw_left->ptr<std::int16_t>(y);
    std::int16_t* out_right = raw_right->ptr<std::int16_t>(y);
    if (use_avx512)
      winnersRowAvx512(l, rows, cs, out_left, out_right);
    else
      winnersRowAvx2(l, rows, cs, out_left, out_right);
    if (fix_pending) out_left[l.w - 1 - r2] = winner(l, fixed);
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

void LeftRightBlockMatcher::allowAvx512(bool allowed) {
  avx512_allowed.store(allowed, std::memory_order_relaxed);
}

bool LeftRightBlockMatcher::usesAvx512() {
  return avx512_allowed.load(std::memory_order_relaxed) && cpuHasAvx512bwVl();
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
    st.costs.resize(17 * static_cast<std::size_t>(l.nd) + 16);  // the tile, corrected costs
    st.cost_rows.resize(static_cast<std::size_t>(l.cost_stride) * l.nd + 16);
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
