#include "stereo_safety_map/dataset/texture.h"

#include <algorithm>
#include <cmath>

namespace stereo_safety_map {
namespace dataset {

namespace {

// Octaves are added down to the pixel footprint (bandWeight() ends the sum there); this only caps
// the loop: 24 halvings take a 1 km pattern below a millimetre.
constexpr int kMaxOctaves = 24;

inline std::uint32_t hash2(std::int64_t x, std::int64_t y, std::uint32_t seed) {
  std::uint32_t h = seed * 0x9E3779B9u;
  h ^= static_cast<std::uint32_t>(x) * 0x85EBCA6Bu;
  h = (h << 13) | (h >> 19);
  h ^= static_cast<std::uint32_t>(y) * 0xC2B2AE35u;
  h ^= h >> 16;
  h *= 0x7FEB352Du;
  h ^= h >> 15;
  h *= 0x846CA68Bu;
  h ^= h >> 16;
  return h;
}

inline double hashUnit(std::int64_t x, std::int64_t y, std::uint32_t seed) {
  return hash2(x, y, seed) * (2.0 / 4294967295.0) - 1.0;
}

inline double quintic(double t) {
  return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

inline double clamp11(double x) {
  return std::min(1.0, std::max(-1.0, x));
}

inline double smoothstep(double e0, double e1, double x) {
  if (e1 <= e0) return x < e0 ? 0.0 : 1.0;
  const double t = std::min(1.0, std::max(0.0, (x - e0) / (e1 - e0)));
  return t * t * (3.0 - 2.0 * t);
}

// Visibility of a pattern of wavelength `wl` seen with pixel footprint `fp`: 1 when it spans at
// least 4 pixels, 0 below 2 pixels (the Nyquist limit), linear in between.
inline double bandWeight(double wl, double fp) {
  return std::min(1.0, std::max(0.0, 0.5 * (wl / fp) - 1.0));
}

inline std::int64_t fastFloor(double x) {
  const std::int64_t i = static_cast<std::int64_t>(x);
  return i - (x < static_cast<double>(i) ? 1 : 0);
}

inline double noise2(double u, double v, std::uint32_t seed) {
  const std::int64_t iu = fastFloor(u), iv = fastFloor(v);
  const double a = quintic(u - static_cast<double>(iu)), b = quintic(v - static_cast<double>(iv));
  const double n00 = hashUnit(iu, iv, seed), n10 = hashUnit(iu + 1, iv, seed);
  const double n01 = hashUnit(iu, iv + 1, seed), n11 = hashUnit(iu + 1, iv + 1, seed);
  const double n0 = n00 + a * (n10 - n00), n1 = n01 + a * (n11 - n01);
  return n0 + b * (n1 - n0);
}

// Amplitude ratio of successive octaves. 0.7 rather than the usual 0.5 keeps real surfaces
// fine-scale detail (concrete, asphalt and carpet are rough at the millimetre scale), which is
// what stereo matches on.
constexpr double kPersistence = 0.7;
// Sum of the octave amplitudes 1, 0.7, 0.49, ... (normalises the fractal sum).
constexpr double kFbmNorm = 2.94117;
// Makes the normalised fractal sum's standard deviation about 0.5 (measured), so that it spans
// roughly [-1, 1] and `contrast` reads as a modulation depth.
constexpr double kFbmGain = 2.6;

}  // namespace

double valueNoise(double u, double v, std::uint32_t seed) {
  return noise2(u, v, seed);
}

double fractalNoise(double u, double v, double scale, double footprint, std::uint32_t seed) {
  double sum = 0.0, amp = 1.0, wl = scale;
  for (int k = 0; k < kMaxOctaves; ++k) {
    const double w = bandWeight(wl, footprint);
    if (w <= 0.0) break;  // the remaining octaves are even finer
    // Offsets decorrelate the lattices of successive octaves.
    sum += amp * w * noise2(u / wl + 17.31 * k, v / wl - 5.77 * k, seed + 1013u * k);
    amp *= kPersistence;
    wl *= 0.5;
  }
  return clamp11(kFbmGain * sum / kFbmNorm);
}

double evaluateTexture(const Material& m, double u, double v, double footprint) {
  const double fp = std::max(footprint, 1e-6);
  if (m.angle_deg != 0.0) {
    const double a = m.angle_deg * M_PI / 180.0, c = std::cos(a), s = std::sin(a);
    const double ru = c * u + s * v, rv = -s * u + c * v;
    u = ru;
    v = rv;
  }
  const double s = m.scale;
  switch (m.texture) {
    case TextureKind::kPlain:
      return 0.0;
    case TextureKind::kNoise:
      return fractalNoise(u, v, s, fp, m.seed);
    case TextureKind::kSpeckle: {
      const double base = fractalNoise(u, v, s, fp, m.seed);
      const double wl = 0.25 * s;
      const double n = noise2(u / wl, v / wl, m.seed + 31u);
      const double spots = smoothstep(0.3, 0.55, n) - smoothstep(0.3, 0.55, -n);
      return clamp11(0.5 * base + 0.9 * bandWeight(wl, fp) * spots);
    }
    case TextureKind::kTiles:
    case TextureKind::kBricks: {
      const bool bricks = m.texture == TextureKind::kBricks;
      const double lu = s, lv = bricks ? s / 3.0 : s;
      const double fv = v / lv;
      const double row = std::floor(fv);
      double fu = u / lu;
      if (bricks && std::fmod(std::abs(row), 2.0) > 0.5) fu += 0.5;  // running bond
      const double col = std::floor(fu);
      const double a = fu - col, b = fv - row;
      const double de = std::min(std::min(a, 1.0 - a) * lu, std::min(b, 1.0 - b) * lv);
      const double half = 0.5 * m.line_width * lv;
      const double grout = 1.0 - smoothstep(half - 0.5 * fp, half + 0.5 * fp, de);
      const double shade = 0.6 * hashUnit(static_cast<std::int64_t>(col),
                                          static_cast<std::int64_t>(row), m.seed + 7u);
      const double w = bandWeight(lv, fp);
      const double mean = -2.0 * m.line_width;  // average over many tiles: grout is dark
      const double pattern = w * ((1.0 - grout) * shade - grout) + (1.0 - w) * mean;
      return clamp11(pattern + m.detail * fractalNoise(u, v, 0.5 * lv, fp, m.seed + 3u));
    }
    case TextureKind::kStripes: {
      // Square wave with edges about one footprint wide.
      const double q = std::sin(2.0 * M_PI * u / s) * s / (2.0 * M_PI * fp);
      return clamp11(q) * bandWeight(s, fp);
    }
    case TextureKind::kChecker: {
      const double q = std::sin(M_PI * u / s) * std::sin(M_PI * v / s) * s / (M_PI * fp);
      return clamp11(q) * bandWeight(2.0 * s, fp);
    }
  }
  return 0.0;
}

double evaluateGrain(const Material& m, double u, double v, double footprint) {
  const double fp = std::max(footprint, 1e-6);
  double sum = 0.0, wl = m.grain_size;
  for (int k = 0; k < 3; ++k) {
    const double w = bandWeight(wl, fp);
    if (w > 0.0) sum += w * noise2(u / wl + 3.7 * k, v / wl - 8.1 * k, m.seed + 7919u * (k + 1));
    wl *= 2.0;
  }
  // Value noise has a standard deviation of about 0.3: scale three octaves to about 0.5.
  return clamp11(0.95 * sum);
}

}  // namespace dataset
}  // namespace stereo_safety_map
