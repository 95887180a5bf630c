// A series of per-frame values (stage times, rates) of the offline evaluators: mean, quantile
// (nearest rank) and max, NaN when empty. Header-only.
#pragma once

#include <algorithm>
#include <cstddef>
#include <limits>
#include <numeric>
#include <vector>

namespace stereo_safety_map {
namespace tools {

struct Series {
  std::vector<double> v;
  void add(double x) { v.push_back(x); }
  double mean() const {
    return v.empty() ? kNaN() : std::accumulate(v.begin(), v.end(), 0.0) / v.size();
  }
  double quantile(double q) const {
    if (v.empty()) return kNaN();
    std::vector<double> s = v;
    std::sort(s.begin(), s.end());
    return s[std::min(s.size() - 1, static_cast<std::size_t>(q * (s.size() - 1) + 0.5))];
  }
  double max() const { return v.empty() ? kNaN() : *std::max_element(v.begin(), v.end()); }

 private:
  static double kNaN() { return std::numeric_limits<double>::quiet_NaN(); }
};

}  // namespace tools
}  // namespace stereo_safety_map
