// When each cell of the local safety map was last observed, and what the map may still vouch for
// (ours: paper 000 keeps every voxel until it leaves the robot-local window, Sec. IV).
//
// Policy. A cell is observed in a frame when at least one of the frame's points (finite, within
// [min_range, max_range], inside the grid's window) falls into its column. A cell labelled safe
// (Level or Inclined, with or without a potential drop-off edge) whose column has not been
// observed for longer than max_cell_age seconds falls back to Unknown: the map no longer vouches
// that it is safe (someone may have stepped in, a door may have closed). Nothing else changes:
// Non-ground stays Non-ground until the voxel grid itself says otherwise (re-observed as free, or
// scrolled out of the window), Unknown and Unexamined stay what they are. So aging only ever
// turns safe into Unknown, never unsafe into anything else, and never anything into safe.
//
// ROS-free. Times are seconds in whatever clock the frames are stamped with; only differences
// are used. Storage is one entry per (u, v) column of the window in a ring addressed like the
// voxel grid's (global index modulo the window size), so scrolling moves nothing: an entry left
// by a column that scrolled out is recognised by its stored index and reads as never observed.
#pragma once

#include "stereo_safety_map/core/safety_map.h"

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace stereo_safety_map {

class ObservationAge {
 public:
  /// Returned by lastObserved() for a column never observed (since the last clear()).
  static constexpr double kNever = -std::numeric_limits<double>::infinity();

  /// Sizes the ring for a window of size_u x size_v columns and clears it. Non-positive sizes
  /// give an empty ring that observes nothing.
  void resize(int size_u, int size_v);
  /// Forgets every observation; keeps the size.
  void clear();

  int sizeU() const { return size_u_; }
  int sizeV() const { return size_v_; }

  /// Column (u, v) (global indices of Eq. (1), 000 Sec. IV) observed at time t. An older t than
  /// the stored one is ignored (observations never make a column older); a non-finite t too.
  void observe(int u, int v, double t);
  /// Time column (u, v) was last observed; kNever when it was not (or another column has used
  /// its slot since).
  double lastObserved(int u, int v) const;

  /// Applies the policy of the file comment to `map` at time `now`: every Level / Inclined cell
  /// whose column was last observed more than `max_age` seconds before `now` (or never) becomes
  /// Unknown and loses its drop-off flag. Returns the number of cells changed. Does nothing (and
  /// returns 0) when max_age <= 0 or either value is not finite.
  std::size_t apply(double now, double max_age, SafetyMap* map) const;

 private:
  struct Entry {
    std::int32_t u = 0;
    std::int32_t v = 0;
    double t = kNever;
  };
  std::size_t slot(int u, int v) const;

  int size_u_ = 0;
  int size_v_ = 0;
  std::vector<Entry> entries_;
};

}  // namespace stereo_safety_map
