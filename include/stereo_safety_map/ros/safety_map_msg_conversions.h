// stereo_safety_map/SafetyMap message -> the core's SafetyMap (core/safety_map.h), complete:
// grid, labels, drop-off edges, segment per cell and the segments with their planes. The hybrid
// map's safetyMapFromMsg() (hybrid_conversions.h) reads the grid and labels only; the safety gate
// also needs each Inclined cell's slope. To be folded into conversions.h.
//
// Like conversions.h: validates, returns an empty string on success and otherwise a one-line
// reason naming the offending field, never throws.
#pragma once

#include "stereo_safety_map/core/safety_map.h"
#include "stereo_safety_map/ros/msgs.h"

#include <string>

namespace stereo_safety_map {

/// Checks and copies everything the message holds into `out`: what safetyMapFromMsg() checks
/// (sizes, labels 0..4, resolution, an axis-aligned origin on the lattice of 000 Eq. (1)), plus a
/// `segment` array empty or one entry per cell, each -1 or an index into `segments`, segment
/// labels 0..4 and finite planes and slopes for valid planes; robot_u / robot_v from
/// robot_position. column_height is not in the message and is left empty. On error `out` is
/// unspecified.
std::string fromSafetyMapMsg(const SafetyMapMsg& msg, SafetyMap* out);

}  // namespace stereo_safety_map
