// Fusion of a single-frame obstacle cue into the safety map, ROS-free.
//
// Paper 000's voxel grid needs several frames before an obstacle's voxels reach occ_t (with the
// paper's incr_H = 10 and occ_t = 100, ten hits: 000 Sec. IV; its frame latency, Sec. VII-B).
// Paper 003 finds obstacles in one range image (obstacle_detection.h). The cue carries the
// detected obstacle points of recent frames (fixed frame) and marks the cells that hold them
// Non-ground in the labelled map, right after 000's labelling (Alg. 2) has produced it.
//
// Design (the choices the cue has to make, and why):
//  - The cue is applied to the labelled map, never to the voxel grid: the grid's log-odds stay
//    the evidence of 000 Sec. IV alone, so a false detection cannot linger in the 3D model, and
//    dropping the cue gives back exactly the map 000 computes. Each new map is recomputed from
//    the grid and the live cues are applied to it again.
//  - A cue lives `lifetime` seconds around its stamp: long enough to bridge the frames the grid
//    needs to confirm an obstacle (and the one-frame lag between two nodelets), short enough
//    that a false detection or a moving object does not stay in the map.
//  - It only ever sets cells to Non-ground (and clears their drop-off annotation, which 000
//    Sec. VI gives safe cells only): it can make the map more cautious, never less.
//  - Points higher than `max_z` (the robot's top: base z + robot_height, 000 Sec. V-A) are
//    overhangs the robot passes under and are ignored, as the height map ignores them.
//  - A cell needs `min_points_per_cell` cue points (over all live cues), so that a stray point
//    does not block a cell.
#pragma once

#include "stereo_safety_map/core/safety_map.h"

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace stereo_safety_map {

struct ObstacleCueConfig {
  /// A cue marks the maps whose stamp lies within this many seconds of its own [s], [0, 60].
  /// 1 s: 15 frames at the datasets' 15 Hz, more than the ~10 frames the grid needs to reach
  /// occ_t; at the wheelchair's 0.35 m/s a false cue stays at most 0.35 m behind the chair.
  double lifetime = 1.0;
  /// Cue points (over all live cues) a cell needs to be marked, [1, 1000000]. 3: one or two
  /// stray points do not block a cell; a real obstacle fills a 0.1 m cell with tens of points
  /// per frame at the ranges that matter (f ~ 550 px: 11 px per 0.1 m at 5 m).
  int min_points_per_cell = 3;
  /// Cues kept at most (the oldest is dropped first), [1, 10000].
  int max_cues = 64;

  /// Empty when valid, otherwise a message naming the parameter and its range.
  std::string validate() const;
};

/// What apply() did.
struct ObstacleCueStats {
  int live_cues = 0;                   ///< cues within the lifetime of the map's stamp
  std::size_t points_used = 0;         ///< their points inside the map and below max_z
  std::size_t cells_marked = 0;        ///< cells with enough points (already Non-ground included)
  std::size_t cells_changed = 0;       ///< of which were not Non-ground before
  std::size_t safe_cells_changed = 0;  ///< of which were Level or Inclined
};

/// The live obstacle cues and their application to a labelled map. Not thread-safe: the caller
/// serialises addCue() and apply(). Buffers are reused: once every cue slot has been filled
/// with its largest point count, neither call allocates.
class ObstacleCueFusion {
 public:
  /// Throws std::invalid_argument when config.validate() is not empty.
  explicit ObstacleCueFusion(const ObstacleCueConfig& config = ObstacleCueConfig());

  const ObstacleCueConfig& config() const { return config_; }

  /// Adds the obstacle points of one frame, in the map's fixed frame, taken at `stamp` [s].
  /// Non-finite points are skipped; a non-finite stamp is refused (returns false).
  bool addCue(double stamp, const std::vector<Eigen::Vector3f>& points_fixed);

  /// Marks Non-ground every cell of `map` holding at least min_points_per_cell points of the
  /// cues whose stamp is within `lifetime` of `stamp`, counting only points at or below `max_z`
  /// (fixed frame). Cues outside that window are forgotten (older ones have expired; newer ones
  /// mean time went backwards, e.g. a bag restarted). Only ever changes labels to Non-ground.
  /// `marked` (optional) receives one entry per map cell, 1 where the cue marked it.
  ObstacleCueStats apply(double stamp, float max_z, SafetyMap* map,
                         std::vector<std::uint8_t>* marked = nullptr);

  /// Forgets every cue.
  void clear();

  /// Number of cues held.
  int size() const { return static_cast<int>(count_); }

 private:
  struct Cue {
    double stamp = 0.0;
    std::vector<Eigen::Vector3f> points;
  };
  void forget(std::size_t k);

  ObstacleCueConfig config_;
  std::vector<Cue> cues_;  ///< the first count_ are live, in arrival order
  std::size_t count_ = 0;
  std::vector<std::uint32_t> counts_;  ///< per map cell
};

}  // namespace stereo_safety_map
