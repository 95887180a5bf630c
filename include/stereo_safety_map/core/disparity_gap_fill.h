// Row gap fill (ours; issue 15 "low texture without losing drop-offs"): on a floor with little
// texture a block matcher (000 Sec. III, 002 Sec. 2.2) finds depth only on the few edges that
// cross the epipolar lines (tile joints, paving seams), and the texture, uniqueness and
// left-right tests rightly refuse the smooth tiles between them. The map then sees stripes of
// floor and leaves the rest Unknown, and the stripes break up into the small and thin segments
// that Alg. 2 (000 Sec. VI) cannot label safe.
//
// A planar surface has a disparity that is affine in the pixel coordinates, and a level floor
// seen by a level camera has the same disparity along a whole image row. So, along one row, the
// gap between two valid disparities that agree within `max_step` pixels, each confirmed by its
// valid neighbour on the far side (so that a lone survivor of the filters does not bridge
// anything), is filled by linear interpolation, as long as the gap is at most `max_width` metres
// wide at that depth. Rows only: a depth step that matters to the wheelchair (a curb, a drop-off)
// runs across the image, along the rows, and a column fill would smooth it into a slope (the
// failure of SGBM in issue 15); a row that crosses such an edge obliquely sees the two levels
// at different disparities (a 5 cm step at 8 m with the 0.12 m stereo head: > 0.3 px), which
// `max_step` keeps apart. An obstacle in the gap shows its own edges to the matcher, at its own
// disparity, and breaks the gap; only a thing the matcher cannot see at all could be bridged,
// and `max_width` bounds how wide it could be. Nor is a gap filled under something nearer: a
// pixel above it in its image column with a larger disparity (a table top's edge, a shelf) says
// that the gap may be the floor under an overhang, which would read Level where the overhang's
// own surface was missed (measured: without this rule the fill raised the dev split's FN on
// scenes with tables).
#pragma once

#include "stereo_safety_map/core/stereo_camera_model.h"

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace stereo_safety_map {

struct RowGapFillConfig {
  bool enabled = false;    ///< off = the matcher's disparity unchanged (000, 002)
  double max_width = 0.4;  ///< widest gap filled, at the gap's depth [m], (0, 10]
  double max_step = 0.25;  ///< largest disparity difference across the gap [px], (0, 4]
  std::string validate() const;
};

/// Fills `disparity` (CV_32FC1, invalid <= 0 or non-finite) in place, row by row, as above.
/// `above` (optional) is the per-column buffer it needs, reused by the caller so that the hot
/// path does not allocate. Returns the number of pixels filled.
int fillRowGaps(const RowGapFillConfig& config, const StereoCameraModel& camera, cv::Mat* disparity,
                std::vector<float>* above = nullptr);

}  // namespace stereo_safety_map
