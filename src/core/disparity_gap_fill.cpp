#include "stereo_safety_map/core/disparity_gap_fill.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

namespace stereo_safety_map {

std::string RowGapFillConfig::validate() const {
  std::ostringstream os;
  if (!(max_width > 0.0 && max_width <= 10.0)) {
    os << "row_gap_fill_max_width = " << max_width << " must be in (0, 10]";
  } else if (!(max_step > 0.0 && max_step <= 4.0)) {
    os << "row_gap_fill_max_step = " << max_step << " must be in (0, 4]";
  }
  return os.str();
}

namespace {

inline bool valid(float d) {
  return std::isfinite(d) && d > 0.0f;
}

}  // namespace

int fillRowGaps(const RowGapFillConfig& config, const StereoCameraModel& camera, cv::Mat* disparity,
                std::vector<float>* above) {
  if (!config.enabled || disparity == nullptr || disparity->empty() ||
      disparity->type() != CV_32FC1 || camera.baseline <= 0.0) {
    return 0;
  }
  // Lateral width of g pixels at disparity d: g * Z / fx = g * B / (d - (cx - cx_right)).
  const double px_per_disparity = config.max_width / camera.baseline;
  const float d_offset = static_cast<float>(camera.cx - camera.cx_right);
  const float max_step = static_cast<float>(config.max_step);
  const int cols = disparity->cols;
  std::vector<float> local;
  std::vector<float>& max_above = above != nullptr ? *above : local;
  max_above.assign(static_cast<std::size_t>(cols), 0.0f);
  int filled = 0;
  for (int y = 0; y < disparity->rows; ++y) {
    float* row = disparity->ptr<float>(y);
    int a = -1;  // last valid pixel with a valid left neighbour agreeing with it
    for (int x = 0; x < cols; ++x) {
      const float d = row[x];
      if (!valid(d)) continue;
      if (a >= 0 && x - a > 1 && x + 1 < cols && valid(row[x + 1]) &&
          std::abs(row[x + 1] - d) <= max_step && std::abs(d - row[a]) <= max_step) {
        const float da = row[a];
        const double d_eff = std::min(da, d) - d_offset;
        const int gap = x - a - 1;
        if (d_eff > 0.0f && gap <= px_per_disparity * d_eff) {
          // Not under something nearer: a pixel with a larger disparity above the gap in its
          // column (a table's edge, a shelf) means the gap may be floor seen under an overhang
          // whose own face the matcher missed, or the overhang's face itself.
          const float step = (d - da) / static_cast<float>(x - a);
          bool under = false;
          for (int k = a + 1; k < x && !under; ++k)
            under = max_above[k] > da + step * static_cast<float>(k - a) + max_step;
          if (!under) {
            for (int k = a + 1; k < x; ++k)
              row[k] = da + step * static_cast<float>(k - a);
            filled += gap;
          }
        }
      }
      // x is an anchor for the next gap when its left neighbour agrees with it.
      a = (x > 0 && valid(row[x - 1]) && std::abs(row[x - 1] - d) <= max_step) ? x : -1;
    }
    for (int x = 0; x < cols; ++x)
      if (valid(row[x]) && row[x] > max_above[x]) max_above[x] = row[x];
  }
  return filled;
}

}  // namespace stereo_safety_map
